/* Unbiased photon gathering: the estimator of 1/p_acc and its bounds (photon_gathering.h);
 * the renderer's use of it is gathering_pass.c. */
#include "photon_gathering.h"

#include "medium.h"
#include "sampling.h"

#include <float.h>
#include <math.h>

float vf_upg_density(const vf_upg_source *src, vf_vec3 dir) {
  if (src->bsdf == NULL) {
    float pdf, cos_light;
    return vf_light_emission_toward(src->light, src->light_normal, dir, &pdf, &cos_light) > 0.0f ? pdf : 0.0f;
  }
  float pdf = 0.0f;
  vf_vec3 f = vf_bsdf_evaluate(src->bsdf, dir, NULL, &pdf, NULL);
  return vf_is_zero(f) ? 0.0f : pdf;
}

float vf_upg_sharpness(const vf_upg_source *src) {
  if (src->bsdf == NULL) {
    const vf_light *l = src->light;
    return l->kind == VF_LIGHT_SPOT ? l->cone_pdf_w : l->kind == VF_LIGHT_POINT ? VF_UNIFORM_SPHERE_PDF_W : VF_INV_PI;
  }
  const vf_bsdf *b = src->bsdf;
  if (b->phase) { /* HG's peak, forwards for g >= 0, backwards for g < 0 */
    float g = fabsf(b->phase_g);
    return (1.0f + g) / (4.0f * VF_PI * (1.0f - g) * (1.0f - g));
  }
  const float *p = b->lobe_probability;
  float s = (p[VF_LOBE_DIFFUSE] + (b->rough ? p[VF_LOBE_BASE] : 0.0f)) * VF_INV_PI;
  if (p[VF_LOBE_GLOSSY] > 0.0f) s += p[VF_LOBE_GLOSSY] * (b->material->phong_exponent + 1.0f) * (0.5f * VF_INV_PI);
  if (b->rough) {
    float rough = p[VF_LOBE_ROUGH_CONDUCTOR] + p[VF_LOBE_ROUGH_DIELECTRIC];
    if (rough > 0.0f) s += rough / (4.0f * VF_PI * b->alpha * b->alpha * b->local_fix.z);
  }
  if (b->extended && b->layered) { /* the sheen, cosine-sampled; the rough coat as the GGX lobes, in its frame */
    s += p[VF_LOBE_SHEEN] * VF_INV_PI;
    if (p[VF_LOBE_ROUGH_COAT] > 0.0f && b->coat_fix.z > 0.0f)
      s += p[VF_LOBE_ROUGH_COAT] / (4.0f * VF_PI * b->coat_alpha * b->coat_alpha * b->coat_fix.z);
  }
  return s;
}

/* ---- bounds over a cone ------------------------------------------------------------------ */

/* The largest cosine between unit u and a direction of the cone (unit axis a, half-angle
 * with cosine ch and sine sh): cos(max(0, angle(a, u) - theta)). */
static float max_cos(vf_vec3 a, vf_vec3 u, float ch, float sh) {
  float ca = vf_dot(a, u);
  if (ca >= ch) return 1.0f;
  float sa = sqrtf(vf_fmaxf_zero(1.0f - ca * ca));
  return ca * ch + sa * sh;
}

/* The microfacet normals m = +-normalize(c + k w) of the directions w of the cone (unit
 * axis a, chord rho = |w - a| at most 2 sin(theta / 2)), turned above the surface: c + k w
 * lies in the ball of radius k rho around c + k a, so m lies within the angle `spread` of
 * that centre's direction `centre` (turned above the surface); spread is pi where the ball
 * holds the origin. */
typedef struct {
  vf_vec3 centre;
  float spread;
} normal_cone;

static normal_cone normals_of(vf_vec3 c, float k, vf_vec3 a, float rho) {
  vf_vec3 centre = vf_add(c, vf_scale(a, k));
  float len = vf_length(centre), r = k * rho;
  normal_cone n = {vf_vec3_make(0.0f, 0.0f, 1.0f), VF_PI};
  if (!(r < len)) return n;
  n.centre = vf_scale(centre, (centre.z < 0.0f ? -1.0f : 1.0f) / len);
  n.spread = asinf(r / len);
  return n;
}

/* The largest GGX D over the cone of normals: D falls with m's angle to the surface normal
 * (for alpha <= 1; it rises for alpha > 1). */
