#include "local_render.h"

#include "../common/clock.h"
#include "../common/error.h"
#include "../common/forecast.h"
#include "../common/metrics.h"
#include "film_cmd.h"
#include "interrupt.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

/* Measuring costs a pass over the pixels (~1% of an iteration): done after every
 * iteration only when a target may stop the render, else for the live line at most this
 * often, and for each plain progress line. */
#define PROGRESS_MEASURE_SECONDS 1.0

/* What the render loop's delivery callback and progress line share during one run. */
typedef struct {
  const vf_local_render_options *o;
  vf_render_control *control; /* its delivery interval follows the checkpoints' cost */
  uint32_t run;              /* of the entries this run appends to the convergence log */
  float *mean;               /* owned scratch: the film's mean image */
  vf_convergence_entry last; /* the latest measurement (valid when measured) */
  int measured, target_reached;
  double last_measure_time;  /* status->seconds of that measurement */
  uint64_t done_before;      /* iterations of the run's earlier render calls */
  double seconds_before;     /* and their wall time */
  uint64_t film_before;      /* iterations the film held when the run began */
  unsigned lines;            /* plain progress lines printed (VF_PROGRESS_LINES) */
  double last_line_seconds;  /* the run's seconds at the last of them */
  /* measurements for the forecast's slope, each at 1.1 times the iterations of the one
   * before (so that the latest VF_FORECAST_POINTS span a factor 4.6), ring of the latest */
  vf_error_point rmse_points[VF_FORECAST_POINTS], estimated_points[VF_FORECAST_POINTS];
  unsigned points, points_next;
} local_run;

/* The measurement as a forecast point, when it is far enough past the last one. */
static void keep_point(local_run *lr, const vf_convergence_entry *e) {
  unsigned last = (lr->points_next + VF_FORECAST_POINTS - 1) % VF_FORECAST_POINTS;
  if (e->iterations < 1 || (lr->points > 0 && (double)e->iterations < 1.1 * (double)lr->estimated_points[last].iterations))
    return;
  lr->rmse_points[lr->points_next] = (vf_error_point){e->iterations, e->rmse};
  lr->estimated_points[lr->points_next] = (vf_error_point){e->iterations, e->estimated_rmse};
  lr->points_next = (lr->points_next + 1) % VF_FORECAST_POINTS;
  if (lr->points < VF_FORECAST_POINTS) lr->points++;
}

/* The ring in order of iterations, into out; how many. */
static size_t ordered_points(const local_run *lr, const vf_error_point *ring, vf_error_point *out) {
  for (unsigned i = 0; i < lr->points; i++)
    out[i] = ring[(lr->points_next + VF_FORECAST_POINTS - lr->points + i) % VF_FORECAST_POINTS];
  return lr->points;
}

static void measure(local_run *lr, const vf_film *film) {
  const vf_cli_stop *stop = lr->o->stop;
  vf_convergence_entry e = {lr->run, film->render_seconds, film->cpu_seconds, vf_iterset_count(&film->iterations),
                            NAN, NAN, vf_film_estimate_rmse(film)};
  if (lr->o->reference) {
    vf_error_metrics m;
    vf_film_mean(film, lr->mean);
    if (vf_metrics_compute(lr->mean, lr->o->reference->rgb, film->width, film->height, NULL, &m) == VF_OK &&
        m.pixels > 0) {
      e.rmse = m.rmse_all;
      e.rel_mse = m.rel_mse_all;
    }
  }
  lr->last = e;
  lr->measured = 1;
  keep_point(lr, &e);
  if ((stop->target_rmse > 0 && e.rmse <= stop->target_rmse) ||
      (stop->target_error > 0 && e.estimated_rmse <= stop->target_error))
    lr->target_reached = 1;
}

/* Whether the progress shows after the iteration that ends `seconds` into the run. */
static int progress_due(const local_run *lr, double seconds) {
  switch (lr->o->progress) {
  case VF_PROGRESS_LIVE: return 1;
  case VF_PROGRESS_LINES: return lr->lines == 0 || seconds - lr->last_line_seconds >= VF_PROGRESS_LINE_SECONDS;
  default: return 0;
  }
}

/* The render loop's delivery: measure, and at a due checkpoint log and write the film. */
static int deliver(void *ctx, vf_film *film, const vf_render_status *st) {
  local_run *lr = ctx;
  int targets = lr->o->stop->target_rmse > 0 || lr->o->stop->target_error > 0;
  int shown = progress_due(lr, lr->seconds_before + st->seconds);
  if (st->delivery_due || targets ||
      (shown && (lr->o->progress == VF_PROGRESS_LINES ||
                 st->seconds - lr->last_measure_time >= PROGRESS_MEASURE_SECONDS))) {
    measure(lr, film);
    lr->last_measure_time = st->seconds;
  }
  if (st->delivery_due) {
    double t0 = vf_seconds_now();
    int err = vf_convergence_append(&film->convergence, &lr->last);
    if (err == VF_OK && lr->o->output) err = vf_film_write(film, lr->o->output);
    if (err != VF_OK) return err;
    lr->control->delivery_interval = vf_cli_checkpoint_next(&lr->o->checkpoint, vf_seconds_now() - t0);
  }
  return lr->target_reached ? VF_RENDER_STOP : VF_OK;
}

