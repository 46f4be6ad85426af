/* A render as `vcmfarm render` takes it (cli/render_cmd.c): its options, and the preview and
 * summary lines that `continue`, `fetch` and `submit --wait` share with it. */
#ifndef VF_RENDER_JOB_H
#define VF_RENDER_JOB_H

#include "../common/film.h"
#include "../common/settings.h"
#include "../worker/render/render.h"
#include "../worker/render/vcm.h"
#include "options.h"

#include <stddef.h>
#include <stdint.h>

typedef struct {
  const char *scene, *output, *preview; /* borrowed from argv; preview may be NULL */
  const char *camera;                   /* --camera NAME|INDEX of a model file, or NULL */
  const char *background;               /* --background COLOR|FILE.exr, or NULL */
  vf_cli_settings overrides;
  vf_cli_stop stop;
  vf_cli_checkpoint checkpoint;
  double exposure;
  int threads;    /* 0: one per CPU */
  uint64_t start; /* the first global iteration */
  int quiet;
  int verbose;    /* -v: the settings text and the renderer's set-up in the header */
  const char *allocation_from; /* --allocation-from FILM (render), or NULL */
} vf_render_job;

/* --allocation-from FILM (render, submit): the allocation of camera sub-paths FILM records
 * (docs/FILM.md, vcmfarm:allocation), used instead of rendering a pilot. *settings are the
 * command's, overrides applied, not yet validated; `pilot_option` is --pilot as given (-1:
 * not given). Without --pilot and without a pilot in the settings the pilot is FILM's; with
 * `auto` as the algorithm (which would choose by rendering pilots) the algorithm is FILM's.
 * FILM's pilot must then be the settings', its size theirs. *samples (malloc'ed, width x
 * height opaque counts, the caller frees) on success; VF_EUSAGE naming the file and the
 * mismatch (a film without an allocation, of another scene -- scene_hash, the content hash
 * of the scene being rendered -- size or pilot), or FILM's reading
 * error with its name. The counts are moved, never interpreted (common/allocation.h). */
int vf_render_job_allocation_from(const char *path, const uint8_t scene_hash[32], long long pilot_option,
                                  vf_settings *settings, uint8_t **samples);

/* The --help lines of --allocation-from, shared by render and submit. */
#define VF_CLI_ALLOCATION_FROM_HELP                                                          \
  "      --allocation-from FILM  with a pilot: the allocation of camera sub-paths FILM\n"   \
  "                           records (a film rendered with --pilot), instead of\n"        \
  "                           rendering the pilot; --pilot N must be FILM's (default:\n"   \
  "                           FILM's), the scene and size FILM's, and -a auto takes\n"      \
  "                           FILM's algorithm\n"

/* The header of render and continue, what a user needs to know of the render before it
 * starts: "SCENE, WxH, ALGORITHM" (" (auto)" after what --algorithm auto chose), into
 * out (truncated to n). */
void vf_render_job_format_what(const char *scene, const vf_settings *settings, vf_algorithm chosen, char *out,
                               size_t n);
/* And what ends it: "16 iterations", "iterations [5,9)" (start > 0), "for 10 s", "until
 * estimated RMSE <= 0.01", or with several conditions "the first of 100 iterations, 10 s,
 * estimated RMSE <= 0.01". */
void vf_render_job_format_stop(const vf_cli_stop *stop, uint64_t start, char *out, size_t n);
/* With -v, the header's further lines: the settings text and what the renderer enabled and
 * skipped (vf_vcm_describe). */
void vf_render_job_print_details(const vf_settings *settings, const vf_renderer *renderer);

/* What `--algorithm auto` with a pilot measured and chose (vf_render_choose_algorithm), on
 * stderr: one line. */
void vf_render_job_print_choice(const vf_auto_choice *choice, int pilot);

/* Writes the film's mean, tone-mapped (exposure in stops) to sRGB, as the PNG `path`:
 * the preview of render, continue, fetch and submit --wait. */
int vf_preview_write(const vf_film *film, const char *path, double exposure);

/* Writes the film's mean as the sRGB preview PNG when the job asks for one. */
int vf_render_job_write_preview(const vf_render_job *job, const vf_film *film);

/* The summary's first lines on stderr: the film's iterations, rates over `seconds`, and
 * the renderer's statistics over the `rendered` iterations they were gathered on. */
void vf_render_job_print_summary(const vf_film *film, double seconds, const vf_vcm_stats *stats, uint64_t rendered,
                                 int interrupted);

/* The preview options of the commands that write films (-p/--preview, -e/--exposure),
 * with their --help lines, as the settings options are shared (cli/options.h). */
#define VF_CLI_PREVIEW_HELP                                                     \
  "  -p, --preview IMAGE.png  also write a tone-mapped sRGB preview\n"         \
  "  -e, --exposure E         preview exposure in stops (default 0)\n"
/* Checks a --preview path before any work: writable, ending in .png. */
int vf_cli_preview_check(const char *preview);

/* The summary's last lines: the error, why it stopped (or NULL), and what was written. */
void vf_render_job_print_result(const vf_render_job *job, double estimated_rmse, double rmse, const char *stopped_by);
/* "estimated RMSE X" on stderr, or that it is not known yet (NaN: fewer than two
 * iterations to compare). */
void vf_render_job_print_estimate(double estimated_rmse);

#endif
