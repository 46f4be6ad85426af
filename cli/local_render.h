/* The local render: `render` and `continue`, one driver.
 *
 * Renders a film's free global iterations, from a first index upward (gaps first, then
 * after its last), on this machine through the one render loop (vf_render_range), until
 * the stop conditions end it or SIGINT/SIGTERM (cli/interrupt.h) interrupts it. Meanwhile
 * it measures the film's error (against a reference when there is one, and the
 * no-reference estimate), shows its progress, stops at a target, and at every due
 * film checkpoint appends an entry to the film's convergence log and writes the film
 * atomically to the output. A killed render therefore keeps its work up to its last
 * checkpoint: the file at the output path is always a complete, valid film, at most one
 * checkpoint interval old. */
#ifndef VF_LOCAL_RENDER_H
#define VF_LOCAL_RENDER_H

#include "../common/film.h"
#include "../common/image.h"
#include "../worker/render/render.h"
#include "options.h"

#include <stdint.h>

/* How a render shows its progress on stderr. A terminal gets one line rewritten after
 * every iteration; a log (a file, a pipe, a batch system's output) gets a plain line after
 * the first iteration and then one every VF_PROGRESS_LINE_SECONDS, so that it shows the
 * render is alive without filling up. */
typedef enum {
  VF_PROGRESS_NONE,  /* -q: nothing */
  VF_PROGRESS_LIVE,  /* the live line, "\r"-rewritten */
  VF_PROGRESS_LINES, /* plain lines, spaced in time */
} vf_progress_mode;
#define VF_PROGRESS_LINE_SECONDS 10.0

/* The mode for this process's stderr: NONE when quiet, LIVE on a terminal, else LINES. */
vf_progress_mode vf_progress_mode_for_stderr(int quiet);

typedef struct {
  const char *output;          /* borrowed: the film path written at every due checkpoint */
  const vf_image *reference;   /* borrowed, or NULL; the film's size */
  const vf_cli_stop *stop;     /* borrowed: iterations, time, targets */
  vf_cli_checkpoint checkpoint; /* when film checkpoints are due */
  vf_progress_mode progress;   /* how progress shows on stderr */
} vf_local_render_options;

typedef struct {
  uint64_t iterations;        /* added to the film by this run */
  double seconds;             /* wall time of the run */
  double render_seconds;      /* of it, the render loop's: every iteration and the
                               * checkpoints due between them, not the final write */
  vf_vcm_stats stats;         /* summed over the run */
  double first_seconds;       /* seconds and rays when the run's first iteration ended: */
  uint64_t first_rays;        /* it also paid for first touches of the renderer's buffers */
  vf_convergence_entry last;  /* the latest measurement of the film */
  int target_reached;         /* a target holds (perhaps before anything was rendered) */
  int interrupted;            /* SIGINT or SIGTERM ended the run */
} vf_local_render_result;

/* Renders into film (stamped by renderer, holding any iterations) the free global
 * iterations from `first` upward, as options say. A film that already meets a target is
 * left as it is (result->target_reached, result->iterations 0, nothing written). Otherwise
 * VF_EINVAL when no iteration finished (nothing written), or the render loop's and the
 * writer's errors; *result is filled in every case. */
int vf_local_render(vf_renderer *renderer, vf_film *film, uint64_t first, const vf_local_render_options *options,
                    vf_local_render_result *result);

/* Reads a reference image: a film or any RGB EXR (a film's R, G, B hold its mean).
 * VF_ENOENT / VF_EEXR naming the file, VF_EMISMATCH when it is not width x height. *out is
 * written only on success and the caller owns it (vf_image_destroy). */
int vf_reference_load(const char *path, int width, int height, vf_image *out);

#endif
