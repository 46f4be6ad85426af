/* Helper of test_farm.sh (not a test by itself): a hostile or confused peer.
 *
 *   farm_peer URL KEYFILE
 *
 * Run while the coordinator at URL has one queued job and no worker. Sends a frame under
 * another key, a frame of another protocol version, garbage, a frame whose header claims
 * an oversized payload, raw bytes below the nanomsg protocol (ipc:// only), and then, as
 * a registered worker holding a lease, results that do not match it (tiles whose chunk is
 * cut short, holds a NaN, or lies outside the film; another film size, other settings,
 * another range; a message above the result size cap). Checks each is refused as
 * docs/PROTOCOL.md says, hands the lease back, and that the coordinator still answers.
 * Exit status 0 when every expectation held. */
#include "common/error.h"
#include "common/farm_client.h"
#include "common/film_wire.h"
#include "common/message.h"
#include "common/settings.h"

#include <errno.h>
#include <math.h>
#include <nanomsg/nn.h>
#include <nanomsg/reqrep.h>
#include <sodium.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

static int failures;

static void expect(int cond, const char *what) {
  printf("%s %s\n", cond ? "ok  " : "FAIL", what);
  if (!cond) failures++;
}

/* Sends raw bytes on a fresh REQ socket; returns the reply length (reply in *out, nn_freemsg)
 * or -1 when nothing came within timeout_ms. */
static int raw_exchange(const char *url, const void *bytes, size_t len, int timeout_ms, void **out) {
  int s = nn_socket(AF_SP, NN_REQ);
  nn_setsockopt(s, NN_SOL_SOCKET, NN_RCVTIMEO, &timeout_ms, sizeof timeout_ms);
  nn_connect(s, url);
  nn_send(s, bytes, len, 0);
  void *buf = NULL;
  int n = nn_recv(s, &buf, NN_MSG, 0);
  if (n >= 0) *out = buf;
  nn_close(s);
  return n;
}

static void put_u32(uint8_t *p, uint32_t v) {
  p[0] = (uint8_t)(v >> 24);
  p[1] = (uint8_t)(v >> 16);
  p[2] = (uint8_t)(v >> 8);
  p[3] = (uint8_t)v;
}

/* A frame built by hand: any version, any claimed length, tag under `key`. */
static uint8_t *hand_frame(const uint8_t *key, uint32_t version, const uint8_t *payload, uint32_t len,
                           uint32_t claimed, size_t *frame_len) {
  uint8_t *f = malloc(12 + len + 32);
  memcpy(f, "VCMF", 4);
  put_u32(f + 4, version);
  put_u32(f + 8, claimed);
  memcpy(f + 12, payload, len);
  crypto_auth(f + 12 + len, f, 12 + len, key);
  *frame_len = 12 + len + 32;
  return f;
}

static void test_frames(const char *url, const vf_wire_key *key) {
  Vcmfarm__StatusRequest sr = VCMFARM__STATUS_REQUEST__INIT;
  Vcmfarm__Envelope env = VCMFARM__ENVELOPE__INIT;
  env.body_case = VCMFARM__ENVELOPE__BODY_STATUS_REQUEST;
  env.status_request = &sr;
  env.protocol_version = VF_PROTOCOL_VERSION + 1;
  uint8_t payload[256];
  uint32_t plen = (uint32_t)vcmfarm__envelope__pack(&env, payload);
  void *reply = NULL;
  size_t len;

  uint8_t other_key[32];
  randombytes_buf(other_key, sizeof other_key);
  uint8_t *f = hand_frame(other_key, VF_PROTOCOL_VERSION, payload, plen, plen, &len);
  expect(raw_exchange(url, f, len, 500, &reply) < 0, "a frame under another key gets no answer");
  free(f);

  f = hand_frame(key->bytes, VF_PROTOCOL_VERSION + 1, payload, plen, plen, &len);
  int n = raw_exchange(url, f, len, 5000, &reply);
  free(f);
  Vcmfarm__Envelope *answer = NULL;
  int ok = n >= 0 && vf_message_unpack(key, reply, (size_t)n, &answer) == VF_OK &&
           answer->body_case == VCMFARM__ENVELOPE__BODY_ERROR &&
           answer->error->code == VCMFARM__ERROR_CODE__ERROR_VERSION && strstr(answer->error->message, "version");
  if (ok) printf("     coordinator says: %s\n", answer->error->message);
  expect(ok, "a frame of another protocol version is refused with a message naming the versions");
  vf_message_free(answer);
  if (n >= 0) nn_freemsg(reply);

  uint8_t garbage[200];
  randombytes_buf(garbage, sizeof garbage);
  expect(raw_exchange(url, garbage, sizeof garbage, 500, &reply) < 0, "garbage gets no answer");

  f = hand_frame(key->bytes, VF_PROTOCOL_VERSION, payload, plen, 0x7fffffffu, &len);
  expect(raw_exchange(url, f, len, 500, &reply) < 0, "a header claiming a 2 GiB payload gets no answer");
  free(f);

  f = hand_frame(key->bytes, VF_PROTOCOL_VERSION, garbage, sizeof garbage, sizeof garbage, &len);
  expect(raw_exchange(url, f, len, 500, &reply) < 0, "an authentic frame holding no Envelope gets no answer");
  free(f);

  if (strncmp(url, "ipc://", 6) == 0) {
    int s = socket(AF_UNIX, SOCK_STREAM, 0);
    struct sockaddr_un addr = {.sun_family = AF_UNIX};
    snprintf(addr.sun_path, sizeof addr.sun_path, "%s", url + 6);
    int connected = connect(s, (struct sockaddr *)&addr, sizeof addr) == 0;
    if (connected) connected = write(s, garbage, sizeof garbage) == (ssize_t)sizeof garbage;
    close(s);
    expect(connected, "raw bytes below the nanomsg protocol were delivered (and must be survived)");
  }
}

