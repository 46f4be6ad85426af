/* upg's vertex merging: each camera vertex gathers the light vertices within the radius,
 * as vcm's merging finds them (on surfaces, and in media at medium vertices), and joins
 * each one's predecessor to itself, with the unbiased estimate of the acceptance
 * probability's reciprocal (photon_gathering.h has the estimator and its medium case,
 * gathering_pass.h the phase). */
#include "gathering_pass.h"

#include "photon_gathering.h"
#include "segment.h"
#include "vertex_merging.h"
#include "volume_merging.h"
#include "wavefront.h"

#include <math.h>

/* The light sub-path (global index) whose chunk-list range holds vertex i of chunk c: the
 * last path of the chunk that begins at or before i (path_begin is non-decreasing over a
 * chunk's paths; empty paths begin where the next does). */
static uint32_t path_of_vertex(const vf_vcm *v, uint32_t c, uint32_t i) {
  uint32_t lo = c * LIGHT_CHUNK, hi = lo + LIGHT_CHUNK < v->num_pixels ? lo + LIGHT_CHUNK : v->num_pixels;
  hi--; /* the answer lies in [lo, hi] */
  while (lo < hi) {
    uint32_t mid = lo + (hi - lo + 1) / 2;
    if (v->path_begin[mid] <= i) lo = mid;
    else hi = mid - 1;
  }
  return lo;
}

/* The ray origin of a tentative direction from point p with geometric normal n (zero
 * vector: a punctual light) on the side of dir: where the light sub-path's own ray would
 * start (vf_wavefront_scatter, light_pass.c's light_start). */
static vf_vec3 tentative_origin(const vf_vcm *v, vf_vec3 p, vf_vec3 n, vf_vec3 dir) {
  if (vf_is_zero(n)) return p;
  return vf_offset_ray_origin(p, vf_dot(n, dir) > 0.0f ? n : vf_neg(n), v->offset_scale);
}

/* What a tentative ray must find (vf_upg_lands): from `origin`, its first hit within the
 * radius of the camera vertex on a surface that stores light vertices. In a scene with
 * media, the ray is a sub-path's segment from `place` (near_in_medium: a medium vertex, or
 * a light's point in its medium), its distances sampled as the sub-path samples them
 * (vf_segment_trace_rng, numbers from rng): it must end at such a surface, or for a target
 * in a medium (target_in_medium) scatter within the radius of it. */
typedef struct {
  vf_vcm *v;
  int thread;
  vf_vec3 from, normal; /* L and its geometric normal (zero vector: a punctual light, a medium vertex) */
  vf_vec3 target;
  float radius_sq; /* the camera vertex's merge radius, squared */
  float tfar;
  const gathering_place *place; /* media: where L is */
  int near_in_medium, target_in_medium;
  vf_rng *rng; /* media: the free flights' numbers, the trials' stream */
} landing;

/* The medium a sub-path leaving place pl along dir travels in (vf_medium_leaving). */
static int leaving(const vf_vcm *v, const gathering_place *pl, vf_vec3 dir) {
  if (pl->shape == VF_HIT_MEDIUM) return pl->medium;
  const vf_shape *sh = &v->scene->shapes[pl->shape];
  if (!sh->interface) return pl->medium;
  return vf_dot(pl->normal, dir) > 0.0f ? sh->exterior : sh->interior;
}

/* A tentative direction through media: the segment's free flight decides where it ends. A
 * hit beyond tfar (the far side of the ball) cannot land, so the first ray stops there; a
 * flight that scatters beyond it, in the piece taken as unbounded, fails as well. */