static float max_d(normal_cone n, float alpha) {
  if (alpha > 1.0f) return alpha * alpha * VF_INV_PI; /* D's largest value, at the horizon */
  float peak = 1.0f / (VF_PI * alpha * alpha);
  /* atan2 keeps the angle's precision near the normal, where acos of a cosine close to 1
   * does not: at alpha 0.0025 acos's rounding made the bound a few percent short. */
  float angle = atan2f(sqrtf(n.centre.x * n.centre.x + n.centre.y * n.centre.y), n.centre.z) - n.spread;
  if (!(angle > 0.0f)) return peak;
  if (angle >= 0.5f * VF_PI) return 0.0f;
  return vf_ggx_d(vf_vec3_make(sinf(angle), 0.0f, cosf(angle)), alpha, alpha);
}

/* The largest fix.m over the cone of normals, or 0 where none faces fix (refraction
 * needs fix.m > 0). Where the cone crosses the surface's plane, the normals turned above
 * it come from both sides: then only fix.m <= 1 is known. */
static float max_cos_normal(normal_cone n, vf_vec3 fix) {
  if (!(acosf(fminf(1.0f, n.centre.z)) + n.spread < 0.5f * VF_PI)) return 1.0f;
  return vf_fmaxf_zero(max_cos(n.centre, fix, cosf(n.spread), sinf(n.spread)));
}

/* The bound of a medium vertex's phase function times its continuation: HG of the cosine
 * between the direction of travel (-fix) and a direction of the cone, a monotonic function
 * of that cosine (rising for g >= 0, falling for g < 0), at its largest or its smallest
 * over the cone (the smallest being minus the largest cosine with fix). */
static float phase_bound(const vf_bsdf *b, vf_vec3 axis, float ch, float one_minus_ch) {
  float sh = sqrtf(vf_fmaxf_zero(one_minus_ch * (1.0f + ch)));
  vf_vec3 fix = b->geometric;
  float c = b->phase_g >= 0.0f ? max_cos(axis, vf_neg(fix), ch, sh) : -max_cos(axis, fix, ch, sh);
  return vf_hg(fminf(1.0f, fmaxf(-1.0f, c)), b->phase_g) * b->continuation;
}

/* The bound of a light vertex's BSDF: the sum of each non-delta lobe's bound, times the
 * continuation probability, in the BSDF's frame (the shading one where it has one; the
 * densities there are what vf_bsdf_evaluate returns, zero where the shading fold is). */
static float bsdf_bound(const vf_bsdf *b, vf_vec3 world_axis, float ch, float one_minus_ch) {
  if (b->phase) return phase_bound(b, world_axis, ch, one_minus_ch);
  const float *p = b->lobe_probability;
  vf_vec3 a = vf_frame_to_local(&b->frame, world_axis);
  float sh = sqrtf(vf_fmaxf_zero(one_minus_ch * (1.0f + ch)));
  float rho = sqrtf(2.0f * one_minus_ch);
  const vf_vec3 z = vf_vec3_make(0.0f, 0.0f, 1.0f), fix = b->local_fix;
  float bound = 0.0f;
  /* Every lobe but refraction reflects (gen.z > 0), refraction transmits (gen.z < 0): a
   * cone on one side of the surface needs the other side's lobes not at all. */
  /* (with a margin for max_cos's rounding: the GGX lobes do not vanish at the horizon) */
  int above = max_cos(a, z, ch, sh) > -1e-4f, below = max_cos(a, vf_neg(z), ch, sh) > -1e-4f;
  float cosine = p[VF_LOBE_DIFFUSE] + (b->rough ? p[VF_LOBE_BASE] : 0.0f) +
                 (b->extended && b->layered ? p[VF_LOBE_SHEEN] : 0.0f);
  if (above && cosine > 0.0f) bound += cosine * vf_fmaxf_zero(max_cos(a, z, ch, sh)) * VF_INV_PI;
  if (above && p[VF_LOBE_GLOSSY] > 0.0f) {
    float n = b->material->phong_exponent;
    float c = max_cos(a, vf_bsdf_reflect_local(fix), ch, sh);
    /* cos^n magnifies the roundings of c and of the density's own cosine n times. */
    if (c > 0.0f)
      bound += p[VF_LOBE_GLOSSY] * (n + 1.0f) * (0.5f * VF_INV_PI) * vf_phong_power(fminf(c, 1.0f), n) *
               (1.0f + 4.0f * n * FLT_EPSILON);
  }
  if (b->rough) {
    float pc = p[VF_LOBE_ROUGH_CONDUCTOR], pd = p[VF_LOBE_ROUGH_DIELECTRIC];
    float g1_fix = 1.0f / (1.0f + b->lambda_fix);
    if (above && pc + pd > 0.0f) /* reflection: G1(fix) D / (4 fix.z), Fresnel <= 1 (bsdf.c, reflect_rough) */
      bound += (pc + pd) * g1_fix * max_d(normals_of(fix, 1.0f, a, rho), b->alpha) / (4.0f * fix.z);
    if (below && pd > 0.0f) {
      /* Refraction: G1(fix) D ci / fix.z (1 - F) eta^2 |co| / |fix + eta gen|^2 with
       * |co|, 1 - F <= 1 and ci = fix.m at most its largest over the normals (bsdf.c,
       * refract_rough); |fix + eta gen| >= |1 - eta| always, and >= |fix + eta a| - eta rho
       * over the cone. */
      float eta = b->eta;
      float len = fmaxf(vf_length(vf_add(fix, vf_scale(a, eta))) - eta * rho, fabsf(1.0f - eta));
      if (!(len > 0.0f)) return INFINITY;
      normal_cone n = normals_of(fix, eta, a, rho);
      bound += pd * g1_fix * max_d(n, b->alpha) * max_cos_normal(n, fix) / fix.z * eta * eta / (len * len);
    }
  }
  if (b->extended && b->layered && p[VF_LOBE_ROUGH_COAT] > 0.0f && b->coat_fix.z > 0.0f) {
    /* The rough coat in its own frame: G1(fix) D / (4 fix.z) there, for the directions above
     * its surface (bsdf.c, layered_evaluate). */
    vf_vec3 ac = vf_frame_to_local(&b->coat_frame, world_axis), fix_c = b->coat_fix;
    if (max_cos(ac, z, ch, sh) > -1e-4f)
      bound += p[VF_LOBE_ROUGH_COAT] / (1.0f + b->coat_lambda_fix) *
               max_d(normals_of(fix_c, 1.0f, ac, rho), b->coat_alpha) / (4.0f * fix_c.z);
  }
  return bound * b->continuation;
}

