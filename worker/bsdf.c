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