static int lands_through_media(landing *l, vf_vec3 dir) {
  vf_vcm *v = l->v;
  vf_vec3 o = tentative_origin(v, l->from, l->normal, dir);
  vf_hit hit;
  v->stats[l->thread].rays++;
  int found = vf_accel_intersect(v->accel, o, dir, l->tfar, &hit);
  int medium = leaving(v, l->place, dir);
  if (!found && medium < 0) return 0; /* nothing to scatter in, nothing to land on */
  vf_segment seg;
  float u = vf_rng_float(l->rng);
  if (vf_segment_trace_rng(v, l->thread, medium, l->near_in_medium, o, dir, found, &hit, u, l->rng, &seg) !=
      VF_SEGMENT_VERTEX)
    return 0;
  if (!vf_vertex_merging_within(l->radius_sq, hit.position.x, hit.position.y, hit.position.z, l->target)) return 0;
  if (vf_hit_in_medium(&hit)) return l->target_in_medium;
  if (l->target_in_medium) return 0;
  vf_bsdf b;
  return bsdf_at(v, &b, &hit, vf_neg(dir)) && !b.is_delta;
}

static int lands(void *ctx, vf_vec3 dir) {
  landing *l = ctx;
  vf_vcm *v = l->v;
  if (v->has_media) return lands_through_media(l, dir);
  vf_hit hit;
  v->stats[l->thread].rays++;
  if (!vf_accel_intersect(v->accel, tentative_origin(v, l->from, l->normal, dir), dir, l->tfar, &hit)) return 0;
  if (!vf_vertex_merging_within(l->radius_sq, hit.position.x, hit.position.y, hit.position.z, l->target)) return 0;
  /* Stored there, as light_pass.c stores: a surface that scatters, not only specularly. */
  vf_bsdf b;
  return bsdf_at(v, &b, &hit, vf_neg(dir)) && !b.is_delta;
}

/* Whether the segment from p (normal n) to q (normal nq; zero vector: a punctual light) is
 * free, tested as a shadow ray of the passes is (segment_ends), at once. */
static int visible(vf_vcm *v, int thread, vf_vec3 p, vf_vec3 n, vf_vec3 q, vf_vec3 nq) {
  vf_vec3 o, e;
  segment_ends(v, p, n, q, nq, &o, &e);
  v->stats[thread].rays++;
  return !vf_accel_occluded(v->accel, o, vf_sub(e, o), 1.0f);
}

/* The estimate of 1/p_acc of a source at `from` (normal n: its offsets; zero vector for a
 * punctual light) for the ball of the radius around `target`, with the trials of whichever
 * estimator costs less. Either is exact; the cone's trials number |C| M / p_acc on
 * average, the sub-path's own draws 1 / p_acc, and a trial of either costs about a BSDF
 * evaluation (rays are P(C) / p_acc with both): the draws where |C| M >= 1, which a wide
 * cone (the source close to the target, a corner) or a loose bound makes. A light's own
 * point has no draws here; its bounds are tight (|C| M <= 4). 0 where nothing reaches the
 * ball (then no light vertex, or camera vertex, could have landed there). In a scene with
 * media, the trials' flights start at `place` (near_in_medium: a medium vertex's) and land
 * by scattering in the ball where target_in_medium (lands_through_media); else NULL, 0, 0. */
static double inverse_acceptance(vf_vcm *v, int thread, const merge_params *merge, const vf_upg_source *src,
                                 vf_vec3 from, vf_vec3 n, vf_vec3 target, float dist, const gathering_place *place,
                                 int near_in_medium, int target_in_medium, vf_rng *rng) {
  vf_vec3 axis;
  float cos_half, omc;
  vf_upg_cone(from, target, merge->radius, &axis, &cos_half, &omc);
  float bound = vf_upg_bound(src, axis, cos_half, omc);
  if (!(bound > 0.0f)) return 0.0;
  landing ctx = {v, thread, from, n, target, merge->radius_sq, dist + 2.0f * merge->radius,
                 place, near_in_medium, target_in_medium, rng};
  if (src->bsdf != NULL && !(2.0 * M_PI * (double)omc * (double)bound < 1.0))
    return vf_upg_inverse_acceptance_draws(src->bsdf, axis, cos_half, rng, lands, &ctx, &v->stats[thread].upg);
  return vf_upg_inverse_acceptance(src, axis, cos_half, omc, bound, rng, lands, &ctx, &v->stats[thread].upg);
}

