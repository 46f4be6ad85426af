/* Vertex merging in participating media: the point-point estimator of "Unifying points,
 * beams and paths" (Krivanek et al. 2014), a camera vertex in a medium merging the light
 * vertices in media within the merge radius r, with a 3D kernel.
 *
 * A merge at a medium vertex estimates the same path as a connection there, with the
 * acceptance probability of a ball, (4/3) pi r^3 n_light times the light vertex's volume
 * density, where a surface merge has a disc's, pi r^2 n_light times its area density. The
 * MIS quantities (mis.h) count the merges of both kinds in the units of a surface merge:
 * a medium vertex adds mis(eta_m / eta_s) = mis(4 r / 3) where a surface vertex adds 1
 * (vf_vcm.medium_merge), so that every recursion and every weight keeps its form; a merge
 * at a medium vertex has its weight relative to its own eta_m, the surface formula's terms
 * over that ratio (vf_mis_weight_merge_medium, mis.h). Surface and medium light vertices merge only
 * with camera vertices of their kind: the surface grid never offers a medium vertex
 * (vertex_merging.c), and the light vertices in media get a grid of their own, here.
 *
 * The ratio holds for one radius at a time: a radius per pixel (pixel_radius.h) and media
 * are not rendered together. */
#ifndef VF_VOLUME_MERGING_H
#define VF_VOLUME_MERGING_H

#include "vcm_internal.h"

/* A light vertex in a medium as merging reads it. */
struct medium_photon {
  vf_vec3 position; /* first: the grid reads it at offset 0 */
  vf_vec3 throughput;
  vf_vec3 fix;
  vf_mis mis;
  uint32_t medium;
  int path_length;
  uint32_t source; /* its chunk c and index i there, (c << vf_vcm.chunk_shift) | i: upg's gatherings */
};

/* The iteration's light vertices in media, gathered from the chunks in chunk order, and
 * their grid. After the light pass. */
int vf_volume_merging_build(vf_vcm *v);

/* The merge estimate at camera vertex `position` in a medium, whose phase "BSDF" is b
 * (radiance set), MIS quantities cam and path length path_length: the sum over light
 * vertices in media within the radius, weighted, over (4/3) pi r^3 n_light. Not yet
 * multiplied by the camera sub-path's throughput. */
vf_vec3 vf_volume_merging_estimate(const vf_vcm *v, const vf_bsdf *b, vf_vec3 position, const vf_mis *cam,
                                   int path_length);

/* Light vertex k (of vf_vcm.medium_photons) merged at the camera vertex of phase "BSDF" b
 * and quantities cam, as vf_volume_merging_estimate merges each: upg's fall-back for the
 * light vertices in media that no gathering can join (gathering_pass.c). */
vf_vec3 vf_volume_merging_one(const vf_vcm *v, const vf_bsdf *b, const vf_mis *cam, uint32_t k);

void vf_volume_merging_destroy(vf_vcm *v);

#endif
