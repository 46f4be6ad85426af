/* `vcmfarm info`: every attribute of a film, its image mean, its estimated RMSE and its
 * convergence log, as aligned text or as JSON (cJSON; NaN becomes null). */
#include "info_cmd.h"

#include "../common/allocation.h"

#include "options.h"
#include "../common/error.h"
#include "../common/film.h"
#include "../common/settings.h"

#include <cjson/cJSON.h>
#include <getopt.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

static const char usage[] =
    "usage: vcmfarm info FILM [--json]\n"
    "\n"
    "Prints every attribute of FILM (format version, scene hash and name, settings, seed,\n"
    "iteration set and count, light frames, render and CPU time, non-finite samples, light\n"
    "vertices merged with bias by upg), the image mean, the estimated RMSE (no reference\n"
    "needed, docs/FILM.md), what it covers, and the convergence log.\n"
    "\n"
    "  --json      print one JSON object instead (unknown values are null)\n"
    "  -h, --help  this text\n"
    "\n"
    "Exit status: 0 done, 2 FILM is missing, damaged or not a film.\n";

typedef struct {
  char *iterations; /* owned */
  double image_mean, estimated_rmse;
  vf_settings settings;
  int have_settings;
  char hash[65];
  int format_version; /* the file's */
} summary;

static int summarise(const vf_film *film, summary *out) {
  size_t text_size = film->iterations.count * 46 + 1, n = (size_t)film->width * (size_t)film->height;
  char *iterations = malloc(text_size);
  float *rgb = malloc(3 * n * sizeof *rgb);
  if (iterations == NULL || rgb == NULL) {
    free(iterations);
    free(rgb);
    return vf_error_set(VF_ENOMEM, "out of memory");
  }
  vf_iterset_format(&film->iterations, iterations, text_size);
  vf_film_mean(film, rgb);
  double sum = 0.0;
  for (size_t i = 0; i < 3 * n; i++) sum += rgb[i];
  free(rgb);
  out->iterations = iterations;
  out->image_mean = sum / (3.0 * (double)n);
  out->estimated_rmse = vf_film_estimate_rmse(film);
  out->have_settings = vf_settings_parse(&out->settings, film->settings_text) == VF_OK;
  for (int i = 0; i < 32; i++) snprintf(out->hash + 2 * i, 3, "%02x", film->scene_hash[i]);
  return VF_OK;
}

/* What the estimated RMSE covers under the film's algorithm, in a sentence, into out. An
 * unbiased algorithm's film that counts biased merges (upg's fall-backs, which auto-unbiased
 * may have chosen) says so with the count: those merges' bias is not in the estimate. */
static void estimate_sentence(const vf_film *film, vf_algorithm a, char *out, size_t n) {
  switch (vf_algorithm_estimate_scope(a)) {
  case VF_ESTIMATE_ERROR:
    if (film->biased_merges > 0)
      snprintf(out, n,
               "the error, except the bias of the %" PRIu64 " light %s merged as vcm merges (biased_merges)",
               film->biased_merges, vf_cli_plural(film->biased_merges, "vertex", "vertices"));
    else
      snprintf(out, n, "%s",
               a == VF_ALGO_UPG ? "the error: upg is unbiased (biased_merges 0: no light vertex merged as vcm merges)"
                                : "the error: the algorithm is unbiased");
    break;
  case VF_ESTIMATE_VARIANCE: snprintf(out, n, "variance only: merging's bias at the film's radii is not in it"); break;
  default:
    snprintf(out, n, "the error if auto chose pt, variance only if it chose vcm (render's first line says which)");
  }
}

static cJSON *json_number(double v) { return isfinite(v) ? cJSON_CreateNumber(v) : cJSON_CreateNull(); }

/* 64-bit counts go out as numbers (exact up to 2^53, beyond any real film). */
static int print_json(const char *path, const vf_film *film, const summary *s) {
  cJSON *root = cJSON_CreateObject(), *log = NULL;
  if (root == NULL) return VF_ENOMEM;
  cJSON_AddStringToObject(root, "file", path);
  cJSON_AddNumberToObject(root, "format_version", s->format_version);
  cJSON_AddNumberToObject(root, "width", film->width);
  cJSON_AddNumberToObject(root, "height", film->height);
  cJSON_AddStringToObject(root, "scene_hash", s->hash);
  cJSON_AddStringToObject(root, "scene", film->scene_name);
  cJSON_AddStringToObject(root, "settings", film->settings_text);
  cJSON_AddItemToObject(root, "algorithm",
                        s->have_settings ? cJSON_CreateString(vf_algorithm_name(s->settings.algorithm)) : cJSON_CreateNull());
  cJSON_AddItemToObject(root, "seed", s->have_settings ? cJSON_CreateNumber((double)s->settings.seed) : cJSON_CreateNull());
  cJSON_AddStringToObject(root, "iterations", s->iterations);
  cJSON_AddNumberToObject(root, "iteration_count", (double)vf_iterset_count(&film->iterations));
  cJSON_AddNumberToObject(root, "light_frames", (double)vf_iterset_count(&film->iterations)); /* one per iteration */
  cJSON_AddNumberToObject(root, "render_seconds", film->render_seconds);
  cJSON_AddNumberToObject(root, "cpu_seconds", film->cpu_seconds);
  cJSON_AddNumberToObject(root, "nonfinite_samples", (double)film->nonfinite_samples);
  cJSON_AddNumberToObject(root, "biased_merges", (double)film->biased_merges);
  if (film->samples != NULL) {
    vf_allocation_report a;
    vf_allocation_describe(film->samples, (size_t)film->width * (size_t)film->height, &a);
    cJSON *o = cJSON_AddObjectToObject(root, "allocation");
    if (o != NULL) {
      cJSON_AddNumberToObject(o, "mean_camera_sub_paths", a.mean);
      cJSON *levels = cJSON_AddArrayToObject(o, "pixels_of_1_2_4_8_16");
      for (int i = 0; levels != NULL && i < VF_ALLOCATION_LEVELS; i++)
        cJSON_AddItemToArray(levels, cJSON_CreateNumber((double)a.pixels[i]));
      cJSON_AddNumberToObject(o, "pixels_without_merging", (double)a.no_merging);
    }
  }
  cJSON_AddItemToObject(root, "image_mean", json_number(s->image_mean));
  cJSON_AddItemToObject(root, "estimated_rmse", json_number(s->estimated_rmse));
  if (s->have_settings)
    cJSON_AddStringToObject(root, "estimate_covers",
                            vf_estimate_scope_name(vf_algorithm_estimate_scope(s->settings.algorithm)));
  if ((log = cJSON_AddArrayToObject(root, "convergence")) != NULL)
    for (size_t i = 0; i < film->convergence.count; i++) {
      const vf_convergence_entry *e = &film->convergence.entries[i];
      cJSON *o = cJSON_CreateObject();
      if (o == NULL) break;
      cJSON_AddNumberToObject(o, "run", e->run);
      cJSON_AddNumberToObject(o, "wall_seconds", e->wall_seconds);
      cJSON_AddNumberToObject(o, "cpu_seconds", e->cpu_seconds);
      cJSON_AddNumberToObject(o, "iterations", (double)e->iterations);
      cJSON_AddItemToObject(o, "rmse", json_number(e->rmse));
      cJSON_AddItemToObject(o, "rel_mse", json_number(e->rel_mse));
      cJSON_AddItemToObject(o, "estimated_rmse", json_number(e->estimated_rmse));
      cJSON_AddItemToArray(log, o);
    }
  char *text = cJSON_Print(root);
  cJSON_Delete(root);
  if (text == NULL) return vf_error_set(VF_ENOMEM, "out of memory for the JSON text");
  puts(text);
  free(text);
  return VF_OK;
}

