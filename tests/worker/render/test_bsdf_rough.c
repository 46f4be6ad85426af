/* Tests of the rough lobes of worker/render/bsdf.c (GGX conductor and dielectric, the glTF
 * metallic-roughness model, and their mixtures with the older lobes) against probability
 * and an independent double-precision reference, never against numbers copied from an
 * earlier run:
 * 1. the density vf_bsdf_sample() reports is vf_bsdf_evaluate()'s for that direction, and a
 *    camera sub-path's vertex evaluates a transmission to the radiance BTDF, 1/eta^2 times
 *    the light sub-path's f that sample() returns (worker/render/bsdf.h);
 * 2. the reverse density is the direct density of the edge walked the other way
 *    (tech. rep. sec. 3-5), f is reciprocal for reflection, and for transmission obeys the
 *    generalised reciprocity f(i, o) / eta_o^2 = f(o, i) / eta_i^2;
 * 3. the sampled directions follow the evaluated density (chi-square, one Sidak family);
 * 4. the directional albedo by importance sampling equals the reference's quadrature
 *    (bsdf_cases.c), and is at most 1, except where the glTF specification's BRDF itself
 *    reflects more (listed in the output).
 * Configurations, seeds and the statistical budget are those of bsdf_cases.h. */
#include "check.h"
#include "bsdf_cases.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

static int verbose;

/* Relative rounding of a GGX density or f whose half vector is recomputed from other float
 * directions (the other side, a world-frame round trip): the half vector moves by a few
 * FLT_EPSILON, and D's logarithmic derivative is ~4 / alpha where the lobe has its mass. */
static double ggx_rounding(double alpha) { return 2e-5 + 64.0 * FLT_EPSILON / fmax(alpha, 1e-3); }

static double alpha_of(const config *c) { return (double)c->mc->material.roughness * c->mc->material.roughness; }

/* ---- 1. the sampled density is the evaluated density ---- */

static void test_sampled_pdf_matches_evaluated_pdf_and_radiance_btdf(void) {
  long nonspecular_total = 0, refractions_total = 0;
  double worst_radiance = 0.0;
  for (int k = 0; k < ROUGH_CONFIG_COUNT; k++) {
    config c;
    make_rough_config(&c, k);
    CHECK(c.ok);
    if (!c.ok) continue;
    vf_bsdf camera = c.bsdf;
    camera.radiance = 1;
    vf_rng r = test_rng(CASE_ROUGH_PDF, (uint64_t)k);
    long nonspecular = 0, refractions = 0;
    for (int i = 0; i < 4000; i++) {
      bsdf_draw s = draw_sample(&c.bsdf, &r);
      if (vf_is_zero(s.f) || (s.event & VF_BSDF_SPECULAR)) {
        if (!vf_is_zero(s.f)) expect_near("specular pdf == reverse pdf", c.label, s.rev, s.pdf, 0.0);
        continue;
      }
      vf_vec3 f = s.f, gen = s.gen;
      float pdf = s.pdf, rev = s.rev, cos_gen = s.cos_gen, e_cos, e_pdf, e_rev;
      nonspecular++;
      /* the same float computation on the same direction: equal bit for bit */
      vf_vec3 fe = vf_bsdf_evaluate(&c.bsdf, gen, &e_cos, &e_pdf, &e_rev);
      expect_near("sample pdf == evaluate direct pdf", c.label, pdf, e_pdf, 0.0);
      expect_near("sample reverse pdf == evaluate reverse pdf", c.label, rev, e_rev, 0.0);
      expect_near("sample cos == evaluate cos", c.label, cos_gen, e_cos, 0.0);
      for (int ch = 0; ch < 3; ch++) expect_near("sample f == evaluate f", c.label, vf_vec3_get(f, ch), vf_vec3_get(fe, ch), 0.0);
      if (!(pdf > 0.0f) || !(rev > 0.0f)) CHECK_FAIL_("non-positive density [%s]: %g %g", c.label, pdf, rev);
      /* a camera sub-path's vertex: the same densities, f / eta^2 across the surface */
      float r_pdf, r_rev;
      vf_vec3 fr = vf_bsdf_evaluate(&camera, gen, NULL, &r_pdf, &r_rev);
      int refracted = (s.event & VF_BSDF_REFRACTION) != 0;
      refractions += refracted;
      double scale = refracted ? 1.0 / ((double)c.bsdf.eta * c.bsdf.eta) : 1.0;
      expect_near("radiance vertex: same direct pdf", c.label, r_pdf, pdf, 0.0);
      expect_near("radiance vertex: same reverse pdf", c.label, r_rev, rev, 0.0);
      for (int ch = 0; ch < 3; ch++) {
        double e = rel_err(vf_vec3_get(fr, ch), vf_vec3_get(f, ch) * scale, 0.0);
        worst_radiance = fmax(worst_radiance, e);
        expect_le("radiance vertex: f == light sub-path's f / eta^2 (rel. err)", c.label, e, 4.0 * FLT_EPSILON);
      }
    }
    expect_ge("non-specular samples drawn", c.label, (double)nonspecular, 100.0);
    if (vf_is_zero(c.mc->material.dielectric)) expect_near("refractions of an opaque material", c.label, refractions, 0, 0);
    else if (ddot(dv(c.normal), dv(c.fix)) > 0.0 || c.theta == 0.0) /* from inside: mostly internal reflection */
      expect_ge("refractions drawn", c.label, (double)refractions, 10.0);
    nonspecular_total += nonspecular;
    refractions_total += refractions;
  }
  printf("  info: %ld non-specular samples (%ld refractions); radiance BTDF vs f / eta^2 worst rel. err %.2e\n",
         nonspecular_total, refractions_total, worst_radiance);
}

