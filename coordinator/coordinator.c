#include "coordinator.h"

#include "../common/blob.h"
#include "../common/clock.h"
#include "../common/error.h"
#include "../common/message.h"
#include "blobs.h"
#include "checkpoint.h"
#include "farm.h"
#include "gate.h"
#include "log.h"
#include "merger.h"
#include "replay.h"
#include "ship.h"
#include "state.h"

#include <errno.h>
#include <math.h>
#include <nanomsg/nn.h>
#include <nanomsg/reqrep.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <stdint.h>
#include <unistd.h>
#include <uv.h>

#define TICK_MS 200
/* A tick later than its period by more than this is a stall of the coordinator itself
 * (SIGSTOP, a paused VM, swapping, a debugger, a long blocking call on the loop). */
#define STALL_SECONDS 1.0
/* At most this many requests read at a tick before anyone is expired (bounded: a tick
 * must end); what a stall left queued is normally far less. */
#define DRAIN_MAX 4096
#define STOP_CHECK_MS 10
#define COLLECT_SECONDS 3600.0
#define MESSAGES_PER_WAKEUP 32
#define REPLY_GIVE_UP_SECONDS 30.0
/* Requests that do not authenticate get the fixed refusal (common/wire.h, docs/PROTOCOL.md
 * "A wrong key") within a budget over all peers: the requests refused so weigh at most
 * REFUSED_BYTES_PER_SECOND, in bursts of one request of the largest size, each counted as
 * at least REFUSAL_MIN_COST (so at most 16 refusals a second); beyond it, no answer, as
 * before refusals existed. They are logged at most once per UNAUTHENTICATED_LOG_SECONDS. */
#define REFUSED_BYTES_PER_SECOND ((double)(1 << 20))
#define REFUSED_BYTES_BURST ((double)VF_WIRE_MAX_REQUEST_FRAME)
#define REFUSAL_MIN_COST ((size_t)64 << 10)
#define UNAUTHENTICATED_LOG_SECONDS 10.0

typedef struct {
  uv_loop_t loop;
  uv_poll_t recv_poll, send_poll;
  uv_timer_t tick, stop_check;
  uv_signal_t sigint, sigterm;
  int socket;
  vf_wire_key key;
  vf_replay *replay; /* owned: the nonces of the requests let through */
  uint64_t replays_refused;
  double refusal_budget, refusal_time; /* bytes the next refusals may answer, and when it was topped up */
  uint64_t unauthenticated, refusals;  /* since the last line of the log about them */
  double unauthenticated_logged;
  vf_farm farm;
  vf_dashboard *dashboard; /* owned; NULL without --http */
  vf_gate *gate;           /* owned; NULL unless listening on tcp:// */
  char gate_dir[4096];     /* the private directory of the REP socket behind the gate, or "" */
  char gate_url[4200];
  double checkpoint_interval, last_checkpoint;
  double last_collect;  /* of blobs no job names (coordinator/blobs.h) */
  double last_tick_at;  /* vf_seconds_now() of the last tick, or of the tick timer's start */
  volatile sig_atomic_t *stop; /* the caller's stop flag, or NULL */
  /* Replies waiting for room to be sent, oldest first, owned (rarely more than one: a raw
   * REP socket drops a reply its peer's pipe cannot take rather than refuse it). */
  struct pending_reply *pending, **pending_tail;
  double pending_since;
} coordinator;

/* A reply and the routing header of its request (a raw REP socket's backtrace, owned as a
 * nanomsg chunk) that says which peer it goes to. */
typedef struct pending_reply {
  struct pending_reply *next;
  uint8_t *frame;
  size_t len;
  void *control;
} pending_reply;

/* Where a reply goes and what it answers: the routing header (owned, a nanomsg chunk) and
 * the request's stamp, which the reply is bound to (common/wire.h). Allocated per request;
 * its address is the farm's token for a reply given later. */
typedef struct {
  void *control;
  vf_wire_stamp request;
} reply_route;

static void on_readable(uv_poll_t *handle, int status, int events);

