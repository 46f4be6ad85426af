/* The coordinator's TCP front (coordinator/gate.h): what it forwards and what it bounds.
 *
 * One thread drives everything: the gate's libuv loop, a raw nanomsg REP socket behind it
 * that echoes every request (and drops those whose body starts with 'X', as the
 * coordinator drops what fails authentication), nanomsg REQ clients speaking SP over TCP as
 * workers do, and plain TCP sockets that behave as hostile peers: too many connections,
 * messages announced and never finished, sizes above the cap, wrong protocol headers,
 * replies left unread. */
#include "check.h"
#include "coordinator/gate.h"
#include "common/clock.h"

#include <errno.h>
#include <fcntl.h>
#include <nanomsg/nn.h>
#include <nanomsg/reqrep.h>
#include <netinet/in.h>
#include <stdint.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <unistd.h>
#include <uv.h>

#define MIB ((size_t)1 << 20)

typedef struct {
  uv_loop_t loop;
  vf_gate *gate;
  int rep;
  char dir[64], path[96], url[64];
} rig;

static vf_gate_limits small_limits(void) {
  vf_gate_limits l = vf_gate_defaults(MIB + 64, 8 * MIB);
  l.max_connections = 8;
  l.max_bytes = 3 * MIB;
  l.handshake_seconds = 0.5;
  l.stall_seconds = 0.5;
  l.answer_seconds = 0.7;
  return l;
}

static int rig_open(rig *r, const vf_gate_limits *limits) {
  memset(r, 0, sizeof *r);
  snprintf(r->dir, sizeof r->dir, "/tmp/vf-test-gate-XXXXXX");
  if (mkdtemp(r->dir) == NULL) return -1;
  snprintf(r->path, sizeof r->path, "%s/s", r->dir);
  char ipc[128];
  snprintf(ipc, sizeof ipc, "ipc://%s", r->path);
  r->rep = nn_socket(AF_SP_RAW, NN_REP);
  int unlimited = -1;
  nn_setsockopt(r->rep, NN_SOL_SOCKET, NN_RCVMAXSIZE, &unlimited, sizeof unlimited);
  if (r->rep < 0 || nn_bind(r->rep, ipc) < 0) return -1;
  uv_loop_init(&r->loop);
  if (vf_gate_start(&r->loop, "tcp://127.0.0.1:0", r->path, limits, &r->gate) != 0) return -1;
  snprintf(r->url, sizeof r->url, "tcp://127.0.0.1:%d", vf_gate_port(r->gate));
  return 0;
}

static void rig_close(rig *r) {
  vf_gate_close(r->gate);
  uv_run(&r->loop, UV_RUN_DEFAULT);
  vf_gate_destroy(r->gate);
  uv_loop_close(&r->loop);
  nn_close(r->rep);
  unlink(r->path);
  rmdir(r->dir);
}

/* The coordinator's part: echo each request to its sender, drop those starting with 'X'. */
static void serve(rig *r) {
  for (;;) {
    void *body = NULL, *control = NULL;
    struct nn_iovec iov = {&body, NN_MSG};
    struct nn_msghdr hdr = {&iov, 1, &control, NN_MSG};
    int n = nn_recvmsg(r->rep, &hdr, NN_DONTWAIT);
    if (n < 0) return;
    if (n > 0 && ((char *)body)[0] == 'X') {
      nn_freemsg(body);
      nn_freemsg(control);
      continue;
    }
    struct nn_iovec out = {&body, NN_MSG};
    struct nn_msghdr reply = {&out, 1, &control, NN_MSG};
    if (nn_sendmsg(r->rep, &reply, NN_DONTWAIT) < 0) {
      nn_freemsg(body);
      nn_freemsg(control);
    }
  }
}

static void pump(rig *r, double seconds) {
  double end = vf_seconds_now() + seconds;
  do {
    uv_run(&r->loop, UV_RUN_NOWAIT);
    serve(r);
    usleep(500);
  } while (vf_seconds_now() < end);
}

