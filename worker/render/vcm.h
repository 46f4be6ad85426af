/* One progressive VCM iteration, and the whole technique family built from it.
 *
 * An iteration with global index k (tech. rep. sec. 2.3, paper fig. 6):
 *   1. trace one light sub-path per pixel; store its non-specular vertices and project
 *      each onto the camera (light tracing, t = 1);
 *   2. build the range-search grid over the stored light vertices, radius r_k;
 *   3. trace one camera sub-path per pixel; at each vertex: emission hit (s = 0), light
 *      sampling (s = 1), connection to the vertices of the pixel's own light sub-path, and
 *      vertex merging with every light vertex within r_k; then continue.
 * Each technique is weighted by the recursive MIS scheme of worker/render/mis.h. The algorithms
 * bpt, pt, lt, ppm and bpm are this same iteration with techniques switched off. bpt,
 * which needs no grid, runs 1 and 3 tile by tile: each camera tile first traces its own
 * pixels' light sub-paths and keeps their BSDFs for its connections (its fused pass,
 * worker/render/fused_pass.c). vcm with --vcm-stages 1 runs the same fused pass, merging
 * with a grid of the light vertices of iteration k - 1 built first
 * (worker/render/single_stage.h, tech. rep. sec. 6.2).
 * The phases are files of their own: 1. worker/render/light_pass.c, 2. worker/render/vertex_merging.c
 * (over worker/render/hashgrid.c), 3. worker/render/camera_pass.c, whose vertex merging queries
 * vertex_merging.c runs; both passes trace with worker/render/wavefront.c and share the state of
 * worker/render/vcm_internal.h. vcm.c sets up and runs them.
 *
 * The merge radius of iteration k is r_1 sqrt(i^(alpha - 1)), i = k + 1 (paper sec. 6.1),
 * r_1 = radius_factor x the scene's bounding-sphere radius. Random numbers of light
 * sub-path p and camera sub-path p come from streams keyed by (seed, k, p): any iteration
 * can be rendered anywhere, in any order, on any number of threads, with the same result. */
#ifndef VF_VCM_H
#define VF_VCM_H

#include "../../common/pool.h"
#include "../../common/settings.h"
#include "accel.h"
#include "../scene/scene.h"

#include <stdint.h>
#include <stdio.h>

typedef struct vf_vcm vf_vcm;

typedef struct {
  uint64_t rays;            /* closest-hit and occlusion queries */
  uint64_t light_vertices;  /* stored for connection and merging */
  uint64_t nonfinite;       /* NaN or Inf samples refused (never accumulated) */
  /* upg (photon_gathering.h): light vertices gathered without bias, their tentative
   * directions and the rays traced for them, gatherings stopped at the trial cap,
   * directions whose density exceeded its bound (both 0 in a correct render), and light
   * vertices merged as vcm merges them (biased). */
  uint64_t upg_gatherings, upg_trials, upg_rays, upg_truncated, upg_bound_exceeded, upg_fallbacks;
  double light_seconds;     /* wall time of the three phases: light sub-paths, */
  double grid_seconds;      /* range-search grid, */
  double camera_seconds;    /* camera sub-paths */
} vf_vcm_stats;

/* Prepares a renderer for the scene (borrowed, must outlive it) with the given settings.
 * The accel, pool and scene are borrowed. */
int vf_vcm_create(const vf_scene *scene, const vf_accel *accel, const vf_settings *settings, vf_pool *pool,
                  vf_vcm **out);
void vf_vcm_destroy(vf_vcm *vcm);

/* Frees what an iteration allocates and the next one would reuse (light vertices, splats,
 * photons, the grid's arrays: hundreds of bytes per pixel), for a renderer that is done
 * for a while: after a range of iterations, while its film is shipped or written. The
 * next iteration allocates them again; renders are unchanged. */
void vf_vcm_trim(vf_vcm *vcm);

/* Renders global iteration `iteration`: writes one camera-path estimate per pixel into
 * camera_rgb and the light-tracing frame into light_rgb (3 floats per pixel each, top row
 * first, overwritten). Adds to *stats. */
int vf_vcm_iteration(vf_vcm *vcm, uint64_t iteration, float *camera_rgb, float *light_rgb, vf_vcm_stats *stats);

/* With a pilot (vf_settings.pilot, common/allocation.h): each pixel's camera sub-paths per
 * iteration, width x height counts, copied. An iteration fails with VF_EINVAL until they
 * are set, but in the pilot phase. VF_ENOMEM, or VF_EINVAL on a renderer without a pilot
 * or for counts that are not powers of two from 1 to VF_ALLOCATION_MAX. */
int vf_vcm_set_allocation(vf_vcm *vcm, const uint8_t *samples);
/* In the pilot phase (on), iterations are the pilot render's: one camera sub-path a pixel,
 * numbers from the pilot seed (vf_allocation_seed). */
void vf_vcm_set_pilot_phase(vf_vcm *vcm, int on);
int vf_vcm_pilot_phase(const vf_vcm *vcm);

/* The algorithm this renderer runs: the settings' one, or for auto and auto-unbiased the
 * one chosen from the scene at vf_vcm_create (never an auto). */
vf_algorithm vf_vcm_algorithm(const vf_vcm *vcm);
/* What `--algorithm auto` (vcm or pt) or `auto-unbiased` (pt, bpt or upg) resolves to for
 * a scene, by the rule vf_vcm_create applies: a pure function of the scene's materials and
 * lights, so a client that has loaded the scene knows it without a renderer. *reason (if
 * not NULL) receives a static sentence. */
vf_algorithm vf_vcm_auto_algorithm(const vf_scene *scene, vf_algorithm requested, const char **reason);

double vf_vcm_merge_radius(const vf_vcm *vcm, uint64_t iteration);

/* Vertex merging tests its candidates with AVX-512 where the CPU has it, else with SSE2;
 * both give the same hits in the same order. vf_vcm_limit_simd(vcm) makes vertex merging
 * use SSE2 on any machine, so that tests can compare the two; vf_vcm_merge_simd names the
 * one in use. */
void vf_vcm_limit_simd(vf_vcm *vcm);
const char *vf_vcm_merge_simd(const vf_vcm *vcm);

/* Prints which techniques and scene features are enabled and which work is skipped. */
void vf_vcm_describe(const vf_vcm *vcm, FILE *out);

#endif
