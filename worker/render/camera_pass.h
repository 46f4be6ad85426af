/* Phase 3 of an iteration: the camera sub-paths (vcm.h, step 3).
 *
 * Traces one camera sub-path per pixel, tile by tile, from the random streams keyed by
 * (seed, iteration, pixel), with the techniques the algorithm enables at each vertex:
 * emission hit (s = 0), light sampling (s = 1), connection to the vertices of the pixel's
 * light sub-path (s > 1, t > 1), vertex merging (queued, run per tile by
 * vertex_merging.c), then continuation. Reads what phases 1 and 2 left in vf_vcm, and
 * writes one estimate per pixel into vf_vcm.camera_rgb. Private to the renderer
 * (vcm_internal.h). */
#ifndef VF_CAMERA_PASS_H
#define VF_CAMERA_PASS_H

#include "vcm_internal.h"

/* Runs the camera pass of the iteration vf_vcm holds, after vf_light_pass_run and (when
 * vertex merging is on) vf_vertex_merging_build_grid, one task per camera tile. NaN or Inf
 * pixel estimates are written as 0 and counted. bpt runs its tiles from its fused pass
 * instead (fused_pass.h). */
void vf_camera_pass_run(vf_vcm *v);

/* The camera tiles of the image: tasks of the camera pass, and bpt's chunks. */
uint32_t vf_camera_pass_tiles(const vf_vcm *v);

/* Camera tile `index` (< vf_camera_pass_tiles, row-major over the image). */
camera_tile vf_camera_pass_tile(const vf_vcm *v, uint32_t index);

/* The camera pass of one tile on `thread`: its pixels' camera sub-paths, their shadow
 * rays and vertex merging queries, and their estimates written to vf_vcm.camera_rgb. */
void vf_camera_pass_run_tile(vf_vcm *v, int thread, const camera_tile *tile);

#endif