/* A join through media: the transmittance of the segment from p (at place pp, normal np
 * for its offsets: zero in a medium) to q (normal nq, density rho_q), numbers from rng,
 * with the distance densities of q seen from p (*fwd_q) and of p seen from q (*rev_p);
 * zero where a surface blocks it. */
static vf_vec3 join_through_media(vf_vcm *v, int thread, const gathering_place *pp, vf_vec3 p, vf_vec3 np, vf_vec3 q,
                                  vf_vec3 nq, float rho_q, vf_rng *rng, float *fwd_q, float *rev_p) {
  vf_vec3 d = vf_normalize(vf_sub(q, p));
  int medium = leaving(v, pp, d);
  float rho_p = pp->shape == VF_HIT_MEDIUM ? vf_medium_density_at(&v->media[pp->medium], p) : 1.0f;
  return vf_segment_transmittance_rng(v, thread, medium, p, np, rho_p, q, nq, rho_q, 0, rng, fwd_q, rev_p);
}

/* The place of a stored light vertex for its tentative draws: a medium vertex's medium,
 * or a surface with the outward normal its hit had and, where the shape is no interface,
 * the medium around it (vf_vcm.shape_medium, or where that cannot tell found by
 * vf_medium_at_point from the side of the camera vertex, `towards`; both sides have the
 * same medium there). */
static gathering_place place_of_vertex(const vf_vcm *v, const light_vertex *lv, vf_vec3 towards) {
  gathering_place pl = {vf_vec3_splat(0.0f), VF_HIT_MEDIUM, -1};
  if (vertex_in_medium(lv)) {
    pl.medium = (int)lv->at.point.primitive;
    return pl;
  }
  pl.shape = vertex_shape(lv);
  const vf_shape *sh = &v->scene->shapes[pl.shape];
  pl.normal = v->interpolated[pl.shape] ? vf_surface_triangle_normal(sh, lv->at.point.primitive) : lv->at.normal;
  if (!sh->interface && (pl.medium = v->shape_medium[pl.shape]) == VF_SHAPE_MEDIUM_UNKNOWN) {
    vf_vec3 n = pl.normal;
    pl.medium = vf_medium_at_point(v, vf_offset_ray_origin(lv->position, vf_dot(n, towards) > 0.0f ? n : vf_neg(n),
                                                           v->offset_scale));
  }
  return pl;
}

/* The geometric normal of a BSDF's vertex, on the side its path arrived from; zero at a
 * point in a medium (nothing to move a ray off). */
static vf_vec3 geometric_normal(const vf_bsdf *b) {
  if (b->phase) return vf_vec3_splat(0.0f);
  return b->shading ? b->geometric : b->frame.n;
}

/* A light vertex found within the radius of a camera vertex, as a gathering reads it: on a
 * surface, grid point k of vf_vcm.merge_points; in a medium, vf_vcm.medium_photons[k]. */
typedef struct {
  vf_vec3 position, throughput;
  vf_mis mis;
  uint32_t name; /* its chunk c and index i there, (c << chunk_shift) | i */
  uint32_t k;
  int length;
  int in_medium;
} found_vertex;

/* From the light's side: the light vertex's predecessor L (a light vertex pred with its BSDF
 * lb, or its sub-path's point on its light, origin) joined to camera vertex q, with 1/p_acc
 * of L's continuation landing within the radius of q (in a medium: scattering there, when
 * y_in_medium). */