static void resume_receiving(coordinator *c) {
  uv_poll_stop(&c->send_poll);
  uv_poll_start(&c->recv_poll, UV_READABLE, on_readable);
}

/* Sends a frame to the peer of `control` (taken on success, and then freed by nanomsg).
 * Returns 0 sent or dropped for good, -1 when there is no room now. */
static int send_frame(coordinator *c, uint8_t *frame, size_t len, void **control) {
  struct nn_iovec iov = {frame, len};
  struct nn_msghdr hdr = {&iov, 1, control, NN_MSG};
  if (nn_sendmsg(c->socket, &hdr, NN_DONTWAIT) >= 0) return 0;
  int e = nn_errno();
  if (e == EAGAIN) return -1;
  vf_log("reply dropped: %s", nn_strerror(e));
  return 0;
}

static void drop_pending(coordinator *c) {
  pending_reply *p = c->pending;
  c->pending = p->next;
  if (c->pending == NULL) c->pending_tail = &c->pending;
  free(p->frame);
  if (p->control) nn_freemsg(p->control);
  free(p);
  c->pending_since = vf_seconds_now();
}

static void on_writable(uv_poll_t *handle, int status, int events) {
  coordinator *c = handle->data;
  while (c->pending != NULL) {
    if (send_frame(c, c->pending->frame, c->pending->len, &c->pending->control) < 0) return;
    c->pending->control = NULL; /* nanomsg's now */
    drop_pending(c);
  }
  resume_receiving(c);
}

static void deliver(coordinator *c, uint8_t *frame, size_t len, void *control);

/* Packs and sends a reply along `route`, which this takes (and frees). */
static void send_reply(coordinator *c, vf_farm_reply *reply, reply_route *route) {
  uint8_t *frame;
  size_t len;
  void *control = route->control;
  vf_wire_stamp request = route->request;
  free(route);
  int err = vf_message_pack(&c->key, &request, &reply->env, &frame, &len, NULL);
  if (err != VF_OK) {
    vf_log("cannot encode the %s reply: %s", vf_message_name(&reply->env), vf_error_detail(err));
    vf_farm_reply_release(reply);
    vf_farm_reply_error(reply, VCMFARM__ERROR_CODE__ERROR_INTERNAL, "reply could not be encoded");
    if (vf_message_pack(&c->key, &request, &reply->env, &frame, &len, NULL) != VF_OK) {
      nn_freemsg(control);
      return;
    }
  }
  if (request.version == VF_PROTOCOL_VERSION) vf_replay_keep_reply(c->replay, &request, frame, len);
  deliver(c, frame, len, control);
}

/* Sends a frame (taken) to the peer of `control` (taken), now or once there is room. */
static void deliver(coordinator *c, uint8_t *frame, size_t len, void *control) {
  if (c->pending == NULL && send_frame(c, frame, len, &control) == 0) {
    free(frame);
    return;
  }
  pending_reply *p = malloc(sizeof *p);
  if (p == NULL) {
    vf_log("reply dropped: out of memory");
    free(frame);
    nn_freemsg(control);
    return;
  }
  *p = (pending_reply){NULL, frame, len, control};
  if (c->pending == NULL) c->pending_since = vf_seconds_now();
  *c->pending_tail = p;
  c->pending_tail = &p->next;
  uv_poll_stop(&c->recv_poll);
  uv_poll_start(&c->send_poll, UV_READABLE, on_writable);
}

/* A request that failed authentication (err, its detail): answered with the fixed refusal
 * when it is small and the budget allows, else dropped; control is taken either way. */
