/* Frames and messages (common/wire.h, common/message.h): round trips, payloads that cannot
 * be read on the wire, replies bound to their requests, and every way a frame can be wrong
 * refused with the right code before its payload is used. */
#define _GNU_SOURCE /* memmem */
#include "check.h"
#include "common/error.h"
#include "common/message.h"

#include <sodium.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

static vf_wire_key key_a, key_b;

static Vcmfarm__Envelope *status_request(Vcmfarm__StatusRequest *sr, Vcmfarm__Envelope *env) {
  vcmfarm__status_request__init(sr);
  sr->job_id = 42;
  vcmfarm__envelope__init(env);
  env->body_case = VCMFARM__ENVELOPE__BODY_STATUS_REQUEST;
  env->status_request = sr;
  return env;
}

/* A frame sealed by hand as common/wire.h specifies it, with any version and clock: a
 * request (request subkey, AD = header) or the reply to `request_nonce`. */
static uint8_t *hand_sealed(const vf_wire_key *key, uint32_t version, int64_t sent_ms, const uint8_t *request_nonce,
                            const uint8_t *payload, size_t len, size_t *frame_len) {
  uint8_t *f = malloc(44 + len + 16), k[32], ad[68];
  memcpy(f, "VCMF", 4);
  for (int i = 0; i < 4; i++) f[4 + i] = (uint8_t)(version >> (24 - 8 * i));
  for (int i = 0; i < 4; i++) f[8 + i] = (uint8_t)(len >> (24 - 8 * i));
  for (int i = 0; i < 8; i++) f[12 + i] = (uint8_t)((uint64_t)sent_ms >> (56 - 8 * i));
  randombytes_buf(f + 20, 24);
  memcpy(ad, f, 44);
  if (request_nonce) memcpy(ad + 44, request_nonce, 24);
  crypto_kdf_derive_from_key(k, 32, request_nonce ? 2 : 1, "vcmfarm8", key->bytes);
  crypto_aead_xchacha20poly1305_ietf_encrypt_detached(f + 44, f + 44 + len, NULL, payload, len, ad,
                                                      request_nonce ? 68 : 44, NULL, f + 20, k);
  *frame_len = 44 + len + 16;
  return f;
}

static void test_round_trip(void) {
  Vcmfarm__StatusRequest sr;
  Vcmfarm__Envelope env, *out = NULL;
  uint8_t *frame;
  size_t len;
  vf_wire_stamp sealed, opened;
  int64_t before = vf_wire_now_ms();
  CHECK_INT_EQ(vf_message_pack(&key_a, NULL, status_request(&sr, &env), &frame, &len, &sealed), VF_OK);
  CHECK_INT_EQ(vf_message_unpack(&key_a, NULL, frame, len, &out, &opened), VF_OK);
  CHECK(out != NULL && out->body_case == VCMFARM__ENVELOPE__BODY_STATUS_REQUEST);
  if (out) CHECK_INT_EQ(out->status_request->job_id, 42);
  CHECK_INT_EQ(out ? out->protocol_version : 0, VF_PROTOCOL_VERSION);
  CHECK(memcmp(sealed.nonce, opened.nonce, VF_WIRE_NONCE_SIZE) == 0);
  CHECK_INT_EQ(opened.sent_ms, sealed.sent_ms);
  CHECK(opened.sent_ms >= before && opened.sent_ms <= vf_wire_now_ms());
  CHECK_INT_EQ(opened.version, VF_PROTOCOL_VERSION);
  vf_message_free(out);
  free(frame);
}

/* Two frames of the same message differ everywhere but in magic, version and length. */
static void test_nonces_are_fresh(void) {
  Vcmfarm__StatusRequest sr;
  Vcmfarm__Envelope env;
  uint8_t *f1, *f2;
  size_t l1, l2;
  vf_wire_stamp s1, s2;
  vf_message_pack(&key_a, NULL, status_request(&sr, &env), &f1, &l1, &s1);
  vf_message_pack(&key_a, NULL, status_request(&sr, &env), &f2, &l2, &s2);
  CHECK_INT_EQ(l1, l2);
  CHECK(memcmp(s1.nonce, s2.nonce, VF_WIRE_NONCE_SIZE) != 0);
  CHECK(memcmp(f1 + VF_WIRE_HEADER_SIZE, f2 + VF_WIRE_HEADER_SIZE, l1 - VF_WIRE_HEADER_SIZE) != 0);
  free(f1);
  free(f2);
}