/* ---- 2. reverse density and (generalised) reciprocity ---- */

static void test_reverse_pdf_is_swapped_direct_pdf_and_f_is_reciprocal(void) {
  double worst_rev = 0.0, worst_f = 0.0, worst_ft = 0.0;
  long pairs_total = 0, transmissions_total = 0;
  for (int k = 0; k < ROUGH_CONFIG_COUNT; k++) {
    config c;
    make_rough_config(&c, k);
    if (!c.ok) continue;
    const vf_material *m = &c.mc->material;
    vf_rng r = test_rng(CASE_ROUGH_REVERSE, (uint64_t)k);
    long pairs = 0, nonzero = 0, transmissions = 0;
    for (int i = 0; i < 2000; i++) {
      swapped_pair q;
      if (!make_swapped_pair(&c, &r, i, &q)) continue;
      /* Both sides compute the microfacet normal m of the pair from float directions. Near
       * a dielectric's critical angle Fresnel's F (and 1 - F) varies like the cosine ct of
       * the refracted direction to m, so the rounding of m is magnified by ~1 / ct^2; ct
       * is the smaller cosine to m of a refraction. */
      int across = ddot(dv(q.b), c.up) < 0.0;
      dvec hm = dnormalize(dadd(dv(c.fix), dscale(dv(q.b), across ? c.bsdf.eta : 1.0)));
      double ci = fabs(ddot(hm, dv(c.fix))), ct = fmin(ci, fabs(ddot(hm, dv(q.b))));
      if (!across) ct = sqrt(fmax(0.0, 1.0 - (1.0 - ci * ci) / ((double)c.bsdf.eta * c.bsdf.eta)));
      double ill = vf_is_zero(m->dielectric) ? 0.0 : 16.0 * FLT_EPSILON / fmax(1e-30, ct * ct);
      double tol = ggx_rounding(alpha_of(&c)) + ill;
      int conditioned = ill < 1e-4; /* the worst figures printed: pairs away from the critical angle */
      pairs++;
      nonzero += q.d_ab > 0.0f;
      transmissions += across && q.d_ab > 0.0f;
      double e_rev = fmax(rel_err(q.r_ab, q.d_ba, 0.0), rel_err(q.r_ba, q.d_ab, 0.0));
      if (conditioned) worst_rev = fmax(worst_rev, e_rev);
      if (!(e_rev <= tol))
        CHECK_FAIL_("reverse pdf [%s]: evaluate(a,b) %g %g vs evaluate(b,a) %g %g", c.label, q.d_ab, q.r_ab, q.d_ba,
                    q.r_ba);
      /* across the surface, f(fix -> b) / eta_b^2 = f(b -> fix) / eta_fix^2 with eta_b / eta_fix = bsdf.eta */
      double eta2 = across ? (double)c.bsdf.eta * c.bsdf.eta : 1.0;
      for (int ch = 0; ch < 3; ch++) {
        double e = rel_err(vf_vec3_get(q.f_ab, ch), eta2 * vf_vec3_get(q.f_ba, ch), 0.0);
        if (conditioned && across) worst_ft = fmax(worst_ft, e);
        else if (conditioned) worst_f = fmax(worst_f, e);
        if (!(e <= tol))
          CHECK_FAIL_("%s [%s]: f(a,b) %g vs %g f(b,a) %g", across ? "generalised reciprocity" : "reciprocity", c.label,
                      vf_vec3_get(q.f_ab, ch), eta2, vf_vec3_get(q.f_ba, ch));
      }
    }
    expect_ge("pairs with non-zero density", c.label, (double)nonzero, 100.0);
    if (!vf_is_zero(m->dielectric) && c.theta < 1.4) expect_ge("transmitting pairs", c.label, (double)transmissions, 10.0);
    if (verbose) printf("  %-36s pairs %4ld (non-zero %4ld, across %4ld)\n", c.label, pairs, nonzero, transmissions);
    pairs_total += pairs;
    transmissions_total += transmissions;
  }
  printf("  info: %ld pairs (%ld across the surface); worst rel. err away from critical angles: reverse pdf %.2e, "
         "f %.2e, f eta^2 across %.2e\n",
         pairs_total, transmissions_total, worst_rev, worst_f, worst_ft);
}

