#include "local_render.h"

#include "../common/clock.h"
#include "../common/error.h"
#include "../common/metrics.h"
#include "film_cmd.h"
#include "interrupt.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

/* Measuring costs a pass over the pixels (~1% of an iteration): done after every
 * iteration only when a target may stop the render, else for the progress line at most
 * this often. */
#define PROGRESS_MEASURE_SECONDS 1.0

/* What the render loop's delivery callback and progress line share during one run. */
typedef struct {
  const vf_local_render_options *o;
  uint32_t run;              /* of the entries this run appends to the convergence log */
  float *mean;               /* owned scratch: the film's mean image */
  vf_convergence_entry last; /* the latest measurement (valid when measured) */
  int measured, target_reached;
  double last_measure_time;  /* status->seconds of that measurement */
  uint64_t done_before;      /* iterations of the run's earlier render calls */
  double seconds_before;     /* and their wall time */
} local_run;

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
  if ((stop->target_rmse > 0 && e.rmse <= stop->target_rmse) ||
      (stop->target_error > 0 && e.estimated_rmse <= stop->target_error))
    lr->target_reached = 1;
}

/* The render loop's delivery: measure, and at a due checkpoint log and write the film. */
static int deliver(void *ctx, vf_film *film, const vf_render_status *st) {
  local_run *lr = ctx;
  int targets = lr->o->stop->target_rmse > 0 || lr->o->stop->target_error > 0;
  if (st->delivery_due || targets ||
      (lr->o->progress && st->seconds - lr->last_measure_time >= PROGRESS_MEASURE_SECONDS)) {
    measure(lr, film);
    lr->last_measure_time = st->seconds;
  }
  if (st->delivery_due) {
    int err = vf_convergence_append(&film->convergence, &lr->last);
    if (err == VF_OK && lr->o->output) err = vf_film_write(film, lr->o->output);
    if (err != VF_OK) return err;
  }
  return lr->target_reached ? VF_RENDER_STOP : VF_OK;
}

/* The progress line: a total and an ETA only where the stop condition gives one. */
static void progress(void *ctx, const vf_render_status *st) {
  local_run *lr = ctx;
  const vf_cli_stop *stop = lr->o->stop;
  char error[96] = "", total[32] = "", eta[32] = "";
  if (lr->measured) {
    int n = snprintf(error, sizeof error, "  est. RMSE %.3g", lr->last.estimated_rmse);
    if (lr->o->reference && n > 0 && (size_t)n < sizeof error)
      snprintf(error + n, sizeof error - (size_t)n, "  RMSE %.3g", lr->last.rmse);
  }
  uint64_t done = lr->done_before + st->iterations_done;
  double seconds = lr->seconds_before + st->seconds;
  double rate = seconds > 0.0 ? (double)done / seconds : 0.0;
  double mrays = st->seconds > 0.0 ? (double)st->stats.rays / st->seconds * 1e-6 : 0.0;
  if (stop->iterations > 0) {
    snprintf(total, sizeof total, "/%llu", (unsigned long long)stop->iterations);
    if (rate > 0.0) snprintf(eta, sizeof eta, "  ETA %.1f s", (double)((uint64_t)stop->iterations - done) / rate);
  } else if (stop->time_limit > 0.0) {
    snprintf(eta, sizeof eta, "  ETA %.1f s", seconds < stop->time_limit ? stop->time_limit - seconds : 0.0);
  }
  fprintf(stderr, "\r  iteration %llu%s  %.2f it/s  %.1f Mrays/s%s  elapsed %.1f s%s   ", (unsigned long long)done,
          total, rate, mrays, error, seconds, eta);
}

static void stats_add(vf_vcm_stats *sum, const vf_vcm_stats *s) {
  sum->rays += s->rays;
  sum->light_vertices += s->light_vertices;
  sum->nonfinite += s->nonfinite;
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
  local_run lr = {.o = o, .run = vf_convergence_next_run(&film->convergence, vf_iterset_count(&film->iterations),
                                                         film->render_seconds)};
  lr.mean = malloc(3 * (size_t)film->width * (size_t)film->height * sizeof *lr.mean);
  if (lr.mean == NULL) return vf_error_set(VF_ENOMEM, "out of memory for a %dx%d image", film->width, film->height);
  measure(&lr, film);
  int err = VF_OK;
  if (lr.target_reached) goto done; /* a film that already meets its target stays as it is */

  vf_render_control control = {.interrupt = &vf_interrupted, .ctx = &lr, .progress = o->progress ? progress : NULL,
                               .delivery_interval = o->checkpoint_interval, .deliver = deliver};
  uint64_t remaining = vf_cli_stop_iterations(o->stop);
  vf_interrupt_saved saved;
  vf_interrupt_catch(&saved);
  double start = vf_seconds_now();
  /* One call per gap of the iteration set: the loop over iterations stays in vf_render_range. */
  while (remaining > 0 && !vf_interrupted && !lr.target_reached) {
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
  result->interrupted = vf_interrupted != 0;
  vf_interrupt_restore(&saved);
  if (o->progress) fputc('\n', stderr);
  /* Every call's final delivery wrote the film. */
  if (err == VF_OK && result->iterations == 0) err = vf_error_set(VF_EINVAL, "no iteration finished; nothing written");
done:
  result->last = lr.last;
  result->target_reached = lr.target_reached;
  free(lr.mean);
  return err;
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
