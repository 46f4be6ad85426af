/* What `render` and `continue` do while vf_render_range runs: measure the film's error
 * (against a reference when there is one, and the no-reference estimate), append an entry
 * to its convergence log and write it (atomically) at every due checkpoint, stop at a
 * target error, and show the progress line.
 *
 * A killed render therefore keeps the work up to its last checkpoint: the film at the
 * output path is always a complete, valid film, at most one checkpoint interval old. */
#ifndef VF_LOCAL_RENDER_H
#define VF_LOCAL_RENDER_H

#include "../common/film.h"
#include "../common/image.h"
#include "../worker/render.h"

typedef struct {
  const char *output;        /* borrowed: the film path written at every due checkpoint */
  const vf_image *reference; /* borrowed, or NULL; same size as the film */
  double target_rmse;        /* > 0: stop once the RMSE against the reference is <= this */
  double target_error;       /* > 0: stop once the estimated RMSE is <= this */
  int tty;                   /* show the progress line on stderr */
  /* state, filled while rendering */
  uint32_t run;              /* of the entries this session appends */
  float *mean;               /* owned scratch: the film's mean image */
  vf_convergence_entry last; /* the latest measurement (valid when measured) */
  int measured;
  double last_measure_time;  /* status->seconds of that measurement */
  int target_reached;
  unsigned writes;           /* films written at checkpoints */
} vf_checkpointer;

/* Prepares a checkpointer for film (its convergence log decides the run). reference and
 * output are borrowed. VF_ENOMEM. */
int vf_checkpointer_init(vf_checkpointer *cp, const vf_film *film, const char *output, const vf_image *reference,
                         double target_rmse, double target_error, int tty);
void vf_checkpointer_destroy(vf_checkpointer *cp);

/* Points control's ctx, checkpoint and progress at this checkpointer. */
void vf_checkpointer_attach(vf_checkpointer *cp, vf_render_control *control, double interval);

/* Measures film now into cp->last (times, iterations, RMSE and relative MSE when there is
 * a reference, the estimate); sets cp->target_reached when a target holds. */
void vf_checkpointer_measure(vf_checkpointer *cp, const vf_film *film);

/* Reads a reference image: a film or any RGB EXR (a film's R, G, B hold its mean).
 * VF_ENOENT / VF_EEXR naming the file, VF_EMISMATCH when it is not width x height. *out is
 * written only on success and the caller owns it (vf_image_destroy). */
int vf_reference_load(const char *path, int width, int height, vf_image *out);

#endif
