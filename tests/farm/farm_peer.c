/* Helper of test_farm.sh (not a test by itself): a hostile or confused peer.
 *
 *   farm_peer URL KEYFILE
 *
 * Run while the coordinator at URL has one queued job and no worker. Sends frames under
 * another key (answered with the fixed refusal within a budget of bytes a second), frames
 * of other protocol versions (ours + 1, 8, and 7 in its own layout), garbage, a
 * frame whose header claims an oversized payload, raw bytes below the nanomsg protocol
 * (ipc:// only); captured Register, LeaseRequest and SubmitJob frames sent again, requests
 * sent too long ago or ahead, a ciphertext altered; and then, as
 * a registered worker holding a lease, results that do not match it (tiles whose chunk is
 * cut short, holds a NaN, or lies outside the film; another film size, other settings,
 * another range; a message above the result size cap). Checks each is refused as
 * docs/PROTOCOL.md says, hands the lease back, and that the coordinator still answers.
 * Exit status 0 when every expectation held.
 *
 *   farm_peer --flood ...        what unfinished messages cost (flood, below)
 *   farm_peer --congest ...      the gate's large-message budget held full for a while (congest)
 *   farm_peer --connections ...  how many connections the TCP gate serves (count_connections) */
#include "common/clock.h"
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
#include <sys/time.h>
#include <sys/un.h>
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
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

/* A request sealed by hand as common/wire.h specifies it: any version, clock and claimed
 * length, under `key` (the request subkey derived from it). *nonce (may be NULL) gets its
 * nonce, to open the reply with. */
static uint8_t *hand_sealed(const uint8_t *key, uint32_t version, int64_t sent_ms, const uint8_t *payload,
                            uint32_t len, uint32_t claimed, size_t *frame_len, vf_wire_stamp *stamp) {
  uint8_t *f = malloc(44 + len + 16), k[32];
  memcpy(f, "VCMF", 4);
  put_u32(f + 4, version);
  put_u32(f + 8, claimed);
  put_u32(f + 12, (uint32_t)((uint64_t)sent_ms >> 32));
  put_u32(f + 16, (uint32_t)sent_ms);
  randombytes_buf(f + 20, 24);
  crypto_kdf_derive_from_key(k, 32, 1, "vcmfarm8", key);
  crypto_aead_xchacha20poly1305_ietf_encrypt_detached(f + 44, f + 44 + len, NULL, payload, len, f, 44, NULL, f + 20, k);
  if (stamp) {
    stamp->version = version;
    stamp->sent_ms = sent_ms;
    memcpy(stamp->nonce, f + 20, 24);
  }
  *frame_len = 44 + len + 16;
  return f;
}

