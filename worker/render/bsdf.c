#include "bsdf.h"
#include "medium.h"

#include "microfacet.h"
#include "sampling.h"
#include "sheen.h"

#include <math.h>
#include <stddef.h>

static float mean3(vf_vec3 c) { return (c.x + c.y + c.z) * (1.0f / 3.0f); }

float vf_fresnel_dielectric(float cos_i, float eta) {
  if (eta == 1.0f) return 0.0f;
  /* In double: 1 - sin_t^2 cancels badly both for an index near 1 at grazing angles and
   * near the critical angle, and this runs once per dielectric vertex, not per sample. */
  double e = eta, ci = cos_i;
  if (ci < 0.0) {
    e = 1.0 / e;
    ci = -ci;
  }
  double sin_t2 = (1.0 - ci * ci) / (e * e);
  if (sin_t2 >= 1.0) return 1.0f; /* total internal reflection */
  double ct = sqrt(1.0 - sin_t2);
  double rs = (ci - e * ct) / (ci + e * ct);
  double rp = (e * ci - ct) / (e * ci + ct);
  return (float)(0.5 * (rs * rs + rp * rp));
}

/* ---- per material ---------------------------------------------------------------------- */

static int is_rough(float roughness) { return vf_ggx_alpha(roughness) >= VF_GGX_ALPHA_DELTA; }

/* The glTF model's dielectric layer: Schlick's Fresnel from F0_d at normal incidence to
 * F90_d at grazing incidence, F0_d = 0.04 and F90_d = 1 by the core specification, or with
 * KHR_materials_specular (and KHR_materials_ior) F0_d = min(((ior - 1) / (ior + 1))^2
 * specularColor, 1) specular and F90_d = specular [KHR_materials_specular, "Implementation"]. */
static void gltf_dielectric(const vf_material *m, vf_vec3 *f0, float *f90) {
  if (!m->specular_set) {
    *f0 = vf_vec3_splat(VF_GLTF_DIELECTRIC_F0);
    *f90 = 1.0f;
    return;
  }
  vf_vec3 c = m->specular_f0;
  *f0 = vf_scale(vf_vec3_make(fminf(c.x, 1.0f), fminf(c.y, 1.0f), fminf(c.z, 1.0f)), m->specular);
  *f90 = m->specular;
}

/* The specular layer's F0 and F90 in the glTF model: the metal's (base_color, 1) and the
 * dielectric's mixed by metallic [glTF, B.3.5: the metal and dielectric BRDFs' specular
 * layers, mixed by metallic, are one layer, Schlick's Fresnel being linear in F0 and F90]. */
static vf_vec3 gltf_f0(const vf_material *m, float *f90) {
  vf_vec3 f0;
  float d90;
  gltf_dielectric(m, &f0, &d90);
  *f90 = d90 + (1.0f - d90) * m->metallic;
  return vf_add(f0, vf_scale(vf_sub(m->base_color, f0), m->metallic));
}

/* Schlick's F0 + (F90 - F0) (1 - c)^5 and its cosine-weighted hemispherical average
 * F0 + (F90 - F0) / 21. */
static vf_vec3 schlick_f90(vf_vec3 f0, float f90, float c) {
  return vf_add(f0, vf_scale(vf_sub(vf_vec3_splat(f90), f0), vf_fresnel_schlick_weight(c)));
}
static vf_vec3 schlick_f90_average(vf_vec3 f0, float f90) {
  return vf_add(f0, vf_scale(vf_sub(vf_vec3_splat(f90), f0), 1.0f / 21.0f));
}

static int fresnel_model_of(const vf_material *m) {
  if (m->gltf) return VF_FRESNEL_SCHLICK;
  return vf_is_zero(m->conductor_eta) && vf_is_zero(m->conductor_k) ? VF_FRESNEL_ONE : VF_FRESNEL_COMPLEX;
}

