/* Vertex merging: each camera vertex merged with every light vertex within the radius r_k
 * of the iteration, found by a range search over the hashed grid of hashgrid.c, and
 * weighted by eq. 38-39 of the tech. rep. (mis.h). Not to be confused with merging films (vf_film_merge) or the `merge`
 * command: here it is always light vertices into camera vertices.
 *
 * Phase 2 of an iteration builds the grid (vf_vertex_merging_build_grid); phase 3, the
 * camera pass, queues a vertex_merging_query (vcm_internal.h) at each camera vertex that
 * merges and runs a tile's queries at the end of the tile (vf_vertex_merging_run_tile).
 * Private to the renderer. */
#ifndef VF_VERTEX_MERGING_H
#define VF_VERTEX_MERGING_H

#include "../../common/vec3.h"
#include "vcm_internal.h"

/* Phase 2: the range-search grid over every chunk's light vertices where they are, and
 * what vertex merging reads of them copied into the grid's order. Only when vertex merging
 * is on and there are light vertices. Returns VF_OK, VF_ENOMEM, or the grid's error. */
int vf_vertex_merging_build_grid(vf_vcm *v);

/* After the camera pass: gives the pages of the copies made for it back to the kernel
 * when they are large, so that the next iteration's light pass and grid build do not hold
 * them too (48 bytes per light vertex, the peak of an iteration's memory otherwise). */
void vf_vertex_merging_release(vf_vcm *v);

/* Runs the thread's queued queries (vf_vcm.stats[thread].queries) and adds each one's
 * estimate to its pixel of tile_rgb, in queue order; empties the queue. */
void vf_vertex_merging_run_tile(vf_vcm *v, int thread, float *tile_rgb);

/* The vertex merging estimate of one query at once, not yet scaled by its throughput: for
 * a query that could not be queued. */
vf_vec3 vf_vertex_merging_now(const vf_vcm *v, const vertex_merging_query *q);

/* Whether this CPU and build test candidates with AVX-512 (F and VL), for
 * vf_vcm.vertex_merging_avx512; else SSE2 (or one at a time without it). */
int vf_vertex_merging_detect_avx512(void);

#endif