static vf_gate_stats stats(rig *r) {
  vf_gate_stats s;
  vf_gate_get_stats(r->gate, &s);
  return s;
}

/* ---- clients ---- */

static int req_open(rig *r) {
  int s = nn_socket(AF_SP, NN_REQ);
  int unlimited = -1;
  nn_setsockopt(s, NN_SOL_SOCKET, NN_RCVMAXSIZE, &unlimited, sizeof unlimited);
  nn_connect(s, r->url);
  return s;
}

/* A request and its echo through the gate: 1 when the echo came back equal in time. */
static int req_call(rig *r, int s, const uint8_t *data, size_t len, double timeout) {
  if (nn_send(s, data, len, 0) != (int)len) return 0;
  double end = vf_seconds_now() + timeout;
  while (vf_seconds_now() < end) {
    pump(r, 0.001);
    void *buf = NULL;
    int n = nn_recv(s, &buf, NN_MSG, NN_DONTWAIT);
    if (n < 0) continue;
    int same = (size_t)n == len && memcmp(buf, data, len) == 0;
    nn_freemsg(buf);
    return same;
  }
  return 0;
}

/* A plain TCP connection to the gate, non-blocking, after `hello` bytes of a REQ's
 * protocol header (8: all of it); with a receive buffer of `rcvbuf` bytes unless 0. */
static int raw_open_rcvbuf(rig *r, size_t hello, int rcvbuf) {
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (rcvbuf > 0) setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
  struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons((uint16_t)vf_gate_port(r->gate)),
                          .sin_addr.s_addr = htonl(INADDR_LOOPBACK)};
  if (connect(fd, (struct sockaddr *)&a, sizeof a) != 0) {
    close(fd);
    return -1;
  }
  fcntl(fd, F_SETFL, O_NONBLOCK);
  static const uint8_t req_hello[8] = {0, 'S', 'P', 0, 0, NN_REQ, 0, 0};
  if (hello > 0 && write(fd, req_hello, hello) != (ssize_t)hello) {
    close(fd);
    return -1;
  }
  return fd;
}

static int raw_open(rig *r, size_t hello) { return raw_open_rcvbuf(r, hello, 0); }

/* Writes all of data, running the rig while the socket is full; 0 when the gate closed it
 * or it stayed full for `timeout` seconds. */
static int raw_send(rig *r, int fd, const void *data, size_t len, double timeout) {
  const uint8_t *p = data;
  double end = vf_seconds_now() + timeout;
  while (len > 0) {
    ssize_t w = send(fd, p, len, MSG_NOSIGNAL);
    if (w > 0) {
      p += w, len -= (size_t)w;
      continue;
    }
    if (w < 0 && errno != EAGAIN) return 0;
    if (vf_seconds_now() > end) return 0;
    pump(r, 0.001);
  }
  return 1;
}

static void put_be64(uint8_t *p, uint64_t v) {
  for (int i = 7; i >= 0; i--, v >>= 8) p[i] = (uint8_t)v;
}

/* The header of a message of `size` bytes, and `sent` of its bytes: a REQ request id then
 * filler. */
static int raw_message(rig *r, int fd, uint64_t size, size_t sent, uint32_t id) {
  uint8_t header[8];
  put_be64(header, size);
  if (!raw_send(r, fd, header, 8, 2.0)) return 0;
  uint8_t *body = calloc(1, sent + 4);
  body[0] = (uint8_t)(0x80 | id >> 24), body[1] = (uint8_t)(id >> 16), body[2] = (uint8_t)(id >> 8),
  body[3] = (uint8_t)id;
  if (sent > 4) body[4] = 'X'; /* dropped by the echo, when it gets there */
  int ok = raw_send(r, fd, body, sent, 2.0);
  free(body);
  return ok;
}