void vf_bsdf_lobes_of(const vf_material *m, vf_bsdf_lobes *lobes) {
  /* The conductor's albedo for lobe selection and Russian roulette: its weight times the
   * hemispherical average of its Fresnel reflectance; the glTF base's: its weight times the
   * average of 1 - F of the glTF dielectric. */
  vf_vec3 conductor = vf_vec3_splat(0.0f), base = vf_vec3_splat(0.0f);
  lobes->fresnel_model = fresnel_model_of(m);
  if (m->gltf) {
    float f90, d90;
    vf_vec3 f0 = gltf_f0(m, &f90), d0;
    conductor = schlick_f90_average(f0, f90);
    /* The base under 1 - max_rgb(F_d); F_d's largest channel is d0's largest at every angle
     * (F90_d >= F0_d). */
    gltf_dielectric(m, &d0, &d90);
    float coat = 1.0f - schlick_f90_average(vf_vec3_splat(vf_max_component(d0)), d90).x;
    base = vf_scale(m->base_color, (1.0f - m->metallic) * coat);
  } else if (lobes->fresnel_model == VF_FRESNEL_COMPLEX) {
    conductor = vf_mul(m->conductor, vf_fresnel_conductor_average(m->conductor_eta, m->conductor_k));
  } else {
    conductor = m->conductor;
  }
  /* The layers: the sheen's albedo averaged over cosine-distributed directions, the coat's
   * weight times its Fresnel's average (bsdf.h). */
  vf_vec3 sheen = vf_vec3_splat(0.0f), coat = vf_vec3_splat(0.0f);
  lobes->layered = m->gltf && (m->clearcoat > 0.0f || !vf_is_zero(m->sheen_color));
  if (lobes->layered) {
    if (!vf_is_zero(m->sheen_color)) sheen = vf_scale(m->sheen_color, vf_sheen_albedo_average(m->sheen_roughness));
    if (m->clearcoat > 0.0f)
      coat = vf_vec3_splat(m->clearcoat * schlick_f90_average(vf_vec3_splat(VF_GLTF_DIELECTRIC_F0), 1.0f).x);
  }
  int rough = is_rough(m->roughness);
  /* An index-matched dielectric only transmits straight on, whatever its roughness. */
  int rough_dielectric = rough && m->ior != 1.0f;
  float albedo[VF_LOBE_COUNT] = {mean3(m->diffuse), mean3(m->glossy), mean3(m->mirror), 0.0f, 0.0f, 0.0f, 0.0f,
                                 mean3(base)};
  albedo[rough_dielectric ? VF_LOBE_ROUGH_DIELECTRIC : VF_LOBE_DIELECTRIC] = mean3(m->dielectric);
  albedo[rough ? VF_LOBE_ROUGH_CONDUCTOR : VF_LOBE_CONDUCTOR] = mean3(conductor);
  albedo[VF_LOBE_SHEEN] = mean3(sheen);
  albedo[is_rough(m->clearcoat_roughness) ? VF_LOBE_ROUGH_COAT : VF_LOBE_COAT] = mean3(coat);
  /* Summed in the order of the original four lobes first: with the others zero, a material
   * of those four gets its probabilities and continuation bit for bit as before. */
  float total = albedo[0] + albedo[1] + albedo[2] + albedo[3];
  for (int i = VF_LOBE_CONDUCTOR; i < VF_LOBE_COUNT; i++) total += albedo[i];
  lobes->black = !(total > 0.0f);
  for (int i = 0; i < VF_LOBE_COUNT; i++) lobes->lobe_probability[i] = lobes->black ? 0.0f : albedo[i] / total;
  vf_vec3 sum = vf_add(vf_add(m->diffuse, m->glossy), vf_add(m->mirror, m->dielectric));
  sum = vf_add(sum, vf_add(conductor, base));
  if (lobes->layered) sum = vf_add(sum, vf_add(sheen, coat));
  lobes->continuation = fminf(1.0f, vf_max_component(sum));
  const float *p = lobes->lobe_probability;
  lobes->rough = p[VF_LOBE_ROUGH_CONDUCTOR] > 0.0f || p[VF_LOBE_ROUGH_DIELECTRIC] > 0.0f || p[VF_LOBE_BASE] > 0.0f;
  lobes->layered = lobes->layered && !lobes->black;
  lobes->extended = lobes->rough || p[VF_LOBE_CONDUCTOR] > 0.0f || lobes->layered;
  lobes->is_delta = p[VF_LOBE_DIFFUSE] == 0.0f && p[VF_LOBE_GLOSSY] == 0.0f && !lobes->rough &&
                    p[VF_LOBE_SHEEN] == 0.0f && p[VF_LOBE_ROUGH_COAT] == 0.0f;
  lobes->alpha = vf_ggx_alpha(m->roughness);
}

unsigned vf_material_kinds(const vf_material *m) {
  vf_bsdf_lobes l;
  vf_bsdf_lobes_of(m, &l);
  const float *p = l.lobe_probability;
  unsigned kinds = 0;
  if (p[VF_LOBE_MIRROR] > 0.0f || p[VF_LOBE_DIELECTRIC] > 0.0f || p[VF_LOBE_CONDUCTOR] > 0.0f ||
      p[VF_LOBE_COAT] > 0.0f)
    kinds |= VF_KIND_SPECULAR;
  if (p[VF_LOBE_GLOSSY] > 0.0f || p[VF_LOBE_ROUGH_CONDUCTOR] > 0.0f || p[VF_LOBE_ROUGH_DIELECTRIC] > 0.0f ||
      p[VF_LOBE_SHEEN] > 0.0f || p[VF_LOBE_ROUGH_COAT] > 0.0f)
    kinds |= VF_KIND_GLOSSY;
  if (p[VF_LOBE_DIFFUSE] > 0.0f || p[VF_LOBE_BASE] > 0.0f) kinds |= VF_KIND_DIFFUSE;
  return kinds;
}

int vf_bsdf_init(vf_bsdf *b, const vf_material *m, vf_vec3 normal, vf_vec3 world_fix) {
  vf_bsdf_lobes lobes;
  vf_bsdf_lobes_of(m, &lobes);
  return vf_bsdf_setup(b, m, &lobes, normal, world_fix);
}

/* ---- the rough lobes ------------------------------------------------------------------- *
 * Local directions: fix (z > 0) and gen; m the microfacet normal (z > 0). Sources as in
 * worker/render/microfacet.h. Every lobe's density is its sampler's: the visible normals of fix
 * (Heitz18 eq. 1) mapped to gen by the Jacobian of reflection or refraction. */

/* f and the two densities (without the continuation probability) being summed. */
typedef struct {
  vf_vec3 f;
  float direct_pdf_w, reverse_pdf_w;
} lobe_value;

static vf_vec3 conductor_reflectance(const vf_bsdf *b, float c) {
  const vf_material *m = b->material;
  switch (b->fresnel_model) {
  case VF_FRESNEL_SCHLICK: return schlick_f90(b->f0, b->f90, c);
  case VF_FRESNEL_COMPLEX: return vf_mul(m->conductor, vf_fresnel_conductor(c, m->conductor_eta, m->conductor_k));
  default: return m->conductor;
  }
}

