#include "render_job.h"

#include "../common/allocation.h"
#include "../common/blob.h"

#include "../common/error.h"
#include "../common/image.h"

#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>

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
  if (film->samples != NULL) {
    vf_allocation_report a;
    vf_allocation_describe(film->samples, (size_t)film->width * (size_t)film->height, &a);
    char text[256];
    vf_allocation_summary(&a, text, sizeof text);
    fprintf(stderr, "allocation from the pilot: %s\n", text);
  }
  if (stats->upg_gatherings + stats->upg_fallbacks > 0) {
    double g = stats->upg_gatherings ? (double)stats->upg_gatherings : 1.0;
    fprintf(stderr,
            "gathering: %llu light vertices without bias, %.2f tentative directions and %.2f rays each; "
            "%llu merged as vcm merges (biased)",
            (unsigned long long)stats->upg_gatherings, (double)stats->upg_trials / g, (double)stats->upg_rays / g,
            (unsigned long long)stats->upg_fallbacks);
    if (stats->upg_truncated || stats->upg_bound_exceeded)
      fprintf(stderr, "; %llu stopped at the trial cap, %llu directions above their bound",
              (unsigned long long)stats->upg_truncated, (unsigned long long)stats->upg_bound_exceeded);
    fprintf(stderr, "\n");
  }
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

void vf_render_job_format_what(const char *scene, const vf_settings *settings, vf_algorithm chosen, char *out,
                               size_t n) {
  snprintf(out, n, "%s, %dx%d, %s%s", scene, settings->width, settings->height, vf_algorithm_name(chosen),
           vf_algorithm_is_auto(settings->algorithm) ? (settings->algorithm == VF_ALGO_AUTO ? " (auto)" : " (auto-unbiased)")
                                                     : "");
}

/* Appends to out (of n bytes, holding a string) as snprintf would at its end. */
static void append(char *out, size_t n, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void append(char *out, size_t n, const char *fmt, ...) {
  size_t used = strlen(out);
  if (used + 1 >= n) return;
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(out + used, n - used, fmt, ap);
  va_end(ap);
}

void vf_render_job_format_stop(const vf_cli_stop *stop, uint64_t start, char *out, size_t n) {
  int count = stop->iterations > 0 || !vf_cli_stop_open_ended(stop);
  int conditions = count + (stop->time_limit > 0.0) + (stop->target_rmse > 0.0) + (stop->target_error > 0.0);
  const char *sep = "";
  out[0] = '\0';
  if (conditions > 1) append(out, n, "the first of ");
  if (count) {
    uint64_t k = vf_cli_stop_iterations(stop);
    if (start > 0)
      append(out, n, "iterations [%llu,%llu)", (unsigned long long)start, (unsigned long long)(start + k));
    else
      append(out, n, "%llu iteration%s", (unsigned long long)k, k == 1 ? "" : "s");
    sep = ", ";
  }
  if (stop->time_limit > 0.0) {
    append(out, n, "%s%s%g s", sep, conditions > 1 ? "" : "for ", stop->time_limit);
    sep = ", ";
  }
  if (stop->target_rmse > 0.0) {
    append(out, n, "%s%sRMSE <= %g against %s", sep, conditions > 1 ? "" : "until ", stop->target_rmse,
           stop->reference ? stop->reference : "the reference");
    sep = ", ";
  }
  if (stop->target_error > 0.0)
    append(out, n, "%s%sestimated RMSE <= %g", sep, conditions > 1 ? "" : "until ", stop->target_error);
}

/* A candidate's name: its algorithm, and the share of pixels that merge for vcm merging
 * per pixel. */
static void print_candidate(const vf_auto_choice *choice, int i) {
  double merging = choice->candidates[i].merging;
  fputs(vf_algorithm_name(choice->candidates[i].algorithm), stderr);
  if (merging > 0.0 && merging < 1.0) fprintf(stderr, " merging in %.1f%% of pixels", 100.0 * merging);
}

void vf_render_job_print_choice(const vf_auto_choice *choice, int pilot) {
  fprintf(stderr, "auto: pilots of %d iterations (%.2f s); efficiency, 1 / (s an iteration x variance):", pilot,
          choice->render_seconds);
  for (int i = 0; i < choice->count; i++) {
    fputs(i ? ", " : " ", stderr);
    print_candidate(choice, i);
    fprintf(stderr, " %.4g (%.2f camera sub-paths a pixel)", choice->candidates[i].efficiency,
            choice->candidates[i].camera_subpaths);
  }
  fputs("; chose ", stderr);
  print_candidate(choice, choice->chosen);
  fputs("\n", stderr);
}

void vf_render_job_print_details(const vf_settings *settings, const vf_renderer *renderer) {
  char text[512];
  if (vf_settings_format(settings, text, sizeof text) == VF_OK) fprintf(stderr, "settings: %s\n", text);
  vf_vcm_describe(vf_renderer_vcm(renderer), stderr);
}

int vf_render_job_allocation_from(const char *path, const uint8_t scene_hash[32], long long pilot_option,
                                  vf_settings *settings, uint8_t **samples) {
  vf_film *film = NULL;
  vf_settings recorded;
  int err = vf_film_read(path, &film);
  if (err != VF_OK) return vf_error_set(err, "--allocation-from %s: %s", path, vf_error_detail(err));
  if (film->samples == NULL) {
    err = vf_error_set(VF_EUSAGE, "--allocation-from %s: the film has no allocation of camera sub-paths (%s)", path,
                       film->pilot ? "it is a pilot's film" : "it was rendered without a pilot, or before its pilot ended");
    goto done;
  }
  if (memcmp(film->scene_hash, scene_hash, sizeof film->scene_hash) != 0) {
    /* An allocation is a pilot's picture of one scene through one camera. */
    char have[65], want[65];
    vf_blob_hex(film->scene_hash, have);
    vf_blob_hex(scene_hash, want);
    err = vf_error_set(VF_EUSAGE, "--allocation-from %s: the film was rendered from another scene (its content hash "
                       "%.8s..., this scene's %.8s...; another --camera or --background?)", path, have, want);
    goto done;
  }
  if ((err = vf_settings_parse(&recorded, film->settings_text)) != VF_OK) {
    err = vf_error_set(VF_EUSAGE, "--allocation-from %s: its settings do not read: %s", path, vf_error_detail(err));
    goto done;
  }
  if (pilot_option < 0 && settings->pilot == 0) settings->pilot = recorded.pilot;
  if (vf_settings_choose_by_pilots(settings) && !vf_algorithm_is_auto(recorded.algorithm))
    settings->algorithm = recorded.algorithm;
  if (vf_settings_choose_by_pilots(settings)) {
    err = vf_error_set(VF_EUSAGE, "--allocation-from %s: the film names no algorithm auto could have chosen: name "
                       "one (-a pt, bpt or vcm)", path);
  } else if (film->width != settings->width || film->height != settings->height) {
    err = vf_error_set(VF_EUSAGE, "--allocation-from %s: the film is %dx%d, this render %dx%d (one count a pixel)",
                       path, film->width, film->height, settings->width, settings->height);
  } else if (recorded.pilot != settings->pilot) {
    err = vf_error_set(VF_EUSAGE, "--allocation-from %s: its allocation comes from a pilot of %d iterations, this "
                       "render's pilot is %d (--pilot; films of different pilots never merge)",
                       path, recorded.pilot, settings->pilot);
  } else {
    *samples = film->samples;
    film->samples = NULL;
  }
done:
  vf_film_destroy(film);
  return err;
}