/* A frame of protocol version 7 and earlier: payload in clear, HMAC tag. */
static uint8_t *legacy_frame(const uint8_t *key, uint32_t version, const uint8_t *payload, uint32_t len,
                             size_t *frame_len) {
  uint8_t *f = malloc(12 + len + 32);
  memcpy(f, "VCMF", 4);
  put_u32(f + 4, version);
  put_u32(f + 8, len);
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
  int64_t now = vf_wire_now_ms();
  vf_wire_stamp stamp;

  uint8_t other_key[32];
  randombytes_buf(other_key, sizeof other_key);
  uint8_t *f = hand_sealed(other_key, VF_PROTOCOL_VERSION, now, payload, plen, plen, &len, NULL);
  int n = raw_exchange(url, f, len, 5000, &reply);
  expect(n >= 0 && vf_wire_is_refusal(reply, (size_t)n),
         "a frame under another key gets the fixed refusal (60 bytes, the same for every request)");
  if (n >= 0) nn_freemsg(reply);
  free(f);
  uint8_t *filler = calloc(1, 1 << 20);
  f = hand_sealed(other_key, VF_PROTOCOL_VERSION, now, filler, 1u << 20, 1u << 20, &len, NULL);
  n = raw_exchange(url, f, len, 5000, &reply);
  expect(n >= 0 && vf_wire_is_refusal(reply, (size_t)n), "a frame of 1 MiB under another key gets the same refusal");
  if (n >= 0) nn_freemsg(reply);
  free(f);
  free(filler);

  f = hand_sealed(key->bytes, VF_PROTOCOL_VERSION + 1, now, payload, plen, plen, &len, &stamp);
  n = raw_exchange(url, f, len, 5000, &reply);
  free(f);
  Vcmfarm__Envelope *answer = NULL;
  int ok = n >= 0 && vf_message_unpack(key, &stamp, reply, (size_t)n, &answer, NULL) == VF_OK &&
           answer->body_case == VCMFARM__ENVELOPE__BODY_ERROR &&
           answer->error->code == VCMFARM__ERROR_CODE__ERROR_VERSION && strstr(answer->error->message, "version");
  if (ok) printf("     coordinator says: %s\n", answer->error->message);
  expect(ok, "a frame of another protocol version is refused with a message naming the versions");
  vf_message_free(answer);
  if (n >= 0) nn_freemsg(reply);

  /* Version 12: a peer from before a submission carried its pilots' seconds. */
  f = hand_sealed(key->bytes, 12, now, payload, plen, plen, &len, &stamp);
  n = raw_exchange(url, f, len, 5000, &reply);
  free(f);
  answer = NULL;
  ok = n >= 0 && vf_message_unpack(key, &stamp, reply, (size_t)n, &answer, NULL) == VF_OK &&
       answer->body_case == VCMFARM__ENVELOPE__BODY_ERROR && answer->error->code == VCMFARM__ERROR_CODE__ERROR_VERSION &&
       strstr(answer->error->message, "peer speaks protocol version 12, this vcmfarm speaks version 13");
  if (ok) printf("     coordinator says: %s\n", answer->error->message);
  expect(ok, "a version-12 frame is refused, naming both versions");
  vf_message_free(answer);
  if (n >= 0) nn_freemsg(reply);

  f = legacy_frame(key->bytes, 7, payload, plen, &len);
  n = raw_exchange(url, f, len, 5000, &reply);
  free(f);
  ok = n >= 44 && memcmp(reply, "VCMF", 4) == 0 && ((uint8_t *)reply)[7] == VF_PROTOCOL_VERSION &&
       crypto_auth_verify((uint8_t *)reply + n - 32, reply, (size_t)n - 32, key->bytes) == 0;
  expect(ok, "a version-7 frame is answered in the version-7 layout, saying our version (so a version-7 peer reports it)");
  if (n >= 0) nn_freemsg(reply);

  uint8_t garbage[200];
  randombytes_buf(garbage, sizeof garbage);
  expect(raw_exchange(url, garbage, sizeof garbage, 500, &reply) < 0, "garbage gets no answer");

  f = hand_sealed(key->bytes, VF_PROTOCOL_VERSION, now, payload, plen, 0x7fffffffu, &len, NULL);
  expect(raw_exchange(url, f, len, 500, &reply) < 0, "a header claiming a 2 GiB payload gets no answer");
  free(f);

  f = hand_sealed(key->bytes, VF_PROTOCOL_VERSION, now, garbage, sizeof garbage, sizeof garbage, &len, NULL);
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

/* Sends a frame (again) and returns the reply to its request, or NULL. */
static Vcmfarm__Envelope *replayed_exchange(const char *url, const vf_wire_key *key, const uint8_t *frame, size_t len,
                                            const vf_wire_stamp *stamp, int timeout_ms) {
  void *reply = NULL;
  int n = raw_exchange(url, frame, len, timeout_ms, &reply);
  Vcmfarm__Envelope *answer = NULL;
  if (n >= 0 && vf_message_unpack(key, stamp, reply, (size_t)n, &answer, NULL) != VF_OK) answer = NULL;
  if (n >= 0) nn_freemsg(reply);
  return answer;
}

/* Sends a request sealed now and returns its reply (NULL when none came in timeout_ms);
 * *frame and *frame_len keep the frame as it went, to be sent again. */
static Vcmfarm__Envelope *sealed_exchange(const char *url, const vf_wire_key *key, Vcmfarm__Envelope *q,
                                          int timeout_ms, uint8_t **frame, size_t *frame_len, vf_wire_stamp *stamp) {
  if (vf_message_pack(key, NULL, q, frame, frame_len, stamp) != VF_OK) return NULL;
  return replayed_exchange(url, key, *frame, *frame_len, stamp, timeout_ms);
}

static Vcmfarm__Status *farm_status(vf_farm_client *c, Vcmfarm__Envelope **reply) {
  Vcmfarm__StatusRequest sr = VCMFARM__STATUS_REQUEST__INIT;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_STATUS_REQUEST;
  q.status_request = &sr;
  if (vf_farm_request(c, &q, VCMFARM__ENVELOPE__BODY_STATUS, 10000, reply) != VF_OK) return NULL;
  return (*reply)->status;
}

/* Captured requests sent again: Register, LeaseRequest and SubmitJob each have their
 * effect once; the copy has none, and gets the reply its original had (as a resend by
 * nanomsg would). A request sent 10 minutes ago or 10 minutes ahead, and one whose
 * ciphertext was altered, get no answer. */
static void test_replays(const char *url, const vf_wire_key *key, vf_farm_client *c) {
  void *reply = NULL;
  uint8_t *frame;
  size_t len;
  Vcmfarm__Envelope *status_reply = NULL, *answer;
  Vcmfarm__Status *st = farm_status(c, &status_reply);
  size_t workers_before = st ? st->n_workers : 0, jobs_before = st ? st->n_jobs : 0;
  vf_message_free(status_reply);

  Vcmfarm__Register reg = VCMFARM__REGISTER__INIT;
  reg.name = "replayed";
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_REGISTER;
  q.register_ = &reg;
  vf_wire_stamp stamp;
  answer = sealed_exchange(url, key, &q, 10000, &frame, &len, &stamp);
  uint64_t worker_id = answer && answer->body_case == VCMFARM__ENVELOPE__BODY_REGISTERED ? answer->registered->worker_id : 0;
  expect(worker_id != 0, "a register is answered");
  vf_message_free(answer);
  answer = replayed_exchange(url, key, frame, len, &stamp, 5000);
  expect(answer && answer->body_case == VCMFARM__ENVELOPE__BODY_REGISTERED && answer->registered->worker_id == worker_id,
         "the same register sent again gets the reply it had");
  vf_message_free(answer);
  free(frame);
  st = farm_status(c, &status_reply);
  expect(st && st->n_workers == workers_before + 1, "the replayed register made no phantom worker");
  vf_message_free(status_reply);

  Vcmfarm__LeaseRequest lr = VCMFARM__LEASE_REQUEST__INIT;
  lr.worker_id = worker_id;
  q.body_case = VCMFARM__ENVELOPE__BODY_LEASE_REQUEST;
  q.lease_request = &lr;
  Vcmfarm__Envelope *lease = sealed_exchange(url, key, &q, 10000, &frame, &len, &stamp);
  int leased = lease && lease->body_case == VCMFARM__ENVELOPE__BODY_LEASE;
  expect(leased, "a lease request is answered with a lease");
  answer = replayed_exchange(url, key, frame, len, &stamp, 5000);
  expect(leased && answer && answer->body_case == VCMFARM__ENVELOPE__BODY_LEASE &&
             answer->lease->lease_id == lease->lease->lease_id,
         "the same lease request sent again gets the reply it had");
  vf_message_free(answer);
  free(frame);
  if (leased) {
    Vcmfarm__Heartbeat hb = VCMFARM__HEARTBEAT__INIT;
    hb.worker_id = worker_id;
    hb.lease_id = lease->lease->lease_id;
    q.body_case = VCMFARM__ENVELOPE__BODY_HEARTBEAT;
    q.heartbeat = &hb;
    answer = NULL;
    int alive = vf_farm_request(c, &q, VCMFARM__ENVELOPE__BODY_HEARTBEAT_ACK, 10000, &answer) == VF_OK &&
                answer->heartbeat_ack->lease_valid;
    expect(alive, "the lease is still valid after the replayed lease request");
    vf_message_free(answer);

    Vcmfarm__SubmitJob sj = VCMFARM__SUBMIT_JOB__INIT;
    sj.name = "replayed";
    sj.scene = lease->lease->scene;
    sj.scene_hash = lease->lease->scene_hash;
    sj.settings = lease->lease->settings;
    sj.iterations = 1;
    sj.priority = 1;
    q.body_case = VCMFARM__ENVELOPE__BODY_SUBMIT;
    q.submit = &sj;
    answer = sealed_exchange(url, key, &q, 10000, &frame, &len, &stamp);
    uint64_t job = answer && answer->body_case == VCMFARM__ENVELOPE__BODY_SUBMITTED ? answer->submitted->job_id : 0;
    if (answer && !job && answer->body_case == VCMFARM__ENVELOPE__BODY_ERROR) printf("     %s\n", answer->error->message);
    expect(job != 0, "a submission is answered");
    vf_message_free(answer);
    answer = replayed_exchange(url, key, frame, len, &stamp, 5000);
    expect(answer && answer->body_case == VCMFARM__ENVELOPE__BODY_SUBMITTED && answer->submitted->job_id == job,
           "the same submission sent again gets the reply it had");
    vf_message_free(answer);
    free(frame);
    st = farm_status(c, &status_reply);
    expect(st && st->n_jobs == jobs_before + 1, "the replayed submission made no second job");
    vf_message_free(status_reply);
    Vcmfarm__CancelRequest cr = VCMFARM__CANCEL_REQUEST__INIT;
    Vcmfarm__RemoveRequest rr = VCMFARM__REMOVE_REQUEST__INIT;
    cr.job_id = rr.job_id = job;
    q.body_case = VCMFARM__ENVELOPE__BODY_CANCEL;
    q.cancel = &cr;
    if (vf_farm_request(c, &q, VCMFARM__ENVELOPE__BODY_RESULT_ACK, 10000, &answer) == VF_OK) vf_message_free(answer);
    q.body_case = VCMFARM__ENVELOPE__BODY_REMOVE;
    q.remove = &rr;
    expect(vf_farm_request(c, &q, VCMFARM__ENVELOPE__BODY_RESULT_ACK, 10000, &answer) == VF_OK, "the job is removed");
    vf_message_free(answer);

    Vcmfarm__LeaseRelease rel = VCMFARM__LEASE_RELEASE__INIT;
    rel.worker_id = worker_id;
    rel.lease_id = lease->lease->lease_id;
    q.body_case = VCMFARM__ENVELOPE__BODY_RELEASE;
    q.release = &rel;
    if (vf_farm_request(c, &q, VCMFARM__ENVELOPE__BODY_RESULT_ACK, 10000, &answer) == VF_OK) vf_message_free(answer);
  }
  vf_message_free(lease);

  Vcmfarm__StatusRequest sr = VCMFARM__STATUS_REQUEST__INIT;
  Vcmfarm__Envelope se = VCMFARM__ENVELOPE__INIT;
  se.body_case = VCMFARM__ENVELOPE__BODY_STATUS_REQUEST;
  se.status_request = &sr;
  se.protocol_version = VF_PROTOCOL_VERSION;
  uint8_t payload[64];
  uint32_t plen = (uint32_t)vcmfarm__envelope__pack(&se, payload);
  int64_t now = vf_wire_now_ms();
  uint8_t *f = hand_sealed(key->bytes, VF_PROTOCOL_VERSION, now, payload, plen, plen, &len, NULL);
  int n = raw_exchange(url, f, len, 5000, &reply);
  expect(n >= 0, "a status request sealed by hand now is answered");
  if (n >= 0) nn_freemsg(reply);
  f[44] ^= 0x20; /* the ciphertext, with a new nonce so that it is no replay */
  randombytes_buf(f + 20, 24);
  n = raw_exchange(url, f, len, 1000, &reply);
  expect(n >= 0 && vf_wire_is_refusal(reply, (size_t)n),
         "a request whose ciphertext was altered gets the refusal, as one under another key");
  if (n >= 0) nn_freemsg(reply);
  free(f);
  f = hand_sealed(key->bytes, VF_PROTOCOL_VERSION, now - 600000, payload, plen, plen, &len, NULL);
  expect(raw_exchange(url, f, len, 1000, &reply) < 0, "a request sent 10 minutes ago gets no answer");
  free(f);
  f = hand_sealed(key->bytes, VF_PROTOCOL_VERSION, now + 600000, payload, plen, plen, &len, NULL);
  expect(raw_exchange(url, f, len, 1000, &reply) < 0, "a request sent 10 minutes ahead gets no answer");
  free(f);
}

/* Requests of 1 MiB under another key, sent one after the other as fast as they are
 * answered or given up (after 200 ms): the coordinator refuses at most 1 MiB of them a
 * second after a burst of its largest request (4.26 MB: 4 of them), and answers nothing
 * but the refusal. */
static void test_refusal_rate(const char *url) {
  uint8_t other_key[32], *payload = calloc(1, 1 << 20);
  randombytes_buf(other_key, sizeof other_key);
  int answered = 0, unanswered = 0, other = 0, sent = 16;
  double start = vf_seconds_now();
  for (int i = 0; i < sent; i++) {
    size_t len;
    void *reply = NULL;
    uint8_t *f = hand_sealed(other_key, VF_PROTOCOL_VERSION, vf_wire_now_ms(), payload, 1u << 20, 1u << 20, &len, NULL);
    int n = raw_exchange(url, f, len, 200, &reply);
    free(f);
    if (n < 0) unanswered++;
    else if (vf_wire_is_refusal(reply, (size_t)n)) answered++;
    else other++;
    if (n >= 0) nn_freemsg(reply);
  }
  free(payload);
  double seconds = vf_seconds_now() - start;
  printf("     %d requests of 1 MiB under another key in %.2f s: %d refused, %d unanswered\n", sent, seconds, answered,
         unanswered);
  expect(other == 0 && answered >= 4 && answered <= 4 + (int)seconds + 1 && unanswered > 0,
         "requests under another key get refusals of at most 1 MiB a second after a burst, nothing else");
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
  /* tile (0, 0) uncompressed: 18 channels of w x h, the first FLOAT (docs/FILM.md, proto Tile) */
  size_t w = m->width < 64 ? m->width : 64, h = m->height < 64 ? m->height : 64, raw = 72 * w * h;
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
    spoilt = calloc(VF_WIRE_MAX_RESULT + 16384, 1);
    t->chunk = (ProtobufCBinaryData){spoilt ? VF_WIRE_MAX_RESULT + 16384 : 0, spoilt};
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

/* The resident memory of process pid, in bytes (0 when it cannot be read). */
static long long rss_bytes(long pid) {
  char path[64], line[256];
  snprintf(path, sizeof path, "/proc/%ld/status", pid);
  FILE *f = fopen(path, "r");
  long long kb = 0;
  while (f && fgets(line, sizeof line, f))
    if (sscanf(line, "VmRSS: %lld kB", &kb) == 1) break;
  if (f) fclose(f);
  return kb * 1024;
}

/* A stream socket to the coordinator below nanomsg: the unix socket of an ipc:// URL, or
 * TCP to the gate (coordinator/gate.h) of a tcp://127.0.0.1:PORT one. -1 on failure. */
static int raw_connect(const char *url) {
  int fd;
  if (strncmp(url, "ipc://", 6) == 0) {
    fd = socket(AF_UNIX, SOCK_STREAM, 0);
    struct sockaddr_un addr = {.sun_family = AF_UNIX};
    snprintf(addr.sun_path, sizeof addr.sun_path, "%s", url + 6);
    if (connect(fd, (struct sockaddr *)&addr, sizeof addr) != 0) return close(fd), -1;
  } else {
    const char *colon = strrchr(url, ':');
    if (strncmp(url, "tcp://127.0.0.1:", 16) != 0 || colon == NULL) return -1;
    fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in addr = {.sin_family = AF_INET, .sin_port = htons((uint16_t)atoi(colon + 1)),
                               .sin_addr.s_addr = htonl(INADDR_LOOPBACK)};
    if (connect(fd, (struct sockaddr *)&addr, sizeof addr) != 0) return close(fd), -1;
  }
  return fd;
}

/* AddressSanitizer keeps a byte of shadow memory for every 8 bytes of the program's, and
 * the coordinator's resident size counts the shadow of what it holds: in the sanitized
 * build (tests/sanitize.sh), where the coordinator is instrumented as this program is,
 * 10 messages of 4.26 MB grow it by 48.1 MB against 42.7 MB without the sanitizer. The
 * bound on its growth is then 9/8 of the one given. */
#if defined(__SANITIZE_ADDRESS__)
#define SHADOW_FACTOR (9.0 / 8.0)
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define SHADOW_FACTOR (9.0 / 8.0)
#endif
#endif
#ifndef SHADOW_FACTOR
#define SHADOW_FACTOR 1.0
#endif

/* Opens `n` connections below nanomsg and on each starts a message of `claimed` bytes,
 * sending all of it but the last byte, so that the coordinator holds what it was sent
 * without ever seeing a message it could refuse: what a peer without the key can cost.
 * Over tcp:// the gate reads a message only once it has room for it, so a write that makes
 * no progress for a second leaves that connection waiting. Prints the coordinator's
 * resident memory before and after, and checks it still answers a status request
 * meanwhile; fails when it grew by more than max_growth_mb (with AddressSanitizer's
 * shadow, SHADOW_FACTOR of it).
 *
 *   farm_peer --flood URL KEYFILE CONNECTIONS CLAIMED_BYTES PID MAX_GROWTH_MB */
static int flood(const char *url, const vf_wire_key *key, int n, unsigned long long claimed, long pid,
                 double max_growth_mb) {
  signal(SIGPIPE, SIG_IGN);
  int tcp = strncmp(url, "tcp://", 6) == 0;
  long long before = rss_bytes(pid);
  int *fds = calloc((size_t)n, sizeof *fds);
  size_t block = 1 << 20;
  uint8_t *junk = calloc(1, block);
  int refused = 0, unread = 0;
  unsigned long long sent_total = 0;
  for (int i = 0; i < n; i++) {
    if ((fds[i] = raw_connect(url)) < 0) return 2;
    struct timeval tv = {tcp ? 1 : 5, 0};
    setsockopt(fds[i], SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
    /* The SP header, then per message (ipc://) a type byte, 1: normal, and the size, 64
     * bits big-endian; over tcp:// the size alone. */
    uint8_t hello[8] = {0, 'S', 'P', 0, 0, NN_REQ, 0, 0}, size[9] = {1};
    for (int b = 0; b < 8; b++) size[1 + b] = (uint8_t)(claimed >> (56 - 8 * b));
    size_t skip = tcp ? 1 : 0;
    if (write(fds[i], hello, 8) != 8 || write(fds[i], size + skip, 9 - skip) != (ssize_t)(9 - skip)) return 2;
    unsigned long long left = claimed - 1;
    int stuck = 0;
    while (left > 0) {
      ssize_t w = write(fds[i], junk, left < block ? left : block);
      if (w < 0 && errno == EAGAIN) stuck = 1; /* the gate does not read it: no room */
      if (w <= 0) break;                       /* or closed: the coordinator refused the size */
      left -= (unsigned long long)w;
      sent_total += (unsigned long long)w;
    }
    unread += stuck;
    refused += left > 0 && !stuck;
  }
  usleep(500 * 1000);
  long long after = rss_bytes(pid);
  vf_farm_client *c;
  Vcmfarm__Envelope *reply = NULL;
  int alive = vf_farm_client_open(url, key, &c) == VF_OK && farm_status(c, &reply) != NULL;
  vf_message_free(reply);
  if (alive) vf_farm_client_close(c);
  printf("connections %d claiming %llu bytes each: %d cut off by the coordinator, %d left unread, %.1f MB sent; "
         "coordinator RSS %.1f MB -> %.1f MB (+%.1f MB); %s\n",
         n, claimed, refused, unread, (double)sent_total / 1e6, (double)before / 1e6, (double)after / 1e6,
         (double)(after - before) / 1e6, alive ? "it still answers" : "IT DOES NOT ANSWER");
  for (int i = 0; i < n; i++) close(fds[i]);
  free(fds);
  free(junk);
  double limit_mb = max_growth_mb * SHADOW_FACTOR;
  int bounded = (double)(after - before) / 1e6 <= limit_mb;
  if (!bounded) printf("FAIL the coordinator grew by more than %.1f MB\n", limit_mb);
  return alive && bounded ? 0 : 1;
}

/* Congestion by a peer without the key: `n` connections each announce a request of
 * `claimed` bytes and send all of it but its last byte, so that the gate keeps its room
 * reserved (coordinator/gate.h) and its large-message budget is full; held `seconds`,
 * then closed. Workers' results wait at the gate meanwhile; their heartbeats must not.
 * Prints what it sent; exit status 0 once the connections are closed.
 *
 *   farm_peer --congest URL CONNECTIONS CLAIMED_BYTES SECONDS */
static int congest(const char *url, int n, unsigned long long claimed, double seconds) {
  signal(SIGPIPE, SIG_IGN);
  int tcp = strncmp(url, "tcp://", 6) == 0, unread = 0;
  int *fds = calloc((size_t)n, sizeof *fds);
  size_t block = 1 << 20;
  uint8_t *junk = calloc(1, block);
  if (fds == NULL || junk == NULL) return 2;
  unsigned long long sent_total = 0;
  double t0 = vf_seconds_now();
  for (int i = 0; i < n; i++) {
    if ((fds[i] = raw_connect(url)) < 0) return 2;
    struct timeval tv = {1, 0};
    setsockopt(fds[i], SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
    uint8_t hello[8] = {0, 'S', 'P', 0, 0, NN_REQ, 0, 0}, size[9] = {1};
    for (int b = 0; b < 8; b++) size[1 + b] = (uint8_t)(claimed >> (56 - 8 * b));
    size_t skip = tcp ? 1 : 0;
    if (write(fds[i], hello, 8) != 8 || write(fds[i], size + skip, 9 - skip) != (ssize_t)(9 - skip)) return 2;
    unsigned long long left = claimed - 1;
    while (left > 0) {
      ssize_t w = write(fds[i], junk, left < block ? left : block);
      if (w <= 0) break; /* no room at the gate (it reads nothing of it), or closed */
      left -= (unsigned long long)w;
      sent_total += (unsigned long long)w;
    }
    unread += left > 0;
  }
  printf("congest: %d connections claiming %llu bytes each, %.1f MB sent, %d waiting unread; holding %.1f s\n", n,
         claimed, (double)sent_total / 1e6, unread, seconds);
  fflush(stdout);
  double left_s = seconds - (vf_seconds_now() - t0);
  if (left_s > 0) usleep((useconds_t)(left_s * 1e6));
  for (int i = 0; i < n; i++) close(fds[i]);
  free(fds);
  free(junk);
  return 0;
}

/* Opens `n` TCP connections to the gate at once and counts those it serves (its SP header
 * arrives) and those it refuses (reset or closed before a byte): prints
 * "served S refused R". The connections stay open until all are counted.
 *
 *   farm_peer --connections URL N */
static int count_connections(const char *url, int n) {
  int *fds = calloc((size_t)n, sizeof *fds), served = 0, refused = 0;
  for (int i = 0; i < n; i++) {
    if ((fds[i] = raw_connect(url)) < 0) {
      refused++;
      continue;
    }
    struct pollfd p = {fds[i], POLLIN, 0};
    uint8_t header[8];
    ssize_t got = poll(&p, 1, 5000) == 1 ? recv(fds[i], header, sizeof header, MSG_WAITALL) : -1;
    if (got == 8 && memcmp(header, "\0SP\0", 4) == 0) served++;
    else refused++;
  }
  printf("served %d refused %d\n", served, refused);
  for (int i = 0; i < n; i++)
    if (fds[i] >= 0) close(fds[i]);
  free(fds);
  return 0;
}

int main(int argc, char **argv) {
  if (argc == 4 && strcmp(argv[1], "--connections") == 0) return count_connections(argv[2], atoi(argv[3]));
  if (argc == 6 && strcmp(argv[1], "--congest") == 0) {
    unsigned long long claimed = strcmp(argv[4], "cap") == 0 ? VF_WIRE_MAX_REQUEST_FRAME : strtoull(argv[4], NULL, 10);
    return congest(argv[2], atoi(argv[3]), claimed, atof(argv[5]));
  }
  if (argc == 8 && strcmp(argv[1], "--flood") == 0) {
    vf_wire_key key;
    if (vf_wire_key_load(argv[3], &key) != VF_OK) return 2;
    /* "cap": a message as large as the coordinator takes */
    unsigned long long claimed = strcmp(argv[5], "cap") == 0 ? VF_WIRE_MAX_REQUEST_FRAME : strtoull(argv[5], NULL, 10);
    return flood(argv[2], &key, atoi(argv[4]), claimed, atol(argv[6]), atof(argv[7]));
  }
  if (argc != 3) {
    fprintf(stderr, "usage: farm_peer URL KEYFILE\n       farm_peer --flood URL KEYFILE CONNECTIONS CLAIMED_BYTES PID "
                    "MAX_GROWTH_MB\n       farm_peer --congest URL CONNECTIONS CLAIMED_BYTES SECONDS\n"
                    "       farm_peer --connections URL N\n");
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
  test_replays(argv[1], &key, c);
  test_refusal_rate(argv[1]);
  Vcmfarm__Envelope *reply;
  int alive = farm_status(c, &reply) != NULL;
  expect(alive && reply->status->n_jobs == 1 && reply->status->jobs[0]->iterations_done == 0 &&
             reply->status->jobs[0]->results_refused == 7,
         "the coordinator still answers; its job has no iteration and 7 refused results");
  if (alive) vf_message_free(reply);
  vf_farm_client_close(c);
  return failures ? 1 : 0;
}