/* Reflection off microfacet m = normalize(fix + gen) [Walter07 eq. 13], both above the
 * surface. Conductor and dielectric reflection share D G2 / (4 cos_fix cos_gen)
 * [Walter07 eq. 20] with the height-correlated Smith G2 = 1 / (1 + Lambda(fix) +
 * Lambda(gen)) [Heitz14, sec. 6]; the density of reflecting into gen is
 * G1(fix) D / (4 cos_fix), the visible normals times the Jacobian 1 / (4 fix.m)
 * [Walter07 eq. 14], and the reverse one the same seen from gen. The glTF base is
 * (1 - max_rgb F_d(fix.m)) (1 - metallic) base_color / pi, cosine-sampled [glTF, B.3.5;
 * KHR_materials_specular: dielectric_brdf = F_d specular + (1 - max_rgb F_d) diffuse]. */
static void reflect_rough(const vf_bsdf *b, vf_vec3 gen, lobe_value *v) {
  const vf_material *mat = b->material;
  const float *p = b->lobe_probability;
  const vf_vec3 fix = b->local_fix;
  vf_vec3 m = vf_normalize(vf_add(fix, gen));
  float c = vf_dot(fix, m);
  if (p[VF_LOBE_ROUGH_CONDUCTOR] > 0.0f || p[VF_LOBE_ROUGH_DIELECTRIC] > 0.0f) {
    float a = b->alpha, d = vf_ggx_d(m, a, a);
    float lambda_gen = vf_ggx_lambda(gen, a, a);
    float shared = d / (4.0f * fix.z * gen.z * (1.0f + b->lambda_fix + lambda_gen));
    float direct = d / (4.0f * fix.z * (1.0f + b->lambda_fix)), reverse = d / (4.0f * gen.z * (1.0f + lambda_gen));
    float pc = p[VF_LOBE_ROUGH_CONDUCTOR];
    if (pc > 0.0f) {
      v->f = vf_add(v->f, vf_scale(conductor_reflectance(b, c), shared));
      v->direct_pdf_w += pc * direct;
      v->reverse_pdf_w += pc * reverse;
    }
    float pd = p[VF_LOBE_ROUGH_DIELECTRIC];
    if (pd > 0.0f) {
      float fr = vf_fresnel_dielectric(c, b->eta); /* the microfacet's, from either side */
      v->f = vf_add(v->f, vf_scale(mat->dielectric, fr * shared));
      v->direct_pdf_w += pd * fr * direct;
      v->reverse_pdf_w += pd * fr * reverse;
    }
  }
  float pb = p[VF_LOBE_BASE];
  if (pb > 0.0f) {
    float coat = 1.0f - b->dielectric_f0_max - (b->dielectric_f90 - b->dielectric_f0_max) * vf_fresnel_schlick_weight(c);
    v->f = vf_add(v->f, vf_scale(b->base, coat * VF_INV_PI));
    v->direct_pdf_w += pb * gen.z * VF_INV_PI;
    v->reverse_pdf_w += pb * fix.z * VF_INV_PI;
  }
}

/* Refraction through microfacet m, the generalised half vector normalize(fix + eta gen)
 * turned above the surface [Walter07 eq. 16], fix and gen on opposite sides of m. With
 * ci = fix.m > 0, co = gen.m < 0 and denom = ci + eta co, the radiance BTDF is
 * tint (1 - F(ci)) D G ci |co| / (cos_fix |cos_gen| denom^2) [Walter07 eq. 21 with eta_fix
 * = 1, eta_gen = eta], G the separable Smith G1(fix) G1(gen) [Walter07 eq. 23: the
 * height-correlated form of reflection does not hold across the surface, Heitz14 sec. 6],
 * and a light sub-path's f is eta^2 times it (see bsdf.h). The density of refracting into
 * gen is the visible normals times (1 - F) times the Jacobian eta^2 |co| / denom^2
 * [Walter07 eq. 17]; the reverse one, from gen's side with 1 / eta, works out to
 * G1(gen) D |co| / |cos_gen| (1 - F) ci / denom^2 (Fresnel is the same from both sides of
 * a refraction). */
static void refract_rough(const vf_bsdf *b, vf_vec3 gen, int radiance, lobe_value *v) {
  const float eta = b->eta, a = b->alpha;
  const vf_vec3 fix = b->local_fix;
  vf_vec3 m = vf_add(fix, vf_scale(gen, eta));
  float len = vf_length(m);
  if (!(len > 0.0f)) return;
  m = vf_scale(m, (m.z < 0.0f ? -1.0f : 1.0f) / len);
  float ci = vf_dot(fix, m), co = vf_dot(gen, m);
  if (!(ci > 0.0f) || !(co < 0.0f)) return;
  float transmitted = 1.0f - vf_fresnel_dielectric(ci, eta);
  float denom = ci + eta * co;
  if (!(transmitted > 0.0f) || denom == 0.0f) return;
  float d = vf_ggx_d(m, a, a), denom2 = denom * denom;
  float g1_fix = 1.0f / (1.0f + b->lambda_fix), g1_gen = vf_ggx_g1(gen, a, a);
  float btdf = transmitted * d * g1_fix * g1_gen * ci * -co / (fix.z * -gen.z * denom2);
  float pd = b->lobe_probability[VF_LOBE_ROUGH_DIELECTRIC];
  v->f = vf_add(v->f, vf_scale(b->material->dielectric, radiance ? btdf : btdf * eta * eta));
  v->direct_pdf_w += pd * g1_fix * d * ci / fix.z * transmitted * eta * eta * -co / denom2;
  v->reverse_pdf_w += pd * g1_gen * d * -co / -gen.z * transmitted * ci / denom2;
}

