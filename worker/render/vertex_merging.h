/* Vertex merging: each camera vertex merged with every light vertex within the radius r_k
 * of the iteration, found by a range search over the hashed grid of hashgrid.c, and
 * weighted by eq. 38-39 of the tech. rep. (mis.h). Not to be confused with merging films
 * (vf_film_merge) or the `merge` command: here it is always light vertices into camera
 * vertices.
 *
 * Phase 2 of an iteration builds the grid and copies what merging reads of the light
 * vertices into the grid's order (vf_vertex_merging_build_grid); phase 3, the camera pass,
 * queues a vertex_merging_query (vcm_internal.h) at each camera vertex that merges and runs
 * a tile's queries at the end of the tile (vf_vertex_merging_run_tile).
 *
 * A query has two implementations, which give the same bits (tests/worker/render/test_vertex_merging.c):
 *   vertex_merging.c  the reference, SmallVCM's range query: for each cell of the query's
 *                     neighbourhood, for each light vertex in it, the distance test and
 *                     the merge (vf_vertex_merging_estimate, vf_vertex_merging_one);
 *   merge_pipeline.c  the fast path the renderer runs: a tile's queries as a software
 *                     pipeline whose candidate tests are SIMD (merge_pipeline.h).
 * Private to the renderer. */
#ifndef VF_VERTEX_MERGING_H
#define VF_VERTEX_MERGING_H

#include "../../common/vec3.h"
#include "vcm_internal.h"

#include <stddef.h>
#include <stdint.h>

/* What vertex merging reads of the light vertices, in the grid's order (index k of the
 * grid's sorted points), in two arrays: the distance and path-length tests of a query's
 * candidates read only merge_point (16 bytes, four to a line), and only the candidates that
 * pass read their photon (32 bytes, aligned: one line). A query is bound by the lines it
 * misses, not by its arithmetic.
 *
 * The merge points are the grid's own sorted points (vf_hashgrid_points_writable), whose
 * positions are there already: the gather writes each light vertex's path length and shape
 * over its grid index, once it has read the index, so that the positions cost no second
 * array at the peak of an iteration's memory. */
struct merge_point {
  float x, y, z;
  uint32_t path_length_shape; /* as in light_vertex */
};
_Static_assert(sizeof(merge_point) == 16, "the SIMD candidate tests read a merge point as four floats");
_Static_assert(sizeof(merge_point) == sizeof(vf_grid_point) && offsetof(merge_point, x) == offsetof(vf_grid_point, x) &&
                   offsetof(merge_point, path_length_shape) == offsetof(vf_grid_point, index),
               "a merge point is a grid point whose index became the path length");
/* Whether point (x, y, z) lies within the merge radius of q (radius_sq, its square: the
 * query's, merge_params): the test every query makes of its candidates, and upg's
 * tentative rays of their hits (gathering_pass.c), with the same float operations
 * (merge_pipeline.c's SIMD tests repeat them lane by lane). */
static inline int vf_vertex_merging_within(float radius_sq, float x, float y, float z, vf_vec3 q) {
  float dx = x - q.x, dy = y - q.y, dz = z - q.z;
  return dx * dx + dy * dy + dz * dz <= radius_sq;
}

/* The fast path's candidate tests read up to this many points past the last. */
#define MERGE_POINT_PAD 7u
_Static_assert(MERGE_POINT_PAD <= VF_HASHGRID_POINT_PAD, "the grid pads its points for the candidate tests");

struct photon {
  vf_vec3 throughput;
  vf_vec3 direction; /* world, towards the previous light vertex */
  float d_vcm;
  float vm; /* a global radius: d_vm at it; a radius per pixel: c_vm, d_vm's share that does
             * not depend on the radius (vf_vcm.photon_c_vc holds the rest: vf_photon_mis) */
};
_Static_assert(sizeof(photon) == 32, "two photons to a cache line");

/* The MIS quantities of photon k, for weights formed with a query's vf_mis_config
 * (vf_mis_d_vm; merging never reads d_vc). */
static inline vf_mis vf_photon_mis(const vf_vcm *v, uint32_t k) {
  const photon *ph = &v->photons[k];
  return (vf_mis){ph->d_vcm, v->photon_c_vc ? v->photon_c_vc[k] : 0.0f, ph->vm};
}

/* Phase 2: the range-search grid over the light vertices of `chunks` (num_chunks of them,
 * vertex i of chunk c named (c << shift) + i: the iteration's chunks and chunk_shift, or
 * in the single-stage iteration the lists of the iteration before, single_stage.h) where
 * they are, and what vertex merging reads of them copied into the grid's order
 * (vf_vcm.merge_points, vf_vcm.photons). Only when vertex merging is on and there are
 * light vertices. Returns VF_OK, VF_ENOMEM, or the grid's error. */
int vf_vertex_merging_build_grid(vf_vcm *v, const light_chunk *chunks, unsigned shift);

/* After the camera pass: gives the pages of the copies made for it back to the kernel
 * when they are large, so that the next iteration's light pass and grid build do not hold
 * them too (48 bytes per light vertex, the peak of an iteration's memory otherwise). */
void vf_vertex_merging_release(vf_vcm *v);

/* The reference. The vertex merging estimate of camera vertex q, not yet scaled by its
 * throughput: the sum over the light vertices within the radius of vf_vertex_merging_one,
 * in the grid's order, times the normalisation 1 / (pi r^2 n_light). Used as it is for a
 * query that could not be queued, for a query with more hits than the fast path keeps,
 * and on targets without the fast path. */
vf_vec3 vf_vertex_merging_estimate(const vf_vcm *v, const vertex_merging_query *q);

/* Merges camera vertex q with light vertex k (an index into the grid's order), which lies
 * within the radius: the light vertex's throughput times the camera BSDF, with the MIS
 * weight of eq. 38-39; zero when the joined path would be longer than the maximum. */
vf_vec3 vf_vertex_merging_one(const vf_vcm *v, const vertex_merging_query *q, uint32_t k);

/* Runs the thread's queued queries (vf_vcm.scratch[thread].queries) and adds each one's
 * estimate times its throughput to its pixel of tile_rgb, in queue order; empties the
 * queue. The fast path where the target has it (merge_pipeline.h), else the reference. */
void vf_vertex_merging_run_tile(vf_vcm *v, int thread, float *tile_rgb);

#endif
