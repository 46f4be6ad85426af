/* "Render global iterations [begin, end) of a job into a film": the one render loop.
 *
 * `vcmfarm render`, `continue` and the farm's workers all call vf_render_range; nothing
 * else loops over iterations. A renderer owns the Embree scene, the thread pool and the
 * VCM state for one scene and one set of settings; it can render any iterations, in any
 * order, into any film whose size matches. */
#ifndef VF_RENDER_H
#define VF_RENDER_H

#include "../common/clock.h"
#include "../common/film.h"
#include "../common/settings.h"
#include "scene.h"
#include "vcm.h"

#include <signal.h>
#include <stdint.h>

typedef struct vf_renderer vf_renderer;

typedef struct {
  uint64_t iterations_done; /* in this call */
  uint64_t iterations_total; /* requested in this call (UINT64_MAX when open-ended) */
  double seconds;           /* wall time of this call so far */
  vf_vcm_stats stats;       /* of this call so far */
} vf_render_status;

typedef struct {
  double time_limit; /* > 0: no new iteration starts after this many seconds */
  void (*progress)(void *ctx, const vf_render_status *status); /* after each iteration, or NULL */
  void *ctx;
  volatile sig_atomic_t *interrupt; /* when it becomes non-zero, stop after the current iteration */
} vf_render_control;

/* The scene is borrowed and must outlive the renderer. threads <= 0: one per CPU. */
int vf_renderer_create(const vf_scene *scene, const vf_settings *settings, int threads, vf_renderer **out);
void vf_renderer_destroy(vf_renderer *r);
const vf_vcm *vf_renderer_vcm(const vf_renderer *r);

/* Renders iterations begin, begin + 1, ... < end into film (its size must match the
 * settings), stopping early as `control` says (NULL: never). The film's scene hash and
 * settings must be those of this renderer (set them with vf_renderer_stamp). Each
 * iteration enters the film whole or not at all. *status (may be NULL) gets the totals. */
int vf_render_range(vf_renderer *r, vf_film *film, uint64_t begin, uint64_t end, const vf_render_control *control,
                    vf_render_status *status);

/* Writes the renderer's scene hash and settings text into an empty film. */
int vf_renderer_stamp(const vf_renderer *r, vf_film *film);

#endif