static void refuse_unauthenticated(coordinator *c, const uint8_t *frame, size_t len, int err, void *control) {
  double now = vf_seconds_now(), cost = (double)(len > REFUSAL_MIN_COST ? len : REFUSAL_MIN_COST);
  c->refusal_budget = fmin(REFUSED_BYTES_BURST, c->refusal_budget + (now - c->refusal_time) * REFUSED_BYTES_PER_SECOND);
  c->refusal_time = now;
  uint8_t *refusal = NULL;
  if (err == VF_EAUTH && vf_wire_knows_refusal(frame, len) && c->refusal_budget >= cost &&
      (refusal = malloc(VF_WIRE_REFUSAL_SIZE)) != NULL) {
    c->refusal_budget -= cost;
    c->refusals++;
    memcpy(refusal, vf_wire_refusal, VF_WIRE_REFUSAL_SIZE);
    deliver(c, refusal, VF_WIRE_REFUSAL_SIZE, control);
  } else {
    nn_freemsg(control);
  }
  c->unauthenticated++;
  if (now - c->unauthenticated_logged < UNAUTHENTICATED_LOG_SECONDS) return;
  vf_log("refused a message of %zu bytes: %s%s (%llu refused since the last such line, %llu answered)", len,
         vf_error_detail(err), refusal ? "; answered that the key is refused" : "",
         (unsigned long long)c->unauthenticated, (unsigned long long)c->refusals);
  c->unauthenticated = c->refusals = 0;
  c->unauthenticated_logged = now;
}

/* The farm answers a result later, from the merge thread's completion on the loop. */
static void reply_later(void *ctx, uint64_t token, vf_farm_reply *reply) {
  send_reply(ctx, reply, (reply_route *)(uintptr_t)token);
}

static void serve(coordinator *c, const uint8_t *frame, size_t len, void *control) {
  Vcmfarm__Envelope *request;
  vf_farm_reply reply;
  double t0 = vf_seconds_now();
  reply_route *route = malloc(sizeof *route);
  if (route == NULL) {
    vf_log("ignored a message of %zu bytes: out of memory", len);
    nn_freemsg(control);
    return;
  }
  route->control = control;
  int err = vf_message_unpack(&c->key, NULL, frame, len, &request, &route->request);
  if (err == VF_EVERSION) {
    vf_log("refused a message: %s", vf_error_detail(err));
    vf_farm_reply_error(&reply, VCMFARM__ERROR_CODE__ERROR_VERSION, vf_error_detail(err));
    send_reply(c, &reply, route);
    vf_farm_reply_release(&reply);
    return;
  }
  if (err == VF_OK) {
    /* Before anything looks at it: a replayed request has no effect at all. */
    int64_t now_ms = vf_wire_now_ms();
    err = vf_replay_check(c->replay, &route->request, now_ms);
    if (err != VF_OK) {
      c->replays_refused++;
      size_t kept_len = 0;
      const uint8_t *kept = vf_replay_reply(c->replay, &route->request, now_ms, &kept_len);
      uint8_t *again = kept ? malloc(kept_len ? kept_len : 1) : NULL;
      vf_log("refused a %s message of %zu bytes (%llu refused so far): %s%s", vf_message_name(request), len,
             (unsigned long long)c->replays_refused, vf_error_detail(err),
             again ? "; answered with the reply it had" : "");
      vf_message_free(request);
      if (again) { /* a resend (or a replay, which learns nothing new): its reply again, no effect */
        memcpy(again, kept, kept_len);
        deliver(c, again, kept_len, control);
        free(route);
        return;
      }
      if (vf_replay_before_start(c->replay, &route->request, now_ms)) { /* still no effect: "send it again" */
        vf_farm_reply_error(&reply, VCMFARM__ERROR_CODE__ERROR_RESEND,
                            "sent before this coordinator started: send it again");
        send_reply(c, &reply, route);
        vf_farm_reply_release(&reply);
        return;
      }
    }
  } else {
    /* A peer without the key gets the fixed refusal at most, which tells it nothing but
     * that it is refused; a malformed message nothing. */
    free(route);
    refuse_unauthenticated(c, frame, len, err, control);
    return;
  }
  if (err != VF_OK) {
    /* No answer: a replay gets nothing a captured reply could not already tell. */
    nn_freemsg(control);
    free(route);
    return;
  }
  c->farm.request = request;
  c->farm.request_token = (uint64_t)(uintptr_t)route;
  vf_farm_handle(&c->farm, request, vf_seconds_now(), &reply);
  if (!reply.deferred) send_reply(c, &reply, route);
  vf_farm_reply_release(&reply);
  if (request->body_case == VCMFARM__ENVELOPE__BODY_RESULT) /* the loop's share of a part's cost */
    vf_ship_part_work(&c->farm, vf_seconds_now() - t0, 0);
  if (c->farm.request != NULL) vf_message_free(c->farm.request); /* else the handler took it */
  c->farm.request = NULL;
  c->farm.loop_busy += vf_seconds_now() - t0;
}