/* 1 once the gate has closed fd (end of stream or reset), within `timeout` seconds. */
static int raw_closed(rig *r, int fd, double timeout) {
  double end = vf_seconds_now() + timeout;
  uint8_t buf[4096];
  while (vf_seconds_now() < end) {
    ssize_t n = recv(fd, buf, sizeof buf, 0);
    if (n == 0 || (n < 0 && errno != EAGAIN)) return 1;
    if (n < 0) pump(r, 0.002);
  }
  return 0;
}

/* ---- cases ---- */

static void test_requests_and_replies_pass_unchanged(void) {
  rig r;
  vf_gate_limits l = small_limits();
  l.max_message = 4 * MIB + 64;
  l.max_bytes = 16 * MIB;
  CHECK(rig_open(&r, &l) == 0);
  int s = req_open(&r);
  uint8_t small[] = "heartbeat";
  CHECK(req_call(&r, s, small, sizeof small, 5.0));
  size_t big = 4 * MIB; /* as large as a request may be, with nanomsg's 4-byte header */
  uint8_t *data = malloc(big);
  for (size_t i = 0; i < big; i++) data[i] = (uint8_t)(i * 2654435761u >> 24);
  for (int i = 0; i < 3; i++) CHECK(req_call(&r, s, data, big, 10.0));
  free(data);
  pump(&r, 0.05);
  vf_gate_stats st = stats(&r);
  CHECK_INT_EQ(st.forwarded, 4);
  CHECK_INT_EQ(st.answered, 4);
  CHECK_INT_EQ(st.bytes_reserved, 0); /* every request answered: all room back */
  CHECK_INT_EQ(st.connections, 1);
  nn_close(s);
  rig_close(&r);
}

/* A farm starting: 200 workers connect at once. nanomsg accepts unix connections with a
 * backlog of 10; the gate passes connections on a few at a time, and every worker is
 * answered. */
static void test_a_burst_of_connections_is_served(void) {
  rig r;
  vf_gate_limits l = small_limits();
  l.max_connections = 256;
  CHECK(rig_open(&r, &l) == 0);
  enum { N = 200 };
  int s[N], answered = 0;
  for (int i = 0; i < N; i++) {
    s[i] = req_open(&r);
    char q[32];
    int len = snprintf(q, sizeof q, "register %d", i);
    nn_send(s[i], q, (size_t)len, 0);
  }
  double end = vf_seconds_now() + 20.0;
  int got[N] = {0};
  while (answered < N && vf_seconds_now() < end) {
    pump(&r, 0.001);
    for (int i = 0; i < N; i++) {
      void *buf = NULL;
      if (got[i] || nn_recv(s[i], &buf, NN_MSG, NN_DONTWAIT) < 0) continue;
      got[i] = 1;
      answered++;
      nn_freemsg(buf);
    }
  }
  CHECK_INT_EQ(answered, N);
  vf_gate_stats st = stats(&r);
  CHECK_INT_EQ(st.connections, N);
  printf("     %d workers connected at once: %d answered, peak %zu connections\n", N, answered, st.peak_connections);
  for (int i = 0; i < N; i++) nn_close(s[i]);
  rig_close(&r);
}

static void test_connections_beyond_the_cap_are_refused(void) {
  rig r;
  vf_gate_limits l = small_limits();
  l.max_connections = 4;
  CHECK(rig_open(&r, &l) == 0);
  int fds[4];
  for (int i = 0; i < 4; i++) fds[i] = raw_open(&r, 8);
  pump(&r, 0.1);
  CHECK_INT_EQ(stats(&r).connections, 4);
  int extra = raw_open(&r, 8);
  CHECK(extra >= 0 && raw_closed(&r, extra, 2.0));
  CHECK_INT_EQ(stats(&r).refused_at_cap, 1);
  CHECK_INT_EQ(stats(&r).connections, 4);
  for (int i = 0; i < 4; i++) CHECK(!raw_closed(&r, fds[i], 0.01)); /* the first four are served */
  /* A worker arriving at the cap gets through once a connection leaves: nanomsg connects
   * again by itself. */
  int s = req_open(&r);
  pump(&r, 0.3);
  close(fds[0]);
  uint8_t q[] = "lease?";
  CHECK(req_call(&r, s, q, sizeof q, 5.0));
  CHECK(stats(&r).connections <= 4);
  nn_close(s);
  for (int i = 1; i < 4; i++) close(fds[i]);
  close(extra);
  rig_close(&r);
}

