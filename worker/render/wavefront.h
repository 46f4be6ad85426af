/* Rays, shadow packets and scattering: what the light pass and the camera pass both trace
 * with.
 *
 * Both passes trace VF_ACCEL_PACKET sub-paths at once, as a wavefront: each step sends the
 * rays of all lanes to Embree as one packet (vf_wavefront_trace), then continues each
 * lane's path (vf_wavefront_scatter); a lane whose path ends takes its pass's next path.
 * Shadow rays wait in the thread's shadow_packet (vcm_internal.h) until it is full.
 *
 * Private to the renderer. The helpers below are inline here, not in wavefront.c, because
 * they run at every vertex and every shadow ray of both passes. */
#ifndef VF_WAVEFRONT_H
#define VF_WAVEFRONT_H

#include "../../common/sampler.h"
#include "sample_dims.h"
#include "surface.h"
#include "vcm_internal.h"

#include <math.h>

/* Traces the packet's shadow rays; returns the mask of those blocked. */
static inline uint32_t trace_packet(vf_vcm *v, int thread, shadow_packet *pk) {
  v->stats[thread].rays += (uint64_t)pk->n;
  uint32_t blocked = vf_accel_occluded_packet(v->accel, pk->org, pk->dir, pk->tfar, pk->n);
  pk->n = 0;
  return blocked;
}

/* The ends of the shadow ray of the segment from p (normal n) to q (normal nq; zero
 * vector: a point in space): both moved off their surfaces towards each other. */
static inline __attribute__((always_inline)) void segment_ends(const vf_vcm *v, vf_vec3 p, vf_vec3 n, vf_vec3 q,
                                                               vf_vec3 nq, vf_vec3 *o, vf_vec3 *e) {
  vf_vec3 d = vf_sub(q, p);
  *o = vf_offset_ray_origin(p, vf_dot(n, d) > 0.0f ? n : vf_neg(n), v->offset_scale);
  *e = vf_is_zero(nq) ? q : vf_offset_ray_origin(q, vf_dot(nq, d) < 0.0f ? nq : vf_neg(nq), v->offset_scale);
}

/* Adds the shadow ray of the segment from p (normal n) to q (normal nq; zero vector: a
 * point in space) to the packet, for `owner` (segment_ends). Always inline: as a call,
 * its four vectors were packed into registers and spilled at every shadow ray. */
static inline __attribute__((always_inline)) void queue_segment(vf_vcm *v, shadow_packet *pk, int owner, vf_vec3 p,
                                                                vf_vec3 n, vf_vec3 q, vf_vec3 nq) {
  vf_vec3 o, e;
  segment_ends(v, p, n, q, nq, &o, &e);
  pk->org[pk->n] = o;
  pk->dir[pk->n] = vf_sub(e, o);
  pk->tfar[pk->n] = 1.0f;
  pk->owner[pk->n++] = owner;
}

/* The same for the ray from p (normal n) along dir to infinity. */
static inline void queue_direction(vf_vcm *v, shadow_packet *pk, int owner, vf_vec3 p, vf_vec3 n, vf_vec3 dir) {
  pk->org[pk->n] = vf_offset_ray_origin(p, vf_dot(n, dir) > 0.0f ? n : vf_neg(n), v->offset_scale);
  pk->dir[pk->n] = dir;
  pk->tfar[pk->n] = INFINITY;
  pk->owner[pk->n++] = owner;
}

/* vf_sampler_start for a sub-path: the independent sampler draws every number from the
 * path's stream and never reads the sobol state (index and scramble: three splitmix64
 * rounds and a bit reversal for every sub-path), which is then left at zero; the stream is
 * the one vf_sampler_start would seed. */
static inline void path_sampler_start(vf_sampler *s, vf_sampler_kind kind, uint64_t seed, uint64_t iteration,
                                      uint64_t path, uint32_t stream) {
  if (kind == VF_SAMPLER_SOBOL) {
    vf_sampler_start(s, kind, seed, iteration, path, stream);
    return;
  }
  s->sobol = 0;
  vf_sampler_defer_rng(s, seed, iteration, path, stream);
  s->index = s->index_reversed = s->scramble = 0;
}

/* The BSDF at a hit for a path arriving from world_fix; 0 when nothing scatters there. */
static inline int bsdf_at(const vf_vcm *v, vf_bsdf *b, const vf_hit *hit, vf_vec3 world_fix) {
  if (__builtin_expect(v->interpolated[hit->shape], 0))
    return vf_surface_bsdf(b, v->scene, v->lobes, hit->shape, hit->primitive, hit->u, hit->v, hit->normal, world_fix);
  int m = v->scene->shapes[hit->shape].material;
  return vf_bsdf_setup(b, &v->scene->materials[m], &v->lobes[m], hit->normal, world_fix);
}