/* Serves up to `max` requests waiting on the socket (fewer when a reply must wait for
 * room). Returns how many were read. */
static int receive(coordinator *c, int max) {
  int i = 0;
  for (; i < max && c->pending == NULL; i++) {
    void *buf = NULL, *control = NULL;
    struct nn_iovec iov = {&buf, NN_MSG};
    struct nn_msghdr hdr = {&iov, 1, &control, NN_MSG};
    int n = nn_recvmsg(c->socket, &hdr, NN_DONTWAIT);
    if (n < 0) {
      int e = nn_errno();
      if (e != EAGAIN && e != EINTR) vf_log("receive: %s", nn_strerror(e));
      return i;
    }
    if (control == NULL) { /* a raw REP socket always gives the backtrace; without it, no answer can go */
      nn_freemsg(buf);
      continue;
    }
    serve(c, buf, (size_t)n, control);
    nn_freemsg(buf);
  }
  return i;
}

static void on_readable(uv_poll_t *handle, int status, int events) { receive(handle->data, MESSAGES_PER_WAKEUP); }

static void on_stop_check(uv_timer_t *timer) {
  coordinator *c = timer->data;
  if (!*c->stop) return;
  vf_log("asked to stop: checkpointing and stopping");
  uv_stop(&c->loop);
}

static void on_tick(uv_timer_t *timer) {
  coordinator *c = timer->data;
  double now = vf_seconds_now();
  /* libuv runs due timers before it polls for I/O: after a stall this tick comes first,
   * with the workers' heartbeats of meanwhile still unread. The silence was ours, not
   * theirs: the gap is excused (vf_farm_stalled), and what is queued is read before
   * anyone is expired. */
  double gap = now - c->last_tick_at - TICK_MS / 1000.0;
  c->last_tick_at = now;
  if (gap > STALL_SECONDS) vf_farm_stalled(&c->farm, gap, now);
  if (receive(c, DRAIN_MAX) > 0) {
    /* A stall inside the drain (the process stopped while it read) is the coordinator's
     * too: without this, the expiry below would see the workers silent for all of it. */
    double after = vf_seconds_now();
    if (after - now > STALL_SECONDS) vf_farm_stalled(&c->farm, after - now, after);
    now = after;
  }
  vf_farm_expire(&c->farm, now);
  vf_farm_tick(&c->farm, now);
  if (c->pending != NULL && now - c->pending_since > REPLY_GIVE_UP_SECONDS) {
    vf_log("reply dropped: the peer did not take it within %.0f s", REPLY_GIVE_UP_SECONDS);
    drop_pending(c);
    if (c->pending == NULL) resume_receiving(c);
  }
  if (now - c->last_collect >= COLLECT_SECONDS) {
    vf_blobs_collect(&c->farm, 86400.0); /* left by submissions that failed, references */
    c->last_collect = now;
  }
  if (now - c->last_checkpoint >= c->checkpoint_interval) {
    vf_farm_checkpoint(&c->farm, 0);
    c->last_checkpoint = now;
  }
}

static void on_signal(uv_signal_t *handle, int signum) {
  coordinator *c = handle->data;
  vf_log("%s: checkpointing and stopping", signum == SIGTERM ? "SIGTERM" : "SIGINT");
  uv_stop(&c->loop);
}

static int socket_fd(int socket, int option, int *fd) {
  size_t size = sizeof *fd;
  if (nn_getsockopt(socket, NN_SOL_SOCKET, option, fd, &size) < 0)
    return vf_error_set(VF_ENET, "nanomsg: cannot get the socket's descriptor: %s", nn_strerror(nn_errno()));
  return VF_OK;
}