static vf_vec3 gather_from_light(vf_vcm *v, int thread, const vertex_merging_query *q, const gathering_prev *prev,
                                 const light_vertex *pred, const vf_bsdf *lb, const light_origin *origin,
                                 int y_in_medium, vf_rng *rng) {
  const vf_vec3 zero = vf_vec3_splat(0.0f);
  /* The connection of the predecessor L and q (camera_pass.c's connect_vertices). */
  vf_vec3 lpos = pred ? pred->position : origin->position;
  vf_vec3 d = vf_sub(lpos, q->position);
  float dist2 = vf_length_sq(d);
  if (!(dist2 > 0.0f)) return zero;
  float dist = sqrtf(dist2);
  d = vf_scale(d, 1.0f / dist); /* from q towards L */
  float cos_camera, camera_pdf, camera_rev_pdf;
  vf_vec3 fc = vf_bsdf_evaluate(&q->bsdf, d, &cos_camera, &camera_pdf, &camera_rev_pdf);
  if (vf_is_zero(fc)) return zero;

  vf_upg_source src = {NULL, NULL, zero};
  vf_vec3 light_value, lnormal;
  vf_mis light_mis;
  float cos_light = 1.0f, light_pdf = 0.0f, light_rev_pdf = 0.0f;
  if (pred) {
    vf_vec3 fl = vf_bsdf_evaluate(lb, vf_neg(d), &cos_light, &light_pdf, &light_rev_pdf);
    if (vf_is_zero(fl)) return zero;
    light_value = vf_scale(vf_mul(pred->throughput, fl), cos_light);
    light_mis = pred->mis;
    lnormal = normal_of_vertex(v, pred, lb);
    src.bsdf = lb;
  } else {
    const vf_light *l = &v->lights->lights[origin->light];
    float dir_pdf;
    float factor = vf_light_emission_toward(l, origin->normal, vf_neg(d), &dir_pdf, &cos_light);
    if (!(factor > 0.0f)) return zero;
    if (origin->coat.weight > 0.0f) factor *= vf_light_coat_transmit(&origin->coat, vf_neg(d));
    float pick = l->pick_probability;
    float area_pdf = l->is_delta ? 1.0f : l->inv_area;
    /* What the light sub-path's throughput would be after emitting towards q, times the
     * emission density of that direction: the emitted value over the point's density. */
    light_value = vf_scale(origin->radiance, factor / (pick * area_pdf));
    vf_mis_light_start(&light_mis, &v->merge.mis, area_pdf * pick, area_pdf * dir_pdf * pick, cos_light, l->is_delta, 1);
    lnormal = l->is_delta ? zero : origin->normal;
    src.light = l;
    src.light_normal = origin->normal;
  }
  vf_vec3 value = vf_mul(vf_mul(light_value, fc), q->throughput);
  if (!v->has_media) {
    /* The light vertex as if it had landed at q: the weight of merging it there (eq. 38-39),
     * whose approximate acceptance density every technique's weight shares (see the top of
     * photon_gathering.h). */
    float w = vf_mis_weight_gather(light_mis, &q->mis, &q->merge.mis, pred != NULL, cos_light, light_pdf, light_rev_pdf,
                                   dist, cos_camera, camera_pdf, camera_rev_pdf);
    value = vf_scale(value, w * cos_camera / (dist2 * v->merge.mis.light_paths));
    if (vf_is_zero(value)) return zero;
    if (!visible(v, thread, q->position, geometric_normal(&q->bsdf), lpos, lnormal)) return zero;
    double inverse = inverse_acceptance(v, thread, &q->merge, &src, lpos, lnormal, q->position, dist, NULL, 0, 0, rng);
    return vf_scale(value, (float)inverse);
  }
  /* Through media: the join's transmittance, its distance densities in the weight, and the
   * tentative draws' free flights from L's place (photon_gathering.h, "In media"). */
  int pred_in_medium = pred != NULL && vertex_in_medium(pred);
  float rho_l = pred_in_medium ? vf_medium_density_at(&v->media[pred->at.point.primitive], lpos) : 1.0f;
  float fwd_l, rev_q;
  vf_vec3 tr = join_through_media(v, thread, &prev->here, q->position, geometric_normal(&q->bsdf), lpos, lnormal,
                                  rho_l, rng, &fwd_l, &rev_q);
  if (vf_is_zero(tr)) return zero;
  float w = vf_mis_weight_gather_media(light_mis, &q->mis, &q->merge.mis, pred != NULL,
                                       pred_in_medium ? v->medium_merge : 1.0f, cos_light, light_pdf, light_rev_pdf,
                                       dist, cos_camera, rev_q, fwd_l, y_in_medium ? v->medium_merge : 0.0f,
                                       camera_pdf, camera_rev_pdf);
  value = vf_scale(vf_mul(value, tr), w * cos_camera / (dist2 * v->merge.mis.light_paths));
  if (vf_is_zero(value)) return zero;
  gathering_place place = {zero, VF_HIT_MEDIUM, -1};
  if (pred) place = place_of_vertex(v, pred, vf_neg(d));
  else place.medium = v->light_medium[origin->light];
  double inverse = inverse_acceptance(v, thread, &q->merge, &src, lpos, lnormal, q->position, dist, &place,
                                      pred_in_medium, y_in_medium, rng);
  return vf_scale(value, (float)inverse);
}

