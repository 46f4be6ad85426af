#include "forecast.h"

#include <math.h>
#include <string.h>

static const char *const stop_names[VF_STOP_COUNT_] = {"",           "iterations", "time",  "target_rmse",
                                                       "target_error", "cancelled",  "failed"};

const char *vf_stop_reason_name(vf_stop_reason r) { return (unsigned)r < VF_STOP_COUNT_ ? stop_names[r] : ""; }

int vf_stop_reason_parse(const char *name) {
  for (int i = 0; i < VF_STOP_COUNT_; i++)
    if (strcmp(name, stop_names[i]) == 0) return i;
  return -1;
}

double vf_forecast_slope(const vf_error_point *points, size_t count, int *fitted) {
  if (fitted) *fitted = 0;
  /* The latest usable points, walking back from the end. */
  double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0, lo = INFINITY, hi = 0.0;
  size_t used = 0;
  for (size_t i = count; i-- > 0 && used < VF_FORECAST_POINTS;) {
    const vf_error_point *p = &points[i];
    if (p->iterations < 1 || !(p->error > 0.0) || !isfinite(p->error)) continue;
    double x = log((double)p->iterations), y = log(p->error);
    sx += x, sy += y, sxx += x * x, sxy += x * y;
    lo = fmin(lo, (double)p->iterations);
    hi = fmax(hi, (double)p->iterations);
    used++;
  }
  double d = (double)used * sxx - sx * sx;
  if (used < 2 || hi < 1.2 * lo || !(d > 0.0)) return VF_FORECAST_DEFAULT_SLOPE;
  double s = -((double)used * sxy - sx * sy) / d;
  if (!isfinite(s)) return VF_FORECAST_DEFAULT_SLOPE;
  if (fitted) *fitted = 1;
  return fmin(fmax(s, VF_FORECAST_MIN_SLOPE), VF_FORECAST_MAX_SLOPE);
}

typedef struct {
  double progress, eta, slope;
} outlook;

static outlook target_outlook(uint64_t done, double rate, double target, double error, const vf_error_point *log,
                              size_t count) {
  outlook o = {0.0, -1.0, 0.0};
  if (!(error >= 0.0) || !isfinite(error) || done < 1) return o; /* nothing measured yet */
  if (error <= target) return (outlook){1.0, 0.0, 0.0};
  o.slope = vf_forecast_slope(log, count, NULL);
  double n = (double)done, needed = n * pow(error / target, 1.0 / o.slope);
  o.progress = isfinite(needed) && needed > 0.0 ? fmin(n / needed, 1.0) : 0.0;
  if (rate > 0.0 && isfinite(needed)) o.eta = fmax(needed - n, 0.0) / rate;
  return o;
}

void vf_forecast_compute(const vf_forecast_input *in, vf_forecast *out) {
  outlook o[VF_STOP_COUNT_];
  int set[VF_STOP_COUNT_] = {0};
  if (in->iterations > 0) {
    set[VF_STOP_ITERATIONS] = 1;
    uint64_t left = in->done < in->iterations ? in->iterations - in->done : 0;
    o[VF_STOP_ITERATIONS] = (outlook){fmin((double)in->done / (double)in->iterations, 1.0),
                                      left == 0 ? 0.0 : in->rate > 0.0 ? (double)left / in->rate : -1.0, 0.0};
  }
  if (in->time_limit > 0.0) {
    set[VF_STOP_TIME] = 1;
    o[VF_STOP_TIME] = (outlook){fmin(fmax(in->seconds / in->time_limit, 0.0), 1.0),
                                fmax(in->time_limit - in->seconds, 0.0), 0.0};
  }
  if (in->target_rmse > 0.0) {
    set[VF_STOP_TARGET_RMSE] = 1;
    o[VF_STOP_TARGET_RMSE] =
        target_outlook(in->done, in->rate, in->target_rmse, in->rmse, in->rmse_log, in->rmse_count);
  }
  if (in->target_error > 0.0) {
    set[VF_STOP_TARGET_ERROR] = 1;
    o[VF_STOP_TARGET_ERROR] = target_outlook(in->done, in->rate, in->target_error, in->estimated_rmse,
                                             in->estimated_log, in->estimated_count);
  }
  /* The earliest known ETA; without any, the condition furthest along. */
  int best = VF_STOP_NONE;
  for (int r = VF_STOP_ITERATIONS; r <= VF_STOP_TARGET_ERROR; r++) {
    if (!set[r]) continue;
    if (best == VF_STOP_NONE) {
      best = r;
      continue;
    }
    const outlook *a = &o[r], *b = &o[best];
    if (a->eta >= 0.0 ? (b->eta < 0.0 || a->eta < b->eta) : (b->eta < 0.0 && a->progress > b->progress)) best = r;
  }
  if (best == VF_STOP_NONE) {
    *out = (vf_forecast){VF_STOP_NONE, 0.0, -1.0, 0.0};
    return;
  }
  *out = (vf_forecast){(vf_stop_reason)best, o[best].progress, o[best].eta, o[best].slope};
}
