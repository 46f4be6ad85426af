/* Segments through participating media: segment.h. */
#include "segment.h"

#include "medium.h"

#include <math.h>

/* Index-matched boundaries a segment may cross; a path whose segment crosses more ends
 * there (a scene would need that many nested shells of fog along one line). */
#define SEGMENT_PIECES_MAX 32

/* The pieces of a segment: each one's medium (-1: vacuum) and length. */
typedef struct {
  int medium[SEGMENT_PIECES_MAX];
  float length[SEGMENT_PIECES_MAX];
  int n;
} pieces;

float vf_segment_vertex_density(const vf_vcm *v, const vf_hit *hit) {
  if (!vf_hit_in_medium(hit)) return 1.0f;
  return vf_medium_density_at(&v->media[hit->primitive], hit->position);
}

/* Piece k's distance density for an end that is a vertex in its medium (rho: the density
 * scale there) or not (a surface, or a piece merely crossed). */
static float piece_factor(const vf_vcm *v, const pieces *ps, int k, int vertex_end, float rho) {
  int m = ps->medium[k];
  if (m < 0) return 1.0f;
  float pass, scatter;
  vf_medium_piece_pdf(&v->media[m], ps->length[k], rho, &pass, &scatter);
  return vertex_end ? scatter : pass;
}

/* The densities of both ends of the segment made of ps (segment.h). */
static void end_densities(const vf_vcm *v, const pieces *ps, int near_in_medium, float near_rho, int far_in_medium,
                          float far_rho, float *fwd, float *rev) {
  float f = 1.0f, r = 1.0f;
  for (int k = 0; k < ps->n; k++) {
    f *= k == ps->n - 1 ? piece_factor(v, ps, k, far_in_medium, far_rho) : piece_factor(v, ps, k, 0, 1.0f);
    r *= k == 0 ? piece_factor(v, ps, k, near_in_medium, near_rho) : piece_factor(v, ps, k, 0, 1.0f);
  }
  *fwd = f;
  *rev = r;
}

/* The medium on the far side of index-matched boundary `hit`, crossed along dir. */
static int crossed(const vf_vcm *v, const vf_hit *hit, vf_vec3 dir) {
  const vf_shape *sh = &v->scene->shapes[hit->shape];
  return vf_dot(hit->normal, dir) < 0.0f ? sh->interior : sh->exterior;
}

static int is_boundary(const vf_vcm *v, const vf_hit *hit) { return v->scene->shapes[hit->shape].material < 0; }

int vf_segment_trace(vf_vcm *v, int thread, int medium, int near_in_medium, vf_vec3 origin, vf_vec3 dir, int found,
                     vf_hit *hit, float u, vf_sampler *sampler, vf_segment *seg) {
  pieces ps;
  ps.n = 0;
  float near_rho = near_in_medium ? vf_medium_density_at(&v->media[medium], origin) : 1.0f;
  vf_vec3 weight = vf_vec3_splat(1.0f), o = origin;
  float total = 0.0f;
  vf_hit h;
  if (found) h = *hit;
  for (;;) {
    if (ps.n == SEGMENT_PIECES_MAX) return VF_SEGMENT_ENDED;
    float length = found ? h.t : INFINITY;
    if (medium >= 0) {
      float t;
      vf_vec3 w;
      float number = ps.n == 0 ? u : vf_rng_float(vf_sampler_rng(sampler));
      int event = vf_medium_sample_piece(&v->media[medium], o, dir, length, number, vf_sampler_rng(sampler), &t, &w);
      if (event == VF_PIECE_ABSORBED) return VF_SEGMENT_ENDED;
      weight = vf_mul(weight, w);
      if (event == VF_PIECE_SCATTERED) {
        ps.medium[ps.n] = medium;
        ps.length[ps.n++] = t;
        vf_hit m;
        m.t = total + t;
        m.shape = VF_HIT_MEDIUM;
        m.primitive = (uint32_t)medium;
        m.position = vf_add(o, vf_scale(dir, t));
        m.normal = vf_vec3_splat(0.0f);
        m.u = m.v = 0.0f;
        *hit = m;
        float rho = vf_medium_density_at(&v->media[medium], m.position);
        end_densities(v, &ps, near_in_medium, near_rho, 1, rho, &seg->fwd, &seg->rev);
        seg->weight = weight;
        seg->medium = medium;
        return VF_SEGMENT_VERTEX;
      }
    }
    ps.medium[ps.n] = medium;
    ps.length[ps.n++] = length;
    if (!found) {
      end_densities(v, &ps, near_in_medium, near_rho, 0, 1.0f, &seg->fwd, &seg->rev);
      seg->weight = weight;
      seg->medium = medium;
      return VF_SEGMENT_ESCAPED;
    }
    total += h.t;
    if (!is_boundary(v, &h)) {
      h.t = total;
      *hit = h;
      end_densities(v, &ps, near_in_medium, near_rho, 0, 1.0f, &seg->fwd, &seg->rev);
      seg->weight = weight;
      seg->medium = medium;
      return VF_SEGMENT_VERTEX;
    }
    /* Through the boundary, without a vertex. */
    medium = crossed(v, &h, dir);
    o = vf_offset_ray_origin(h.position, vf_dot(h.normal, dir) > 0.0f ? h.normal : vf_neg(h.normal), v->offset_scale);
    v->stats[thread].rays++;
    found = vf_accel_intersect(v->accel, o, dir, INFINITY, &h);
  }
}

