/* The coordinator's replay guard (coordinator/replay.h): fresh requests pass once, copies
 * and requests outside the window are refused, and a guard full beyond its capacity shrinks
 * its window rather than forget a nonce that could then be replayed. */
#include "check.h"
#include "common/error.h"
#include "coordinator/replay.h"

#include <sodium.h>
#include <stdlib.h>

static vf_wire_stamp stamp_at(int64_t sent_ms) {
  vf_wire_stamp s = {VF_PROTOCOL_VERSION, sent_ms, {0}};
  randombytes_buf(s.nonce, sizeof s.nonce);
  return s;
}

static const int64_t now = 1800000000000; /* 2027-01-15, Unix ms */

static void test_a_copy_is_refused(void) {
  vf_replay *r;
  CHECK_INT_EQ(vf_replay_create(64, &r), VF_OK);
  vf_wire_stamp s = stamp_at(now - 5);
  CHECK_INT_EQ(vf_replay_check(r, &s, now), VF_OK);
  CHECK_INT_EQ(vf_replay_check(r, &s, now + 1000), VF_EREPLAY);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EREPLAY), "replayed");
  vf_wire_stamp other = stamp_at(now - 5); /* same time, another nonce */
  CHECK_INT_EQ(vf_replay_check(r, &other, now), VF_OK);
  CHECK_INT_EQ(vf_replay_count(r), 2);
  vf_replay_destroy(r);
}

/* A coordinator remembers no nonce across a restart: what was sent before it started is
 * refused, what is sent from then on passes. */
static void test_requests_before_the_start_are_refused(void) {
  vf_replay *r;
  CHECK_INT_EQ(vf_replay_create(64, &r), VF_OK);
  vf_wire_stamp before = stamp_at(now - 1000), edge = stamp_at(now - 1), at = stamp_at(now), later = stamp_at(now + 10);
  CHECK_INT_EQ(vf_replay_check(r, &before, now), VF_OK); /* a guard not started: the window alone */
  vf_replay_destroy(r);
  CHECK_INT_EQ(vf_replay_create(64, &r), VF_OK);
  vf_replay_start(r, now);
  CHECK_INT_EQ(vf_replay_check(r, &before, now + 5), VF_EREPLAY);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EREPLAY), "before this coordinator started");
  CHECK_INT_EQ(vf_replay_before_start(r, &before, now + 5), 1); /* answered "send it again" */
  CHECK_INT_EQ(vf_replay_check(r, &edge, now + 5), VF_EREPLAY);
  vf_wire_stamp stale = stamp_at(now - VF_WIRE_MAX_AGE_MS - 10);
  CHECK_INT_EQ(vf_replay_before_start(r, &stale, now + 5), 0); /* stale: no answer at all */
  CHECK_INT_EQ(vf_replay_before_start(r, &at, now + 5), 0);
  CHECK_INT_EQ(vf_replay_check(r, &at, now + 5), VF_OK);
  CHECK_INT_EQ(vf_replay_check(r, &later, now + 20), VF_OK);
  vf_replay_destroy(r);
}

static void test_window(void) {
  vf_replay *r;
  CHECK_INT_EQ(vf_replay_create(64, &r), VF_OK);
  vf_wire_stamp old = stamp_at(now - VF_WIRE_MAX_AGE_MS - 1), edge = stamp_at(now - VF_WIRE_MAX_AGE_MS);
  vf_wire_stamp ahead = stamp_at(now + VF_WIRE_MAX_AHEAD_MS + 1), skewed = stamp_at(now + VF_WIRE_MAX_AHEAD_MS);
  CHECK_INT_EQ(vf_replay_check(r, &old, now), VF_EREPLAY);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EREPLAY), "stale");
  CHECK_INT_EQ(vf_replay_check(r, &ahead, now), VF_EREPLAY);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EREPLAY), "future");
  CHECK_INT_EQ(vf_replay_check(r, &edge, now), VF_OK);
  CHECK_INT_EQ(vf_replay_check(r, &skewed, now), VF_OK);
  /* the copy of a request is refused for as long as its original could pass */
  CHECK_INT_EQ(vf_replay_check(r, &skewed, now + VF_WIRE_MAX_AHEAD_MS + VF_WIRE_MAX_AGE_MS), VF_EREPLAY);
  CHECK_INT_EQ(vf_replay_check(r, &skewed, now + VF_WIRE_MAX_AHEAD_MS + VF_WIRE_MAX_AGE_MS + 1), VF_EREPLAY);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EREPLAY), "stale");
  vf_replay_destroy(r);
}

