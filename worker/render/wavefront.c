/* Tracing a wavefront of sub-paths and continuing them: wavefront.h. */
#include "wavefront.h"

#include "segment.h"

#include <math.h>

static int intersect(vf_vcm *v, int thread, vf_vec3 org, vf_vec3 dir, vf_hit *hit) {
  v->stats[thread].rays++;
  return vf_accel_intersect(v->accel, org, dir, INFINITY, hit);
}

/* Closest hits of the m rays: one packet, or single rays when too few to fill one. Both
 * give the same hits (vf_accel_intersect_packet). */
#define PACKET_MIN 2
static uint32_t intersect_rays(vf_vcm *v, int thread, const vf_vec3 *org, const vf_vec3 *dir, int m, vf_hit *hits) {
  if (m >= PACKET_MIN) {
    v->stats[thread].rays += (uint64_t)m;
    return vf_accel_intersect_packet(v->accel, org, dir, m, hits);
  }
  uint32_t found = 0;
  for (int k = 0; k < m; k++) found |= (uint32_t)intersect(v, thread, org[k], dir[k], &hits[k]) << k;
  return found;
}

uint32_t vf_wavefront_trace(vf_vcm *v, int thread, path_state *const *states, uint32_t active, int *lane_of, int *m,
                            vf_hit *hits) {
  vf_vec3 org[VF_ACCEL_PACKET], dir[VF_ACCEL_PACKET];
  int n = 0;
  for (int i = 0; i < VF_ACCEL_PACKET; i++)
    if (active >> i & 1u) {
      lane_of[n] = i;
      org[n] = states[i]->origin;
      dir[n++] = states[i]->direction;
    }
  *m = n;
  return intersect_rays(v, thread, org, dir, n, hits);
}

int vf_wavefront_scatter(vf_vcm *v, const vf_bsdf *b, const vf_hit *hit, path_state *s, vf_sampler *sampler,
                         uint32_t vertex_dims, int radiance) {
  /* Russian roulette, then the direction. Where the sampler serves the direction's pair
   * (sobol, vertices up to VF_SOBOL_BOUNCES) the roulette is folded into it: the pair's
   * first coordinate u decides (the path goes on if u < continuation) and, rescaled to
   * u / continuation, is the direction's first number. The decision and the direction
   * are then one 2D point of a well-stratified sequence: a number of its own would be
   * stratified alone, and its interaction with the direction (the path's whole future
   * hangs on both) would converge at Monte Carlo's rate (docs/BENCHMARKS.md, "Error
   * slopes"). The rescaled u is uniform on [0, 1) given survival, so the densities are
   * those of the unfolded order. Every number is below 1, so a continuation of 1 always
   * survives. Elsewhere (the independent sampler, deeper vertices) the roulette takes a
   * number of its own first, drawn only where drawing moves the later ones
   * (vf_sampler_in_order). */
  float rnd[3];
  uint32_t direction_pair = vf_dim_at(vertex_dims, VF_DIM_BSDF_DIRECTION);
  if (!vf_sampler_in_order(sampler, direction_pair)) {
    vf_sampler_2d(sampler, direction_pair, rnd);
    if (b->continuation < 1.0f) {
      if (!(rnd[0] < b->continuation)) return 0;
      rnd[0] = fminf(rnd[0] / b->continuation, 0x1.fffffep-1f);
    }
  } else {
    uint32_t roulette = vf_dim_at(vertex_dims, VF_DIM_ROULETTE);
    if ((b->continuation < 1.0f || vf_sampler_in_order(sampler, roulette)) &&
        vf_sampler_1d(sampler, roulette) >= b->continuation)
      return 0;
    vf_sampler_2d(sampler, direction_pair, rnd);
  }
  rnd[2] = vf_sampler_1d(sampler, vf_dim_at(vertex_dims, VF_DIM_BSDF_LOBE));
  vf_vec3 gen;
  float pdf, rev_pdf, cos_gen;
  unsigned event;
  vf_vec3 f = vf_bsdf_sample(b, rnd, &gen, &pdf, &rev_pdf, &cos_gen, &event);
  if (vf_is_zero(f) || !(pdf > 0.0f)) return 0;
  int specular = (event & VF_BSDF_SPECULAR) != 0;
  /* A merge at a point in a medium counts as v->medium_merge surface merges (volume_merging.h). */
  vf_mis_scatter_at(&s->mis, &v->merge.mis, cos_gen, pdf, rev_pdf, specular, b->phase ? v->medium_merge : 1.0f);
  float scale = cos_gen / pdf;
  if (radiance && (event & VF_BSDF_REFRACTION)) scale /= b->eta * b->eta;
  s->throughput = vf_mul(s->throughput, vf_scale(f, scale));
  s->specular_path &= specular;
  s->origin = vf_offset_ray_origin(hit->position, vf_dot(hit->normal, gen) > 0.0f ? hit->normal : vf_neg(hit->normal), v->offset_scale);
  s->direction = gen;
  if (__builtin_expect(v->has_media, 0)) {
    s->medium = vf_medium_leaving(v, hit, gen, s->medium);
    s->from_medium = vf_hit_in_medium(hit);
  }
  return 1;
}