static void print_text(const char *path, const vf_film *film, const summary *s) {
  printf("file               %s\n", path);
  printf("format_version     %d\n", s->format_version);
  printf("size               %dx%d\n", film->width, film->height);
  printf("scene              %s\n", film->scene_name[0] ? film->scene_name : "(unknown)");
  printf("scene_hash         %s\n", s->hash);
  printf("settings           %s\n", film->settings_text);
  if (s->have_settings) {
    printf("algorithm          %s\n", vf_algorithm_name(s->settings.algorithm));
    printf("seed               %" PRIu64 "\n", s->settings.seed);
  }
  printf("iterations         %s\n", s->iterations);
  printf("iteration_count    %" PRIu64 "\n", vf_iterset_count(&film->iterations));
  printf("light_frames       %" PRIu64 "\n", vf_iterset_count(&film->iterations)); /* one per iteration */
  printf("render_seconds     %.3f\n", film->render_seconds);
  printf("cpu_seconds        %.3f\n", film->cpu_seconds);
  printf("nonfinite_samples  %" PRIu64 "\n", film->nonfinite_samples);
  printf("biased_merges      %" PRIu64 "\n", film->biased_merges);
  if (film->samples != NULL) {
    vf_allocation_report a;
    vf_allocation_describe(film->samples, (size_t)film->width * (size_t)film->height, &a);
    char text[256];
    vf_allocation_summary(&a, text, sizeof text);
    printf("allocation         %s\n", text);
  }
  printf("image_mean         %.6g\n", s->image_mean);
  printf("estimated_rmse     %.6g\n", s->estimated_rmse);
  if (s->have_settings) {
    char covers[160];
    estimate_sentence(film, s->settings.algorithm, covers, sizeof covers);
    printf("estimate_covers    %s\n", covers);
  }
  printf("convergence log    %zu entr%s\n", film->convergence.count, film->convergence.count == 1 ? "y" : "ies");
  if (film->convergence.count)
    printf("  %4s %12s %12s %12s %12s %12s %14s\n", "run", "wall_s", "cpu_s", "iterations", "rmse", "rel_mse",
           "estimated_rmse");
  for (size_t i = 0; i < film->convergence.count; i++) {
    const vf_convergence_entry *e = &film->convergence.entries[i];
    printf("  %4" PRIu32 " %12.3f %12.3f %12" PRIu64 " %12.6g %12.6g %14.6g\n", e->run, e->wall_seconds, e->cpu_seconds,
           e->iterations, e->rmse, e->rel_mse, e->estimated_rmse);
  }
}

int vf_cmd_info(int argc, char **argv) {
  static const struct option options[] = {{"json", no_argument, 0, 'J'}, {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
  int json = 0, c;
  optind = 0; /* 0: getopt starts again from scratch (glibc), forgetting the last argv */
  while ((c = vf_cli_getopt(argc, argv, "h", options)) != -1) {
    switch (c) {
    case 'J': json = 1; break;
    case 'h': fputs(usage, stdout); return VF_EXIT_OK;
    default:
      return vf_cli_bad_option("info");
    }
  }
  if (optind != argc - 1) return vf_cli_usage_error("info", "expected exactly one FILM");
  const char *path = argv[optind];
  vf_film *film = NULL;
  summary s = {0};
  int err = vf_film_read(path, &film);
  if (err == VF_OK) err = vf_film_read_version(path, &s.format_version);
  if (err == VF_OK) err = summarise(film, &s);
  if (err == VF_OK) {
    if (json) err = print_json(path, film, &s);
    else print_text(path, film, &s);
  }
  free(s.iterations);
  vf_film_destroy(film);
  return err == VF_OK ? VF_EXIT_OK : vf_cli_fail("info", err);
}
