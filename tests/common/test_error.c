/* Error codes and details (common/error.c): a detail belongs to the code it was recorded
 * for, so a bare `return VF_E...` after an earlier, unrelated failure shows its own code's
 * message, never the earlier text; wrapping a detail in a longer one works; details are
 * per thread. */
#include "check.h"
#include "common/error.h"
#include "common/iterset.h"

#include <pthread.h>

static void test_detail_belongs_to_its_code(void) {
  vf_error_clear();
  CHECK_INT_EQ(vf_error_code(), VF_OK);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EINVAL), "invalid argument"); /* none recorded */
  CHECK_INT_EQ(vf_error_set(VF_EFILM, "a.exr: attribute %s is malformed", "vcmfarm:iterations"), VF_EFILM);
  CHECK_INT_EQ(vf_error_code(), VF_EFILM);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EFILM), "a.exr: attribute vcmfarm:iterations is malformed");
  /* asked for another code: that code's own message, not the text recorded for EFILM */
  CHECK(strcmp(vf_error_detail(VF_ENOMEM), vf_strerror(VF_ENOMEM)) == 0);
  CHECK(strcmp(vf_error_detail(VF_EIO), "input/output error") == 0);
  vf_error_clear();
  CHECK(strcmp(vf_error_detail(VF_EFILM), vf_strerror(VF_EFILM)) == 0);
  CHECK_INT_EQ(vf_error_code(), VF_OK);
}

/* A real bare return: vf_iterset_format into no room returns VF_EINVAL without a detail. */
static void test_bare_return_does_not_show_a_stale_detail(void) {
  vf_error_set(VF_EOVERLAP, "films share iterations: an earlier failure, already handled");
  vf_iterset set;
  vf_iterset_init(&set);
  char text[1];
  int err = vf_iterset_format(&set, text, 0);
  CHECK_INT_EQ(err, VF_EINVAL);
  CHECK(strcmp(vf_error_detail(err), vf_strerror(VF_EINVAL)) == 0);
  CHECK(strstr(vf_error_detail(err), "earlier failure") == NULL);
  /* and a detail the failing call does record is the one shown */
  err = vf_iterset_add(&set, 5, 5);
  CHECK_INT_EQ(err, VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(err), "empty iteration range [5,5)");
  vf_iterset_destroy(&set);
}

static void test_wrapping_a_detail(void) {
  int err = vf_error_set(VF_EINVAL, "file name with a control character at byte %d", 3);
  err = vf_error_set(err, "files[%d]: %s", 2, vf_error_detail(err));
  CHECK_INT_EQ(err, VF_EINVAL);
  CHECK(strcmp(vf_error_detail(VF_EINVAL), "files[2]: file name with a control character at byte 3") == 0);
  /* wrapping a code that has no detail wraps its message */
  err = vf_error_set(VF_ENOMEM, "scene.json: %s", vf_error_detail(VF_ENOMEM));
  CHECK(strcmp(vf_error_detail(err), "scene.json: out of memory") == 0);
  /* an empty detail is none */
  vf_error_set(VF_EIO, "%s", "");
  CHECK_INT_EQ(vf_error_code(), VF_OK);
  CHECK(strcmp(vf_error_detail(VF_EIO), "input/output error") == 0);
}

static void *other_thread(void *arg) {
  const char **seen = arg;
  seen[0] = vf_error_detail(VF_ESCENE); /* this thread recorded nothing */
  vf_error_set(VF_ESCENE, "thread: its own detail");
  seen[1] = vf_error_detail(VF_ESCENE);
  return NULL;
}

static void test_details_are_per_thread(void) {
  vf_error_set(VF_ESCENE, "main: scene.json: unknown material 'gold'");
  const char *seen[2] = {NULL, NULL};
  pthread_t t;
  CHECK_INT_EQ(pthread_create(&t, NULL, other_thread, seen), 0);
  pthread_join(t, NULL);
  CHECK(seen[0] && strcmp(seen[0], "invalid scene") == 0);
  CHECK(seen[1] && strcmp(seen[1], "thread: its own detail") == 0);
  CHECK_STR_CONTAINS(vf_error_detail(VF_ESCENE), "unknown material 'gold'");
}

static void test_strerror_covers_every_code(void) {
#define XX(code, msg, _) CHECK(strcmp(vf_strerror(VF_##code), msg) == 0);
  VF_ERRNO_MAP(XX)
#undef XX
  CHECK(strcmp(vf_strerror(VF_OK), "success") == 0);
  CHECK(strcmp(vf_strerror(-1), "unknown error") == 0);
  CHECK(strcmp(vf_error_detail(-1), "unknown error") == 0);
}

int main(void) {
  RUN(test_detail_belongs_to_its_code);
  RUN(test_bare_return_does_not_show_a_stale_detail);
  RUN(test_wrapping_a_detail);
  RUN(test_details_are_per_thread);
  RUN(test_strerror_covers_every_code);
  return check_finish();
}