static void test_bytes_in_flight_are_bounded(void) {
  rig r;
  vf_gate_limits l = small_limits(); /* 3 MiB in flight, messages of 1 MiB and 64 bytes */
  CHECK(rig_open(&r, &l) == 0);
  /* Three peers announce a message of 1 MiB and send half of it: all the room is taken. */
  int fds[4];
  for (int i = 0; i < 3; i++) {
    fds[i] = raw_open(&r, 8);
    CHECK(raw_message(&r, fds[i], MIB, MIB / 2, (uint32_t)i));
  }
  pump(&r, 0.1);
  CHECK_INT_EQ(stats(&r).bytes_reserved, 3 * MIB);
  /* A fourth waits, unread; a worker's small request does not wait behind it. */
  fds[3] = raw_open(&r, 8);
  CHECK(raw_message(&r, fds[3], MIB, 0, 3));
  pump(&r, 0.05);
  int s = req_open(&r);
  uint8_t q[] = "heartbeat";
  double asked = vf_seconds_now();
  CHECK(req_call(&r, s, q, sizeof q, 5.0));
  CHECK(vf_seconds_now() - asked < l.stall_seconds); /* answered while the large lane is full */
  vf_gate_stats st = stats(&r);
  CHECK_INT_EQ(st.waiting, 1);
  CHECK_INT_EQ(st.bytes_reserved, 3 * MIB);
  CHECK(st.peak_bytes_reserved <= l.max_bytes + l.max_small_bytes);
  /* The stalled three are cut off after stall_seconds; their room goes to the fourth, which
   * is cut off in its turn. */
  for (int i = 0; i < 3; i++) CHECK(raw_closed(&r, fds[i], 2.0));
  pump(&r, 0.05);
  st = stats(&r);
  CHECK_INT_EQ(st.waiting, 0);
  CHECK_INT_EQ(st.bytes_reserved, MIB);
  CHECK(raw_closed(&r, fds[3], 2.0));
  st = stats(&r);
  CHECK_INT_EQ(st.closed_for_time, 4);
  CHECK_INT_EQ(st.bytes_reserved, 0);
  nn_close(s);
  for (int i = 0; i < 4; i++) close(fds[i]);
  rig_close(&r);
}

static void test_small_requests_have_a_bounded_lane(void) {
  rig r;
  vf_gate_limits l = small_limits();
  l.max_small_bytes = 4 * l.small_message;
  CHECK(rig_open(&r, &l) == 0);
  int fds[5];
  for (int i = 0; i < 5; i++) {
    fds[i] = raw_open(&r, 8);
    CHECK(raw_message(&r, fds[i], l.small_message, 100, (uint32_t)i));
  }
  pump(&r, 0.1);
  vf_gate_stats st = stats(&r);
  CHECK_INT_EQ(st.bytes_reserved, 4 * l.small_message);
  CHECK_INT_EQ(st.waiting, 1);
  /* A message that trickles (a byte every 0.3 s, under stall_seconds) is cut off when
   * its whole-message deadline passes: stall_seconds + size / min_rate. */
  vf_gate_limits slow = small_limits();
  slow.min_rate = 64.0 * 1024.0; /* 1 MiB in 16 s: 16.5 s for a 1 MiB message */
  for (int i = 0; i < 5; i++) close(fds[i]);
  rig_close(&r);
  CHECK(rig_open(&r, &slow) == 0);
  int fd = raw_open(&r, 8);
  CHECK(raw_message(&r, fd, 65536, 4, 9)); /* 64 KiB: 1.5 s allowed */
  double start = vf_seconds_now();
  uint8_t byte = 0;
  int closed = 0;
  while (!closed && vf_seconds_now() - start < 4.0) {
    send(fd, &byte, 1, MSG_NOSIGNAL);
    closed = raw_closed(&r, fd, 0.3);
  }
  double took = vf_seconds_now() - start;
  CHECK(closed);
  CHECK(took > 1.2 && took < 2.5);
  CHECK_INT_EQ(stats(&r).closed_for_time, 1);
  close(fd);
  rig_close(&r);
}