/* From the camera's side: light vertex y (lv in its chunk, found as f) joined to the
 * camera vertex before q, prev (with q's radius), with 1/p_acc of prev's continuation
 * landing within the radius of y on a surface where a camera vertex gathers (in a medium:
 * scattering there). */
static vf_vec3 gather_from_camera(vf_vcm *v, int thread, const vertex_merging_query *q, const gathering_prev *prev,
                                  const found_vertex *f, const light_vertex *lv, vf_rng *rng) {
  const vf_vec3 zero = vf_vec3_splat(0.0f);
  vf_vec3 y = f->position;
  vf_vec3 d = vf_sub(y, prev->position);
  float dist2 = vf_length_sq(d);
  if (!(dist2 > 0.0f)) return zero;
  float dist = sqrtf(dist2);
  d = vf_scale(d, 1.0f / dist); /* from the camera vertex towards y */
  float cos_camera, camera_pdf, camera_rev_pdf;
  vf_vec3 fc = vf_bsdf_evaluate(&prev->bsdf, d, &cos_camera, &camera_pdf, &camera_rev_pdf);
  if (vf_is_zero(fc)) return zero;
  vf_bsdf lb;
  bsdf_of_vertex(v, &lb, lv);
  float cos_light, light_pdf, light_rev_pdf;
  vf_vec3 fl = vf_bsdf_evaluate(&lb, vf_neg(d), &cos_light, &light_pdf, &light_rev_pdf);
  if (vf_is_zero(fl)) return zero;
  vf_vec3 value = vf_mul(vf_mul(vf_mul(f->throughput, fl), fc), prev->throughput);
  vf_vec3 nc = geometric_normal(&prev->bsdf), ny = normal_of_vertex(v, lv, &lb);
  vf_upg_source src = {&prev->bsdf, NULL, zero};
  if (!v->has_media) {
    /* The camera vertex as if it had landed at y; y's densities seen from the camera's side
     * are its light BSDF's the other way round. */
    float w = vf_mis_weight_gather_camera(&f->mis, prev->mis, &q->merge.mis, cos_camera, camera_pdf, camera_rev_pdf,
                                          dist, cos_light, light_rev_pdf, light_pdf);
    value = vf_scale(value, w * cos_camera * cos_light / (dist2 * v->merge.mis.light_paths));
    if (vf_is_zero(value)) return zero;
    if (!visible(v, thread, prev->position, nc, y, ny)) return zero;
    double inverse = inverse_acceptance(v, thread, &q->merge, &src, prev->position, nc, y, dist, NULL, 0, 0, rng);
    return vf_scale(value, (float)inverse);
  }
  int prev_in_medium = prev->place.shape == VF_HIT_MEDIUM;
  float rho_y = f->in_medium ? vf_medium_density_at(&v->media[lv->at.point.primitive], y) : 1.0f;
  float fwd_y, rev_c;
  vf_vec3 tr = join_through_media(v, thread, &prev->place, prev->position, nc, y, ny, rho_y, rng, &fwd_y, &rev_c);
  if (vf_is_zero(tr)) return zero;
  float w = vf_mis_weight_gather_camera_media(&f->mis, prev->mis, &q->merge.mis,
                                              prev_in_medium ? v->medium_merge : 1.0f, cos_camera, camera_pdf,
                                              camera_rev_pdf, dist, cos_light, fwd_y, rev_c,
                                              f->in_medium ? v->medium_merge : 0.0f, light_rev_pdf, light_pdf);
  value = vf_scale(vf_mul(value, tr), w * cos_camera * cos_light / (dist2 * v->merge.mis.light_paths));
  if (vf_is_zero(value)) return zero;
  double inverse = inverse_acceptance(v, thread, &q->merge, &src, prev->position, nc, y, dist, &prev->place,
                                      prev_in_medium, f->in_medium, rng);
  return vf_scale(value, (float)inverse);
}

