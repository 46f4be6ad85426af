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

#include "vcm.h"

/* Runs the camera pass of the iteration vf_vcm holds, after vf_light_pass_run and (when
 * vertex merging is on) vf_vertex_merging_build_grid; for bpt's fused pass (vf_vcm.fused)
 * before vf_light_pass_finish, each tile tracing its own light sub-paths first. NaN or Inf
 * pixel estimates are written as 0 and counted. */
void vf_camera_pass_run(vf_vcm *v);

/* The camera tiles of the image: tasks of the camera pass, and bpt's chunks. */
uint32_t vf_camera_pass_tiles(const vf_vcm *v);

#endif