/* ---- the layers (bsdf.h, the top): set-up ------------------------------------------------ */

/* Schlick's Fresnel of the coat, F0 0.04 (ior 1.5) to F90 1 [KHR_materials_clearcoat, "Layering"]. */
static float coat_fresnel(float c) {
  return VF_GLTF_DIELECTRIC_F0 + (1.0f - VF_GLTF_DIELECTRIC_F0) * vf_fresnel_schlick_weight(c);
}

/* What of the coat depends on fix in its frame. */
static void coat_fix_terms(vf_bsdf *b) {
  b->coat_lambda_fix = vf_ggx_lambda(b->coat_fix, b->coat_alpha, b->coat_alpha);
  b->coat_fix_transmit = 1.0f - b->coat_weight * coat_fresnel(fabsf(b->coat_fix.z));
}

/* From the material set up with (a textured copy, perhaps), as vf_bsdf_setup_extended reads
 * the glTF model's values: the coat in the shading frame until vf_bsdf_set_coat_normal. */
static void layers_setup(vf_bsdf *b) {
  const vf_material *m = b->material;
  const float *p = b->lobe_probability;
  b->coat_weight = p[VF_LOBE_ROUGH_COAT] > 0.0f || p[VF_LOBE_COAT] > 0.0f ? m->clearcoat : 0.0f;
  b->coat_alpha = vf_ggx_alpha(m->clearcoat_roughness);
  b->coat_frame = b->frame;
  b->coat_fix = b->local_fix;
  b->coat_fix_ratio = 1.0f; /* vf_bsdf_setup_shading sets its own */
  coat_fix_terms(b);
  b->sheen_color = m->sheen_color;
  b->sheen_roughness = m->sheen_roughness;
  b->sheen_alpha = vf_sheen_alpha(m->sheen_roughness);
  b->sheen_max = p[VF_LOBE_SHEEN] > 0.0f ? vf_max_component(m->sheen_color) : 0.0f;
  b->sheen_fix_albedo = b->sheen_max > 0.0f ? vf_sheen_albedo(b->local_fix.z, b->sheen_roughness) : 0.0f;
  b->sheen_fix_scale = 1.0f - b->sheen_max * fminf(b->sheen_fix_albedo, 1.0f);
}

void vf_bsdf_set_coat_normal(vf_bsdf *b, vf_vec3 coat_normal, vf_vec3 world_fix) {
  if (!b->layered || !b->shading || b->phase) return;
  vf_vec3 n = vf_dot(coat_normal, b->geometric) < 0.0f ? vf_neg(coat_normal) : coat_normal;
  b->coat_frame = vf_frame_from_normal(n);
  b->coat_fix = vf_frame_to_local(&b->coat_frame, world_fix);
  b->coat_fix_ratio = fabsf(b->coat_fix.z) / fabsf(vf_dot(b->geometric, world_fix));
  coat_fix_terms(b);
}

void vf_bsdf_setup_extended(vf_bsdf *b, const vf_bsdf_lobes *lobes, int entering) {
  b->radiance = 0;
  b->rough = lobes->rough;
  b->fresnel_model = lobes->fresnel_model;
  b->alpha = lobes->alpha;
  b->lambda_fix = vf_ggx_lambda(b->local_fix, lobes->alpha, lobes->alpha);
  if (b->material->gltf) { /* from the material set up with, which may be a textured copy */
    vf_vec3 d0;
    b->f0 = gltf_f0(b->material, &b->f90);
    gltf_dielectric(b->material, &d0, &b->dielectric_f90);
    b->dielectric_f0_max = vf_max_component(d0);
    b->base = vf_scale(b->material->base_color, 1.0f - b->material->metallic);
  }
  if (lobes->lobe_probability[VF_LOBE_ROUGH_DIELECTRIC] > 0.0f)
    b->eta = entering ? b->material->ior : 1.0f / b->material->ior;
  b->layered = lobes->layered;
  if (b->layered) layers_setup(b);
}

/* f and densities of the rough lobes for local gen (without the continuation probability). */
static void rough_lobes(const vf_bsdf *b, vf_vec3 gen, int radiance, lobe_value *v) {
  if (gen.z > 0.0f) reflect_rough(b, gen, v);
  else if (gen.z < 0.0f && b->lobe_probability[VF_LOBE_ROUGH_DIELECTRIC] > 0.0f) refract_rough(b, gen, radiance, v);
}

/* ---- shading normals (vf_bsdf_setup_shading) ------------------------------------------ */

