/* "Render global iterations [begin, end) of a job into a film": the one render loop.
 *
 * `vcmfarm render`, `continue` and the farm's workers all call vf_render_range; nothing
 * else loops over iterations. A renderer owns the Embree scene, the thread pool and the
 * VCM state for one scene and one set of settings; it can render any iterations, in any
 * order, into any film whose size matches. */
#ifndef VF_RENDER_H
#define VF_RENDER_H

#include "../../common/clock.h"
#include "../../common/film.h"
#include "../../common/film_accum.h"
#include "../../common/settings.h"
#include "../scene/scene.h"
#include "vcm.h"

#include <signal.h>
#include <stdint.h>

typedef struct vf_renderer vf_renderer;

typedef struct {
  uint64_t iterations_done; /* in this call */
  uint64_t iterations_total; /* requested in this call (UINT64_MAX when open-ended) */
  double seconds;           /* wall time of this call so far */
  vf_vcm_stats stats;       /* of this call so far */
  double first_seconds;     /* seconds and stats.rays when the call's first iteration ended: */
  uint64_t first_rays;      /* the first pays for first touches of the renderer's buffers */
  int delivery_due;         /* for the delivery callback: a delivery is due (below) */
  int final;                /* for the delivery callback: the call after the last iteration */
} vf_render_status;

/* A delivery callback's "stop rendering" answer (a target error was reached). */
#define VF_RENDER_STOP 1

typedef struct {
  double time_limit; /* > 0: no new iteration starts after this many seconds */
  void (*progress)(void *ctx, const vf_render_status *status); /* after each iteration, or NULL */
  void *ctx;
  volatile sig_atomic_t *interrupt; /* when it becomes non-zero, stop after the current iteration */
  /* Delivery: where the film's iterations go while the loop runs. The local render writes
   * the film to its output (a film checkpoint, cli/local_render.c); a worker ships a part of
   * its lease to the coordinator and empties the film (worker/worker.c). Called after every
   * iteration, before progress, with the film holding it, and once more after the last
   * iteration of the call with status->final set. Its status->delivery_due is set every
   * delivery_interval seconds of this call (> 0; else never), except after the range's last
   * iteration, and on the final call, which happens only if an iteration entered the film
   * since the last due delivery: a range that runs to its end is delivered once at its end,
   * outside status->seconds, however the interval falls. Cheap work
   * (a target test) may run at every call, expensive work (writing the film) only when due.
   * Returns VF_OK to go on, VF_RENDER_STOP to stop (a last, final call follows), or a
   * negative error, which stops the loop without a final call and is returned. NULL: none.
   * The interval is read after every iteration: a delivery may change it (the local render
   * spaces its checkpoints by their cost). */
  double delivery_interval;
  int (*deliver)(void *ctx, vf_film *film, const vf_render_status *status);
  /* When not NULL (borrowed, the film's size): the iterations' pixels go to this compact
   * accumulator instead of the film's sums, and everything else of them (indices, counts,
   * times) to the film; the film's pixels are then the accumulator's (common/film_accum.h).
   * A worker's choice: half the memory of a film's sums, shipped from there. */
  vf_film_accum *accum;
} vf_render_control;

/* With a pilot (vf_settings.pilot, common/allocation.h), before the job's first iteration:
 * unless the film has its allocation of camera sub-paths, renders the pilot's iterations
 * into a film of their own (control's interrupt only), computes the allocation from it
 * into film, adds the pilot's times to film's, and drops it; *status (may be NULL) gets
 * the pilot's (its non-finite samples, which are in no image of the job, to report). VF_OK
 * at once without a pilot or with an allocation; VF_EINVAL, film unchanged, if interrupted.
 * vf_render_range refuses a film of a job with a pilot that has no allocation. */
int vf_render_pilot(vf_renderer *r, vf_film *film, const vf_render_control *control, vf_render_status *status);
/* Iterations [begin, end) of the pilot render (end <= pilot), into a film of the pilot's
 * (no allocation; marked a pilot's, vf_film.pilot, so that it never merges into an image):
 * vf_render_range with the pilot's numbers and one camera sub-path a pixel. Parts of it
 * merge like any films' into the film of [0, pilot) that vf_allocation_compute reads. */
int vf_render_pilot_range(vf_renderer *r, vf_film *pilot, uint64_t begin, uint64_t end, const vf_render_control *control,
                          vf_render_status *status);

/* `--algorithm auto` with a pilot: the algorithm chosen by measuring each candidate's pilot
 * (vf_render_choose_algorithm): pt, bpt, vcm, and vcm merging in some pixels only. */