static void close_handle(uv_handle_t *h, void *arg) {
  if (!uv_is_closing(h)) uv_close(h, NULL);
}

/* The socket file of an ipc:// URL, or NULL for another transport. */
static const char *ipc_path(const char *url) { return strncmp(url, "ipc://", 6) == 0 ? url + 6 : NULL; }

/* nanomsg's ipc:// bind unlinks whatever is at the path first. Refuse a path that holds
 * anything but a socket (a user's file would be deleted), and a socket that another
 * process still listens on (its clients would be taken over). */
static int check_ipc_path(const char *url) {
  const char *path = ipc_path(url);
  if (path == NULL) return VF_OK;
  struct stat st;
  if (lstat(path, &st) != 0) return VF_OK; /* nothing there */
  if (!S_ISSOCK(st.st_mode))
    return vf_error_set(VF_EUSAGE, "--listen %s: %s exists and is not a socket; refusing to replace it", url, path);
  struct sockaddr_un addr = {.sun_family = AF_UNIX};
  if (strlen(path) >= sizeof addr.sun_path) return VF_OK; /* nanomsg refuses it with its own error */
  memcpy(addr.sun_path, path, strlen(path) + 1);
  int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return VF_OK;
  int live = connect(fd, (struct sockaddr *)&addr, sizeof addr) == 0;
  close(fd);
  if (live) return vf_error_set(VF_EUSAGE, "--listen %s: another process listens on %s", url, path);
  return VF_OK; /* a socket left by a process that ended */
}

/* nn_bind, with an ipc:// socket file that only this user may connect to (mode 0700):
 * connecting needs write permission on the file. Other local users are kept out before
 * they can send a byte; this matters beyond the key, because nanomsg 1.1.5's ipc transport
 * aborts the process on a malformed message-type byte (docs/PROTOCOL.md, "Not yet"). The
 * file is created with these bits by nn_bind itself (synchronous for ipc://), under a
 * umask set around the call, so that no other user can connect in between; the umask is
 * the process's, and the coordinator binds before it starts any thread that writes files. */
static int bind_socket(int socket, const char *url) {
  if (ipc_path(url) == NULL) return nn_bind(socket, url);
  mode_t previous = umask(077);
  int endpoint = nn_bind(socket, url);
  umask(previous);
  return endpoint;
}

static int is_tcp(const char *url) { return strncmp(url, "tcp://", 6) == 0; }

/* Behind the gate the REP socket listens on a unix socket in a directory of its own, that
 * only this user may enter; gate_url is set to it. */
static int make_gate_dir(coordinator *c) {
  const char *tmp = getenv("TMPDIR");
  if (tmp == NULL || *tmp == '\0') tmp = "/tmp";
  snprintf(c->gate_dir, sizeof c->gate_dir, "%s/vcmfarm-gate-XXXXXX", tmp);
  struct sockaddr_un addr;
  if (strlen(c->gate_dir) + 3 > sizeof addr.sun_path) { /* "/s" and the NUL */
    c->gate_dir[0] = '\0';
    return vf_error_set(VF_EUSAGE, "TMPDIR %s is too long a path for a unix socket", tmp);
  }
  if (mkdtemp(c->gate_dir) == NULL) {
    int e = errno;
    c->gate_dir[0] = '\0';
    return vf_error_set(VF_EIO, "cannot create a directory in %s: %s", tmp, strerror(e));
  }
  snprintf(c->gate_url, sizeof c->gate_url, "ipc://%s/s", c->gate_dir);
  return VF_OK;
}

static void remove_gate_dir(coordinator *c) {
  if (c->gate_dir[0] == '\0') return;
  unlink(c->gate_url + 6);
  rmdir(c->gate_dir);
}

/* A worker's blob cache (worker/blob_cache.h) is not a state directory: the worker's
 * eviction would delete the coordinator's scene files. */