/* Nonces leave once their requests are out of the window: the guard does not grow. */
static void test_nonces_expire(void) {
  vf_replay *r;
  CHECK_INT_EQ(vf_replay_create(1024, &r), VF_OK);
  int refused = 0;
  for (int64_t t = 0; t < 10 * VF_WIRE_MAX_AGE_MS; t += 1000) {
    vf_wire_stamp s = stamp_at(now + t);
    refused += vf_replay_check(r, &s, now + t) != VF_OK;
  }
  CHECK_INT_EQ(refused, 0);
  CHECK(vf_replay_count(r) <= (size_t)VF_WIRE_MAX_AGE_MS / 1000 + 1);
  vf_replay_destroy(r);
}

/* More requests than it holds: the oldest are forgotten, and from then on anything sent
 * as early as them is refused; every nonce still held is still found (the index's
 * deletions keep lookups whole). */
static void test_overflow_shrinks_the_window(void) {
  enum { CAP = 256, N = 5000 };
  vf_replay *r;
  CHECK_INT_EQ(vf_replay_create(CAP, &r), VF_OK);
  vf_wire_stamp *s = malloc(N * sizeof *s);
  int refused = 0;
  for (int i = 0; i < N; i++) {
    s[i] = stamp_at(now - 60000 + i); /* one request a millisecond */
    refused += vf_replay_check(r, &s[i], now) != VF_OK;
  }
  CHECK_INT_EQ(refused, 0);
  CHECK_INT_EQ(vf_replay_count(r), CAP);
  int passed = 0;
  for (int i = 0; i < N; i++) passed += vf_replay_check(r, &s[i], now) == VF_OK;
  CHECK_INT_EQ(passed, 0); /* none of them, forgotten or not */
  vf_wire_stamp late = stamp_at(now - 60000 + N - 2 * CAP);
  CHECK_INT_EQ(vf_replay_check(r, &late, now), VF_EREPLAY);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EREPLAY), "oldest request");
  vf_wire_stamp fresh = stamp_at(now);
  CHECK_INT_EQ(vf_replay_check(r, &fresh, now), VF_OK);
  free(s);
  vf_replay_destroy(r);
}

/* Replies kept by their requests' nonces: found for a request seen again within the
 * window, not outside it; the oldest go first when the bytes run out. */
static void test_replies_are_kept(void) {
  vf_replay *r;
  CHECK_INT_EQ(vf_replay_create(1024, &r), VF_OK);
  vf_wire_stamp first = stamp_at(now), second = stamp_at(now), unseen = stamp_at(now);
  uint8_t reply[100] = {1, 2, 3};
  size_t len = 0;
  vf_replay_keep_reply(r, &first, reply, sizeof reply);
  const uint8_t *kept = vf_replay_reply(r, &first, now + 1000, &len);
  CHECK(kept != NULL && len == sizeof reply && kept[2] == 3);
  CHECK(vf_replay_reply(r, &unseen, now, &len) == NULL);
  CHECK(vf_replay_reply(r, &first, now + VF_WIRE_MAX_AGE_MS + 1, &len) == NULL); /* stale: nothing */
  static uint8_t big[VF_REPLAY_REPLY_MAX + 1];
  vf_replay_keep_reply(r, &second, big, sizeof big); /* too large to keep */
  CHECK(vf_replay_reply(r, &second, now, &len) == NULL);
  /* 4 MiB in all: 80 replies of 64 KiB push the first out */
  for (int i = 0; i < 80; i++) {
    vf_wire_stamp s = stamp_at(now);
    vf_replay_keep_reply(r, &s, big, VF_REPLAY_REPLY_MAX);
  }
  CHECK(vf_replay_reply(r, &first, now, &len) == NULL);
  vf_replay_destroy(r);
}

int main(void) {
  if (sodium_init() < 0) return 1;
  RUN(test_a_copy_is_refused);
  RUN(test_window);
  RUN(test_requests_before_the_start_are_refused);
  RUN(test_nonces_expire);
  RUN(test_overflow_shrinks_the_window);
  RUN(test_replies_are_kept);
  vf_replay_destroy(NULL);
  return check_finish();
}