/* Scene text, settings and names travel encrypted: none of their bytes shows in the frame. */
static void test_payload_is_not_readable(void) {
  Vcmfarm__SubmitJob sj = VCMFARM__SUBMIT_JOB__INIT;
  Vcmfarm__Scene scene = VCMFARM__SCENE__INIT;
  scene.source_case = VCMFARM__SCENE__SOURCE_JSON;
  scene.json = "{\"camera\": {\"position\": [0, 1, 3]}, \"secret-material-name\": 1}";
  sj.name = "confidential-job-name";
  sj.settings = "width=64 height=64 algorithm=vcm seed=12345";
  sj.scene = &scene;
  Vcmfarm__Envelope env = VCMFARM__ENVELOPE__INIT, *out = NULL;
  env.body_case = VCMFARM__ENVELOPE__BODY_SUBMIT;
  env.submit = &sj;
  uint8_t *frame;
  size_t len;
  CHECK_INT_EQ(vf_message_pack(&key_a, NULL, &env, &frame, &len, NULL), VF_OK);
  static const char *secrets[] = {"secret-material-name", "confidential-job-name", "algorithm=vcm", "position"};
  for (size_t i = 0; i < sizeof secrets / sizeof *secrets; i++) {
    int found = memmem(frame, len, secrets[i], strlen(secrets[i])) != NULL;
    if (found) fprintf(stderr, "  '%s' readable in the frame\n", secrets[i]);
    CHECK(!found);
  }
  CHECK(memcmp(frame, "VCMF", 4) == 0 && frame[7] == VF_PROTOCOL_VERSION); /* magic and version stay readable */
  CHECK_INT_EQ(vf_message_unpack(&key_a, NULL, frame, len, &out, NULL), VF_OK);
  if (out) CHECK_STR_CONTAINS(out->submit->scene->json, "secret-material-name");
  vf_message_free(out);
  free(frame);
}

static void test_wrong_key_is_refused(void) {
  Vcmfarm__StatusRequest sr;
  Vcmfarm__Envelope env, *out = NULL;
  uint8_t *frame;
  size_t len;
  vf_message_pack(&key_a, NULL, status_request(&sr, &env), &frame, &len, NULL);
  CHECK_INT_EQ(vf_message_unpack(&key_b, NULL, frame, len, &out, NULL), VF_EAUTH);
  CHECK(out == NULL);
  free(frame);
}

/* Header, clock, nonce, ciphertext or tag: any bit changed and the frame is refused. */
static void test_every_altered_byte_is_refused(void) {
  Vcmfarm__StatusRequest sr;
  Vcmfarm__Envelope env, *out = NULL;
  uint8_t *frame;
  size_t len;
  vf_message_pack(&key_a, NULL, status_request(&sr, &env), &frame, &len, NULL);
  int refused = 0, auth = 0;
  for (size_t i = 0; i < len; i++) {
    frame[i] ^= 0x01;
    int err = vf_message_unpack(&key_a, NULL, frame, len, &out, NULL);
    refused += err != VF_OK;
    auth += err == VF_EAUTH;
    frame[i] ^= 0x01;
  }
  CHECK_INT_EQ(refused, len);
  CHECK_INT_EQ(auth, len - 8); /* all but magic and length (a version changed is no longer authentic) */
  free(frame);
}

