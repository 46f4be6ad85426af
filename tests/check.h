/* Minimal test harness: named cases, assertions that print both values, a closing line
 * "N passed, N failed" that CI reads. Include once per test executable.
 *
 *   static void test_merge_commutes(void) { CHECK_NEAR(a, b, 1e-6); }
 *   int main(void) { RUN(test_merge_commutes); return check_finish(); }
 */
#ifndef VF_TEST_CHECK_H
#define VF_TEST_CHECK_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static int check_failed_in_case;
static int check_cases_passed, check_cases_failed;
static const char *check_case_name = "";

#define CHECK_FAIL_(fmt, ...)                                                                      \
  do {                                                                                             \
    fprintf(stderr, "  FAIL %s:%d in %s: " fmt "\n", __FILE__, __LINE__, check_case_name, __VA_ARGS__); \
    check_failed_in_case = 1;                                                                      \
  } while (0)

#define CHECK(cond)                                                                                \
  do {                                                                                             \
    if (!(cond)) CHECK_FAIL_("%s", #cond);                                                         \
  } while (0)

#define CHECK_INT_EQ(a, b)                                                                         \
  do {                                                                                             \
    long long va_ = (long long)(a), vb_ = (long long)(b);                                          \
    if (va_ != vb_) CHECK_FAIL_("%s == %s: %lld != %lld", #a, #b, va_, vb_);                       \
  } while (0)

#define CHECK_NEAR(a, b, tol)                                                                      \
  do {                                                                                             \
    double va_ = (double)(a), vb_ = (double)(b), vt_ = (double)(tol);                              \
    if (!(fabs(va_ - vb_) <= vt_))                                                                 \
      CHECK_FAIL_("%s ~ %s: %.9g vs %.9g (|diff| %.3g > tol %.3g)", #a, #b, va_, vb_, fabs(va_ - vb_), vt_); \
  } while (0)

#define CHECK_STR_CONTAINS(haystack, needle)                                                       \
  do {                                                                                             \
    const char *h_ = (haystack), *n_ = (needle);                                                   \
    if (h_ == NULL || strstr(h_, n_) == NULL)                                                      \
      CHECK_FAIL_("\"%s\" does not contain \"%s\"", h_ ? h_ : "(null)", n_);                       \
  } while (0)

/* VF_TEST_ONLY=TEXT in the environment runs only the cases whose names contain TEXT (for
 * working on one case; ctest never sets it). */
static inline int check_selected(const char *name) {
  const char *only = getenv("VF_TEST_ONLY");
  return only == NULL || only[0] == '\0' || strstr(name, only) != NULL;
}

/* Wall-clock seconds, for the time each case prints (what a slow test spends, by case). */
static inline double check_seconds(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

#define RUN(fn)                                                                                    \
  if (check_selected(#fn)) do {                                                                    \
    check_case_name = #fn;                                                                         \
    check_failed_in_case = 0;                                                                      \
    double check_start_ = check_seconds();                                                         \
    fn();                                                                                          \
    if (check_failed_in_case) check_cases_failed++;                                                \
    else check_cases_passed++;                                                                     \
    printf("%s %s (%.1f s)\n", check_failed_in_case ? "FAIL" : "ok  ", #fn, check_seconds() - check_start_); \
    fflush(stdout);                                                                                \
  } while (0)

static inline int check_finish(void) {
  printf("%d passed, %d failed\n", check_cases_passed, check_cases_failed);
  return check_cases_failed ? 1 : 0;
}

#endif