/* The "BSDF" of a point in medium m (worker/render/medium.h): sigma_s there and the phase
 * function. */
static inline void bsdf_in_medium(const vf_vcm *v, vf_bsdf *b, uint32_t m, vf_vec3 position, vf_vec3 world_fix) {
  const vf_medium_rt *rt = &v->media[m];
  vf_bsdf_setup_phase(b, vf_scale(rt->sigma_s, vf_medium_density_at(rt, position)), rt->g, rt->continuation, world_fix);
}

/* The BSDF a stored light vertex had. */
static inline void bsdf_of_vertex(const vf_vcm *v, vf_bsdf *b, const light_vertex *lv) {
  uint32_t shape = vertex_shape(lv);
  if (__builtin_expect(shape == VERTEX_IN_MEDIUM, 0)) {
    bsdf_in_medium(v, b, lv->at.point.primitive, lv->position, lv->fix);
    return;
  }
  if (__builtin_expect(v->interpolated[shape], 0)) {
    const vf_shape *sh = &v->scene->shapes[shape];
    vf_vec3 ng = vf_surface_triangle_normal(sh, lv->at.point.primitive);
    vf_surface_bsdf(b, v->scene, v->lobes, shape, lv->at.point.primitive, lv->at.point.u, lv->at.point.v, ng, lv->fix);
    return;
  }
  uint32_t m = (uint32_t)v->scene->shapes[shape].material;
  vf_bsdf_setup(b, &v->scene->materials[m], &v->lobes[m], lv->at.normal, lv->fix);
}

/* The geometric normal of a stored light vertex whose BSDF is lb, for its shadow rays'
 * offsets (which orient it themselves): on an interpolated shape the one its BSDF was set
 * up with (vf_bsdf.geometric), not recomputed for every connection. */
static inline vf_vec3 normal_of_vertex(const vf_vcm *v, const light_vertex *lv, const vf_bsdf *lb) {
  if (__builtin_expect(vertex_in_medium(lv), 0)) return vf_vec3_splat(0.0f); /* a point in space */
  return __builtin_expect(v->interpolated[vertex_shape(lv)], 0) ? lb->geometric : lv->at.normal;
}

/* Before the lanes continue from their hits (bit k of `found`: hits[k], of m): starts the
 * loads that setting up their BSDFs will make (worker/render/surface.h), so that the cache misses
 * of the packet's hits overlap. A lane shades its hit among thousands of instructions of
 * connections and scattering, too far from the next lane's for the processor to overlap
 * them on its own. */
static inline void prefetch_shading(const vf_vcm *v, const vf_hit *hits, uint32_t found, int m) {
  /* Without such a shape the loops would only read every hit's shape to find nothing. */
  if (!v->any_interpolated) return;
  for (int k = 0; k < m; k++)
    if ((found >> k & 1u) && v->interpolated[hits[k].shape])
      vf_surface_prefetch_vertices(&v->scene->shapes[hits[k].shape], hits[k].primitive);
  for (int k = 0; k < m; k++)
    if ((found >> k & 1u) && v->interpolated[hits[k].shape])
      vf_surface_prefetch_texels(v->scene, &v->scene->shapes[hits[k].shape], hits[k].primitive, hits[k].u, hits[k].v);
}

/* One step of a wavefront: the closest hits of the next rays of the active lanes (bit i of
 * `active`: lane i, whose path state is states[i]), as one packet. Ray k is lane
 * lane_of[k]'s, *m rays in all; bit k of the result is set when ray k hit, in hits[k]. */
uint32_t vf_wavefront_trace(vf_vcm *v, int thread, path_state *const *states, uint32_t active, int *lane_of, int *m,
                            vf_hit *hits);

/* Continues a sub-path from vertex `hit` with BSDF b: Russian roulette, direction sampling,
 * throughput and MIS update. A camera sub-path carries radiance, which a refraction
 * scales by 1/eta^2 (bsdf.h); a light sub-path carries flux, which it does not. The numbers
 * come from the sampler's pairs of the vertex whose first pair is vertex_dims
 * (sample_dims.h). Returns 0 when the path ends. */
int vf_wavefront_scatter(vf_vcm *v, const vf_bsdf *b, const vf_hit *hit, path_state *s, vf_sampler *sampler,
                         uint32_t vertex_dims, int radiance);

#endif