static int check_state_dir(const char *dir) {
  char marker[4200];
  struct stat st;
  snprintf(marker, sizeof marker, "%s/" VF_BLOB_CACHE_MARKER, dir);
  if (stat(marker, &st) == 0)
    return vf_error_set(VF_EUSAGE, "--state %s is a worker's scene-file cache (it holds %s), not a state directory",
                        dir, VF_BLOB_CACHE_MARKER);
  return VF_OK;
}

int vf_coordinator_run(const vf_coordinator_config *config) {
  coordinator *c = calloc(1, sizeof *c);
  if (c == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  vf_farm_config fc = {config->state_dir, config->worker_timeout, config->lease_seconds, config->forgive_seconds};
  vf_farm_init(&c->farm, &fc);
  c->checkpoint_interval = config->checkpoint_interval;
  c->refusal_budget = REFUSED_BYTES_BURST;
  c->refusal_time = vf_seconds_now();
  c->unauthenticated_logged = c->refusal_time - UNAUTHENTICATED_LOG_SECONDS;
  c->stop = config->stop;
  vf_log_set_quiet(config->quiet);
  int err = VF_OK, recv_fd, send_fd;
  signal(SIGPIPE, SIG_IGN);
  if (config->key) c->key = *config->key;
  else if ((err = vf_wire_key_load(config->secret_path, &c->key)) != VF_OK) goto free_farm;
  if ((err = check_state_dir(config->state_dir)) != VF_OK || (err = check_ipc_path(config->listen_url)) != VF_OK)
    goto free_farm;
  if ((err = vf_replay_create(VF_REPLAY_CAPACITY, &c->replay)) != VF_OK) goto free_farm;
  vf_replay_start(c->replay, vf_wire_now_ms());
  if ((err = vf_state_lock(config->state_dir, &c->farm.state_lock_fd)) != VF_OK) goto free_farm;
  if ((err = vf_state_load(&c->farm)) != VF_OK) goto unlock;
  vf_blobs_collect(&c->farm, 86400.0); /* before serving anyone, then every hour */
  c->last_collect = vf_seconds_now();
  c->pending_tail = &c->pending;
  /* Raw: requests are answered in any order, so a result merged on the merge thread is
   * answered when it is done while heartbeats and leases are answered meanwhile. */
  if ((c->socket = nn_socket(AF_SP_RAW, NN_REP)) < 0) {
    err = vf_error_set(VF_ENET, "nanomsg socket: %s", nn_strerror(nn_errno()));
    goto unlock;
  }
  int max_size = (int)VF_WIRE_MAX_REQUEST_FRAME; /* nanomsg drops larger messages unread */
  nn_setsockopt(c->socket, NN_SOL_SOCKET, NN_RCVMAXSIZE, &max_size, sizeof max_size);
  const char *bind_url = config->listen_url;
  if (is_tcp(config->listen_url)) {
    if ((err = make_gate_dir(c)) != VF_OK) goto close_socket;
    bind_url = c->gate_url;
  }
  if (bind_socket(c->socket, bind_url) < 0) {
    err = vf_error_set(VF_ENET, "cannot listen on %s: %s", bind_url, nn_strerror(nn_errno()));
    goto close_socket;
  }
  if ((err = socket_fd(c->socket, NN_RCVFD, &recv_fd)) != VF_OK ||
      (err = socket_fd(c->socket, NN_SNDFD, &send_fd)) != VF_OK)
    goto close_socket;
  if (uv_loop_init(&c->loop) != 0) {
    err = vf_error_set(VF_ENOMEM, "libuv: cannot create the loop");
    goto close_socket;
  }
  if (c->gate_dir[0] != '\0') {
    vf_gate_limits limits = vf_gate_defaults(VF_WIRE_MAX_REQUEST_FRAME, VF_WIRE_MAX_FRAME + 64);
    limits.max_connections = config->max_connections;
    limits.max_bytes = config->max_in_flight;
    if ((err = vf_gate_start(&c->loop, config->listen_url, c->gate_url + 6, &limits, &c->gate)) != VF_OK)
      goto close_loop;
  }
  c->farm.checkpoint_loop = &c->loop; /* films are checkpointed off the loop */
  vf_merger *merger = NULL;
  if ((err = vf_merger_start(&c->loop, &merger)) != VF_OK) goto close_loop;
  c->farm.merger = merger; /* and results merged off it */
  c->farm.reply_later = reply_later;
  c->farm.reply_ctx = c;
  uv_poll_init(&c->loop, &c->recv_poll, recv_fd);
  uv_poll_init(&c->loop, &c->send_poll, send_fd);
  uv_timer_init(&c->loop, &c->tick);
  uv_timer_init(&c->loop, &c->stop_check);
  uv_signal_init(&c->loop, &c->sigint);
  uv_signal_init(&c->loop, &c->sigterm);
  c->recv_poll.data = c->send_poll.data = c->tick.data = c->stop_check.data = c->sigint.data = c->sigterm.data = c;
  uv_poll_start(&c->recv_poll, UV_READABLE, on_readable);
  /* From the start: a stall before the first tick (a coordinator stopped right after it
   * began to serve) is as much its own as any later one. */
  c->last_tick_at = vf_seconds_now();
  uv_timer_start(&c->tick, on_tick, TICK_MS, TICK_MS);
  if (c->stop) uv_timer_start(&c->stop_check, on_stop_check, STOP_CHECK_MS, STOP_CHECK_MS);
  if (config->handle_signals) {
    uv_signal_start(&c->sigint, on_signal, SIGINT);
    uv_signal_start(&c->sigterm, on_signal, SIGTERM);
  }
  if (config->http_address &&
      (err = vf_dashboard_start(&c->farm, &c->loop, &c->key, config->http_address, config->status_json,
                                &c->dashboard)) != VF_OK) {
    vf_merger_stop(merger);
    c->farm.merger = NULL;
    goto close_loop;
  }
  c->last_checkpoint = vf_seconds_now();
  vf_log("listening on %s, state in %s, %zu job%s, worker timeout %.1f s", config->listen_url, config->state_dir,
         c->farm.num_jobs, c->farm.num_jobs == 1 ? "" : "s", config->worker_timeout);
  if (c->gate) {
    const vf_gate_limits *l = vf_gate_get_limits(c->gate);
    vf_log("tcp: port %d, at most %zu connections and %.0f MiB of requests in flight (and %.0f MiB of small ones)",
           vf_gate_port(c->gate), l->max_connections, (double)l->max_bytes / 1048576.0,
           (double)l->max_small_bytes / 1048576.0);
  }

  uv_run(&c->loop, UV_RUN_DEFAULT);

  /* Stopping: answer nobody any more, let the checkpoints in flight land, then write every
   * film and the job list here, on this thread, as the last word. */
  uv_poll_stop(&c->recv_poll);
  uv_poll_stop(&c->send_poll);
  uv_timer_stop(&c->tick);
  uv_timer_stop(&c->stop_check);
  vf_dashboard_stop(c->dashboard);
  while (vf_merger_pending(merger) > 0) uv_run(&c->loop, UV_RUN_ONCE); /* their replies still go out */
  vf_merger_stop(merger);
  c->farm.merger = NULL;
  while (vf_checkpoint_pending(&c->farm) > 0) uv_run(&c->loop, UV_RUN_ONCE);
  c->farm.checkpoint_loop = NULL;
  if ((err = vf_farm_checkpoint(&c->farm, 1)) == VF_OK) vf_log("checkpoint written; bye");
close_loop:
  vf_gate_close(c->gate); /* its connections' memory is freed by the callbacks of the run below */
  uv_walk(&c->loop, close_handle, NULL);
  uv_run(&c->loop, UV_RUN_DEFAULT);
  vf_gate_destroy(c->gate);
  vf_dashboard_destroy(c->dashboard);
  uv_loop_close(&c->loop);
close_socket:
  nn_close(c->socket);
  remove_gate_dir(c);
  while (c->pending != NULL) drop_pending(c);
unlock:
  close(c->farm.state_lock_fd);
free_farm:
  vf_replay_destroy(c->replay);
  vf_farm_destroy(&c->farm);
  free(c);
  return err;
}