/* A reply opens only as the answer to its request: not as a request, not for another. */
static void test_reply_is_bound_to_its_request(void) {
  Vcmfarm__StatusRequest sr;
  Vcmfarm__Envelope env, *out = NULL;
  uint8_t *request, *other, *reply;
  size_t request_len, other_len, reply_len;
  vf_wire_stamp request_stamp, other_stamp, seen;
  vf_message_pack(&key_a, NULL, status_request(&sr, &env), &request, &request_len, &request_stamp);
  vf_message_pack(&key_a, NULL, status_request(&sr, &env), &other, &other_len, &other_stamp);
  CHECK_INT_EQ(vf_message_unpack(&key_a, NULL, request, request_len, &out, &seen), VF_OK);
  vf_message_free(out);
  Vcmfarm__HeartbeatAck ack = VCMFARM__HEARTBEAT_ACK__INIT;
  Vcmfarm__Envelope r = VCMFARM__ENVELOPE__INIT;
  r.body_case = VCMFARM__ENVELOPE__BODY_HEARTBEAT_ACK;
  r.heartbeat_ack = &ack;
  CHECK_INT_EQ(vf_message_pack(&key_a, &seen, &r, &reply, &reply_len, NULL), VF_OK);
  out = NULL;
  CHECK_INT_EQ(vf_message_unpack(&key_a, &request_stamp, reply, reply_len, &out, NULL), VF_OK);
  CHECK(out && out->body_case == VCMFARM__ENVELOPE__BODY_HEARTBEAT_ACK);
  vf_message_free(out);
  out = NULL;
  CHECK_INT_EQ(vf_message_unpack(&key_a, &other_stamp, reply, reply_len, &out, NULL), VF_EAUTH);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EAUTH), "not the reply to this request");
  CHECK_INT_EQ(vf_message_unpack(&key_a, NULL, reply, reply_len, &out, NULL), VF_EAUTH);     /* not a request */
  CHECK_INT_EQ(vf_message_unpack(&key_a, &other_stamp, other, other_len, &out, NULL), VF_EAUTH); /* not a reply */
  CHECK(out == NULL);
  free(request);
  free(other);
  free(reply);
}

/* The refusal of a request without the key: fixed bytes, recognised as such, told apart
 * from every sealed reply, and one that an earlier version-8 peer refuses as not authentic
 * (it cannot open it as the reply to its request). */
static void test_refusal_of_a_wrong_key(void) {
  CHECK_INT_EQ(VF_WIRE_REFUSAL_SIZE, VF_WIRE_OVERHEAD); /* no longer than the shortest request */
  CHECK(memcmp(vf_wire_refusal, "VCMF\0\0\0\x08", 8) == 0);
  int zeros = 1;
  for (size_t i = 8; i < VF_WIRE_REFUSAL_SIZE; i++) zeros &= vf_wire_refusal[i] == 0;
  CHECK(zeros);
  CHECK(vf_wire_is_refusal(vf_wire_refusal, VF_WIRE_REFUSAL_SIZE));
  CHECK(!vf_wire_is_refusal(vf_wire_refusal, VF_WIRE_REFUSAL_SIZE - 1));
  CHECK(vf_wire_knows_refusal((const uint8_t *)"VCMF\0\0\0\x08\0\0\0\0", 12));
  CHECK(vf_wire_knows_refusal((const uint8_t *)"VCMF\0\0\0\x09\0\0\0\0", 12));
  CHECK(!vf_wire_knows_refusal((const uint8_t *)"VCMF\0\0\0\x07\0\0\0\0", 12)); /* versions 1 to 7 */
  CHECK(!vf_wire_knows_refusal((const uint8_t *)"VCMG\0\0\0\x08\0\0\0\0", 12));
  CHECK(!vf_wire_knows_refusal((const uint8_t *)"VCMF\0\0\0", 7));
  Vcmfarm__StatusRequest sr;
  Vcmfarm__Envelope env, *out = NULL;
  uint8_t *request, *reply;
  size_t request_len, reply_len;
  vf_wire_stamp stamp, seen;
  vf_message_pack(&key_a, NULL, status_request(&sr, &env), &request, &request_len, &stamp);
  CHECK(request_len >= VF_WIRE_REFUSAL_SIZE);
  CHECK_INT_EQ(vf_message_unpack(&key_a, &stamp, vf_wire_refusal, VF_WIRE_REFUSAL_SIZE, &out, NULL), VF_EAUTH);
  CHECK(out == NULL);
  /* An empty sealed reply has the refusal's size, never its bytes. */
  CHECK_INT_EQ(vf_message_unpack(&key_a, NULL, request, request_len, &out, &seen), VF_OK);
  vf_message_free(out);
  CHECK_INT_EQ(vf_wire_seal(&key_a, &seen, NULL, 0, &reply, &reply_len, NULL), VF_OK);
  CHECK_INT_EQ(reply_len, VF_WIRE_REFUSAL_SIZE);
  CHECK(!vf_wire_is_refusal(reply, reply_len));
  free(request);
  free(reply);
}

