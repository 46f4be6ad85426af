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

/* The densities of both ends of the segment made of ps (segment.h): each piece's pass and
 * scatter densities once (vf_medium_piece_pdf, at unit density: a grid's scales by the
 * vertex's), the pieces before the far end passed, its own by the far end's kind; the
 * same from the near end. */
static void end_densities(const vf_vcm *v, const pieces *ps, int near_in_medium, float near_rho, int far_in_medium,
                          float far_rho, float *fwd, float *rev) {
  float f = 1.0f, r = 1.0f;
  for (int k = 0; k < ps->n; k++) {
    int m = ps->medium[k];
    if (m < 0) continue;
    float pass, scatter;
    vf_medium_piece_pdf(&v->media[m], ps->length[k], 1.0f, &pass, &scatter);
    float far = far_in_medium ? scatter * (v->media[m].grid ? far_rho : 1.0f) : pass;
    float near = near_in_medium ? scatter * (v->media[m].grid ? near_rho : 1.0f) : pass;
    f *= k == ps->n - 1 ? far : pass;
    r *= k == 0 ? near : pass;
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

static vf_vec3 unblocked(const vf_vcm *v, int medium, vf_vec3 p, vf_vec3 n_p, float p_density, vf_vec3 q, vf_vec3 n_q,
                         float q_density, int q_at_infinity, vf_rng *rng, float *fwd_q, float *rev_p);

int vf_segment_trace(vf_vcm *v, int thread, int medium, int near_in_medium, vf_vec3 origin, vf_vec3 dir, int found,
                     vf_hit *hit, float u, vf_sampler *sampler, vf_segment *seg) {
  return vf_segment_trace_rng(v, thread, medium, near_in_medium, origin, dir, found, hit, u, vf_sampler_rng(sampler),
                              seg);
}

int vf_segment_trace_rng(vf_vcm *v, int thread, int medium, int near_in_medium, vf_vec3 origin, vf_vec3 dir, int found,
                         vf_hit *hit, float u, vf_rng *rng, vf_segment *seg) {
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
      float number = ps.n == 0 ? u : vf_rng_float(rng);
      int event = vf_medium_sample_piece(&v->media[medium], o, dir, length, number, rng, &t, &w);
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

vf_vec3 vf_segment_transmittance_unblocked(const vf_vcm *v, int medium, vf_vec3 p, vf_vec3 n_p, float p_density,
                                           vf_vec3 q, vf_vec3 n_q, float q_density, int q_at_infinity,
                                           vf_sampler *sampler, float *fwd_q, float *rev_p) {
  return unblocked(v, medium, p, n_p, p_density, q, n_q, q_density, q_at_infinity, vf_sampler_rng(sampler), fwd_q,
                   rev_p);
}

static vf_vec3 unblocked(const vf_vcm *v, int medium, vf_vec3 p, vf_vec3 n_p, float p_density, vf_vec3 q, vf_vec3 n_q,
                         float q_density, int q_at_infinity, vf_rng *rng, float *fwd_q, float *rev_p) {
  pieces ps;
  vf_vec3 tr = vf_vec3_splat(1.0f);
  *fwd_q = *rev_p = 0.0f;
  int p_in_medium = vf_is_zero(n_p), q_in_medium = !q_at_infinity && vf_is_zero(n_q);
  vf_vec3 dir = q;
  float length = INFINITY;
  if (!q_at_infinity) {
    vf_vec3 d = vf_sub(q, p);
    length = vf_length(d);
    if (!(length > 0.0f)) return vf_vec3_splat(0.0f);
    dir = vf_scale(d, 1.0f / length);
  }
  if (medium >= 0) tr = vf_medium_transmittance_piece(&v->media[medium], p, dir, length, rng);
  if (vf_is_zero(tr)) return tr;
  ps.medium[0] = medium;
  ps.length[0] = length;
  ps.n = 1;
  end_densities(v, &ps, p_in_medium, p_density, q_in_medium, q_density, fwd_q, rev_p);
  return tr;
}

vf_vec3 vf_segment_transmittance(vf_vcm *v, int thread, int medium, vf_vec3 p, vf_vec3 n_p, float p_density, vf_vec3 q,
                                 vf_vec3 n_q, float q_density, int q_at_infinity, vf_sampler *sampler, float *fwd_q,
                                 float *rev_p) {
  return vf_segment_transmittance_rng(v, thread, medium, p, n_p, p_density, q, n_q, q_density, q_at_infinity,
                                      vf_sampler_rng(sampler), fwd_q, rev_p);
}

vf_vec3 vf_segment_transmittance_rng(vf_vcm *v, int thread, int medium, vf_vec3 p, vf_vec3 n_p, float p_density,
                                     vf_vec3 q, vf_vec3 n_q, float q_density, int q_at_infinity, vf_rng *rng,
                                     float *fwd_q, float *rev_p) {
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
    return unblocked(v, medium, p, n_p, p_density, q, n_q, q_density, q_at_infinity, rng, fwd_q, rev_p);
  }
  for (;;) {
    if (ps.n == SEGMENT_PIECES_MAX) return zero;
    /* Each piece aims at the far end itself, as a shadow ray does (wavefront.h): a ray
     * along the first piece's direction from a point moved off a boundary would pass the
     * far end by a hair and could meet its surface. */
    vf_vec3 ray = q_at_infinity ? dir : vf_sub(end, o);
    float scale = q_at_infinity ? 1.0f : vf_length(ray);
    vf_hit h;
    v->stats[thread].rays++;
    int found = vf_accel_intersect(v->accel, o, ray, q_at_infinity ? INFINITY : 1.0f, &h);
    if (found && !is_boundary(v, &h)) return zero;
    float length = found ? h.t * scale : scale;
    vf_vec3 unit = q_at_infinity ? dir : vf_scale(ray, 1.0f / scale);
    if (medium >= 0) {
      tr = vf_mul(tr, vf_medium_transmittance_piece(&v->media[medium], o, unit, length, rng));
      if (vf_is_zero(tr)) return zero;
    }
    ps.medium[ps.n] = medium;
    ps.length[ps.n++] = length;
    if (!found) break;
    medium = crossed(v, &h, unit);
    o = vf_offset_ray_origin(h.position, vf_dot(h.normal, unit) > 0.0f ? h.normal : vf_neg(h.normal), v->offset_scale);
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
