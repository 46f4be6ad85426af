/* bpt's fused pass: phases 1 and 3 of an iteration (vcm.h) in one pass over the camera
 * tiles, each tile tracing its own pixels' light sub-paths just before its camera
 * sub-paths. The single-stage vcm iteration (single_stage.h) runs it too, its camera
 * sub-paths merging with the grid of the iteration before, each tile's light vertices
 * copied for the next one's.
 *
 * It runs in place of the light pass and the camera pass when the algorithm connects
 * sub-paths but does not merge them (bpt: vf_vcm.fused). A camera sub-path connects only
 * to the light sub-path of its own pixel, and without vertex merging there is no grid
 * that needs every light vertex of the iteration at once: so a tile's light vertices are
 * made where they are used, their BSDFs kept beside them (light_chunk.bsdfs), and
 * connected to while they are still in cache; none outlives its tile, and nothing is
 * stored for the whole iteration. The sub-paths are those the separate phases would
 * trace (each draws from its own random stream); the light-tracing splats wait in the
 * tiles' chunks until vf_light_pass_finish makes the light image, after the pass, each
 * pixel summing its terms in tile order.
 *
 * Private to the renderer (vcm_internal.h). */
#ifndef VF_FUSED_PASS_H
#define VF_FUSED_PASS_H

#include "vcm_internal.h"

/* Runs the fused pass of the iteration vf_vcm holds, one task per camera tile: its light
 * sub-paths (vf_light_pass_tile), then its camera pass (vf_camera_pass_run_tile). Adds
 * each thread's time in the light sub-paths to its thread_stats.light_seconds. The caller
 * then runs vf_light_pass_finish. */
void vf_fused_pass_run(vf_vcm *v);

#endif