/* ---- 3. chi-square goodness of fit of the sampled directions ---- */

#define CHI_T 12
#define CHI_PHI 24
#define CHI_SAMPLES 100000

/* One grid per side of the surface, each over the whole sphere in (t, phi) around an axis
 * (the mirror direction of fix, the refraction direction of the macro-surface), with the
 * polar angle theta = 2 atan(s t / (1 - t)): a lobe of width ~s gets as many cells as the
 * rest of the sphere. A direction belongs to the grid of its side; the other side's part of
 * a grid has no mass. */
typedef struct {
  dframe frame;
  double s;
  double sign; /* +1: the side of fix (up), -1: the other */
} chi_grid;

static double theta_of_t(const chi_grid *g, double t) { return 2.0 * atan(g->s * t / (1.0 - t)); }
static double dtheta_dt(const chi_grid *g, double t) {
  return 2.0 * g->s / ((1.0 - t) * (1.0 - t) + g->s * g->s * t * t);
}

/* Mass of cell (it, ip) by the midpoint rule on sub x sub points. */
static double cell_mass_at(const vf_bsdf *b, const chi_grid *g, int it, int ip, int sub) {
  double sum = 0.0;
  for (int a = 0; a < sub; a++) {
    double t = (it + (a + 0.5) / sub) / CHI_T, th = theta_of_t(g, t), w = dtheta_dt(g, t) * sin(th);
    for (int q = 0; q < sub; q++) {
      dvec d = dframe_dir(&g->frame, th, 2.0 * PI_D * (ip + (q + 0.5) / sub) / CHI_PHI);
      float pdf = 0.0f;
      if (ddot(d, dv(b->frame.n)) * g->sign > 0.0) vf_bsdf_evaluate(b, fv(d), NULL, &pdf, NULL);
      sum += pdf * w;
    }
  }
  return sum * (2.0 * PI_D / CHI_PHI) / CHI_T / ((double)sub * sub);
}

/* The midpoint rule refined until its error bound is a twentieth of the cell's Poisson
 * noise, sqrt(mass / samples) (the horizon and the narrow lobes need the refinement):
 * what error is left cannot move the statistic. */