static void test_unanswered_requests_give_their_room_back(void) {
  rig r;
  vf_gate_limits l = small_limits();
  CHECK(rig_open(&r, &l) == 0);
  /* Whole messages the coordinator drops (as it drops what fails authentication): each
   * holds its room until answer_seconds. */
  int fd = raw_open(&r, 8);
  CHECK(raw_message(&r, fd, MIB, MIB, 1));
  CHECK(raw_message(&r, fd, MIB, MIB, 2));
  pump(&r, 0.2);
  vf_gate_stats st = stats(&r);
  CHECK_INT_EQ(st.forwarded, 2);
  CHECK_INT_EQ(st.bytes_reserved, 2 * MIB);
  pump(&r, 0.8);
  st = stats(&r);
  CHECK_INT_EQ(st.answers_given_up, 2);
  CHECK_INT_EQ(st.bytes_reserved, 0);
  CHECK(!raw_closed(&r, fd, 0.01)); /* not a reason to close */
  close(fd);
  rig_close(&r);
}

static void test_bad_framing_and_silence_are_cut_off(void) {
  rig r;
  vf_gate_limits l = small_limits();
  CHECK(rig_open(&r, &l) == 0);
  /* a size above the cap: closed at its header, nothing reserved */
  int big = raw_open(&r, 8);
  uint8_t header[8];
  put_be64(header, l.max_message + 1);
  CHECK(raw_send(&r, big, header, 8, 1.0));
  CHECK(raw_closed(&r, big, 2.0));
  CHECK_INT_EQ(stats(&r).closed_for_size, 1);
  /* the protocol header of another socket type (PUB, 2 * 16) */
  int fd = raw_open(&r, 0);
  uint8_t pub[8] = {0, 'S', 'P', 0, 0, 32, 0, 0};
  CHECK(raw_send(&r, fd, pub, 8, 1.0));
  CHECK(raw_closed(&r, fd, 2.0));
  CHECK_INT_EQ(stats(&r).closed_for_framing, 1);
  /* half a protocol header, then nothing: closed after handshake_seconds */
  int mute = raw_open(&r, 4);
  CHECK(!raw_closed(&r, mute, 0.2));
  CHECK(raw_closed(&r, mute, 2.0));
  /* a message header cut in the middle: after stall_seconds */
  int cut = raw_open(&r, 8);
  CHECK(raw_send(&r, cut, header, 3, 1.0));
  CHECK(raw_closed(&r, cut, 2.0));
  CHECK_INT_EQ(stats(&r).closed_for_time, 2);
  CHECK_INT_EQ(stats(&r).bytes_reserved, 0);
  pump(&r, 0.05);
  CHECK_INT_EQ(stats(&r).connections, 0);
  close(big), close(fd), close(mute), close(cut);
  rig_close(&r);
}

static void test_replies_left_unread_close_the_connection(void) {
  rig r;
  vf_gate_limits l = small_limits();
  l.max_bytes = 16 * MIB;
  l.max_unsent = 2 * MIB;
  CHECK(rig_open(&r, &l) == 0);
  int fd = raw_open_rcvbuf(&r, 8, 4096);
  CHECK(fd >= 0);
  /* Eight echoed requests of 1 MiB, none of their replies read. */
  uint8_t header[8];
  put_be64(header, MIB);
  uint8_t *body = calloc(1, MIB);
  int sent = 1;
  for (uint32_t i = 0; i < 8 && sent; i++) {
    body[0] = 0x80, body[3] = (uint8_t)i;
    sent = raw_send(&r, fd, header, 8, 2.0) && raw_send(&r, fd, body, MIB, 2.0);
  }
  free(body);
  pump(&r, 0.3);
  CHECK_INT_EQ(stats(&r).closed_for_unread, 1);
  CHECK_INT_EQ(stats(&r).connections, 0);
  close(fd);
  rig_close(&r);
}