/* A film of the lease's job holding [begin, end), black. */
static vf_film *lease_film(const Vcmfarm__Lease *l, int width, int height, uint64_t begin, uint64_t end) {
  vf_film *film;
  if (vf_film_create(width, height, &film) != VF_OK) return NULL;
  memcpy(film->scene_hash, l->scene_hash.data, 32);
  snprintf(film->settings_text, sizeof film->settings_text, "%s", l->settings);
  float *zeros = calloc((size_t)width * (size_t)height * 3, sizeof *zeros);
  for (uint64_t k = begin; k < end; k++) vf_film_add_iteration(film, k, zeros, zeros, NULL);
  free(zeros);
  return film;
}

/* How a result is spoiled before it is sent. */
typedef enum { GOOD, SHORT_ARRAY, HALF_WIDTH, OTHER_SETTINGS, NAN_VALUE, TILE_OUTSIDE, OTHER_RANGE, OVERSIZED } spoil;

typedef struct {
  vf_farm_client *c;
  spoil how;
  const char *other_settings;
  char message[1024];
} sender;

static int send_spoiled(void *ctx, Vcmfarm__LeaseResult *m) {
  sender *s = ctx;
  Vcmfarm__Tile *t = m->n_tiles ? m->tiles[0] : NULL;
  ProtobufCBinaryData saved = t ? t->chunk : (ProtobufCBinaryData){0};
  uint8_t *spoilt = NULL;
  /* tile (0, 0) uncompressed: 12 FLOAT channels of w x h (docs/FILM.md, proto Tile) */
  size_t w = m->width < 64 ? m->width : 64, h = m->height < 64 ? m->height : 64, raw = 48 * w * h;
  float nan = NAN;
  switch (s->how) {
  case SHORT_ARRAY: t->chunk.len -= 1; break;
  case HALF_WIDTH: m->width /= 2; break;
  case OTHER_SETTINGS: m->settings = (char *)s->other_settings; break;
  case NAN_VALUE:
    if ((spoilt = calloc(raw, 1)) != NULL) memcpy(spoilt + 4 * 7, &nan, sizeof nan);
    t->chunk = (ProtobufCBinaryData){spoilt ? raw : 0, spoilt};
    break;
  case TILE_OUTSIDE: t->x = 1; break;
  case OTHER_RANGE: m->begin = m->end; m->end++; break;
  case OVERSIZED:
    spoilt = calloc(4800000, 1);
    t->chunk = (ProtobufCBinaryData){spoilt ? 4800000 : 0, spoilt};
    break;
  default: break;
  }
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_RESULT;
  q.result = m;
  int accepted = -1;
  if (vf_farm_request(s->c, &q, VCMFARM__ENVELOPE__BODY_RESULT_ACK, 10000, &reply) == VF_OK) {
    accepted = reply->result_ack->accepted;
    snprintf(s->message, sizeof s->message, "%s", reply->result_ack->message);
    vf_message_free(reply);
  }
  if (t) t->chunk = saved;
  free(spoilt);
  return accepted;
}