/* Frames of versions 12 and 14 (this layout) and of version 7 (HMAC in clear) under the
 * farm key are authentic and refused as another version, and answered so that their
 * sender can tell. */
static void test_other_versions_are_told_apart(void) {
  uint8_t payload[3] = {1, 2, 3}, *p = NULL;
  size_t plen, len;
  vf_wire_stamp stamp = {0};
  uint8_t *f14 = hand_sealed(&key_a, 14, vf_wire_now_ms(), NULL, payload, sizeof payload, &len);
  CHECK_INT_EQ(vf_wire_open(&key_a, NULL, f14, len, &p, &plen, &stamp), VF_EVERSION);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EVERSION), "version 14");
  CHECK_INT_EQ(stamp.version, 14);
  CHECK(memcmp(stamp.nonce, f14 + 20, 24) == 0);
  CHECK_INT_EQ(vf_wire_open(&key_b, NULL, f14, len, &p, &plen, &stamp), VF_EAUTH);
  free(f14);
  /* Version 12, the layout of this one before a submission carried its pilots' seconds: a
   * peer of that build is told which versions differ. */
  uint8_t *f12 = hand_sealed(&key_a, 12, vf_wire_now_ms(), NULL, payload, sizeof payload, &len);
  CHECK_INT_EQ(vf_wire_open(&key_a, NULL, f12, len, &p, &plen, &stamp), VF_EVERSION);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EVERSION), "peer speaks protocol version 12, this vcmfarm speaks version 13");
  free(f12);

  uint8_t f7[12 + 3 + 32];
  memcpy(f7, "VCMF", 4);
  f7[4] = 0, f7[5] = 0, f7[6] = 0, f7[7] = 7;
  f7[8] = 0, f7[9] = 0, f7[10] = 0, f7[11] = 3;
  memcpy(f7 + 12, payload, 3);
  crypto_auth(f7 + 15, f7, 15, key_a.bytes);
  stamp.version = 0;
  CHECK_INT_EQ(vf_wire_open(&key_a, NULL, f7, sizeof f7, &p, &plen, &stamp), VF_EVERSION);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EVERSION), "version 7");
  CHECK_INT_EQ(stamp.version, 7);
  CHECK_INT_EQ(vf_wire_open(&key_b, NULL, f7, sizeof f7, &p, &plen, &stamp), VF_EAUTH);
  /* the refusal goes back as a version-7 peer reads frames: HMAC under the key, our version */
  uint8_t *reply;
  size_t reply_len;
  CHECK_INT_EQ(vf_wire_seal(&key_a, &stamp, payload, sizeof payload, &reply, &reply_len, NULL), VF_OK);
  CHECK_INT_EQ(reply_len, 12 + 3 + 32);
  CHECK_INT_EQ(reply[7], VF_PROTOCOL_VERSION);
  CHECK_INT_EQ(crypto_auth_verify(reply + 15, reply, 15, key_a.bytes), 0);
  free(reply);
}

