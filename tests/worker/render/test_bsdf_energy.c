/* Tests of worker/render/bsdf.c against energy conservation, never against numbers copied from an
 * earlier run: the density integrates to the probability of a non-specular event, and no
 * material reflects more than it receives (directional albedo, by importance sampling against
 * an independent mixture sampler and against the analytic value where there is one).
 * Sections keep the numbers of the single file they came from (1e, 1f here; 1a-1d, 3 and 4 in
 * test_bsdf.c, 2 in test_bsdf_specular.c); seeds, tolerances, the configuration table and the
 * statistical budget are those of bsdf_cases.h. */
#include "check.h"
#include "bsdf_cases.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

static int verbose;

/* ---- 1e, 1f. normalisation and energy ---- */

#define MC_SAMPLES 200000

/* Mass of a normalised cos^n lobe around the mirror direction (at theta_i from the normal)
 * that lies below the horizon; the sampler's draws there fail. In the lobe's frame, at
 * x = cos(alpha) the fraction of azimuths below the horizon is acos(cot alpha cot theta_i) / pi;
 * t = x^(n + 1) makes the lobe uniform, and the midpoint rule integrates over t. */
static double glossy_mass_below_horizon(double n, double theta_i) {
  if (theta_i <= 0.0) return 0.0;
  const int steps = 200000;
  double cot_i = cos(theta_i) / sin(theta_i), sum = 0.0;
  for (int i = 0; i < steps; i++) {
    double t = (i + 0.5) / steps;
    double x = pow(t, 1.0 / (n + 1.0));
    double cot_a = x / sqrt(fmax(1e-300, 1.0 - x * x));
    double c = cot_a * cot_i;
    if (c < 1.0) sum += acos(c) / PI_D;
  }
  return sum / steps;
}

/* Directional albedo of the energy-normalised modified Phong lobe, integral over the upper
 * hemisphere of (n + 2) / (2 pi) cos^n(alpha) cos(theta) (1 at normal incidence). In the lobe's
 * frame cos(theta) = A + B cos(psi) with A = cos(alpha) cos(theta_i), B = sin(alpha) sin(theta_i);
 * its positive part averages over psi to (A psi0 + B sin psi0) / pi with cos psi0 = -A / B;
 * alpha is integrated as in glossy_mass_below_horizon(). */
static double phong_albedo(double n, double theta_i) {
  const int steps = 200000;
  double sum = 0.0;
  for (int i = 0; i < steps; i++) {
    double t = (i + 0.5) / steps;
    double x = pow(t, 1.0 / (n + 1.0));
    double a = x * cos(theta_i), b = sqrt(fmax(0.0, 1.0 - x * x)) * sin(theta_i);
    if (a >= b) sum += a;
    else if (a > -b) {
      double psi0 = acos(-a / b);
      sum += (a * psi0 + b * sin(psi0)) / PI_D;
    }
  }
  return (n + 2.0) / (n + 1.0) * sum / steps;
}

typedef struct {
  running_mean pdf;      /* integral of evaluate's direct pdf over the sphere */
  running_mean albedo[3]; /* integral of f |cos| over the sphere (non-specular lobes) */
} mixture_estimate;

/* Integrals over the sphere with a sampler that does not come from the code under test: a
 * defensive mixture of uniform directions and, when there is a glossy lobe, a uniform cone
 * of three lobe widths around the mirror direction. */
static void estimate_by_mixture(const config *c, uint64_t stream, mixture_estimate *e) {
  const vf_material *m = &c->mc->material;
  int glossy = vf_max_component(m->glossy) > 0.0f;
  double n = m->phong_exponent;
  double cone = glossy ? fmin(PI_D / 2.0, 3.0 / sqrt(n + 1.0)) : 0.0;
  double cone_solid_angle = 2.0 * PI_D * (1.0 - cos(cone));
  dframe lobe = dframe_around(dreflect(dv(c->fix), c->up));
  vf_rng r = test_rng(CASE_INTEGRAL, stream);
  *e = (mixture_estimate){0};
  for (int i = 0; i < MC_SAMPLES; i++) {
    dvec d;
    if (glossy && (i & 1)) {
      double cos_a = 1.0 - ((double)vf_rng_float(&r) + 0x1p-25) * (1.0 - cos(cone));
      double phi = 2.0 * PI_D * vf_rng_float(&r);
      d = dframe_dir(&lobe, acos(cos_a), phi);
    } else {
      d = uniform_sphere_d(&r);
    }
    double q = 1.0 / (4.0 * PI_D);
    if (glossy) q = 0.5 * q + (ddot(d, lobe.n) >= cos(cone) ? 0.5 / cone_solid_angle : 0.0);
    float cos_gen, pdf;
    vf_vec3 f = vf_bsdf_evaluate(&c->bsdf, fv(d), &cos_gen, &pdf, NULL);
    rm_add(&e->pdf, pdf / q);
    for (int ch = 0; ch < 3; ch++) rm_add(&e->albedo[ch], vf_vec3_get(f, ch) * cos_gen / q);
  }
}