static int send_result(vf_farm_client *c, uint64_t worker_id, const Vcmfarm__Lease *l, const vf_film *film, spoil how,
                       const char *other_settings, char *message, size_t message_len) {
  Vcmfarm__LeaseResult m = VCMFARM__LEASE_RESULT__INIT;
  m.worker_id = worker_id;
  m.lease_id = l->lease_id;
  m.job_id = l->job_id;
  m.begin = l->begin;
  sender s = {c, how, other_settings, ""};
  int rc = vf_film_send_tiles(film, &m, 10, send_spoiled, &s);
  snprintf(message, message_len, "%s", s.message);
  return rc;
}

static void test_results(vf_farm_client *c) {
  Vcmfarm__Register reg = VCMFARM__REGISTER__INIT;
  reg.name = "farm_peer";
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply, *lease_reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_REGISTER;
  q.register_ = &reg;
  if (vf_farm_request(c, &q, VCMFARM__ENVELOPE__BODY_REGISTERED, 10000, &reply) != VF_OK) {
    expect(0, "register");
    return;
  }
  uint64_t worker_id = reply->registered->worker_id;
  vf_message_free(reply);
  Vcmfarm__LeaseRequest lr = VCMFARM__LEASE_REQUEST__INIT;
  lr.worker_id = worker_id;
  q.body_case = VCMFARM__ENVELOPE__BODY_LEASE_REQUEST;
  q.lease_request = &lr;
  if (vf_farm_request(c, &q, VCMFARM__ENVELOPE__BODY_LEASE, 10000, &lease_reply) != VF_OK) {
    expect(0, "a lease of the queued job");
    return;
  }
  const Vcmfarm__Lease *l = lease_reply->lease;
  vf_settings s;
  vf_settings_parse(&s, l->settings);
  char message[1024], other_settings[512];
  s.seed += 1;
  vf_settings_format(&s, other_settings, sizeof other_settings);
  vf_film *film = lease_film(l, s.width, s.height, l->begin, l->end);
  static const struct {
    spoil how;
    const char *what;
  } cases[] = {
      {SHORT_ARRAY, "a result whose tile chunk is cut short is refused"},
      {HALF_WIDTH, "a result claiming another film size is refused"},
      {OTHER_SETTINGS, "a result with other settings is refused"},
      {NAN_VALUE, "a result with a NaN in a tile is refused"},
      {TILE_OUTSIDE, "a result with a tile outside the film is refused"},
      {OTHER_RANGE, "a result for another range than its lease is refused"},
      {OVERSIZED, "a result message above the size cap is refused"},
  };
  for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
    expect(film && send_result(c, worker_id, l, film, cases[i].how, other_settings, message, sizeof message) == 0,
           cases[i].what);
    printf("     %s\n", message);
  }
  vf_film_destroy(film);

  Vcmfarm__LeaseRelease rel = VCMFARM__LEASE_RELEASE__INIT;
  rel.worker_id = worker_id;
  rel.lease_id = l->lease_id;
  q.body_case = VCMFARM__ENVELOPE__BODY_RELEASE;
  q.release = &rel;
  int released = vf_farm_request(c, &q, VCMFARM__ENVELOPE__BODY_RESULT_ACK, 10000, &reply) == VF_OK;
  expect(released && reply->result_ack->accepted, "the lease is handed back");
  if (released) vf_message_free(reply);
  vf_message_free(lease_reply);
}

int main(int argc, char **argv) {
  if (argc != 3) {
    fprintf(stderr, "usage: farm_peer URL KEYFILE\n");
    return 2;
  }
  vf_wire_key key;
  vf_farm_client *c;
  if (sodium_init() < 0 || vf_wire_key_load(argv[2], &key) != VF_OK || vf_farm_client_open(argv[1], &key, &c) != VF_OK) {
    fprintf(stderr, "farm_peer: %s\n", vf_error_detail(VF_EINVAL));
    return 2;
  }
  test_frames(argv[1], &key);
  test_results(c);
  Vcmfarm__StatusRequest sr = VCMFARM__STATUS_REQUEST__INIT;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_STATUS_REQUEST;
  q.status_request = &sr;
  int alive = vf_farm_request(c, &q, VCMFARM__ENVELOPE__BODY_STATUS, 10000, &reply) == VF_OK;
  expect(alive && reply->status->n_jobs == 1 && reply->status->jobs[0]->iterations_done == 0 &&
             reply->status->jobs[0]->results_refused == 7,
         "the coordinator still answers; its job has no iteration and 7 refused results");
  if (alive) vf_message_free(reply);
  vf_farm_client_close(c);
  return failures ? 1 : 0;
}