int vf_bsdf_setup_shading(vf_bsdf *b, const vf_material *m, const vf_bsdf_lobes *lobes, vf_vec3 geometric,
                          vf_vec3 shading, vf_vec3 world_fix) {
  float cos_fix = vf_dot(geometric, world_fix);
  if (!(fabsf(cos_fix) > 1e-7f) || lobes->black) return 0;
  int entering = cos_fix > 0.0f;
  vf_vec3 ng = entering ? geometric : vf_neg(geometric);
  /* A shading normal on the back of the surface (a file's normals against its winding)
   * is taken as pointing to the front. */
  vf_vec3 ns = vf_dot(shading, geometric) < 0.0f ? vf_neg(shading) : shading;
  if (!entering) ns = vf_neg(ns);
  float cos_fix_shading = vf_dot(ns, world_fix);
  if (!(cos_fix_shading > 1e-7f)) return 0;
  b->material = m;
  b->frame = vf_frame_from_normal(ns);
  b->local_fix = vf_frame_to_local(&b->frame, world_fix);
  if (!(b->local_fix.z > 0.0f)) return 0;
  b->eta = 1.0f;
  b->fresnel = 0.0f;
  b->diffuse = m->diffuse;
  if (lobes->lobe_probability[VF_LOBE_DIELECTRIC] > 0.0f) {
    b->eta = entering ? m->ior : 1.0f / m->ior;
    b->fresnel = vf_fresnel_dielectric(b->local_fix.z, b->eta);
  }
  memcpy(b->lobe_probability, lobes->lobe_probability, sizeof b->lobe_probability);
  b->continuation = lobes->continuation;
  b->is_delta = lobes->is_delta;
  b->radiance = 0;
  b->rough = 0;
  b->phase = 0;
  b->layered = 0;
  b->fresnel_model = lobes->fresnel_model;
  if (lobes->extended) vf_bsdf_setup_extended(b, lobes, entering);
  b->extended = 1; /* evaluate and sample go through bsdf.c, which applies the shading */
  b->shading = 1;
  b->geometric = ng;
  b->fix_ratio = b->local_fix.z / fabsf(cos_fix);
  b->coat_fix_ratio = b->fix_ratio;
  return 1;
}

/* The factor that folds the shading cosines into f (vf_bsdf_setup_shading): for local gen
 * whose cosine with the geometric normal is cos_geometric; zero where gen lies on
 * different sides of the two surfaces. */
static float shading_fold(const vf_bsdf *b, vf_vec3 gen, float cos_geometric) {
  if (!(cos_geometric > 0.0f ? gen.z > 0.0f : cos_geometric < 0.0f && gen.z < 0.0f)) return 0.0f;
  return b->radiance ? fabsf(gen.z) / fabsf(cos_geometric) : b->fix_ratio;
}

/* f and densities of the lobes (not the deltas) for local gen. */
static lobe_value evaluate_local(const vf_bsdf *b, vf_vec3 gen, int radiance) {
  lobe_value v = {vf_vec3_splat(0.0f), 0.0f, 0.0f};
  vf_bsdf_smooth_lobes(b, gen, &v.f, &v.direct_pdf_w, &v.reverse_pdf_w);
  if (b->rough) rough_lobes(b, gen, radiance, &v);
  return v;
}

/* ---- the layers (bsdf.h, the top): evaluation and sampling --------------------------------- */

static vf_vec3 sample_rough(const vf_bsdf *b, float u, float u1, float u2, unsigned *event);

/* The sheen's albedo E for the base's cos of gen (0 without a sheen), and S for it. */
static float sheen_albedo_gen(const vf_bsdf *b, float cos_gen) {
  return b->sheen_max > 0.0f ? vf_sheen_albedo(fabsf(cos_gen), b->sheen_roughness) : 0.0f;
}
static float sheen_scaling(const vf_bsdf *b, float albedo_gen) {
  return fminf(b->sheen_fix_scale, 1.0f - b->sheen_max * fminf(albedo_gen, 1.0f));
}

/* T of the coat for the coat's cos of gen (1 without a coat). */
static float coat_transmit(const vf_bsdf *b, float cos_gen) {
  if (!(b->coat_weight > 0.0f)) return 1.0f;
  return b->coat_fix_transmit * (1.0f - b->coat_weight * coat_fresnel(fabsf(cos_gen)));
}

/* The coat's fold, as shading_fold for its frame (a reflection only): local gen in the coat's
 * frame, gen's cos with the geometric normal. */
static float coat_fold(const vf_bsdf *b, vf_vec3 gen, float cos_geometric) {
  if (!b->shading) return 1.0f;
  if (!(gen.z > 0.0f && cos_geometric > 0.0f)) return 0.0f;
  return b->radiance ? gen.z / cos_geometric : b->coat_fix_ratio;
}

/* f (folded) and the densities (without the continuation probability) of a layered BSDF for
 * world gen; *cos_gen its |cos| with the geometric normal. The densities are the sum of every
 * non-delta lobe's, or zero where f is: sampling fails there, whichever lobe drew gen. */