vf_vec3 vf_segment_transmittance(vf_vcm *v, int thread, int medium, vf_vec3 p, vf_vec3 n_p, float p_density, vf_vec3 q,
                                 vf_vec3 n_q, float q_density, int q_at_infinity, vf_sampler *sampler, float *fwd_q,
                                 float *rev_p) {
  pieces ps;
  ps.n = 0;
  vf_vec3 zero = vf_vec3_splat(0.0f), tr = vf_vec3_splat(1.0f);
  *fwd_q = *rev_p = 0.0f;
  int p_in_medium = vf_is_zero(n_p), q_in_medium = !q_at_infinity && vf_is_zero(n_q);
  vf_vec3 dir;
  float remaining;
  if (q_at_infinity) {
    dir = q;
    remaining = INFINITY;
  } else {
    vf_vec3 d = vf_sub(q, p);
    remaining = vf_length(d);
    if (!(remaining > 0.0f)) return zero;
    dir = vf_scale(d, 1.0f / remaining);
  }
  vf_vec3 o = p_in_medium ? p : vf_offset_ray_origin(p, vf_dot(n_p, dir) > 0.0f ? n_p : vf_neg(n_p), v->offset_scale);
  /* The far end, moved off its surface as a shadow ray's (wavefront.h, segment_ends). */
  vf_vec3 end = q;
  if (!q_at_infinity && !q_in_medium)
    end = vf_offset_ray_origin(q, vf_dot(n_q, dir) < 0.0f ? n_q : vf_neg(n_q), v->offset_scale);
  if (!v->has_boundaries) {
    /* No index-matched boundary anywhere: one piece, in `medium`, blocked by anything. */
    v->stats[thread].rays++;
    if (q_at_infinity ? vf_accel_occluded(v->accel, o, dir, INFINITY) : vf_accel_occluded(v->accel, o, vf_sub(end, o), 1.0f))
      return zero;
    if (medium >= 0) {
      tr = vf_medium_transmittance_piece(&v->media[medium], o, dir, remaining, vf_sampler_rng(sampler));
      if (vf_is_zero(tr)) return zero;
    }
    ps.medium[0] = medium;
    ps.length[0] = remaining;
    ps.n = 1;
    end_densities(v, &ps, p_in_medium, p_density, q_in_medium, q_density, fwd_q, rev_p);
    return tr;
  }
  for (;;) {
    if (ps.n == SEGMENT_PIECES_MAX) return zero;
    float tfar = q_at_infinity ? INFINITY : vf_length(vf_sub(end, o));
    vf_hit h;
    v->stats[thread].rays++;
    int found = vf_accel_intersect(v->accel, o, dir, tfar, &h);
    if (found && !is_boundary(v, &h)) return zero;
    float length = found ? h.t : (q_at_infinity ? INFINITY : remaining);
    if (medium >= 0) {
      tr = vf_mul(tr, vf_medium_transmittance_piece(&v->media[medium], o, dir, length, vf_sampler_rng(sampler)));
      if (vf_is_zero(tr)) return zero;
    }
    ps.medium[ps.n] = medium;
    ps.length[ps.n++] = length;
    if (!found) break;
    remaining -= h.t;
    medium = crossed(v, &h, dir);
    o = vf_offset_ray_origin(h.position, vf_dot(h.normal, dir) > 0.0f ? h.normal : vf_neg(h.normal), v->offset_scale);
  }
  end_densities(v, &ps, p_in_medium, p_density, q_in_medium, q_density, fwd_q, rev_p);
  return tr;
}

int vf_medium_at_point(const vf_vcm *v, vf_vec3 p) {
  /* An irrational-looking direction, so that the ray meets no edge of an axis-aligned
   * scene exactly. */
  vf_vec3 dir = vf_normalize(vf_vec3_make(0.5771f, 0.5780f, -0.5768f));
  vf_vec3 o = p;
  for (int k = 0; k < 4 * SEGMENT_PIECES_MAX; k++) {
    vf_hit h;
    if (!vf_accel_intersect(v->accel, o, dir, INFINITY, &h)) break;
    const vf_shape *sh = &v->scene->shapes[h.shape];
    if (sh->interface) return vf_dot(h.normal, dir) > 0.0f ? sh->interior : sh->exterior;
    o = vf_offset_ray_origin(h.position, vf_dot(h.normal, dir) > 0.0f ? h.normal : vf_neg(h.normal), v->offset_scale);
  }
  return v->scene->medium;
}
