/* Frames and messages (common/wire.h, common/message.h): round trips, and every way a
 * frame can be wrong is refused with the right code before its payload is used. */
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

static void test_round_trip(void) {
  Vcmfarm__StatusRequest sr;
  Vcmfarm__Envelope env, *out = NULL;
  uint8_t *frame;
  size_t len;
  CHECK_INT_EQ(vf_message_pack(&key_a, status_request(&sr, &env), &frame, &len), VF_OK);
  CHECK_INT_EQ(vf_message_unpack(&key_a, frame, len, &out), VF_OK);
  CHECK(out != NULL && out->body_case == VCMFARM__ENVELOPE__BODY_STATUS_REQUEST);
  if (out) CHECK_INT_EQ(out->status_request->job_id, 42);
  CHECK_INT_EQ(out ? out->protocol_version : 0, VF_PROTOCOL_VERSION);
  vf_message_free(out);
  free(frame);
}

static void test_wrong_key_is_refused(void) {
  Vcmfarm__StatusRequest sr;
  Vcmfarm__Envelope env, *out = NULL;
  uint8_t *frame;
  size_t len;
  vf_message_pack(&key_a, status_request(&sr, &env), &frame, &len);
  CHECK_INT_EQ(vf_message_unpack(&key_b, frame, len, &out), VF_EAUTH);
  CHECK(out == NULL);
  free(frame);
}

static void test_every_altered_byte_is_refused(void) {
  Vcmfarm__StatusRequest sr;
  Vcmfarm__Envelope env, *out = NULL;
  uint8_t *frame;
  size_t len;
  vf_message_pack(&key_a, status_request(&sr, &env), &frame, &len);
  int refused = 0;
  for (size_t i = 0; i < len; i++) {
    frame[i] ^= 0x01;
    refused += vf_message_unpack(&key_a, frame, len, &out) != VF_OK;
    frame[i] ^= 0x01;
  }
  CHECK_INT_EQ(refused, len);
  free(frame);
}

static void test_version_is_checked_after_the_tag(void) {
  uint8_t payload[3] = {1, 2, 3}, frame[12 + 3 + 32];
  memcpy(frame, "VCMF", 4);
  frame[4] = 0, frame[5] = 0, frame[6] = 0, frame[7] = 9;
  frame[8] = 0, frame[9] = 0, frame[10] = 0, frame[11] = 3;
  memcpy(frame + 12, payload, 3);
  crypto_auth(frame + 15, frame, 15, key_a.bytes);
  const uint8_t *p;
  size_t plen;
  CHECK_INT_EQ(vf_wire_open(&key_a, frame, sizeof frame, &p, &plen), VF_EVERSION);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EVERSION), "version 9");
  CHECK_INT_EQ(vf_wire_open(&key_b, frame, sizeof frame, &p, &plen), VF_EAUTH);
}

static void test_lengths_are_checked(void) {
  uint8_t *frame;
  size_t len;
  const uint8_t *p;
  size_t plen;
  uint8_t payload[10] = {0};
  vf_wire_seal(&key_a, payload, sizeof payload, &frame, &len);
  CHECK_INT_EQ(vf_wire_open(&key_a, frame, len, &p, &plen), VF_OK);
  CHECK_INT_EQ(plen, 10);
  CHECK_INT_EQ(vf_wire_open(&key_a, frame, len - 1, &p, &plen), VF_EPROTO);
  CHECK_INT_EQ(vf_wire_open(&key_a, frame, 20, &p, &plen), VF_EPROTO);
  frame[8] = 0x7f; /* claims 2 GiB */
  CHECK_INT_EQ(vf_wire_open(&key_a, frame, len, &p, &plen), VF_EPROTO);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EPROTO), "limit");
  frame[8] = 0;
  frame[0] = 'X';
  CHECK_INT_EQ(vf_wire_open(&key_a, frame, len, &p, &plen), VF_EPROTO);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EPROTO), "magic");
  free(frame);
  CHECK_INT_EQ(vf_wire_seal(&key_a, payload, VF_WIRE_MAX_PAYLOAD + 1, &frame, &len), VF_EINVAL);
}

static void test_authentic_garbage_is_refused(void) {
  uint8_t junk[64], *frame;
  size_t len;
  randombytes_buf(junk, sizeof junk);
  vf_wire_seal(&key_a, junk, sizeof junk, &frame, &len);
  Vcmfarm__Envelope *out = NULL;
  CHECK_INT_EQ(vf_message_unpack(&key_a, frame, len, &out), VF_EPROTO);
  free(frame);
  /* An empty Envelope has version 0 and no body. */
  vf_wire_seal(&key_a, junk, 0, &frame, &len);
  CHECK_INT_EQ(vf_message_unpack(&key_a, frame, len, &out), VF_EPROTO);
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
  RUN(test_wrong_key_is_refused);
  RUN(test_every_altered_byte_is_refused);
  RUN(test_version_is_checked_after_the_tag);
  RUN(test_lengths_are_checked);
  RUN(test_authentic_garbage_is_refused);
  RUN(test_key_files);
  return check_finish();
}
