/* Worker tags and job requirements (common/tags.h): what a tag may be, lists from the
 * command line, the limits the wire is held to, and which workers satisfy a job. */
#include "check.h"

#include "common/error.h"
#include "common/tags.h"

#include <string.h>

static int parse(const char *list, vf_tags *t, int requirement) {
  vf_tags_init(t);
  return vf_tags_parse("--tags", list, t, requirement);
}

static void test_a_list_is_split_at_commas_and_deduplicated(void) {
  vf_tags t;
  CHECK_INT_EQ(parse("night,avx512,night,gpu-room", &t, 0), VF_OK);
  CHECK_INT_EQ(t.count, 3);
  char text[128];
  vf_tags_format(&t, text, sizeof text);
  CHECK_STR_CONTAINS(text, "night,avx512,gpu-room");
  CHECK_INT_EQ(strlen(text), strlen("night,avx512,gpu-room"));
}

static void test_empty_items_are_refused(void) {
  const char *bad[] = {"", ",", "a,,b", ",a", "a,"};
  for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
    vf_tags t;
    CHECK_INT_EQ(parse(bad[i], &t, 0), VF_EINVAL);
    CHECK_STR_CONTAINS(vf_error_detail(VF_EINVAL), "empty tag");
    CHECK_INT_EQ(t.count, 0); /* nothing of a refused list is kept */
  }
}

static void test_bad_bytes_are_refused_naming_the_tag(void) {
  vf_tags t;
  CHECK_INT_EQ(parse("ok,has space", &t, 0), VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EINVAL), "tag 'has space' holds a space");
  CHECK_INT_EQ(parse("tab\there", &t, 0), VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EINVAL), "tag 'tab\\x09here' holds a control character");
  CHECK_INT_EQ(parse("caf\xc3", &t, 0), VF_EINVAL); /* a character cut short */
  CHECK_STR_CONTAINS(vf_error_detail(VF_EINVAL), "tag 'caf\\xc3' is not UTF-8");
  CHECK_INT_EQ(parse("caf\xc3\xa9", &t, 0), VF_OK); /* UTF-8 is a tag like any other */
  CHECK_INT_EQ(vf_tags_add("Register.tags", &t, "a,b", 3, 0), VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EINVAL), "Register.tags: tag 'a,b' holds a comma");
}

static void test_length_and_count_are_bounded(void) {
  vf_tags t;
  char longest[VF_TAG_MAX_BYTES + 2];
  memset(longest, 'x', sizeof longest);
  longest[VF_TAG_MAX_BYTES] = '\0';
  CHECK_INT_EQ(parse(longest, &t, 0), VF_OK);
  longest[VF_TAG_MAX_BYTES] = 'x';
  longest[VF_TAG_MAX_BYTES + 1] = '\0';
  CHECK_INT_EQ(parse(longest, &t, 0), VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EINVAL), "is 33 bytes long, at most 32");
  char list[256] = "";
  for (int i = 0; i <= VF_TAGS_MAX; i++) snprintf(list + strlen(list), sizeof list - strlen(list), "%st%d", i ? "," : "", i);
  CHECK_INT_EQ(parse(list, &t, 0), VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EINVAL), "more than 16 tags (at 't16')");
  CHECK_INT_EQ(t.count, 0);
}

static void test_memory_is_a_requirement_not_a_tag(void) {
  vf_tags t;
  CHECK_INT_EQ(parse("mem>=64G", &t, 0), VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EINVAL), "measured, not given");
  CHECK_INT_EQ(parse("mem>=64G,avx512", &t, 1), VF_OK);
  CHECK(vf_tag_memory("mem>=64G") == (UINT64_C(64) << 30));
  CHECK(vf_tag_memory("mem>=3T") == (UINT64_C(3) << 40));
  CHECK(vf_tag_memory("mem>=512M") == (UINT64_C(512) << 20));
  CHECK(vf_tag_memory("avx512") == 0);
  const char *bad[] = {"mem>=", "mem>=64", "mem>=64g", "mem>=0G", "mem>=-1G", "mem>=1.5G", "mem>=2000000T"};
  for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
    CHECK_INT_EQ(parse(bad[i], &t, 1), VF_EINVAL);
    CHECK_STR_CONTAINS(vf_error_detail(VF_EINVAL), "memory is mem>=N");
  }
}

static void test_a_worker_satisfies_every_requirement_or_none(void) {
  vf_tags need, have;
  const char *missing = NULL;
  CHECK_INT_EQ(parse("night,mem>=64G", &need, 1), VF_OK);
  CHECK_INT_EQ(parse("avx512,night", &have, 0), VF_OK);
  CHECK(vf_tags_satisfied(&need, &have, UINT64_C(64) << 30, &missing));
  CHECK(!vf_tags_satisfied(&need, &have, (UINT64_C(64) << 30) - 1, &missing));
  CHECK_STR_CONTAINS(missing, "mem>=64G");
  CHECK(!vf_tags_satisfied(&need, &have, 0, NULL)); /* memory unknown */
  CHECK_INT_EQ(parse("Night", &need, 1), VF_OK);
  CHECK(!vf_tags_satisfied(&need, &have, 0, &missing)); /* bytes compared */
  CHECK_STR_CONTAINS(missing, "Night");
  vf_tags none;
  vf_tags_init(&none);
  CHECK(vf_tags_satisfied(&none, &none, 0, NULL)); /* no requirement: any worker */
}

int main(void) {
  RUN(test_a_list_is_split_at_commas_and_deduplicated);
  RUN(test_empty_items_are_refused);
  RUN(test_bad_bytes_are_refused_naming_the_tag);
  RUN(test_length_and_count_are_bounded);
  RUN(test_memory_is_a_requirement_not_a_tag);
  RUN(test_a_worker_satisfies_every_requirement_or_none);
  return check_finish();
}
