#include "render_job.h"

#include "../common/error.h"
#include "../common/image.h"

#include <math.h>
#include <stdio.h>

int vf_preview_write(const vf_film *film, const char *path, double exposure) {
  vf_image img;
  int err = vf_image_alloc(&img, film->width, film->height);
  if (err != VF_OK) return err;
  vf_film_mean(film, img.rgb);
  err = vf_image_write_png(path, &img, (float)exposure);
  vf_image_destroy(&img);
  return err;
}

int vf_cli_preview_check(const char *preview) {
  int err = vf_cli_writable("--preview", preview);
  return err != VF_OK ? err : vf_cli_extension("--preview", preview, ".png", "a PNG image");
}

int vf_render_job_write_preview(const vf_render_job *job, const vf_film *film) {
  return job->preview ? vf_preview_write(film, job->preview, job->exposure) : VF_OK;
}

void vf_render_job_print_summary(const vf_film *film, double seconds, const vf_vcm_stats *stats, uint64_t rendered,
                                 int interrupted) {
  char set[256];
  if (vf_iterset_format(&film->iterations, set, sizeof set) != VF_OK) snprintf(set, sizeof set, "(long)");
  uint64_t n = vf_iterset_count(&film->iterations);
  double per = rendered ? 1000.0 / (double)rendered : 0.0;
  fprintf(stderr,
          "rendered %llu %s %s in %.2f s: %.3f it/s, %.2f Mrays/s, %llu light vertices/it\n"
          "per iteration: light sub-paths %.1f ms, grid %.1f ms, camera sub-paths %.1f ms; "
          "%llu non-finite %s%s\n",
          (unsigned long long)n, vf_cli_plural(n, "iteration", "iterations"), set, seconds, (double)n / seconds, (double)stats->rays / seconds * 1e-6,
          (unsigned long long)(rendered ? stats->light_vertices / rendered : 0), stats->light_seconds * per,
          stats->grid_seconds * per, stats->camera_seconds * per, (unsigned long long)stats->nonfinite,
          vf_cli_plural(stats->nonfinite, "sample", "samples"), interrupted ? " (interrupted)" : "");
}

void vf_render_job_print_estimate(double estimated_rmse) {
  if (isfinite(estimated_rmse))
    fprintf(stderr, "estimated RMSE %.4g", estimated_rmse);
  else /* one iteration, or one of each replicate missing: no spread to measure yet */
    fprintf(stderr, "estimated RMSE not known yet (it needs at least two iterations)");
}

void vf_render_job_print_result(const vf_render_job *job, double estimated_rmse, double rmse, const char *stopped_by) {
  vf_render_job_print_estimate(estimated_rmse);
  if (job->stop.reference) fprintf(stderr, ", RMSE %.4g against %s", rmse, job->stop.reference);
  if (stopped_by && stopped_by[0]) fprintf(stderr, " (%s)", stopped_by);
  fprintf(stderr, "\nwrote %s%s%s\n", job->output, job->preview ? " and " : "", job->preview ? job->preview : "");
}
