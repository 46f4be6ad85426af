/* The allocation of the sampler's dimensions (common/sampler.h) to the decisions of a
 * sub-path. Each entry is a pair number: a 2D decision takes both coordinates of its pair,
 * a 1D decision the first coordinate of a pair of its own, so that every 2D decision is a
 * well-stratified (0,2)-sequence over the iterations and every 1D one is stratified.
 *
 * Camera sub-path of a pixel:
 *   pair 0            position in the pixel (x, y)
 *   pair 1            point on the thin lens (only with a lens)
 *   vertex i >= 1 (the i-th hit from the camera), pairs 2 + 5 (i - 1) + ...:
 *     +0  next-event estimation: the point on the light (2D)
 *     +1  BSDF sampling: the direction (2D)
 *     +2  next-event estimation: which light (1D)
 *     +3  BSDF sampling: which lobe (1D)
 *     +4  Russian roulette (1D), where the sampler does not serve +1; where it does, the
 *         roulette is folded into +1's first coordinate (worker/render/wavefront.c)
 * Light sub-path:
 *   pair 0            which light (1D)
 *   pair 1            emission: the point on the light (area lights; 2D)
 *   pair 2            emission: the direction (2D)
 *   pair 3            light tracing's lens point for the light's own point (lt, thin lens)
 *   vertex i >= 1 (the i-th hit from the light), pairs 4 + 5 (i - 1) + ...:
 *     +0  the lens point of the connection to the camera (t = 1, thin lens)
 *     +1, +3, +4 as for camera vertices
 * Vertices past VF_SOBOL_BOUNCES take every number from the fallback stream.
 *
 * With the independent sampler the pair numbers are ignored and the numbers are drawn in
 * the order the code asks for them, the order of the streams before the sampler existed. */
#ifndef VF_SAMPLE_DIMS_H
#define VF_SAMPLE_DIMS_H

#include "../../common/sampler.h"

#include <stdint.h>

enum {
  VF_DIM_PIXEL = 0,
  VF_DIM_LENS = 1,
  VF_DIM_CAMERA_VERTEX = 2, /* first pair of camera vertex 1 */
  VF_DIM_LIGHT_PICK = 0,
  VF_DIM_EMIT_POINT = 1,
  VF_DIM_EMIT_DIRECTION = 2,
  VF_DIM_EMITTER_LENS = 3,
  VF_DIM_LIGHT_VERTEX = 4, /* first pair of light vertex 1 */
  VF_DIM_PER_VERTEX = 5,
};
/* Participating media (worker/render/segment.h): the number that samples the distance of
 * the segment that leads to vertex i is the first coordinate of a pair of its own, pair
 * VF_DIM_MEDIUM + i - 1 (a pair number is only a scrambling seed, so these pairs lie far
 * past the others without any cost); past VF_SOBOL_BOUNCES, and for every further number a
 * segment needs (more pieces, tracking), the fallback stream. Drawn only in scenes with
 * media. */
#define VF_DIM_MEDIUM 1000u
static inline uint32_t vf_dim_medium(int vertex) {
  if (vertex < 1 || vertex > VF_SOBOL_BOUNCES) return VF_SAMPLER_FALLBACK;
  return VF_DIM_MEDIUM + (uint32_t)(vertex - 1);
}

/* Offsets within a vertex's pairs. */
enum { VF_DIM_NEE_POINT = 0, VF_DIM_CAMERA_LENS = 0, VF_DIM_BSDF_DIRECTION = 1, VF_DIM_NEE_LIGHT = 2,
       VF_DIM_BSDF_LOBE = 3, VF_DIM_ROULETTE = 4 };

/* The first pair of vertex `vertex` (>= 1) of a sub-path whose vertex 1 starts at `first`,
 * or VF_SAMPLER_FALLBACK past VF_SOBOL_BOUNCES. Add an offset only to a pair that is not
 * the fallback: vf_dim_at does it. */
static inline uint32_t vf_dim_vertex(uint32_t first, int vertex) {
  if (vertex < 1 || vertex > VF_SOBOL_BOUNCES) return VF_SAMPLER_FALLBACK;
  return first + (uint32_t)(vertex - 1) * VF_DIM_PER_VERTEX;
}
static inline uint32_t vf_dim_at(uint32_t vertex_base, uint32_t offset) {
  return vertex_base == VF_SAMPLER_FALLBACK ? VF_SAMPLER_FALLBACK : vertex_base + offset;
}

#endif