/* The fall-back: light vertex f merged as vcm merges it, counted. */
static vf_vec3 merge_as_vcm(vf_vcm *v, int thread, const vertex_merging_query *q, const found_vertex *f) {
  v->stats[thread].upg_fallbacks++;
  if (f->in_medium) return vf_mul(q->throughput, vf_volume_merging_one(v, &q->bsdf, &q->mis, f->k));
  return vf_mul(q->throughput, vf_scale(vf_vertex_merging_one(v, q, f->k), q->merge.vm_normalization));
}

/* Gathers light vertex f (within the radius of q) at camera vertex q, whose predecessor is
 * prev: its estimate, the camera sub-path's throughput included (the camera's side joins
 * at prev, whose throughput is not q's).
 *
 * Which side joins, decided by the path alone so that every path is estimated once: the
 * light's side can where the light vertex was reached by a non-specular choice from a
 * predecessor at a finite distance; the camera's side where q was reached by a
 * non-specular choice from a vertex that is not the lens. A path both can take goes to
 * the side the settings prefer (vf_settings.gather; under auto the side whose joining
 * vertex scatters less sharply, vf_upg_sharpness), a path one can take to that one, and
 * a path neither can take is merged as vcm merges it (counted: biased). Specular choices
 * are told by d_vcm, which vf_mis_scatter zeroes for them and nothing else does. Gatherings
 * at medium vertices follow the same rule (a medium vertex is never specular). */
static vf_vec3 gather(vf_vcm *v, int thread, const vertex_merging_query *q, const gathering_prev *prev,
                      const found_vertex *f, vf_rng *rng) {
  if (f->length + q->path_length > v->settings.max_path_length) return vf_vec3_splat(0.0f);
  uint32_t c = f->name >> v->chunk_shift, i = f->name & ((1u << v->chunk_shift) - 1u);
  const light_vertex *list = v->chunks[c].vertices;
  const light_vertex *pred = NULL;
  const light_origin *origin = NULL;
  if (f->mis.d_vcm != 0.0f) {
    uint32_t path = path_of_vertex(v, c, i);
    if (f->length == 1) {
      if (v->origins[path].light >= 0) origin = &v->origins[path];
    } else if (i > v->path_begin[path] && vertex_path_length(&list[i - 1]) == f->length - 1) {
      pred = &list[i - 1];
    }
  }
  int light_side = pred != NULL || origin != NULL;
  int camera_side = prev->valid && q->mis.d_vcm != 0.0f;
  int prefer_camera = v->settings.gather == VF_GATHER_CAMERA, automatic = v->settings.gather == VF_GATHER_AUTO;
  vf_bsdf lb; /* the predecessor's, set up once for the choice and the light's side */
  if (pred && (!camera_side || !prefer_camera)) bsdf_of_vertex(v, &lb, pred);
  if (light_side && camera_side && automatic) {
    /* The side whose joining vertex scatters less sharply: a function of the path's two
     * vertices next to the gathering, as both sides see them. */
    vf_upg_source ls = {pred ? &lb : NULL, pred ? NULL : &v->lights->lights[origin->light], vf_vec3_splat(0.0f)};
    vf_upg_source cs = {&prev->bsdf, NULL, vf_vec3_splat(0.0f)};
    prefer_camera = vf_upg_sharpness(&cs) < vf_upg_sharpness(&ls);
  }
  if (camera_side && (!light_side || prefer_camera)) return gather_from_camera(v, thread, q, prev, f, &list[i], rng);
  if (light_side) return gather_from_light(v, thread, q, prev, pred, &lb, origin, f->in_medium, rng);
  return merge_as_vcm(v, thread, q, f);
}