/* Every bound is widened by this factor: a direction drawn in the cone lies outside it by
 * a rounding error at times, and its density may then exceed the exact bound by a few
 * units in the last place. A wider bound is as exact, and costs only pdf evaluations. */
#define BOUND_SLACK 1.001f

static float source_bound(const vf_upg_source *src, vf_vec3 axis, float cos_half, float one_minus_cos_half);

float vf_upg_bound(const vf_upg_source *src, vf_vec3 axis, float cos_half, float one_minus_cos_half) {
  return BOUND_SLACK * source_bound(src, axis, cos_half, one_minus_cos_half);
}

static float source_bound(const vf_upg_source *src, vf_vec3 axis, float cos_half, float one_minus_cos_half) {
  if (src->bsdf != NULL) return bsdf_bound(src->bsdf, axis, cos_half, one_minus_cos_half);
  const vf_light *l = src->light;
  switch (l->kind) {
  case VF_LIGHT_AREA_MESH:
  case VF_LIGHT_AREA_SPHERE: {
    float sh = sqrtf(vf_fmaxf_zero(one_minus_cos_half * (1.0f + cos_half)));
    return vf_fmaxf_zero(max_cos(axis, src->light_normal, cos_half, sh)) * VF_INV_PI;
  }
  case VF_LIGHT_POINT: return VF_UNIFORM_SPHERE_PDF_W;
  case VF_LIGHT_SPOT: return l->cone_pdf_w;
  default: return INFINITY;
  }
}

float vf_upg_cone(vf_vec3 from, vf_vec3 to, float r, vf_vec3 *axis, float *cos_half, float *one_minus_cos_half) {
  vf_vec3 d = vf_sub(to, from);
  float dist = vf_length(d);
  *axis = dist > 0.0f ? vf_scale(d, 1.0f / dist) : vf_vec3_make(0.0f, 0.0f, 1.0f);
  if (!(dist > r)) {
    *cos_half = -1.0f;
    *one_minus_cos_half = 2.0f;
    return dist;
  }
  float s = r / dist, c = sqrtf(vf_fmaxf_zero(1.0f - s * s));
  *cos_half = c;
  *one_minus_cos_half = s * s / (1.0f + c); /* 1 - sqrt(1 - s^2), without cancellation */
  return dist;
}

