/* common/forecast.c: the slope of error against iterations, and progress and ETA towards
 * the stop condition that ends a render first (the numbers of `render`'s progress line and
 * of `status`). */
#include "common/forecast.h"

#include "check.h"

#include <math.h>

/* error = c n^-s at n = n0, 2 n0, 4 n0, ... */
static size_t power_law(vf_error_point *p, size_t count, double c, double s, uint64_t n0) {
  for (size_t i = 0; i < count; i++) {
    uint64_t n = n0 << i;
    p[i] = (vf_error_point){n, c * pow((double)n, -s)};
  }
  return count;
}

static void test_the_slope_of_a_power_law_is_found(void) {
  vf_error_point p[20];
  int fitted = 0;
  CHECK_NEAR(vf_forecast_slope(p, power_law(p, 6, 0.3, 0.5, 4), &fitted), 0.5, 1e-9);
  CHECK(fitted);
  CHECK_NEAR(vf_forecast_slope(p, power_law(p, 6, 2.0, 0.8, 1), NULL), 0.8, 1e-9);
  /* Only the latest VF_FORECAST_POINTS count: an early transient is forgotten. */
  power_law(p, 20, 1.0, 0.5, 1);
  for (int i = 0; i < 4; i++) p[i].error *= 10.0;
  CHECK_NEAR(vf_forecast_slope(p, 20, NULL), 0.5, 1e-9);
}

static void test_too_few_or_bad_points_give_the_default_slope(void) {
  vf_error_point p[4] = {{10, 0.1}, {11, 0.09}, {0, 0.5}, {12, NAN}};
  int fitted = 1;
  CHECK_NEAR(vf_forecast_slope(p, 0, &fitted), VF_FORECAST_DEFAULT_SLOPE, 0.0);
  CHECK(!fitted);
  /* 10 to 11 is less than a factor 1.2; n = 0 and NaN are skipped. */
  CHECK_NEAR(vf_forecast_slope(p, 4, &fitted), VF_FORECAST_DEFAULT_SLOPE, 0.0);
  CHECK(!fitted);
  /* A flat or rising error is clamped, never a promise of "never" or "at once". */
  vf_error_point flat[3] = {{10, 0.1}, {100, 0.1}, {1000, 0.1}}, steep[2] = {{10, 1.0}, {100, 1e-6}};
  CHECK_NEAR(vf_forecast_slope(flat, 3, NULL), VF_FORECAST_MIN_SLOPE, 0.0);
  CHECK_NEAR(vf_forecast_slope(steep, 2, NULL), VF_FORECAST_MAX_SLOPE, 0.0);
}

static void test_a_time_limit_counts_seconds_not_a_cap(void) {
  /* render --time 2: no iteration count at all. */
  vf_forecast f;
  vf_forecast_input in = {.done = 400, .seconds = 0.5, .time_limit = 2.0, .rate = 800.0};
  vf_forecast_compute(&in, &f);
  CHECK_INT_EQ(f.by, VF_STOP_TIME);
  CHECK_NEAR(f.progress, 0.25, 1e-12);
  CHECK_NEAR(f.eta, 1.5, 1e-12);
  /* Without a rate yet the time's ETA is still known. */
  in.rate = 0.0;
  vf_forecast_compute(&in, &f);
  CHECK_INT_EQ(f.by, VF_STOP_TIME);
  CHECK_NEAR(f.eta, 1.5, 1e-12);
  /* Iterations that end sooner win: 100 of 120 at 40/s is 0.5 s. */
  in = (vf_forecast_input){.done = 100, .iterations = 120, .seconds = 3.0, .time_limit = 10.0, .rate = 40.0};
  vf_forecast_compute(&in, &f);
  CHECK_INT_EQ(f.by, VF_STOP_ITERATIONS);
  CHECK_NEAR(f.eta, 0.5, 1e-12);
  CHECK_NEAR(f.progress, 100.0 / 120.0, 1e-12);
}

static void test_a_target_is_extrapolated_from_the_slope(void) {
  vf_error_point p[6];
  power_law(p, 6, 1.0, 0.5, 4); /* n = 4 .. 128 */
  double error = p[5].error;    /* 1 / sqrt(128) */
  vf_forecast f;
  vf_forecast_input in = {.done = 128, .rate = 16.0, .target_error = error / 2.0, .estimated_rmse = error,
                          .estimated_log = p, .estimated_count = 6};
  vf_forecast_compute(&in, &f);
  /* Half the error at slope 1/2: four times the iterations. */
  CHECK_INT_EQ(f.by, VF_STOP_TARGET_ERROR);
  CHECK_NEAR(f.slope, 0.5, 1e-9);
  CHECK_NEAR(f.progress, 0.25, 1e-9);
  CHECK_NEAR(f.eta, 3.0 * 128.0 / 16.0, 1e-6);
  /* At slope 1: twice the iterations. */
  power_law(p, 6, 1.0, 1.0, 4);
  in.estimated_rmse = p[5].error;
  in.target_error = p[5].error / 2.0;
  vf_forecast_compute(&in, &f);
  CHECK_NEAR(f.slope, 1.0, 1e-9);
  CHECK_NEAR(f.progress, 0.5, 1e-9);
  CHECK_NEAR(f.eta, 8.0, 1e-6);
  /* Met already: done. */
  in.target_error = 1.0;
  vf_forecast_compute(&in, &f);
  CHECK_NEAR(f.progress, 1.0, 0.0);
  CHECK_NEAR(f.eta, 0.0, 0.0);
  /* The RMSE target with no measurement yet: progress 0, ETA unknown; a time limit then
   * gives the known ETA. */
  in = (vf_forecast_input){.done = 0, .target_rmse = 0.01, .rmse = NAN};
  vf_forecast_compute(&in, &f);
  CHECK_INT_EQ(f.by, VF_STOP_TARGET_RMSE);
  CHECK(f.eta < 0.0);
  in.time_limit = 60.0;
  vf_forecast_compute(&in, &f);
  CHECK_INT_EQ(f.by, VF_STOP_TIME);
  CHECK_NEAR(f.eta, 60.0, 0.0);
}

static void test_nothing_set_forecasts_nothing(void) {
  vf_forecast f;
  vf_forecast_input in = {.done = 5, .rate = 1.0};
  vf_forecast_compute(&in, &f);
  CHECK_INT_EQ(f.by, VF_STOP_NONE);
  CHECK(f.eta < 0.0);
}

static void test_stop_reasons_have_names(void) {
  const char *names[] = {"", "iterations", "time", "target_rmse", "target_error", "cancelled", "failed"};
  for (int i = 0; i < VF_STOP_COUNT_; i++) {
    CHECK(strcmp(vf_stop_reason_name((vf_stop_reason)i), names[i]) == 0);
    CHECK_INT_EQ(vf_stop_reason_parse(names[i]), i);
  }
  CHECK_INT_EQ(vf_stop_reason_parse("done"), -1);
}

int main(void) {
  RUN(test_the_slope_of_a_power_law_is_found);
  RUN(test_too_few_or_bad_points_give_the_default_slope);
  RUN(test_a_time_limit_counts_seconds_not_a_cap);
  RUN(test_a_target_is_extrapolated_from_the_slope);
  RUN(test_nothing_set_forecasts_nothing);
  RUN(test_stop_reasons_have_names);
  return check_finish();
}