static void test_lengths_are_checked(void) {
  uint8_t *frame, *p;
  size_t len, plen;
  uint8_t payload[10] = {0};
  vf_wire_seal(&key_a, NULL, payload, sizeof payload, &frame, &len, NULL);
  CHECK_INT_EQ(len, 10 + VF_WIRE_OVERHEAD);
  CHECK_INT_EQ(vf_wire_open(&key_a, NULL, frame, len, &p, &plen, NULL), VF_OK);
  CHECK_INT_EQ(plen, 10);
  free(p);
  CHECK_INT_EQ(vf_wire_open(&key_a, NULL, frame, len - 1, &p, &plen, NULL), VF_EPROTO);
  CHECK_INT_EQ(vf_wire_open(&key_a, NULL, frame, 20, &p, &plen, NULL), VF_EPROTO);
  CHECK_INT_EQ(vf_wire_open(&key_a, NULL, frame, 8, &p, &plen, NULL), VF_EPROTO);
  frame[8] = 0x7f; /* claims 2 GiB */
  CHECK_INT_EQ(vf_wire_open(&key_a, NULL, frame, len, &p, &plen, NULL), VF_EPROTO);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EPROTO), "limit");
  frame[8] = 0;
  frame[0] = 'X';
  CHECK_INT_EQ(vf_wire_open(&key_a, NULL, frame, len, &p, &plen, NULL), VF_EPROTO);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EPROTO), "magic");
  free(frame);
  CHECK_INT_EQ(vf_wire_seal(&key_a, NULL, payload, VF_WIRE_MAX_PAYLOAD + 1, &frame, &len, NULL), VF_EINVAL);
}

static void test_authentic_garbage_is_refused(void) {
  uint8_t junk[64], *frame;
  size_t len;
  randombytes_buf(junk, sizeof junk);
  vf_wire_seal(&key_a, NULL, junk, sizeof junk, &frame, &len, NULL);
  Vcmfarm__Envelope *out = NULL;
  CHECK_INT_EQ(vf_message_unpack(&key_a, NULL, frame, len, &out, NULL), VF_EPROTO);
  free(frame);
  /* An empty Envelope has version 0 and no body. */
  vf_wire_seal(&key_a, NULL, junk, 0, &frame, &len, NULL);
  CHECK_INT_EQ(vf_message_unpack(&key_a, NULL, frame, len, &out, NULL), VF_EPROTO);
  free(frame);
}

static void test_key_files(void) {
  char dir[] = "/tmp/test_wire_XXXXXX", path[64];
  CHECK(mkdtemp(dir) != NULL);
  snprintf(path, sizeof path, "%s/key", dir);
  CHECK_INT_EQ(vf_wire_key_generate(path), VF_OK);
  struct stat st;
  CHECK_INT_EQ(stat(path, &st), 0);
  CHECK_INT_EQ(st.st_mode & 0777, 0600);
  CHECK_INT_EQ(vf_wire_key_generate(path), VF_EINVAL); /* never replaced */
  vf_wire_key k;
  CHECK_INT_EQ(vf_wire_key_load(path, &k), VF_OK);
  chmod(path, 0644);
  CHECK_INT_EQ(vf_wire_key_load(path, &k), VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EINVAL), "chmod 600");
  unlink(path);
  CHECK_INT_EQ(vf_wire_key_load(path, &k), VF_ENOENT);
  FILE *f = fopen(path, "w");
  fputs("not a key\n", f);
  fclose(f);
  chmod(path, 0600);
  CHECK_INT_EQ(vf_wire_key_load(path, &k), VF_EINVAL);
  unlink(path);
  rmdir(dir);
}

int main(void) {
  if (sodium_init() < 0) return 1;
  randombytes_buf(key_a.bytes, sizeof key_a.bytes);
  randombytes_buf(key_b.bytes, sizeof key_b.bytes);
  RUN(test_round_trip);
  RUN(test_nonces_are_fresh);
  RUN(test_payload_is_not_readable);
  RUN(test_wrong_key_is_refused);
  RUN(test_every_altered_byte_is_refused);
  RUN(test_reply_is_bound_to_its_request);
  RUN(test_refusal_of_a_wrong_key);
  RUN(test_other_versions_are_told_apart);
  RUN(test_lengths_are_checked);
  RUN(test_authentic_garbage_is_refused);
  RUN(test_key_files);
  return check_finish();
}