/* Peers that send what they like and leave at any moment: afterwards nothing is held.
 * Random streams after a valid protocol header, most with a small random size first so that
 * some messages are whole and reach the echo, some cut short, some of sizes above the cap. */
static void test_random_streams_leave_nothing_behind(void) {
  rig r;
  vf_gate_limits l = small_limits();
  l.max_connections = 64;
  CHECK(rig_open(&r, &l) == 0);
  uint64_t state = 0x9e3779b97f4a7c15ull;
#define NEXT() (state ^= state << 13, state ^= state >> 7, state ^= state << 17, state)
  for (int round = 0; round < 8; round++) {
    int fds[40];
    for (int i = 0; i < 40; i++) {
      fds[i] = raw_open(&r, NEXT() % 4 == 0 ? NEXT() % 8 : 8);
      if (fds[i] < 0) continue;
      uint8_t buf[3000];
      for (size_t k = 0; k < sizeof buf; k++) buf[k] = (uint8_t)NEXT();
      size_t len = NEXT() % sizeof buf;
      if (NEXT() % 2 == 0 && len >= 12) { /* a plausible message: size, REQ id, body */
        uint64_t size = NEXT() % 3 == 0 ? NEXT() : len - 8 - NEXT() % 4;
        put_be64(buf, size);
        buf[8] |= 0x80;
      }
      raw_send(&r, fds[i], buf, len, 0.2);
    }
    pump(&r, 0.05);
    for (int i = 0; i < 40; i++)
      if (fds[i] >= 0) close(fds[i]);
  }
#undef NEXT
  pump(&r, 1.0); /* unanswered requests give their room back after answer_seconds */
  vf_gate_stats st = stats(&r);
  CHECK_INT_EQ(st.connections, 0);
  CHECK_INT_EQ(st.bytes_reserved, 0);
  CHECK_INT_EQ(st.waiting, 0);
  CHECK(st.forwarded > 0); /* some messages were whole */
  CHECK(st.closed_for_size > 0);
  printf("     320 random peers: %llu messages forwarded, %llu answered, %llu closed for size, %llu for framing\n",
         (unsigned long long)st.forwarded, (unsigned long long)st.answered, (unsigned long long)st.closed_for_size,
         (unsigned long long)st.closed_for_framing);
  rig_close(&r);
}

static void test_a_port_in_use_and_bad_urls_are_refused(void) {
  rig r;
  vf_gate_limits l = small_limits();
  CHECK(rig_open(&r, &l) == 0);
  vf_gate *other = NULL;
  CHECK(vf_gate_start(&r.loop, r.url, r.path, &l, &other) != 0);
  CHECK(other == NULL);
  CHECK(vf_gate_start(&r.loop, "tcp://127.0.0.1", r.path, &l, &other) != 0);
  CHECK(vf_gate_start(&r.loop, "tcp://127.0.0.1:70000", r.path, &l, &other) != 0);
  CHECK(vf_gate_start(&r.loop, "tcp://no-such-host.invalid:1", r.path, &l, &other) != 0);
  rig_close(&r); /* runs the failed gates' closing too */
}

int main(void) {
  RUN(test_requests_and_replies_pass_unchanged);
  RUN(test_a_burst_of_connections_is_served);
  RUN(test_connections_beyond_the_cap_are_refused);
  RUN(test_bytes_in_flight_are_bounded);
  RUN(test_small_requests_have_a_bounded_lane);
  RUN(test_unanswered_requests_give_their_room_back);
  RUN(test_bad_framing_and_silence_are_cut_off);
  RUN(test_replies_left_unread_close_the_connection);
  RUN(test_random_streams_leave_nothing_behind);
  RUN(test_a_port_in_use_and_bad_urls_are_refused);
  return check_finish();
}