#define VF_AUTO_CANDIDATES 4
/* pt is chosen over bpt and vcm only when its predicted efficiency is at least this many
 * times theirs (render.c, choice_score: what pt samples rarely is in no pilot's estimate),
 * and a tile keeps vcm's merging unless bpt's pilot predicts this many times vcm's
 * efficiency over it (vf_allocation_choose: what bpt samples rarely, merging samples). */
#define VF_AUTO_MARGIN 1.25
typedef struct {
  vf_algorithm algorithm; /* the one chosen */
  int chosen;             /* its index in candidates */
  int count;              /* candidates measured (those the settings allow) and predicted */
  struct {
    vf_algorithm algorithm;
    double merging;         /* the share of pixels that merge: 0 (pt, bpt), 1 (vcm), or
                             * between for vcm merging per pixel, whose figures are predicted
                             * from bpt's and vcm's pilots (common/allocation.h) */
    double light_seconds;   /* per pilot iteration: the light sub-paths' pass and the grid, */
    double camera_seconds;  /* the camera sub-paths' (one a pixel) */
    double camera_subpaths; /* per pixel and iteration, by its pilot's allocation */
    double variance;        /* predicted of an iteration with it (vf_allocation_report) */
    double efficiency;      /* 1 / (seconds an iteration x variance) */
  } candidates[VF_AUTO_CANDIDATES];
  double render_seconds, cpu_seconds; /* of every candidate's pilot */
} vf_auto_choice;

/* `--algorithm auto` with a pilot (settings->algorithm VF_ALGO_AUTO, settings->pilot > 0):
 * renders the pilot (vf_render_pilot_range, iterations [0, pilot)) of each of pt, bpt and
 * vcm that the settings allow, computes each one's allocation of camera sub-paths from it,
 * predicts the efficiency of an iteration with that allocation, 1 / ((t_light + t_camera
 * k) v), t_light and t_camera the measured seconds of the pilot's light and camera passes
 * per iteration, k the allocation's mean camera sub-paths a pixel and v its predicted
 * variance (vf_allocation_report), and sets settings->algorithm to the most efficient,
 * pt's efficiency counted over VF_AUTO_MARGIN. With both bpt's and vcm's pilots,
 * a fourth candidate: vcm without merging in the pixels where bpt's pilot predicts
 * VF_AUTO_MARGIN times vcm's efficiency (vf_allocation_choose), its counts from each
 * pixel's own algorithm, its cost vcm's light pass and each pixel's camera sub-paths at its
 * algorithm's cost; it is a candidate only when
 * some pixels merge and some do not.
 * The choice rests on measured times, so it is made once, by whoever starts the job, and
 * kept in the settings (a film or a farm job then names the algorithm, not auto); what is
 * rendered after it is a pure function of those settings and the allocation as always.
 * samples (width x height, may be NULL) receive the chosen one's allocation: for pt, bpt
 * and vcm the one vf_render_pilot computes for the chosen settings, bit for bit; for vcm
 * merging per pixel the mixed one, which only the pilots of two algorithms give (a film or
 * a job carries it). interrupt may be NULL. VF_EINVAL without
 * auto and a pilot, or when interrupted; the renderer's errors. */
int vf_render_choose_algorithm(const vf_scene *scene, vf_settings *settings, int threads,
                               volatile sig_atomic_t *interrupt, uint8_t *samples, vf_auto_choice *choice);

/* The scene is borrowed and must outlive the renderer. threads <= 0: one per CPU. */
int vf_renderer_create(const vf_scene *scene, const vf_settings *settings, int threads, vf_renderer **out);
void vf_renderer_destroy(vf_renderer *r);
const vf_vcm *vf_renderer_vcm(const vf_renderer *r);
/* The settings it renders with. */
const vf_settings *vf_renderer_settings(const vf_renderer *r);

/* Renders iterations begin, begin + 1, ... < end into film (its size must match the
 * settings), stopping early as `control` says (NULL: never). The film's scene hash and
 * settings must be those of this renderer (set them with vf_renderer_stamp). Each
 * iteration enters the film whole or not at all. *status (may be NULL) gets the totals. */
int vf_render_range(vf_renderer *r, vf_film *film, uint64_t begin, uint64_t end, const vf_render_control *control,
                    vf_render_status *status);

/* Writes the renderer's scene hash, settings text and scene name (a built-in name, or the
 * scene file's absolute path) into an empty film. VF_EINVAL, film unchanged, when the path
 * is longer than a film holds (511 bytes) or not UTF-8. */
int vf_renderer_stamp(const vf_renderer *r, vf_film *film);

#endif
