/* upg's vertex merging: each camera vertex gathers the light vertices within the radius,
 * as vcm's merging finds them, and joins each one's predecessor to itself, with the
 * unbiased estimate of the acceptance probability's reciprocal (photon_gathering.h has the
 * estimator, gathering_pass.h the phase). */
#include "gathering_pass.h"

#include "photon_gathering.h"
#include "vertex_merging.h"
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
 * radius of the camera vertex on a surface that stores light vertices. */
typedef struct {
  vf_vcm *v;
  int thread;
  vf_vec3 from, normal; /* L and its geometric normal (zero vector: a punctual light) */
  vf_vec3 target;
  float radius_sq; /* the camera vertex's merge radius, squared */
  float tfar;
} landing;

static int lands(void *ctx, vf_vec3 dir) {
  landing *l = ctx;
  vf_vcm *v = l->v;
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

/* The light vertex k of the grid merged as vcm merges it: the fall-back. */
static vf_vec3 merge_as_vcm(vf_vcm *v, int thread, const vertex_merging_query *q, uint32_t k) {
  v->stats[thread].upg_fallbacks++;
  return vf_mul(q->throughput, vf_scale(vf_vertex_merging_one(v, q, k), q->merge.vm_normalization));
}

/* The estimate of 1/p_acc of a source at `from` (normal n: its offsets; zero vector for a
 * punctual light) for the ball of the radius around `target`, with the trials of whichever
 * estimator costs less. Either is exact; the cone's trials number |C| M / p_acc on
 * average, the sub-path's own draws 1 / p_acc, and a trial of either costs about a BSDF
 * evaluation (rays are P(C) / p_acc with both): the draws where |C| M >= 1, which a wide
 * cone (the source close to the target, a corner) or a loose bound makes. A light's own
 * point has no draws here; its bounds are tight (|C| M <= 4). 0 where nothing reaches the
 * ball (then no light vertex, or camera vertex, could have landed there). */
static double inverse_acceptance(vf_vcm *v, int thread, const merge_params *merge, const vf_upg_source *src,
                                 vf_vec3 from, vf_vec3 n, vf_vec3 target, float dist, vf_rng *rng) {
  vf_vec3 axis;
  float cos_half, omc;
  vf_upg_cone(from, target, merge->radius, &axis, &cos_half, &omc);
  float bound = vf_upg_bound(src, axis, cos_half, omc);
  if (!(bound > 0.0f)) return 0.0;
  landing ctx = {v, thread, from, n, target, merge->radius_sq, dist + 2.0f * merge->radius};
  if (src->bsdf != NULL && !(2.0 * M_PI * (double)omc * (double)bound < 1.0))
    return vf_upg_inverse_acceptance_draws(src->bsdf, axis, cos_half, rng, lands, &ctx, &v->stats[thread].upg);
  return vf_upg_inverse_acceptance(src, axis, cos_half, omc, bound, rng, lands, &ctx, &v->stats[thread].upg);
}

/* The geometric normal of a BSDF's vertex, on the side its path arrived from. */
static vf_vec3 geometric_normal(const vf_bsdf *b) { return b->shading ? b->geometric : b->frame.n; }

/* From the light's side: the light vertex's predecessor L (a light vertex pred with its BSDF
 * lb, or its sub-path's point on its light, origin) joined to camera vertex q, with 1/p_acc
 * of L's continuation landing within the radius of q. */
static vf_vec3 gather_from_light(vf_vcm *v, int thread, const vertex_merging_query *q, const light_vertex *pred,
                                 const vf_bsdf *lb, const light_origin *origin, vf_rng *rng) {
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
  /* The light vertex as if it had landed at q: the weight of merging it there (eq. 38-39),
   * whose approximate acceptance density every technique's weight shares (see the top of
   * photon_gathering.h). */
  float w = vf_mis_weight_gather(light_mis, &q->mis, &q->merge.mis, pred != NULL, cos_light, light_pdf, light_rev_pdf, dist,
                                 cos_camera, camera_pdf, camera_rev_pdf);
  vf_vec3 value = vf_mul(vf_mul(light_value, fc), q->throughput);
  value = vf_scale(value, w * cos_camera / (dist2 * v->merge.mis.light_paths));
  if (vf_is_zero(value)) return zero;

  if (!visible(v, thread, q->position, geometric_normal(&q->bsdf), lpos, lnormal)) return zero;

  double inverse = inverse_acceptance(v, thread, &q->merge, &src, lpos, lnormal, q->position, dist, rng);
  return vf_scale(value, (float)inverse);
}

/* From the camera's side: light vertex y (grid index k, the chunk vertex lv) joined to the
 * camera vertex before q, prev (with q's radius), with 1/p_acc of prev's continuation landing within the
 * radius of y on a surface where a camera vertex gathers. */
static vf_vec3 gather_from_camera(vf_vcm *v, int thread, const vertex_merging_query *q, const gathering_prev *prev,
                                  uint32_t k, const light_vertex *lv, vf_rng *rng) {
  const vf_vec3 zero = vf_vec3_splat(0.0f);
  const merge_point *mp = &v->merge_points[k];
  vf_vec3 y = vf_vec3_make(mp->x, mp->y, mp->z);
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
  /* The camera vertex as if it had landed at y; y's densities seen from the camera's side
   * are its light BSDF's the other way round. */
  vf_mis light = vf_photon_mis(v, k);
  float w = vf_mis_weight_gather_camera(&light, prev->mis, &q->merge.mis, cos_camera, camera_pdf, camera_rev_pdf, dist,
                                        cos_light, light_rev_pdf, light_pdf);
  vf_vec3 value = vf_mul(vf_mul(vf_mul(v->photons[k].throughput, fl), fc), prev->throughput);
  value = vf_scale(value, w * cos_camera * cos_light / (dist2 * v->merge.mis.light_paths));
  if (vf_is_zero(value)) return zero;
  vf_vec3 nc = geometric_normal(&prev->bsdf);
  if (!visible(v, thread, prev->position, nc, y, normal_of_vertex(v, lv, &lb))) return zero;
  vf_upg_source src = {&prev->bsdf, NULL, zero};
  double inverse = inverse_acceptance(v, thread, &q->merge, &src, prev->position, nc, y, dist, rng);
  return vf_scale(value, (float)inverse);
}

/* Gathers light vertex k of the grid (within the radius of q) at camera vertex q, whose
 * predecessor is prev: its estimate, the camera sub-path's throughput included (the
 * camera's side joins at prev, whose throughput is not q's).
 *
 * Which side joins, decided by the path alone so that every path is estimated once: the
 * light's side can where the light vertex was reached by a non-specular choice from a
 * predecessor at a finite distance; the camera's side where q was reached by a
 * non-specular choice from a surface vertex (not the lens). A path both can take goes to
 * the side the settings prefer (vf_settings.gather; under auto the side whose joining
 * vertex scatters less sharply, vf_upg_sharpness), a path one can take to that one, and
 * a path neither can take is merged as vcm merges it (counted: biased). Specular choices
 * are told by d_vcm, which vf_mis_scatter zeroes for them and nothing else does. */
static vf_vec3 gather(vf_vcm *v, int thread, const vertex_merging_query *q, const gathering_prev *prev, uint32_t k,
                      vf_rng *rng) {
  uint32_t length_shape = v->merge_points[k].path_length_shape;
  int length = (int)(length_shape & ((1u << VERTEX_LENGTH_BITS) - 1u));
  if (length + q->path_length > v->settings.max_path_length) return vf_vec3_splat(0.0f);

  uint32_t name = v->photon_source[k];
  uint32_t c = name >> v->chunk_shift, i = name & ((1u << v->chunk_shift) - 1u);
  const light_vertex *list = v->chunks[c].vertices;
  const light_vertex *pred = NULL;
  const light_origin *origin = NULL;
  if (v->photons[k].d_vcm != 0.0f) {
    uint32_t path = path_of_vertex(v, c, i);
    if (length == 1) {
      if (v->origins[path].light >= 0) origin = &v->origins[path];
    } else if (i > v->path_begin[path] && vertex_path_length(&list[i - 1]) == length - 1) {
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
  if (camera_side && (!light_side || prefer_camera)) return gather_from_camera(v, thread, q, prev, k, &list[i], rng);
  if (light_side) return gather_from_light(v, thread, q, pred, &lb, origin, rng);
  return merge_as_vcm(v, thread, q, k);
}

vf_vec3 vf_gathering_estimate(vf_vcm *v, int thread, const vertex_merging_query *q, const gathering_prev *prev) {
  /* The gathering's own stream: (seed, iteration, camera sub-path, camera vertex). */
  vf_rng rng = vf_rng_for_path(v->settings.seed, v->iteration, q->pixel, VF_STREAM_GATHER | (uint32_t)q->path_length << 8);
  vf_index_range ranges[VF_HASHGRID_MAX_RANGES];
  int num_ranges = vf_hashgrid_candidates(v->grid, q->position, ranges);
  vf_vec3 sum = vf_vec3_splat(0.0f);
  for (int r = 0; r < num_ranges; r++)
    for (uint32_t k = ranges[r].begin; k < ranges[r].end; k++) {
      const merge_point *p = &v->merge_points[k];
      if (vf_vertex_merging_within(q->merge.radius_sq, p->x, p->y, p->z, q->position))
        sum = vf_add(sum, gather(v, thread, q, prev, k, &rng));
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