/* The progress line: progress and ETA towards the stop condition that will end the run
 * (common/forecast.h), never against an iteration count nobody asked for; errors once they
 * are known (the estimate needs two iterations). */
static void progress(void *ctx, const vf_render_status *st) {
  local_run *lr = ctx;
  const vf_cli_stop *stop = lr->o->stop;
  double seconds = lr->seconds_before + st->seconds;
  if (!progress_due(lr, seconds)) return;
  char error[96] = "", total[32] = "", eta[64] = "";
  int n = 0;
  if (lr->measured && isfinite(lr->last.estimated_rmse))
    n = snprintf(error, sizeof error, "  est. RMSE %.3g", lr->last.estimated_rmse);
  if (lr->measured && lr->o->reference && isfinite(lr->last.rmse) && n >= 0 && (size_t)n < sizeof error)
    snprintf(error + n, sizeof error - (size_t)n, "  RMSE %.3g", lr->last.rmse);
  uint64_t done = lr->done_before + st->iterations_done;
  double rate = seconds > 0.0 ? (double)done / seconds : 0.0;
  double mrays = st->seconds > 0.0 ? (double)st->stats.rays / st->seconds * 1e-6 : 0.0;
  uint64_t limit = vf_cli_stop_open_ended(stop) ? (uint64_t)stop->iterations : vf_cli_stop_iterations(stop);
  if (limit > 0) snprintf(total, sizeof total, "/%llu", (unsigned long long)limit);
  vf_error_point rmse_log[VF_FORECAST_POINTS], estimated_log[VF_FORECAST_POINTS];
  /* Targets count the film's iterations, the iteration count this run's. */
  vf_forecast_input in = {.done = lr->film_before + done,
                          .iterations = limit > 0 ? lr->film_before + limit : 0,
                          .seconds = seconds,
                          .time_limit = stop->time_limit,
                          .rate = rate,
                          .target_rmse = stop->target_rmse,
                          .rmse = lr->measured ? lr->last.rmse : NAN,
                          .rmse_log = rmse_log,
                          .rmse_count = ordered_points(lr, lr->rmse_points, rmse_log),
                          .target_error = stop->target_error,
                          .estimated_rmse = lr->measured ? lr->last.estimated_rmse : NAN,
                          .estimated_log = estimated_log,
                          .estimated_count = ordered_points(lr, lr->estimated_points, estimated_log)};
  vf_forecast f;
  vf_forecast_compute(&in, &f);
  if (f.by != VF_STOP_NONE && f.eta >= 0.0)
    snprintf(eta, sizeof eta, "  %.0f%% (%s)  ETA %.1f s", 100.0 * f.progress, vf_stop_reason_name(f.by), f.eta);
  char line[320];
  snprintf(line, sizeof line, "  iteration %llu%s  %.2f it/s  %.1f Mrays/s%s  elapsed %.1f s%s",
           (unsigned long long)done, total, rate, mrays, error, seconds, eta);
  if (lr->o->progress == VF_PROGRESS_LIVE) {
    fprintf(stderr, "\r%s   ", line); /* the spaces cover the end of a longer line before */
  } else {
    fprintf(stderr, "%s\n", line);
    lr->lines++;
    lr->last_line_seconds = seconds;
  }
}

static void stats_add(vf_vcm_stats *sum, const vf_vcm_stats *s) {
  sum->rays += s->rays;
  sum->light_vertices += s->light_vertices;
  sum->nonfinite += s->nonfinite;
  sum->upg_gatherings += s->upg_gatherings;
  sum->upg_trials += s->upg_trials;
  sum->upg_rays += s->upg_rays;
  sum->upg_truncated += s->upg_truncated;
  sum->upg_bound_exceeded += s->upg_bound_exceeded;
  sum->upg_fallbacks += s->upg_fallbacks;
  sum->light_seconds += s->light_seconds;
  sum->grid_seconds += s->grid_seconds;
  sum->camera_seconds += s->camera_seconds;
}

/* The end of the run of free indices that starts at `free_index`: the next index in the
 * set, or UINT64_MAX. */
static uint64_t gap_end(const vf_iterset *set, uint64_t free_index) {
  for (size_t i = 0; i < set->count; i++)
    if (set->ranges[i].begin > free_index) return set->ranges[i].begin;
  return UINT64_MAX;
}