static void test_nonspecular_pdf_integrates_to_nonspecular_probability(void) {
  double worst_z = 0.0;
  for (int k = 0; k < CONFIG_COUNT; k++) {
    config c;
    make_config(&c, k);
    if (!c.ok || c.mc->pdf_consistency_only) continue;
    const vf_bsdf *b = &c.bsdf;
    /* Both non-specular lobes reflect only: a glossy draw below the horizon fails, so the
     * density integrates to the probability that a draw is a successful non-specular one. */
    double below = b->lobe_probability[VF_LOBE_GLOSSY] > 0.0f
                       ? glossy_mass_below_horizon(c.mc->material.phong_exponent, c.theta)
                       : 0.0;
    double expected = b->continuation *
                      (b->lobe_probability[VF_LOBE_DIFFUSE] + b->lobe_probability[VF_LOBE_GLOSSY] * (1.0 - below));
    mixture_estimate e;
    estimate_by_mixture(&c, (uint64_t)k, &e);
    double mean = rm_mean(&e.pdf), se = rm_se(&e.pdf);
    /* 1e-6: float rounding of the pdf values, far below any standard error here */
    expect_near("integral of the direct pdf over the sphere", c.label, mean, expected, K_SE * se + 1e-6);
    double z = se > 0.0 ? fabs(mean - expected) / se : 0.0;
    if (verbose)
      printf("  %-36s integral %.5f expected %.5f (below horizon %.4f) se %.5f z %.2f\n", c.label, mean, expected,
             below, se, z);
    worst_z = fmax(worst_z, z);
  }
  printf("  info: %d samples per configuration, largest |z| %.2f (limit %.1f)\n", MC_SAMPLES, worst_z, K_SE);
}

static void test_directional_albedo_is_at_most_one(void) {
  double worst_z = 0.0, max_albedo = 0.0;
  for (int k = 0; k < CONFIG_COUNT; k++) {
    config c;
    make_config(&c, k);
    if (!c.ok || c.mc->pdf_consistency_only) continue;
    const vf_material *m = &c.mc->material;
    running_mean total[3] = {{0}}, nonspecular[3] = {{0}}, specular[3] = {{0}};
    vf_rng r = test_rng(CASE_ALBEDO, (uint64_t)k);
    for (int i = 0; i < MC_SAMPLES; i++) {
      bsdf_draw s = draw_sample(&c.bsdf, &r);
      int spec = !vf_is_zero(s.f) && (s.event & VF_BSDF_SPECULAR);
      for (int ch = 0; ch < 3; ch++) {
        double w = draw_weight(&c.bsdf, &s, ch);
        rm_add(&total[ch], w);
        rm_add(&nonspecular[ch], spec ? 0.0 : w);
        rm_add(&specular[ch], spec ? w : 0.0);
      }
    }
    mixture_estimate e;
    estimate_by_mixture(&c, (uint64_t)k + 1000, &e);
    double phong_r = vf_max_component(m->glossy) > 0.0f ? phong_albedo(m->phong_exponent, c.theta) : 0.0;
    for (int ch = 0; ch < 3; ch++) {
      double a = rm_mean(&total[ch]), se = rm_se(&total[ch]);
      /* float rounding of f cos / pdf * continuation: a few FLT_EPSILON relative */
      double fp = 1e-6;
      expect_le("directional albedo", c.label, a, 1.0 + K_SE * se + fp);
      max_albedo = fmax(max_albedo, a);
      /* specular lobes: exactly their reflectance (the dielectric: tint (F + (1 - F))) */
      double spec_expected = vf_vec3_get(m->mirror, ch) + vf_vec3_get(m->dielectric, ch);
      double s = rm_mean(&specular[ch]), s_se = rm_se(&specular[ch]);
      expect_near("specular albedo == mirror + dielectric tint", c.label, s, spec_expected, K_SE * s_se + fp);
      /* non-specular lobes: importance sampling against the independent mixture estimate */
      double ns = rm_mean(&nonspecular[ch]), ns_se = rm_se(&nonspecular[ch]);
      double mx = rm_mean(&e.albedo[ch]), mx_se = rm_se(&e.albedo[ch]);
      double both_se = sqrt(ns_se * ns_se + mx_se * mx_se);
      expect_near("non-specular albedo: importance vs mixture sampling", c.label, ns, mx, K_SE * both_se + fp);
      if (both_se > 0.0) worst_z = fmax(worst_z, fmax(0.0, fabs(ns - mx) - fp) / both_se);
      if (s_se > 0.0) worst_z = fmax(worst_z, fmax(0.0, fabs(s - spec_expected) - fp) / s_se);
      /* analytic: the Lambertian lobe's albedo is its colour at every angle, the Phong lobe's
       * is its colour times phong_albedo() (its colour at normal incidence) */
      double ns_expected = vf_vec3_get(m->diffuse, ch) + vf_vec3_get(m->glossy, ch) * phong_r;
      /* 1e-5: phong_albedo's quadrature (~1e-8) and float rounding of the samples */
      expect_near("non-specular albedo == diffuse + glossy x Phong albedo", c.label, ns, ns_expected,
                  K_SE * ns_se + 1e-5);
      expect_near("albedo == diffuse + glossy x Phong albedo + mirror + dielectric", c.label, a,
                  ns_expected + spec_expected, K_SE * se + 1e-5);
      if (ns_se > 0.0) worst_z = fmax(worst_z, fmax(0.0, fabs(ns - ns_expected) - 1e-5) / ns_se);
      if (verbose && ch == 0)
        printf("  %-36s red: albedo %.5f (se %.5f) = non-spec %.5f [mixture %.5f, analytic %.5f] + spec %.5f\n",
               c.label, a, se, ns, mx, ns_expected, s);
    }
  }
  printf("  info: %d importance samples per configuration, largest albedo %.5f, largest |z| %.2f (limit %.1f)\n",
         MC_SAMPLES, max_albedo, worst_z, K_SE);
}

int main(void) {
  const char *v = getenv("VF_TEST_VERBOSE");
  verbose = v && v[0] == '1';
  RUN(test_nonspecular_pdf_integrates_to_nonspecular_probability);
  RUN(test_directional_albedo_is_at_most_one);
  return check_finish();
}