static double cell_mass(const vf_bsdf *b, const chi_grid *g, int it, int ip, double *error) {
  double m = cell_mass_at(b, g, it, ip, 8), finer = m;
  for (int sub = 16; sub <= 256; sub *= 2) {
    finer = cell_mass_at(b, g, it, ip, sub);
    /* three times the last change bounds the finer estimate's error where the rule
     * converges as sqrt(h) or faster (a cell across the horizon converges as h) */
    *error = 3.0 * fabs(finer - m);
    if (*error <= 0.05 * sqrt(finer / CHI_SAMPLES) + 1e-12) break;
    m = finer;
  }
  return finer;
}

static void grids_of(const config *c, chi_grid g[2]) {
  dvec up = c->up, fix = dv(c->fix);
  double s = fmin(1.0, fmax(0.02, 2.0 * alpha_of(c)));
  g[0] = (chi_grid){dframe_around(dreflect(fix, up)), s, 1.0};
  /* the refraction direction of the macro-surface by Snell's law (straight down past the
   * critical angle) */
  double eta = c->bsdf.eta, ci = ddot(fix, up), st2 = (1.0 - ci * ci) / (eta * eta);
  dvec t = st2 < 1.0 ? dsub(dscale(up, ci / eta - sqrt(1.0 - st2)), dscale(fix, 1.0 / eta)) : dscale(up, -1.0);
  g[1] = (chi_grid){dframe_around(dnormalize(t)), s, -1.0};
}

static void test_sampled_directions_follow_evaluated_pdf(void) {
  int tests = 0;
  for (int k = 0; k < ROUGH_CONFIG_COUNT; k++) {
    config c;
    make_rough_config(&c, k);
    if (c.ok && !c.bsdf.is_delta) tests++;
  }
  chi_family family = chi_family_of(tests);
  for (int k = 0; k < ROUGH_CONFIG_COUNT; k++) {
    config c;
    make_rough_config(&c, k);
    if (!c.ok || c.bsdf.is_delta) continue;
    chi_grid g[2];
    grids_of(&c, g);
    int sides = vf_is_zero(c.mc->material.dielectric) ? 1 : 2;
    enum { CELLS = CHI_T * CHI_PHI };
    static chi_cell cells[2 * CELLS];
    static double mass[2 * CELLS];
    double grid_mass = 0.0, quadrature_error = 0.0;
    for (int q = 0; q < sides * CELLS; q++) {
      int cell = q % CELLS;
      double error = 0.0;
      mass[q] = cell_mass(&c.bsdf, &g[q / CELLS], cell / CHI_PHI, cell % CHI_PHI, &error);
      grid_mass += mass[q];
      quadrature_error += error;
      cells[q].observed = 0;
    }
    vf_rng r = test_rng(CASE_ROUGH_CHI2, (uint64_t)k);
    long in_grid = 0;
    for (int i = 0; i < CHI_SAMPLES; i++) {
      bsdf_draw s = draw_sample(&c.bsdf, &r);
      if (vf_is_zero(s.f) || (s.event & VF_BSDF_SPECULAR)) continue;
      dvec d = dnormalize(dv(s.gen));
      int side = ddot(d, dv(c.bsdf.frame.n)) > 0.0 ? 0 : 1;
      if (side >= sides) continue;
      const chi_grid *gr = &g[side];
      double th = acos(fmax(-1.0, fmin(1.0, ddot(d, gr->frame.n))));
      double x = tan(0.5 * th), t = x / (gr->s + x);
      double ph = atan2(ddot(d, gr->frame.t), ddot(d, gr->frame.s));
      if (ph < 0.0) ph += 2.0 * PI_D;
      int it = (int)(t * CHI_T), ip = (int)(ph / (2.0 * PI_D / CHI_PHI));
      if (it >= CHI_T) it = CHI_T - 1;
      if (ip >= CHI_PHI) ip = CHI_PHI - 1;
      cells[side * CELLS + it * CHI_PHI + ip].observed++;
      in_grid++;
    }
    /* Every non-specular draw lands in a grid: the rate's allowance is the cells'
     * quadrature errors, summed. */
    chi_family_check(&family, c.label, cells, mass, sides * CELLS, grid_mass, c.bsdf.continuation, in_grid,
                     CHI_SAMPLES, 0.5 + CHI_SAMPLES * quadrature_error / c.bsdf.continuation, verbose);
  }
  chi_family_report(&family, CHI_SAMPLES);
}

