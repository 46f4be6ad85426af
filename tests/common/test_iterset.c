#include "check.h"
#include "common/error.h"
#include "common/iterset.h"

static void test_add_coalesces_adjacent_ranges(void) {
  vf_iterset s;
  vf_iterset_init(&s);
  CHECK_INT_EQ(vf_iterset_add(&s, 10, 20), VF_OK);
  CHECK_INT_EQ(vf_iterset_add(&s, 0, 10), VF_OK);
  CHECK_INT_EQ(vf_iterset_add(&s, 30, 40), VF_OK);
  CHECK_INT_EQ(vf_iterset_add(&s, 20, 30), VF_OK);
  CHECK_INT_EQ(s.count, 1);
  CHECK_INT_EQ(vf_iterset_count(&s), 40);
  vf_iterset_destroy(&s);
}

static void test_overlap_is_refused_and_leaves_set_unchanged(void) {
  vf_iterset s;
  vf_iterset_init(&s);
  vf_iterset_add(&s, 0, 10);
  vf_iterset_add(&s, 20, 30);
  CHECK_INT_EQ(vf_iterset_add(&s, 5, 15), VF_EOVERLAP);
  CHECK_INT_EQ(vf_iterset_add(&s, 29, 31), VF_EOVERLAP);
  CHECK_INT_EQ(vf_iterset_add(&s, 0, 100), VF_EOVERLAP);
  CHECK_INT_EQ(s.count, 2);
  CHECK_INT_EQ(vf_iterset_count(&s), 20);
  vf_iterset_destroy(&s);
}

static void test_union_and_intersection(void) {
  vf_iterset a, b;
  vf_iterset_init(&a);
  vf_iterset_init(&b);
  vf_iterset_add(&a, 0, 8);
  vf_iterset_add(&b, 8, 16);
  CHECK(!vf_iterset_intersects(&a, &b));
  CHECK_INT_EQ(vf_iterset_union(&a, &b), VF_OK);
  CHECK_INT_EQ(a.count, 1);
  CHECK(vf_iterset_intersects(&a, &b));
  CHECK_INT_EQ(vf_iterset_union(&a, &b), VF_EOVERLAP);
  CHECK_INT_EQ(vf_iterset_count(&a), 16);
  CHECK_INT_EQ(vf_iterset_next_free(&a, 0), 16);
  CHECK_INT_EQ(vf_iterset_next_free(&a, 20), 20);
  CHECK(vf_iterset_contains(&a, 15));
  CHECK(!vf_iterset_contains(&a, 16));
  vf_iterset_destroy(&a);
  vf_iterset_destroy(&b);
}

static void test_text_round_trip(void) {
  vf_iterset a, b;
  vf_iterset_init(&a);
  vf_iterset_init(&b);
  vf_iterset_add(&a, 0, 16);
  vf_iterset_add(&a, 32, 64);
  vf_iterset_add(&a, 1000000000000ULL, 1000000000001ULL);
  char text[256];
  CHECK_INT_EQ(vf_iterset_format(&a, text, sizeof text), VF_OK);
  CHECK_STR_CONTAINS(text, "[0,16) [32,64)");
  CHECK_INT_EQ(vf_iterset_parse(&b, text), VF_OK);
  CHECK(vf_iterset_equal(&a, &b));
  CHECK_INT_EQ(vf_iterset_parse(&b, "[5,3)"), VF_EINVAL);
  CHECK_INT_EQ(vf_iterset_parse(&b, "[0,10) [5,20)"), VF_EINVAL);
  CHECK_INT_EQ(vf_iterset_parse(&b, "[0,10) junk"), VF_EINVAL);
  CHECK(vf_iterset_equal(&a, &b)); /* failed parses leave the set as it was */
  vf_iterset_destroy(&a);
  vf_iterset_destroy(&b);
}

int main(void) {
  RUN(test_add_coalesces_adjacent_ranges);
  RUN(test_overlap_is_refused_and_leaves_set_unchanged);
  RUN(test_union_and_intersection);
  RUN(test_text_round_trip);
  return check_finish();
}