static lobe_value layered_evaluate(const vf_bsdf *b, vf_vec3 world_gen, int radiance, float *cos_gen) {
  const float *p = b->lobe_probability;
  vf_vec3 gen = vf_frame_to_local(&b->frame, world_gen);
  float cos_geometric = b->shading ? vf_dot(b->geometric, world_gen) : gen.z;
  *cos_gen = fabsf(cos_geometric);
  /* the glTF model scaled by S, and the sheen, in the base's frame */
  lobe_value v = evaluate_local(b, gen, radiance);
  float albedo_gen = sheen_albedo_gen(b, gen.z);
  vf_vec3 f = vf_scale(v.f, sheen_scaling(b, albedo_gen));
  const vf_vec3 fix = b->local_fix;
  if (p[VF_LOBE_SHEEN] > 0.0f && gen.z > 0.0f) {
    vf_vec3 h = vf_normalize(vf_add(fix, gen));
    float sheen = vf_sheen_brdf(fix.z, gen.z, h.z, b->sheen_alpha) /
                  fmaxf(1.0f, fmaxf(b->sheen_fix_albedo, albedo_gen));
    f = vf_add(f, vf_scale(b->sheen_color, sheen));
    v.direct_pdf_w += p[VF_LOBE_SHEEN] * gen.z * VF_INV_PI;
    v.reverse_pdf_w += p[VF_LOBE_SHEEN] * fix.z * VF_INV_PI;
  }
  float fold = b->shading ? shading_fold(b, gen, cos_geometric) : 1.0f;
  vf_vec3 gen_c = b->coat_weight > 0.0f ? vf_frame_to_local(&b->coat_frame, world_gen) : gen;
  f = vf_scale(f, coat_transmit(b, gen_c.z) * fold);
  /* the rough coat in its frame: f_ggx as reflect_rough's, Fresnel at the microfacet */
  const vf_vec3 fix_c = b->coat_fix;
  if (p[VF_LOBE_ROUGH_COAT] > 0.0f && fix_c.z > 0.0f && gen_c.z > 0.0f) {
    float a = b->coat_alpha;
    vf_vec3 m = vf_normalize(vf_add(fix_c, gen_c));
    float d = vf_ggx_d(m, a, a), lambda_gen = vf_ggx_lambda(gen_c, a, a);
    float brdf = d / (4.0f * fix_c.z * gen_c.z * (1.0f + b->coat_lambda_fix + lambda_gen));
    float weight = b->coat_weight * coat_fresnel(vf_dot(fix_c, m));
    f = vf_add(f, vf_vec3_splat(weight * brdf * coat_fold(b, gen_c, cos_geometric)));
    v.direct_pdf_w += p[VF_LOBE_ROUGH_COAT] * d / (4.0f * fix_c.z * (1.0f + b->coat_lambda_fix));
    v.reverse_pdf_w += p[VF_LOBE_ROUGH_COAT] * d / (4.0f * gen_c.z * (1.0f + lambda_gen));
  }
  v.f = f;
  if (vf_is_zero(f)) v.direct_pdf_w = v.reverse_pdf_w = 0.0f;
  return v;
}

/* vf_bsdf_sample of a layered BSDF: the lobes in the order of bsdf.h (a glTF model has no
 * mirror or smooth dielectric: its delta lobes are the smooth specular layer and the smooth
 * coat). A non-delta draw is evaluated whole where it landed; a delta one is that lobe's
 * reflection with its weight: the specular layer's F S T, the coat's clearcoat F_c(fix.n_c). */
static vf_vec3 layered_sample(const vf_bsdf *b, const float rnd[3], vf_vec3 *world_gen, float *pdf_w,
                              float *reverse_pdf_w, float *cos_gen, unsigned *event) {
  const float *p = b->lobe_probability;
  const vf_vec3 none = vf_vec3_splat(0.0f);
  float u = rnd[2];
  *event = 0;
  float p_smooth = p[VF_LOBE_DIFFUSE] + p[VF_LOBE_GLOSSY];
  float p_base = p_smooth + p[VF_LOBE_ROUGH_CONDUCTOR] + p[VF_LOBE_ROUGH_DIELECTRIC] + p[VF_LOBE_BASE];
  float p_nondelta = p_base + p[VF_LOBE_SHEEN] + p[VF_LOBE_ROUGH_COAT];
  if (u < p_nondelta) {
    if (u < p_smooth) {
      *world_gen = vf_frame_to_world(&b->frame, vf_bsdf_sample_smooth(b, u, rnd));
    } else if (u < p_base) {
      vf_vec3 gen = sample_rough(b, u - p_smooth, rnd[0], rnd[1], event);
      if (vf_is_zero(gen)) return none;
      *world_gen = vf_frame_to_world(&b->frame, gen);
    } else if (p[VF_LOBE_ROUGH_COAT] == 0.0f || u < p_base + p[VF_LOBE_SHEEN]) {
      *world_gen = vf_frame_to_world(&b->frame, vf_sample_cosine_hemisphere(rnd[0], rnd[1], NULL));
    } else {
      const vf_vec3 fix_c = b->coat_fix;
      if (!(fix_c.z > 0.0f)) return none;
      vf_vec3 m = vf_ggx_sample_visible(fix_c, b->coat_alpha, b->coat_alpha, rnd[0], rnd[1]);
      vf_vec3 gen = vf_sub(vf_scale(m, 2.0f * vf_dot(fix_c, m)), fix_c);
      if (!(gen.z > 0.0f)) return none;
      *world_gen = vf_frame_to_world(&b->coat_frame, gen);
    }
    float c;
    lobe_value v = layered_evaluate(b, *world_gen, 0, &c);
    return vf_bsdf_sampled(v.f, v.direct_pdf_w * b->continuation, v.reverse_pdf_w * b->continuation, c, pdf_w,
                           reverse_pdf_w, cos_gen);
  }
  u -= p_nondelta;
  *event = VF_BSDF_SPECULAR;
  vf_vec3 f, gen_world;
  float choice, cos_geometric, fold, c;
  if (p[VF_LOBE_COAT] > 0.0f && (u >= p[VF_LOBE_CONDUCTOR] || p[VF_LOBE_CONDUCTOR] == 0.0f)) {
    const vf_vec3 fix_c = b->coat_fix;
    if (!(fix_c.z > 0.0f)) return none;
    vf_vec3 gen = vf_bsdf_reflect_local(fix_c);
    gen_world = vf_frame_to_world(&b->coat_frame, gen);
    c = gen.z;
    cos_geometric = b->shading ? vf_dot(b->geometric, gen_world) : c;
    fold = coat_fold(b, gen, cos_geometric);
    f = vf_vec3_splat(b->coat_weight * coat_fresnel(fix_c.z) / c);
    choice = p[VF_LOBE_COAT];
  } else {
    vf_vec3 gen = vf_bsdf_reflect_local(b->local_fix);
    gen_world = vf_frame_to_world(&b->frame, gen);
    c = gen.z;
    cos_geometric = b->shading ? vf_dot(b->geometric, gen_world) : c;
    fold = b->shading ? shading_fold(b, gen, cos_geometric) : 1.0f;
    vf_vec3 gen_c = b->coat_weight > 0.0f ? vf_frame_to_local(&b->coat_frame, gen_world) : gen;
    float layers = sheen_scaling(b, sheen_albedo_gen(b, c)) * coat_transmit(b, gen_c.z);
    f = vf_scale(conductor_reflectance(b, c), layers / c);
    choice = p[VF_LOBE_CONDUCTOR];
  }
  if (!(choice > 0.0f) || !(fold > 0.0f) || vf_is_zero(f)) return none;
  *world_gen = gen_world;
  *pdf_w = *reverse_pdf_w = choice * b->continuation;
  *cos_gen = fabsf(cos_geometric);
  return vf_scale(f, fold);
}

