/* When a render will end, and how far it has come: the one forecast behind `render`'s
 * progress line (local and through the farm), `continue`, and the coordinator's status.
 *
 * A render stops at the first of its stop conditions to hold (an iteration count, a time
 * limit, a target RMSE against a reference, a target estimated RMSE). The forecast asks,
 * for each condition that is set, how long until it holds, and follows the earliest:
 * its progress (0 to 1) and its ETA are the render's, and its name says which it is. So a
 * render with --time alone counts its progress in seconds, never against an iteration cap.
 *
 * Targets are extrapolated from the convergence of the render itself: the error of a
 * Monte Carlo estimate falls as c * n^-s in the number of iterations n (s = 1/2 for an
 * unbiased estimator; vertex merging's shrinking radius and the early transient make it
 * differ), so log(error) is fitted against log(n), by least squares, over the latest
 * measurements (vf_forecast_slope). The iterations that reach the target are then
 * n_target = n (error / target)^(1/s), their time n_target / rate, and the progress n /
 * n_target: linear in iterations, so a progress bar moves at a steady pace at a steady
 * rate. Until two measurements a factor 1.2 apart in n exist, s = 1/2. */
#ifndef VF_FORECAST_H
#define VF_FORECAST_H

#include <stddef.h>
#include <stdint.h>

/* Why a render or a job ended (or, for the forecast, which condition will end it). The
 * names are the machine-readable stop reasons of `status --json`. */
typedef enum {
  VF_STOP_NONE,         /* not ended / no condition */
  VF_STOP_ITERATIONS,   /* "iterations": its iteration count is done */
  VF_STOP_TIME,         /* "time": its time limit ran out */
  VF_STOP_TARGET_RMSE,  /* "target_rmse": RMSE against the reference at most the target */
  VF_STOP_TARGET_ERROR, /* "target_error": estimated RMSE at most the target */
  VF_STOP_CANCELLED,    /* "cancelled" */
  VF_STOP_FAILED,       /* "failed" */
  VF_STOP_COUNT_
} vf_stop_reason;

/* "iterations", "time", ...; "" for VF_STOP_NONE. */
const char *vf_stop_reason_name(vf_stop_reason r);
/* The reason of a name ("" is VF_STOP_NONE); -1 for an unknown one. */
int vf_stop_reason_parse(const char *name);

/* One measurement of a render's error. */
typedef struct {
  uint64_t iterations;
  double error;
} vf_error_point;

/* The points the slope is fitted to: the latest this many. */
#define VF_FORECAST_POINTS 16
#define VF_FORECAST_DEFAULT_SLOPE 0.5
/* Fitted slopes are kept within these (a noisy early fit must not promise the target in
 * a few iterations, nor never). */
#define VF_FORECAST_MIN_SLOPE 0.1
#define VF_FORECAST_MAX_SLOPE 1.5

/* s of error ~ c n^-s fitted to the latest VF_FORECAST_POINTS points with n >= 1 and a
 * finite error > 0 (points in any order of time, ascending n expected); clamped to
 * [MIN, MAX]; VF_FORECAST_DEFAULT_SLOPE when they span less than a factor 1.2 in n.
 * *fitted (if not NULL) says whether the slope came from the points. */
double vf_forecast_slope(const vf_error_point *points, size_t count, int *fitted);

typedef struct {
  uint64_t done;             /* iterations done */
  uint64_t iterations;       /* the iteration condition; 0: none */
  double seconds;            /* the time the time limit counts */
  double time_limit;         /* 0: none */
  double rate;               /* iterations per second now; 0 unknown */
  double target_rmse, rmse;  /* target 0: none; rmse the latest, NaN unknown */
  const vf_error_point *rmse_log; /* the render's RMSE measurements (may be NULL) */
  size_t rmse_count;
  double target_error, estimated_rmse; /* likewise for the estimated RMSE */
  const vf_error_point *estimated_log;
  size_t estimated_count;
} vf_forecast_input;

typedef struct {
  vf_stop_reason by; /* the condition expected to hold first; VF_STOP_NONE: none is set */
  double progress;   /* towards it, in [0, 1]; 0 when nothing is known yet */
  double eta;        /* seconds until it holds; < 0 unknown (no rate yet) */
  double slope;      /* the slope used for a target (by is a target), else 0 */
} vf_forecast;

/* The forecast of a render now. A condition that holds already gives progress 1 and ETA
 * 0. Conditions whose ETA is unknown (no rate yet) take part by their progress alone:
 * with no rate at all, the one furthest along is shown, its ETA unknown. */
void vf_forecast_compute(const vf_forecast_input *in, vf_forecast *out);

#endif
