/* The single-stage iteration of vcm (tech. rep. sec. 6.2; --vcm-stages 1).
 *
 * The two-stage iteration (vcm.h) traces every light sub-path of iteration k and stores
 * its vertices before any camera sub-path starts, because camera sub-paths merge with all
 * of them. The single-stage one delays merging by one iteration: camera sub-paths of
 * iteration k connect to their pixel's light sub-path of iteration k and merge with the
 * light vertices of iteration k - 1. So an iteration is one pass over the camera tiles,
 * bpt's fused pass (fused_pass.h) with merging: each tile traces its pixels' light
 * sub-paths, keeps their vertices' BSDFs for its own connections while they are in cache,
 * and copies the vertices, without BSDFs, to the tile's list of light vertices for the
 * next iteration's grid. Before the pass, the grid is built over the lists that the
 * previous iteration left, with this iteration's radius, and the lists are freed.
 *
 * Why the weights still sum to one: a stored light vertex carries d_vcm and the
 * radius-free c_vc and c_vm (tech. rep. sec. 6.1, mis.h), so merging it one iteration
 * later with that iteration's radius r_k forms every weight of the full path with r_k,
 * as connections and light tracing of iteration k do. The estimator of iteration k is
 * vcm's with merging over an independent set of n_light light sub-paths: that of
 * iteration k - 1 (the sets of neighbouring iterations are correlated through it, which
 * the film's error estimate does not see). Participating media are refused: a light
 * vertex's quantities after a medium vertex hold the merge weight of its iteration's
 * radius (vf_vcm.medium_merge), which the next iteration's radius would not match.
 *
 * The first iteration k of a range (or of a renderer that rendered something else last)
 * has no lists: it traces the light sub-paths of iteration k - 1 first (k - 1 modulo
 * 2^64 for k = 0: the streams of "iteration -1"), the same sub-paths, in the same tiles
 * and order, as iteration k - 1's pass traced, so any range [a, b) renders exactly the
 * iterations of one long run and ranges rendered on different machines merge.
 *
 * Memory: the grid of iteration k - 1's vertices (photons and merge points, 48 bytes a
 * vertex) lives beside the lists of iteration k's (64 bytes a vertex) during the pass,
 * where the two-stage iteration holds its 64-byte vertices beside their grid: the same
 * peak, less the two-stage pass's per-pixel path ranges (docs/BENCHMARKS.md, "Memory").
 *
 * Private to the renderer (vcm_internal.h). */
#ifndef VF_SINGLE_STAGE_H
#define VF_SINGLE_STAGE_H

#include "vcm_internal.h"

/* Renders the iteration vf_vcm holds (setup_iteration in vcm.c) single-stage: the light
 * sub-paths of the iteration before if no lists hold them, the grid, the fused pass, the
 * light image. Adds its times to *stats. VF_OK, VF_ENOMEM or the grid's error. */
int vf_single_stage_iteration(vf_vcm *v, vf_vcm_stats *stats);

/* In the fused pass, after tile `tile`'s light sub-paths were traced on `thread`: copies
 * their vertices into the tile's list for the next iteration's grid (vf_vcm.kept). */
void vf_single_stage_keep_tile(vf_vcm *v, int thread, const camera_tile *tile);

/* Frees the lists (the next iteration traces its predecessor's sub-paths again). */
void vf_single_stage_trim(vf_vcm *v);

#endif