/* ---- 4. albedo against the reference, energy ---- */

#define ALBEDO_SAMPLES 200000
#define REF_STEPS 250

/* The delta lobes' albedo at cos theta: the mirror's reflectance, the smooth dielectric's
 * tint (F + (1 - F)), the smooth conductor's tint x Fresnel. */
static double delta_albedo(const config *c, int ch) {
  const vf_material *m = &c->mc->material;
  const float *p = c->bsdf.lobe_probability;
  double a = vf_vec3_get(m->mirror, ch);
  if (p[VF_LOBE_DIELECTRIC] > 0.0f) a += vf_vec3_get(m->dielectric, ch);
  if (p[VF_LOBE_CONDUCTOR] > 0.0f) a += ref_conductor_reflectance(m, cos(c->theta), ch);
  return a;
}

static void test_albedo_matches_reference_and_is_at_most_one(void) {
  double worst_z = 0.0, max_albedo = 0.0;
  int exceeding = 0;
  for (int k = 0; k < ROUGH_CONFIG_COUNT; k++) {
    config c;
    make_rough_config(&c, k);
    if (!c.ok) continue;
    const vf_material *m = &c.mc->material;
    running_mean total[3] = {{0}};
    vf_rng r = test_rng(CASE_ROUGH_ALBEDO, (uint64_t)k);
    for (int i = 0; i < ALBEDO_SAMPLES; i++) {
      bsdf_draw s = draw_sample(&c.bsdf, &r);
      for (int ch = 0; ch < 3; ch++) rm_add(&total[ch], draw_weight(&c.bsdf, &s, ch));
    }
    ref_albedo ref;
    ref_rough_albedo(m, c.theta, c.bsdf.eta, REF_STEPS, &ref);
    for (int ch = 0; ch < 3; ch++) {
      double a = rm_mean(&total[ch]), se = rm_se(&total[ch]);
      double expected = vf_vec3_get(m->diffuse, ch) + delta_albedo(&c, ch) + ref.reflect[ch] + ref.transmit[ch];
      /* 2e-5: the quadrature (midpoint rule, h^2 ~ 6e-6) and float rounding of the samples */
      expect_near("albedo by importance sampling == reference quadrature", c.label, a, expected, K_SE * se + 2e-5);
      if (se > 0.0) worst_z = fmax(worst_z, fmax(0.0, fabs(a - expected) - 2e-5) / se);
      max_albedo = fmax(max_albedo, a);
      if (expected > 1.0 && m->gltf) {
        /* the glTF BRDF: 1 - F(0.04) on the base ignores what the specular layer reflects at
         * grazing angles (docs/SCENES.md) */
        if (ch == 0) printf("  info: %s: the glTF model's own albedo exceeds 1: reference %.4f, sampled %.4f\n", c.label,
                            expected, a);
        exceeding++;
      } else {
        expect_le("albedo <= 1 (reference)", c.label, expected, 1.0 + 1e-9);
        expect_le("albedo <= 1 (sampled)", c.label, a, 1.0 + K_SE * se + 2e-5);
      }
      if (verbose && ch == 0)
        printf("  %-36s red: albedo %.5f (se %.5f) reference %.5f = reflect %.5f + transmit %.5f + rest %.5f\n",
               c.label, a, se, expected, ref.reflect[0], ref.transmit[0],
               vf_vec3_get(m->diffuse, 0) + delta_albedo(&c, 0));
    }
  }
  printf("  info: %d importance samples per configuration, largest albedo %.5f, largest |z| %.2f (limit %.1f); "
         "%d channels of glTF configurations above 1 by the model itself\n",
         ALBEDO_SAMPLES, max_albedo, worst_z, K_SE, exceeding);
}

int main(void) {
  const char *v = getenv("VF_TEST_VERBOSE");
  verbose = v && v[0] == '1';
  RUN(test_sampled_pdf_matches_evaluated_pdf_and_radiance_btdf);
  RUN(test_reverse_pdf_is_swapped_direct_pdf_and_f_is_reciprocal);
  RUN(test_sampled_directions_follow_evaluated_pdf);
  RUN(test_albedo_matches_reference_and_is_at_most_one);
  return check_finish();
}