/* A direction uniform in the cone around unit axis (frame f) of 1 - cos(half-angle) omc. */
static vf_vec3 cone_direction(const vf_frame *f, float omc, float u1, float u2) {
  float one_minus_cos = u1 * omc, cos_t = 1.0f - one_minus_cos;
  float sin_t = sqrtf(vf_fmaxf_zero(one_minus_cos * (2.0f - one_minus_cos))), phi = 2.0f * VF_PI * u2;
  return vf_frame_to_world(f, vf_vec3_make(sin_t * cosf(phi), sin_t * sinf(phi), cos_t));
}

/* One trial's direction: 1 when it is to be traced (into *dir), 0 when the trial failed
 * without a ray. */
typedef int (*trial_draw)(const void *ctx, vf_rng *rng, vf_vec3 *dir, vf_upg_counts *counts);

/* Trials of `draw` until one lands, or VF_UPG_MAX_TRIALS of them (counted as truncated):
 * their number N. Adds the gathering, its trials and its rays to *counts. */
static uint64_t trials_until_landing(trial_draw draw, const void *draw_ctx, vf_rng *rng, vf_upg_lands lands,
                                     void *ctx, vf_upg_counts *counts) {
  uint64_t n = 0, rays = 0;
  for (;;) {
    if (n == VF_UPG_MAX_TRIALS) {
      counts->truncated++;
      break;
    }
    n++;
    vf_vec3 dir;
    if (!draw(draw_ctx, rng, &dir, counts)) continue;
    rays++;
    if (lands(ctx, dir)) break;
  }
  counts->gatherings++;
  counts->trials += n;
  counts->rays += rays;
  return n;
}

/* A trial of the cone: a direction uniform in it, accepted with probability density / bound. */
typedef struct {
  const vf_upg_source *src;
  vf_frame frame; /* around the cone's axis */
  float one_minus_cos_half, bound;
} cone_trial;

static int draw_in_cone(const void *ctx, vf_rng *rng, vf_vec3 *dir, vf_upg_counts *counts) {
  const cone_trial *t = ctx;
  float u1 = vf_rng_float(rng), u2 = vf_rng_float(rng), u3 = vf_rng_float(rng);
  *dir = cone_direction(&t->frame, t->one_minus_cos_half, u1, u2);
  float pdf = vf_upg_density(t->src, *dir);
  if (pdf > t->bound) counts->bound_exceeded++;
  return u3 * t->bound < pdf;
}

double vf_upg_inverse_acceptance(const vf_upg_source *src, vf_vec3 axis, float cos_half, float one_minus_cos_half,
                                 float bound, vf_rng *rng, vf_upg_lands lands, void *ctx, vf_upg_counts *counts) {
  (void)cos_half;
  cone_trial t = {src, vf_frame_from_normal(axis), one_minus_cos_half, bound};
  uint64_t n = trials_until_landing(draw_in_cone, &t, rng, lands, ctx, counts);
  double solid_angle = 2.0 * M_PI * (double)one_minus_cos_half;
  return (double)n / (solid_angle * (double)bound);
}

/* A trial of the sub-path's own continuation: vf_wavefront_scatter's walk (roulette, then
 * lobe and direction), failing where it ends, is specular or leaves the cone. */
typedef struct {
  const vf_bsdf *bsdf;
  vf_vec3 axis;
  float cos_half;
} own_trial;

static int draw_own(const void *ctx, vf_rng *rng, vf_vec3 *dir, vf_upg_counts *counts) {
  (void)counts;
  const own_trial *t = ctx;
  float roulette = vf_rng_float(rng);
  float rnd[3] = {vf_rng_float(rng), vf_rng_float(rng), vf_rng_float(rng)};
  if (roulette >= t->bsdf->continuation) return 0;
  float pdf, rev_pdf, cos_gen;
  unsigned event;
  vf_vec3 f = vf_bsdf_sample(t->bsdf, rnd, dir, &pdf, &rev_pdf, &cos_gen, &event);
  if (vf_is_zero(f) || !(pdf > 0.0f) || (event & VF_BSDF_SPECULAR)) return 0;
  return vf_dot(*dir, t->axis) >= t->cos_half;
}

double vf_upg_inverse_acceptance_draws(const vf_bsdf *b, vf_vec3 axis, float cos_half, vf_rng *rng,
                                       vf_upg_lands lands, void *ctx, vf_upg_counts *counts) {
  own_trial t = {b, axis, cos_half};
  return (double)trials_until_landing(draw_own, &t, rng, lands, ctx, counts);
}