void vf_bsdf_setup_phase(vf_bsdf *b, vf_vec3 sigma_s, float g, float continuation, vf_vec3 world_fix) {
  memset(b, 0, sizeof *b);
  b->frame = vf_frame_from_normal(world_fix);
  b->local_fix = vf_vec3_make(0.0f, 0.0f, 1.0f);
  b->eta = 1.0f;
  b->continuation = continuation;
  b->extended = 1;
  b->geometric = world_fix;
  b->phase = 1;
  b->phase_g = g;
  b->sigma_s = sigma_s;
}

/* The phase function's evaluate (see vf_bsdf_setup_phase): symmetric, so both densities
 * are one. */
static vf_vec3 phase_evaluate(const vf_bsdf *b, vf_vec3 world_gen, float *cos_gen, float *direct_pdf_w,
                              float *reverse_pdf_w) {
  float p = vf_hg(-vf_dot(b->geometric, world_gen), b->phase_g);
  if (cos_gen) *cos_gen = 1.0f;
  if (direct_pdf_w) *direct_pdf_w = p * b->continuation;
  if (reverse_pdf_w) *reverse_pdf_w = p * b->continuation;
  return vf_scale(b->sigma_s, p);
}

vf_vec3 vf_bsdf_evaluate_extended(const vf_bsdf *b, vf_vec3 world_gen, float *cos_gen, float *direct_pdf_w,
                                  float *reverse_pdf_w, int radiance) {
  if (b->phase) return phase_evaluate(b, world_gen, cos_gen, direct_pdf_w, reverse_pdf_w);
  if (b->layered) {
    float c;
    lobe_value v = layered_evaluate(b, world_gen, radiance, &c);
    if (cos_gen) *cos_gen = c;
    if (direct_pdf_w) *direct_pdf_w = v.direct_pdf_w * b->continuation;
    if (reverse_pdf_w) *reverse_pdf_w = v.reverse_pdf_w * b->continuation;
    return v.f;
  }
  vf_vec3 gen = vf_frame_to_local(&b->frame, world_gen);
  lobe_value v;
  float c = fabsf(gen.z);
  if (b->shading) {
    float cos_geometric = vf_dot(b->geometric, world_gen), fold = shading_fold(b, gen, cos_geometric);
    c = fabsf(cos_geometric);
    if (fold > 0.0f) {
      v = evaluate_local(b, gen, radiance);
      v.f = vf_scale(v.f, fold);
    } else {
      v = (lobe_value){vf_vec3_splat(0.0f), 0.0f, 0.0f};
    }
  } else {
    v = evaluate_local(b, gen, radiance);
  }
  if (cos_gen) *cos_gen = c;
  if (direct_pdf_w) *direct_pdf_w = v.direct_pdf_w * b->continuation;
  if (reverse_pdf_w) *reverse_pdf_w = v.reverse_pdf_w * b->continuation;
  return v.f;
}

/* A local direction of the rough lobes, chosen by u in [0, their summed probability) in the
 * order ROUGH_CONDUCTOR, ROUGH_DIELECTRIC, BASE, and (u1, u2); with VF_BSDF_REFRACTION
 * into *event for a transmission; the zero vector when the draw fails (below the horizon,
 * total internal reflection). The dielectric reflects off its visible normal with
 * probability F (what is left of u decides), else refracts [Walter07 eq. 39, 40]:
 * gen = (ci / eta - cos_t) m - fix / eta. */
