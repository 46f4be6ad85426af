#include "local_render.h"

#include "../common/error.h"
#include "../common/metrics.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

/* Measuring costs a pass over the pixels (~1% of an iteration): done after every
 * iteration only when a target may stop the render, else for the progress line at most
 * this often. */
#define PROGRESS_MEASURE_SECONDS 1.0

int vf_checkpointer_init(vf_checkpointer *cp, const vf_film *film, const char *output, const vf_image *reference,
                         double target_rmse, double target_error, int tty) {
  float *mean = malloc(3 * (size_t)film->width * (size_t)film->height * sizeof *mean);
  if (mean == NULL) return vf_error_set(VF_ENOMEM, "out of memory for a %dx%d image", film->width, film->height);
  *cp = (vf_checkpointer){0};
  cp->output = output;
  cp->reference = reference;
  cp->target_rmse = target_rmse;
  cp->target_error = target_error;
  cp->tty = tty;
  cp->mean = mean;
  cp->run = vf_convergence_next_run(&film->convergence, vf_iterset_count(&film->iterations), film->render_seconds);
  return VF_OK;
}

void vf_checkpointer_destroy(vf_checkpointer *cp) {
  if (cp == NULL) return;
  free(cp->mean);
  cp->mean = NULL;
}

void vf_checkpointer_measure(vf_checkpointer *cp, const vf_film *film) {
  vf_convergence_entry e = {cp->run, film->render_seconds, film->cpu_seconds, vf_iterset_count(&film->iterations),
                            NAN, NAN, vf_film_estimate_rmse(film)};
  if (cp->reference) {
    vf_error_metrics m;
    vf_film_mean(film, cp->mean);
    if (vf_metrics_compute(cp->mean, cp->reference->rgb, film->width, film->height, NULL, &m) == VF_OK &&
        m.pixels > 0) {
      e.rmse = m.rmse_all;
      e.rel_mse = m.rel_mse_all;
    }
  }
  cp->last = e;
  cp->measured = 1;
  if ((cp->target_rmse > 0 && e.rmse <= cp->target_rmse) || (cp->target_error > 0 && e.estimated_rmse <= cp->target_error))
    cp->target_reached = 1;
}

static int on_checkpoint(void *ctx, vf_film *film, const vf_render_status *st) {
  vf_checkpointer *cp = ctx;
  int targets = cp->target_rmse > 0 || cp->target_error > 0;
  if (st->checkpoint_due || targets || (cp->tty && st->seconds - cp->last_measure_time >= PROGRESS_MEASURE_SECONDS)) {
    vf_checkpointer_measure(cp, film);
    cp->last_measure_time = st->seconds;
  }
  if (st->checkpoint_due) {
    int err = vf_convergence_append(&film->convergence, &cp->last);
    if (err != VF_OK) return err;
    if (cp->output) {
      if ((err = vf_film_write(film, cp->output)) != VF_OK) return err;
      cp->writes++;
    }
  }
  return cp->target_reached ? VF_RENDER_STOP : VF_OK;
}

static void progress(void *ctx, const vf_render_status *st) {
  vf_checkpointer *cp = ctx;
  if (!cp->tty) return;
  char error[96] = "";
  if (cp->measured) {
    int n = snprintf(error, sizeof error, "  est. RMSE %.3g", cp->last.estimated_rmse);
    if (cp->reference && n > 0 && (size_t)n < sizeof error)
      snprintf(error + n, sizeof error - (size_t)n, "  RMSE %.3g", cp->last.rmse);
  }
  double rate = st->seconds > 0.0 ? (double)st->iterations_done / st->seconds : 0.0;
  double mrays = st->seconds > 0.0 ? (double)st->stats.rays / st->seconds * 1e-6 : 0.0;
  if (st->iterations_total != UINT64_MAX && rate > 0.0) {
    double eta = (double)(st->iterations_total - st->iterations_done) / rate;
    fprintf(stderr, "\r  iteration %llu/%llu  %.2f it/s  %.1f Mrays/s%s  elapsed %.1f s  ETA %.1f s   ",
            (unsigned long long)st->iterations_done, (unsigned long long)st->iterations_total, rate, mrays, error,
            st->seconds, eta);
  } else {
    fprintf(stderr, "\r  iteration %llu  %.2f it/s  %.1f Mrays/s%s  elapsed %.1f s   ",
            (unsigned long long)st->iterations_done, rate, mrays, error, st->seconds);
  }
}

void vf_checkpointer_attach(vf_checkpointer *cp, vf_render_control *control, double interval) {
  control->ctx = cp;
  control->progress = progress;
  control->checkpoint = on_checkpoint;
  control->checkpoint_interval = interval;
}

int vf_reference_load(const char *path, int width, int height, vf_image *out) {
  vf_image img = {0};
  int err = vf_image_read_exr(path, &img);
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
