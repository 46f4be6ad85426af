#include "farm_client.h"

#include "clock.h"
#include "error.h"

#include <errno.h>
#include <limits.h>
#include <nanomsg/nn.h>
#include <nanomsg/reqrep.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

struct vf_farm_client {
  int socket, endpoint;
  vf_wire_key key;
  char *url; /* owned */
};

int vf_farm_client_open(const char *url, const vf_wire_key *key, vf_farm_client **out) {
  int err;
  vf_farm_client *c = calloc(1, sizeof *c);
  if (c == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  if ((c->url = strdup(url)) == NULL) {
    err = vf_error_set(VF_ENOMEM, "out of memory");
    goto free_client;
  }
  c->key = *key;
  if ((c->socket = nn_socket(AF_SP, NN_REQ)) < 0) {
    err = vf_error_set(VF_ENET, "nanomsg socket: %s", nn_strerror(nn_errno()));
    goto free_url;
  }
  int max_size = (int)VF_WIRE_MAX_FRAME, ivl_max = 5000, resend = INT_MAX, linger = 1000;
  nn_setsockopt(c->socket, NN_SOL_SOCKET, NN_RCVMAXSIZE, &max_size, sizeof max_size);
  nn_setsockopt(c->socket, NN_SOL_SOCKET, NN_RECONNECT_IVL_MAX, &ivl_max, sizeof ivl_max);
  nn_setsockopt(c->socket, NN_SOL_SOCKET, NN_LINGER, &linger, sizeof linger);
  /* We resend ourselves after a timeout, as a new frame; nanomsg's own resend (of the same
   * frame: a replay, which the coordinator refuses) is put off for 24 days. nanomsg also
   * resends a request whose connection broke; the coordinator refuses that too, unless it
   * restarted meanwhile, and our call times out and is made again. */
  nn_setsockopt(c->socket, NN_REQ, NN_REQ_RESEND_IVL, &resend, sizeof resend);
  if ((c->endpoint = nn_connect(c->socket, url)) < 0) {
    err = vf_error_set(VF_ENET, "%s: %s", url, nn_strerror(nn_errno()));
    goto close_socket;
  }
  *out = c;
  return VF_OK;
close_socket:
  nn_close(c->socket);
free_url:
  free(c->url);
free_client:
  free(c);
  return err;
}

void vf_farm_client_close(vf_farm_client *client) {
  if (client == NULL) return;
  nn_close(client->socket);
  free(client->url);
  free(client);
}

const char *vf_farm_client_url(const vf_farm_client *client) { return client->url; }

/* One of the socket's connection statistics, 0 when nanomsg cannot say. */
static uint64_t statistic(const vf_farm_client *c, int which) {
  uint64_t v = nn_get_statistic(c->socket, which);
  return v == (uint64_t)-1 ? 0 : v;
}

/* While nothing accepts connections, nanomsg tries again after 0.1, 0.3, 0.7 s... (its
 * backoff); the wait connects anew every RECONNECT_MS instead, so that a coordinator that
 * starts meanwhile is found at once. */
#define RECONNECT_MS 50

int vf_farm_client_wait_connected(vf_farm_client *c, int timeout_ms) {
  const struct timespec step = {0, 5000000L};
  double start = vf_seconds_now(), attempt = start;
  for (;;) {
    if (statistic(c, NN_STAT_CURRENT_CONNECTIONS) > 0) return VF_OK;
    double now = vf_seconds_now(), waited_ms = (now - start) * 1000.0;
    /* Something listens when a connection is being made or was made (a handshake, a
     * coordinator's gate at its cap): then only the caller's timeout ends the wait. */
    int listener =
        statistic(c, NN_STAT_INPROGRESS_CONNECTIONS) > 0 || statistic(c, NN_STAT_ESTABLISHED_CONNECTIONS) > 0;
    if (!listener && (waited_ms >= VF_FARM_CONNECT_MS || waited_ms >= timeout_ms))
      return vf_error_set(VF_ENET, "no coordinator answered at %s (nothing accepts connections there)", c->url);
    if (waited_ms >= timeout_ms)
      return vf_error_set(VF_ETIMEDOUT, "no coordinator answered at %s within %d ms (the connection did not complete)",
                          c->url, timeout_ms);
    if (!listener && (now - attempt) * 1000.0 >= RECONNECT_MS) {
      nn_shutdown(c->socket, c->endpoint);
      if ((c->endpoint = nn_connect(c->socket, c->url)) < 0)
        return vf_error_set(VF_ENET, "%s: %s", c->url, nn_strerror(nn_errno()));
      attempt = now;
    }
    nanosleep(&step, NULL);
  }
}

static int call_once(vf_farm_client *c, Vcmfarm__Envelope *request, int timeout_ms, Vcmfarm__Envelope **reply) {
  uint8_t *frame;
  size_t len;
  vf_wire_stamp stamp;
  int err = vf_message_pack(&c->key, NULL, request, &frame, &len, &stamp);
  if (err != VF_OK) return err;
  nn_setsockopt(c->socket, NN_SOL_SOCKET, NN_SNDTIMEO, &timeout_ms, sizeof timeout_ms);
  nn_setsockopt(c->socket, NN_SOL_SOCKET, NN_RCVTIMEO, &timeout_ms, sizeof timeout_ms);
  int sent = nn_send(c->socket, frame, len, 0);
  free(frame);
  if (sent < 0) {
    int e = nn_errno();
    if (e == ETIMEDOUT || e == EAGAIN) return vf_error_set(VF_ETIMEDOUT, "%s: could not send within %d ms", c->url, timeout_ms);
    return vf_error_set(VF_ENET, "%s: send: %s", c->url, nn_strerror(e));
  }
  void *buf = NULL;
  int n = nn_recv(c->socket, &buf, NN_MSG, 0);
  if (n < 0) {
    int e = nn_errno();
    if (e == ETIMEDOUT || e == EAGAIN || e == EINTR)
      return vf_error_set(e == EINTR ? VF_ENET : VF_ETIMEDOUT,
                          "%s: no reply within %d ms (is the coordinator running? one that predates key "
                          "refusals also stays silent to a wrong key)",
                          c->url, timeout_ms);
    return vf_error_set(VF_ENET, "%s: receive: %s", c->url, nn_strerror(e));
  }
  if (vf_wire_is_refusal(buf, (size_t)n)) {
    nn_freemsg(buf);
    return vf_error_set(VF_EAUTH, "the coordinator at %s refused the key (wrong --secret?)", c->url);
  }
  Vcmfarm__Envelope *env;
  err = vf_message_unpack(&c->key, &stamp, buf, (size_t)n, &env, NULL);
  nn_freemsg(buf);
  if (err != VF_OK) return err;
  *reply = env;
  return VF_OK;
}

/* A coordinator refuses requests sent before it started (it keeps no nonce across a
 * restart, docs/PROTOCOL.md, "Freshness") and asks for them again: a request queued while
 * it started, or in flight across its restart, is sent again at once as a new frame. */
#define RESENDS_MAX 3

int vf_farm_call(vf_farm_client *c, Vcmfarm__Envelope *request, int timeout_ms, Vcmfarm__Envelope **reply) {
  for (int attempt = 0;; attempt++) {
    Vcmfarm__Envelope *env = NULL;
    int err = call_once(c, request, timeout_ms, &env);
    if (err != VF_OK) return err;
    if (attempt < RESENDS_MAX && env->body_case == VCMFARM__ENVELOPE__BODY_ERROR &&
        env->error->code == VCMFARM__ERROR_CODE__ERROR_RESEND) {
      vf_message_free(env);
      continue;
    }
    *reply = env;
    return VF_OK;
  }
}

/* The code of a coordinator's Error, as our callers tell them apart: a version mismatch, a
 * job that does not exist (a user's mistake: the command line named it), every other
 * refusal. */
static int error_code(Vcmfarm__ErrorCode code) {
  switch (code) {
  case VCMFARM__ERROR_CODE__ERROR_VERSION: return VF_EVERSION;
  case VCMFARM__ERROR_CODE__ERROR_UNKNOWN_JOB: return VF_ENOJOB;
  default: return VF_EREFUSED;
  }
}

int vf_farm_request(vf_farm_client *c, Vcmfarm__Envelope *request, Vcmfarm__Envelope__BodyCase expected,
                    int timeout_ms, Vcmfarm__Envelope **reply) {
  Vcmfarm__Envelope *env = NULL;
  int err = vf_farm_call(c, request, timeout_ms, &env);
  if (err != VF_OK) return err;
  if (env->body_case == VCMFARM__ENVELOPE__BODY_ERROR) {
    err = vf_error_set(error_code(env->error->code), "%s: coordinator refused the %s: %s", c->url,
                       vf_message_name(request), env->error->message);
  } else if (env->body_case != expected) {
    err = vf_error_set(VF_EPROTO, "%s: coordinator answered the %s with a %s", c->url, vf_message_name(request),
                       vf_message_name(env));
  }
  if (err != VF_OK) {
    vf_message_free(env);
    return err;
  }
  *reply = env;
  return VF_OK;
}
