/* The segment between two vertices of a path, through participating media.
 *
 * A segment is a straight line from one vertex to the next. Through media it is made of
 * pieces, each in one medium (or vacuum), separated by index-matched boundaries: the
 * surfaces of shapes without a material (worker/scene/medium.h), which every ray crosses
 * without a vertex, entering the shape's interior or its exterior. A sub-path's segment
 * ends where distance sampling makes it scatter in a medium (a medium vertex) or at the
 * first surface with a material; a connection's segment is blocked by any such surface
 * and attenuated by the transmittance of its pieces.
 *
 * Both give the distance densities of the segment's two ends, which the MIS quantities
 * need in place of the cosines' company alone (vf_mis_hit_media): at a medium vertex the
 * density of scattering there, at a surface the probability of crossing every piece; the
 * pieces before are crossed either way (worker/render/medium.h).
 *
 * A point in a medium is a vf_hit whose shape is VF_HIT_MEDIUM, whose primitive is the
 * medium's index and whose normal is zero. */
#ifndef VF_SEGMENT_H
#define VF_SEGMENT_H

#include "../../common/sampler.h"
#include "vcm_internal.h"

#include <stdint.h>

#define VF_HIT_MEDIUM UINT32_MAX

static inline int vf_hit_in_medium(const vf_hit *h) { return h->shape == VF_HIT_MEDIUM; }

/* The medium a path leaving vertex `hit` along dir travels in, the path having arrived in
 * `medium`: a medium vertex's own; through the surface of a shape with an interface, the
 * medium of the side dir goes to (the normal is the outward one); else unchanged. */
static inline int vf_medium_leaving(const vf_vcm *v, const vf_hit *hit, vf_vec3 dir, int medium) {
  if (vf_hit_in_medium(hit)) return (int)hit->primitive;
  const vf_shape *sh = &v->scene->shapes[hit->shape];
  if (!sh->interface) return medium;
  return vf_dot(hit->normal, dir) > 0.0f ? sh->exterior : sh->interior;
}

/* The density scale of the medium at vertex `hit`, for its distance densities: 1 at a
 * surface and in a homogeneous medium, the grid's at a point of a heterogeneous one. */
float vf_segment_vertex_density(const vf_vcm *v, const vf_hit *hit);

enum { VF_SEGMENT_VERTEX, VF_SEGMENT_ESCAPED, VF_SEGMENT_ENDED };

typedef struct {
  vf_vec3 weight; /* multiplies the sub-path's throughput: transmittance over the sampling's density */
  float fwd;      /* distance density of the far end (the vertex found), from the near end */
  float rev;      /* distance density of the near end, from the far end */
  int medium;     /* the medium the far end is reached in */
} vf_segment;

/* A sub-path's ray from `origin` along unit dir, leaving its vertex (near_in_medium: a
 * medium vertex, at origin) in `medium`, whose first surface Embree found (`found`: *hit)
 * or not. Walks it through index-matched boundaries, sampling distances in the media it
 * crosses (the first piece's with u, the sub-path's number for this segment; the rest
 * from the sampler's stream). Returns VF_SEGMENT_VERTEX with *hit the next vertex (its t
 * the whole segment's length), VF_SEGMENT_ESCAPED when the ray left the scene, or
 * VF_SEGMENT_ENDED when the path ends in a medium; *seg in the first two cases. */
int vf_segment_trace(vf_vcm *v, int thread, int medium, int near_in_medium, vf_vec3 origin, vf_vec3 dir, int found,
                     vf_hit *hit, float u, vf_sampler *sampler, vf_segment *seg);

/* vf_segment_trace with the numbers after the first from rng (upg's tentative draws,
 * photon_gathering.h, which have a stream of their own): the same walk. */
int vf_segment_trace_rng(vf_vcm *v, int thread, int medium, int near_in_medium, vf_vec3 origin, vf_vec3 dir, int found,
                         vf_hit *hit, float u, vf_rng *rng, vf_segment *seg);

/* The transmittance of the connection from vertex p to q, leaving p in `medium`: zero
 * when a surface with a material lies between. p and q are each a surface point (unit
 * normal n_p, n_q: the connection's ends are moved off them) or a point in a medium
 * (zero normal; p_density, q_density the vertices' density scales, vf_segment_vertex_density;
 * for a surface 1); q_at_infinity: q is a direction (an environment or a directional light)
 * and q_dir that direction. *fwd_q and *rev_p: the distance densities of q seen from p and
 * of p seen from q. Heterogeneous media draw from the sampler's stream. */
vf_vec3 vf_segment_transmittance(vf_vcm *v, int thread, int medium, vf_vec3 p, vf_vec3 n_p, float p_density, vf_vec3 q,
                                 vf_vec3 n_q, float q_density, int q_at_infinity, vf_sampler *sampler, float *fwd_q,
                                 float *rev_p);

/* vf_segment_transmittance with its numbers from rng (upg's joins, gathering_pass.c). */
vf_vec3 vf_segment_transmittance_rng(vf_vcm *v, int thread, int medium, vf_vec3 p, vf_vec3 n_p, float p_density,
                                     vf_vec3 q, vf_vec3 n_q, float q_density, int q_at_infinity, vf_rng *rng,
                                     float *fwd_q, float *rev_p);

/* In a scene without index-matched boundaries (vf_vcm.has_boundaries 0) a connection is
 * one piece in one medium: what vf_segment_transmittance gives when nothing blocks it,
 * without tracing, so that the caller traces its occlusion in a packet of shadow rays
 * (wavefront.h) as a scene without media does. */
vf_vec3 vf_segment_transmittance_unblocked(const vf_vcm *v, int medium, vf_vec3 p, vf_vec3 n_p, float p_density,
                                           vf_vec3 q, vf_vec3 n_q, float q_density, int q_at_infinity,
                                           vf_sampler *sampler, float *fwd_q, float *rev_p);

/* A connection's transmittance, whichever way the scene needs: through index-matched
 * boundaries vf_segment_transmittance, which traces the segment (*traced 1: nothing is left
 * to test); else vf_segment_transmittance_unblocked (*traced 0: the caller queues the
 * segment's occlusion as a shadow ray). */
static inline vf_vec3 vf_segment_connection(vf_vcm *v, int thread, int medium, vf_vec3 p, vf_vec3 n_p, float p_density,
                                            vf_vec3 q, vf_vec3 n_q, float q_density, int q_at_infinity,
                                            vf_sampler *sampler, float *fwd_q, float *rev_p, int *traced) {
  *traced = v->has_boundaries;
  if (v->has_boundaries)
    return vf_segment_transmittance(v, thread, medium, p, n_p, p_density, q, n_q, q_density, q_at_infinity, sampler,
                                    fwd_q, rev_p);
  return vf_segment_transmittance_unblocked(v, medium, p, n_p, p_density, q, n_q, q_density, q_at_infinity, sampler,
                                            fwd_q, rev_p);
}

/* The medium at point p: the interior or exterior of the first shape with an interface
 * that a ray from p meets, or the scene's medium. The camera's and the lights' media. */
int vf_medium_at_point(const vf_vcm *v, vf_vec3 p);

#endif