int vf_local_render(vf_renderer *renderer, vf_film *film, uint64_t first, const vf_local_render_options *o,
                    vf_local_render_result *result) {
  *result = (vf_local_render_result){0};
  local_run lr = {.o = o,
                  .run = vf_convergence_next_run(&film->convergence, vf_iterset_count(&film->iterations),
                                                 film->render_seconds),
                  .film_before = vf_iterset_count(&film->iterations)};
  lr.mean = malloc(3 * (size_t)film->width * (size_t)film->height * sizeof *lr.mean);
  if (lr.mean == NULL) return vf_error_set(VF_ENOMEM, "out of memory for a %dx%d image", film->width, film->height);
  measure(&lr, film);
  int err = VF_OK;
  if (lr.target_reached) goto done; /* a film that already meets its target stays as it is */

  vf_render_control control = {.interrupt = &vf_interrupted, .ctx = &lr,
                               .progress = o->progress != VF_PROGRESS_NONE ? progress : NULL,
                               .delivery_interval = vf_cli_checkpoint_next(&o->checkpoint, 0.0), .deliver = deliver};
  lr.control = &control;
  uint64_t remaining = vf_cli_stop_iterations(o->stop);
  vf_interrupt_saved saved;
  vf_interrupt_catch(&saved);
  double start = vf_seconds_now();
  if (film->samples == NULL && vf_renderer_settings(renderer)->pilot > 0) {
    /* The pilot decides the allocation of camera sub-paths before the first iteration
     * (common/allocation.h); its time is the film's. */
    double seconds = film->render_seconds;
    vf_render_status pilot;
    err = vf_render_pilot(renderer, film, &control, &pilot);
    if (err == VF_OK && o->progress != VF_PROGRESS_NONE)
      fprintf(stderr, "pilot: %d iterations in %.2f s, %llu non-finite %s\n", vf_renderer_settings(renderer)->pilot,
              film->render_seconds - seconds, (unsigned long long)pilot.stats.nonfinite,
              vf_cli_plural(pilot.stats.nonfinite, "sample", "samples"));
    lr.seconds_before += film->render_seconds - seconds;
  }
  /* One call per gap of the iteration set: the loop over iterations stays in vf_render_range. */
  while (err == VF_OK && remaining > 0 && !vf_interrupted && !lr.target_reached) {
    uint64_t begin = vf_iterset_next_free(&film->iterations, first), end = gap_end(&film->iterations, begin);
    if (begin >= end) break; /* no free index left below 2^64 - 1 */
    if (end - begin > remaining) end = begin + remaining;
    if (o->stop->time_limit > 0.0) {
      control.time_limit = o->stop->time_limit - (vf_seconds_now() - start);
      if (control.time_limit <= 0.0) break;
    }
    vf_render_status st;
    err = vf_render_range(renderer, film, begin, end, &control, &st);
    if (result->iterations == 0 && st.iterations_done > 0) {
      result->first_seconds = lr.seconds_before + st.first_seconds;
      result->first_rays = result->stats.rays + st.first_rays;
    }
    result->iterations += st.iterations_done;
    stats_add(&result->stats, &st.stats);
    lr.done_before += st.iterations_done;
    lr.seconds_before += st.seconds;
    remaining -= st.iterations_done;
    if (err != VF_OK || st.iterations_done < end - begin) break;
  }
  result->seconds = vf_seconds_now() - start;
  result->render_seconds = lr.seconds_before;
  result->interrupted = vf_interrupted != 0;
  vf_interrupt_restore(&saved);
  if (o->progress == VF_PROGRESS_LIVE) fputc('\n', stderr);
  /* Every call's final delivery wrote the film. */
  if (err == VF_OK && result->iterations == 0) err = vf_error_set(VF_EINVAL, "no iteration finished; nothing written");
done:
  result->last = lr.last;
  result->target_reached = lr.target_reached;
  free(lr.mean);
  return err;
}

vf_progress_mode vf_progress_mode_for_stderr(int quiet) {
  if (quiet) return VF_PROGRESS_NONE;
  return isatty(STDERR_FILENO) ? VF_PROGRESS_LIVE : VF_PROGRESS_LINES;
}

int vf_reference_load(const char *path, int width, int height, vf_image *out) {
  vf_image img = {0};
  int err = vf_reference_read(path, &img, NULL); /* cli/film_cmd.h: a film or any RGB EXR */
  if (err != VF_OK) return err;
  if (img.width != width || img.height != height) {
    err = vf_error_set(VF_EMISMATCH, "reference %s is %dx%d but the film is %dx%d", path, img.width, img.height,
                       width, height);
    vf_image_destroy(&img);
    return err;
  }
  *out = img;
  return VF_OK;
}
