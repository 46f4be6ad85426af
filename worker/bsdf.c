#include "bsdf.h"

#include "sampling.h"

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

void vf_bsdf_lobes_of(const vf_material *m, vf_bsdf_lobes *lobes) {
  float albedo[VF_LOBE_COUNT] = {mean3(m->diffuse), mean3(m->glossy), mean3(m->mirror), mean3(m->dielectric)};
  float total = albedo[0] + albedo[1] + albedo[2] + albedo[3];
  lobes->black = !(total > 0.0f);
  for (int i = 0; i < VF_LOBE_COUNT; i++) lobes->lobe_probability[i] = lobes->black ? 0.0f : albedo[i] / total;
  vf_vec3 sum = vf_add(vf_add(m->diffuse, m->glossy), vf_add(m->mirror, m->dielectric));
  lobes->continuation = fminf(1.0f, vf_max_component(sum));
  lobes->is_delta = lobes->lobe_probability[VF_LOBE_DIFFUSE] == 0.0f && lobes->lobe_probability[VF_LOBE_GLOSSY] == 0.0f;
}

int vf_bsdf_init(vf_bsdf *b, const vf_material *m, vf_vec3 normal, vf_vec3 world_fix) {
  vf_bsdf_lobes lobes;
  vf_bsdf_lobes_of(m, &lobes);
  return vf_bsdf_setup(b, m, &lobes, normal, world_fix);
}

static vf_vec3 reflect_local(vf_vec3 v) { return vf_vec3_make(-v.x, -v.y, v.z); }

vf_vec3 vf_bsdf_sample(const vf_bsdf *b, const float rnd[3], vf_vec3 *world_gen, float *pdf_w,
                       float *reverse_pdf_w, float *cos_gen, unsigned *event) {
  const float *p = b->lobe_probability;
  float u = rnd[2];
  vf_vec3 gen;
  *event = 0;
  if (u < p[VF_LOBE_DIFFUSE] + p[VF_LOBE_GLOSSY]) {
    if (u < p[VF_LOBE_DIFFUSE]) {
      gen = vf_sample_cosine_hemisphere(rnd[0], rnd[1], NULL);
    } else {
      vf_vec3 axis = reflect_local(b->local_fix);
      vf_frame lobe = vf_frame_from_normal(axis);
      gen = vf_frame_to_world(&lobe, vf_sample_power_cosine(rnd[0], rnd[1], b->material->phong_exponent));
    }
    /* Evaluate the direction that is returned, after its round trip through the world
     * frame, so that sample and evaluate agree even for a Phong exponent of 1e5, where
     * cos^n magnifies the frames' rounding 2n times. */
    *world_gen = vf_frame_to_world(&b->frame, gen);
    float d, r, c;
    vf_vec3 f = vf_bsdf_evaluate(b, *world_gen, &c, &d, &r);
    if (!(d > 0.0f)) return vf_vec3_splat(0.0f);
    *pdf_w = d;
    *reverse_pdf_w = r;
    *cos_gen = c;
    return f;
  }
  *event = VF_BSDF_SPECULAR;
  float choice_pdf;
  vf_vec3 weight;
  u -= p[VF_LOBE_DIFFUSE] + p[VF_LOBE_GLOSSY];
  if (u < p[VF_LOBE_MIRROR] || p[VF_LOBE_DIELECTRIC] == 0.0f) {
    gen = reflect_local(b->local_fix);
    choice_pdf = p[VF_LOBE_MIRROR];
    weight = b->material->mirror;
  } else {
    /* Within the dielectric lobe, reflect with probability F: the throughput factor is
     * then tint * F / (p_lobe * F), the same for refraction with 1 - F. */
    u = (u - p[VF_LOBE_MIRROR]) / p[VF_LOBE_DIELECTRIC];
    const vf_vec3 fix = b->local_fix;
    if (u < b->fresnel) {
      gen = reflect_local(fix);
      choice_pdf = p[VF_LOBE_DIELECTRIC] * b->fresnel;
      weight = vf_scale(b->material->dielectric, b->fresnel);
    } else {
      double eta = b->eta, ci = fix.z;
      float cos_t = (float)sqrt(fmax(0.0, 1.0 - (1.0 - ci * ci) / (eta * eta)));
      gen = vf_vec3_make(-fix.x / b->eta, -fix.y / b->eta, -cos_t);
      *event |= VF_BSDF_REFRACTION;
      choice_pdf = p[VF_LOBE_DIELECTRIC] * (1.0f - b->fresnel);
      weight = vf_scale(b->material->dielectric, 1.0f - b->fresnel);
    }
  }
  if (!(choice_pdf > 0.0f) || gen.z == 0.0f) return vf_vec3_splat(0.0f);
  float c = fabsf(gen.z);
  *world_gen = vf_frame_to_world(&b->frame, gen);
  *pdf_w = choice_pdf * b->continuation;
  *reverse_pdf_w = *pdf_w;
  *cos_gen = c;
  /* f such that f * cos / pdf = weight / (choice_pdf * continuation). */
  return vf_scale(weight, 1.0f / c);
}
