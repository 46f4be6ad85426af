/* Phase 1 of an iteration: the light sub-paths (vcm.h, step 1).
 *
 * Traces one light sub-path per pixel, in chunks of LIGHT_CHUNK, from the random streams
 * keyed by (seed, iteration, path). Fills each chunk's list of stored light vertices (in
 * path order; vf_vcm.path_begin and path_end give each path's range), sets num_vertices
 * and chunk_shift, and writes the light-tracing frame (t = 1) into vf_vcm.light_rgb.
 * Private to the renderer (vcm_internal.h). */
#ifndef VF_LIGHT_PASS_H
#define VF_LIGHT_PASS_H

#include "vcm.h"

/* Runs the light pass of the iteration vf_vcm holds (setup_iteration in vcm.c). Returns
 * VF_OK, or VF_ENOMEM when the vertices did not fit in memory or in the grid's names. */
int vf_light_pass_run(vf_vcm *v);

#endif