static vf_vec3 sample_rough(const vf_bsdf *b, float u, float u1, float u2, unsigned *event) {
  const float *p = b->lobe_probability;
  const vf_vec3 fix = b->local_fix, none = vf_vec3_splat(0.0f);
  vf_vec3 gen;
  /* The tests on zero keep a u rounded past the last lobe's end inside a lobe that exists. */
  if (p[VF_LOBE_BASE] > 0.0f && u >= p[VF_LOBE_ROUGH_CONDUCTOR] + p[VF_LOBE_ROUGH_DIELECTRIC]) {
    gen = vf_sample_cosine_hemisphere(u1, u2, NULL);
  } else {
    vf_vec3 m = vf_ggx_sample_visible(fix, b->alpha, b->alpha, u1, u2);
    float ci = vf_dot(fix, m);
    int reflect = p[VF_LOBE_ROUGH_DIELECTRIC] == 0.0f || u < p[VF_LOBE_ROUGH_CONDUCTOR] ||
                  (u - p[VF_LOBE_ROUGH_CONDUCTOR]) / p[VF_LOBE_ROUGH_DIELECTRIC] < vf_fresnel_dielectric(ci, b->eta);
    if (reflect) {
      gen = vf_sub(vf_scale(m, 2.0f * ci), fix);
      if (!(gen.z > 0.0f)) return none;
    } else {
      float eta = b->eta, sin_t2 = (1.0f - ci * ci) / (eta * eta);
      if (!(sin_t2 < 1.0f)) return none;
      float cos_t = sqrtf(1.0f - sin_t2);
      gen = vf_sub(vf_scale(m, ci / eta - cos_t), vf_scale(fix, 1.0f / eta));
      if (!(gen.z < 0.0f)) return none;
      *event |= VF_BSDF_REFRACTION;
    }
  }
  return gen;
}

/* vf_bsdf_sample with the extended lobes: the non-delta lobes in the order DIFFUSE, GLOSSY,
 * ROUGH_CONDUCTOR, ROUGH_DIELECTRIC, BASE, then the delta ones, MIRROR, DIELECTRIC,
 * CONDUCTOR; the smooth conductor is a mirror reflecting tint x Fresnel at the angle of
 * fix. */
static vf_vec3 sample_lobes(const vf_bsdf *b, const float rnd[3], vf_vec3 *world_gen, float *pdf_w,
                            float *reverse_pdf_w, float *cos_gen, unsigned *event) {
  const float *p = b->lobe_probability;
  float u = rnd[2];
  *event = 0;
  float p_smooth = p[VF_LOBE_DIFFUSE] + p[VF_LOBE_GLOSSY];
  float p_nondelta = p_smooth + p[VF_LOBE_ROUGH_CONDUCTOR] + p[VF_LOBE_ROUGH_DIELECTRIC] + p[VF_LOBE_BASE];
  if (u < p_nondelta) {
    vf_vec3 gen = u < p_smooth ? vf_bsdf_sample_smooth(b, u, rnd) : sample_rough(b, u - p_smooth, rnd[0], rnd[1], event);
    if (vf_is_zero(gen)) return gen;
    /* evaluated after the round trip through the world frame, as vf_bsdf_sample does */
    *world_gen = vf_frame_to_world(&b->frame, gen);
    vf_vec3 back = vf_frame_to_local(&b->frame, *world_gen);
    lobe_value v = evaluate_local(b, back, 0);
    return vf_bsdf_sampled(v.f, v.direct_pdf_w * b->continuation, v.reverse_pdf_w * b->continuation,
                           fabsf(back.z), pdf_w, reverse_pdf_w, cos_gen);
  }
  u -= p_nondelta;
  if (!(p[VF_LOBE_CONDUCTOR] > 0.0f && u >= p[VF_LOBE_MIRROR] + p[VF_LOBE_DIELECTRIC]))
    return vf_bsdf_sample_delta(b, u, world_gen, pdf_w, reverse_pdf_w, cos_gen, event);
  *event = VF_BSDF_SPECULAR;
  vf_vec3 gen = vf_bsdf_reflect_local(b->local_fix);
  float c = gen.z;
  *world_gen = vf_frame_to_world(&b->frame, gen);
  *pdf_w = *reverse_pdf_w = p[VF_LOBE_CONDUCTOR] * b->continuation;
  *cos_gen = c;
  return vf_scale(conductor_reflectance(b, c), 1.0f / c);
}

vf_vec3 vf_bsdf_sample_extended(const vf_bsdf *b, const float rnd[3], vf_vec3 *world_gen, float *pdf_w,
                                float *reverse_pdf_w, float *cos_gen, unsigned *event) {
  if (b->phase) {
    float c;
    *world_gen = vf_hg_sample(vf_neg(b->geometric), b->phase_g, rnd[0], rnd[1], &c);
    *event = 0;
    /* Evaluated for the direction returned, so that sample and evaluate agree. */
    float d, r;
    vf_vec3 f = phase_evaluate(b, *world_gen, cos_gen, &d, &r);
    return vf_bsdf_sampled(f, d, r, 1.0f, pdf_w, reverse_pdf_w, cos_gen);
  }
  if (b->layered) return layered_sample(b, rnd, world_gen, pdf_w, reverse_pdf_w, cos_gen, event);
  vf_vec3 f = sample_lobes(b, rnd, world_gen, pdf_w, reverse_pdf_w, cos_gen, event);
  if (!b->shading || vf_is_zero(f)) return f;
  /* In the shading frame, cos_gen is |gen.ns|: fold it into f, and refuse a direction
   * that crosses one surface but not the other (a reflection through the geometric
   * surface, or a refraction that stays on fix's side of it). */
  vf_vec3 gen = vf_frame_to_local(&b->frame, *world_gen);
  float cos_geometric = vf_dot(b->geometric, *world_gen), fold = shading_fold(b, gen, cos_geometric);
  if (!(fold > 0.0f)) return vf_vec3_splat(0.0f);
  *cos_gen = fabsf(cos_geometric);
  return vf_scale(f, fold);
}