/* The gathering's own stream: (seed, iteration, camera sub-path, camera vertex). */
static vf_rng gathering_rng(const vf_vcm *v, const vertex_merging_query *q) {
  return vf_rng_for_path(v->settings.seed, v->iteration, q->pixel, VF_STREAM_GATHER | (uint32_t)q->path_length << 8);
}

vf_vec3 vf_gathering_estimate(vf_vcm *v, int thread, const vertex_merging_query *q, const gathering_prev *prev) {
  vf_rng rng = gathering_rng(v, q);
  vf_index_range ranges[VF_HASHGRID_MAX_RANGES];
  int num_ranges = vf_hashgrid_candidates(v->grid, q->position, ranges);
  vf_vec3 sum = vf_vec3_splat(0.0f);
  for (int r = 0; r < num_ranges; r++)
    for (uint32_t k = ranges[r].begin; k < ranges[r].end; k++) {
      const merge_point *p = &v->merge_points[k];
      if (!vf_vertex_merging_within(q->merge.radius_sq, p->x, p->y, p->z, q->position)) continue;
      found_vertex f = {vf_vec3_make(p->x, p->y, p->z),
                        v->photons[k].throughput,
                        vf_photon_mis(v, k),
                        v->photon_source[k],
                        k,
                        (int)(p->path_length_shape & ((1u << VERTEX_LENGTH_BITS) - 1u)),
                        0};
      sum = vf_add(sum, gather(v, thread, q, prev, &f, &rng));
    }
  return sum;
}

vf_vec3 vf_gathering_estimate_medium(vf_vcm *v, int thread, const vertex_merging_query *q, const gathering_prev *prev) {
  vf_vec3 sum = vf_vec3_splat(0.0f);
  if (v->num_medium_photons == 0) return sum;
  vf_rng rng = gathering_rng(v, q);
  vf_index_range ranges[VF_HASHGRID_MAX_RANGES];
  int num_ranges = vf_hashgrid_candidates(v->volume_grid, q->position, ranges);
  const vf_grid_point *points = vf_hashgrid_points(v->volume_grid);
  for (int r = 0; r < num_ranges; r++)
    for (uint32_t j = ranges[r].begin; j < ranges[r].end; j++) {
      const vf_grid_point *p = &points[j];
      if (!vf_vertex_merging_within(q->merge.radius_sq, p->x, p->y, p->z, q->position)) continue;
      const medium_photon *ph = &v->medium_photons[p->index];
      found_vertex f = {ph->position, ph->throughput, ph->mis, ph->source, p->index, ph->path_length, 1};
      sum = vf_add(sum, gather(v, thread, q, prev, &f, &rng));
    }
  return sum;
}

void vf_gathering_pass_run_tile(vf_vcm *v, int thread, float *tile_rgb) {
  thread_scratch *ts = &v->scratch[thread];
  for (uint32_t n = 0; n < ts->num_queries; n++) {
    const vertex_merging_query *q = &ts->queries[n];
    vf_vec3 contrib = vf_gathering_estimate(v, thread, q, &ts->query_prev[n]);
    float *rgb = &tile_rgb[3 * (size_t)q->tile_pixel];
    rgb[0] += contrib.x;
    rgb[1] += contrib.y;
    rgb[2] += contrib.z;
  }
  ts->num_queries = 0;
}
