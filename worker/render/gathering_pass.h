/* upg's vertex merging (photon_gathering.h has the estimator and why it is unbiased).
 *
 * The grid, the queries and the candidate tests are vcm's (vertex_merging.h): a camera
 * vertex finds the light vertices within the radius as vcm's merging finds them. Each one
 * found is then gathered: its predecessor on its light sub-path (the previous vertex of its
 * chunk's list when that is one segment shorter and of the same path, or the sub-path's
 * first point on its light, vf_vcm.origins) is joined to the camera vertex as a
 * connection, with a visibility ray, and weighted by vf_upg_inverse_acceptance's estimate
 * of 1/p_acc. A light vertex made by a specular choice, or whose predecessor is a light at
 * infinity, is merged as vcm merges it and counted (thread_stats.upg_fallbacks).
 * In a scene with media, a camera vertex in a medium gathers the light vertices in media
 * within the radius the same way (vf_gathering_estimate_medium), at once, and every join
 * and tentative direction goes through media (photon_gathering.h, "In media"): the join's
 * transmittance and the flights' free-flight sampling (segment.h), from where each camera
 * vertex is (gathering_prev.here, .place).
 * Private to the renderer. */
#ifndef VF_GATHERING_PASS_H
#define VF_GATHERING_PASS_H

#include "vcm_internal.h"

/* Runs the thread's queued queries (vf_vcm.scratch[thread].queries) as gatherings and adds
 * each one's estimate to its pixel of tile_rgb, in queue order; empties the queue. The upg
 * counterpart of vf_vertex_merging_run_tile. */
void vf_gathering_pass_run_tile(vf_vcm *v, int thread, float *tile_rgb);

/* The gathering estimate of camera vertex q (its predecessor prev), its camera sub-path's
 * throughput included: what vf_gathering_pass_run_tile adds for a queued query, for one
 * that could not be queued. */
vf_vec3 vf_gathering_estimate(vf_vcm *v, int thread, const vertex_merging_query *q, const gathering_prev *prev);

/* The gatherings at camera vertex q in a medium (its phase "BSDF" q->bsdf; prev with
 * prev->here its place): the light vertices in media within the radius
 * (vf_vcm.volume_grid), each joined from the side gathering_pass.c's rule picks, with the
 * camera sub-path's throughput. Run at once, where vcm merges in media. */
vf_vec3 vf_gathering_estimate_medium(vf_vcm *v, int thread, const vertex_merging_query *q, const gathering_prev *prev);

#endif
