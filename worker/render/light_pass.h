/* Phase 1 of an iteration: the light sub-paths (vcm.h, step 1).
 *
 * Traces one light sub-path per pixel, in chunks of LIGHT_CHUNK (bpt: in camera tiles,
 * vf_light_pass_tile), from the random streams keyed by (seed, iteration, path). Fills each chunk's list of stored light vertices (in
 * path order; vf_vcm.path_begin and path_end give each path's range), sets num_vertices
 * and chunk_shift, and writes the light-tracing frame (t = 1) into vf_vcm.light_rgb.
 * Private to the renderer (vcm_internal.h). */
#ifndef VF_LIGHT_PASS_H
#define VF_LIGHT_PASS_H

#include "vcm_internal.h"

/* Runs the light pass of the iteration vf_vcm holds (setup_iteration in vcm.c). Returns
 * VF_OK, or VF_ENOMEM when the vertices did not fit in memory or in the grid's names. */
int vf_light_pass_run(vf_vcm *v);

/* bpt's fused pass (fused_pass.h): traces the light sub-paths of the camera tile's pixels on
 * `thread`, their vertices and BSDFs into the thread's tile lists (thread_scratch.tile_*),
 * path `local` of the tile (row-major) at tile_begin[local] .. tile_end[local], their splats
 * into the tile's chunk. */
void vf_light_pass_tile(vf_vcm *v, int thread, const camera_tile *tile);

/* After the chunks are traced (vf_light_pass_run does both): checks them, counts the
 * vertices and writes the light image. */
int vf_light_pass_finish(vf_vcm *v);

#endif
