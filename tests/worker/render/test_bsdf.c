/* Tests of worker/render/bsdf.c and worker/render/sampling.h against probability, never against numbers
 * copied from an earlier run: the densities and the directions drawn from them.
 * - pdf identities: the density vf_bsdf_sample() reports is the one vf_bsdf_evaluate() reports
 *   for the same direction, the reverse density is the direct density of the swapped edge
 *   (tech. rep. sec. 3-5), and f is reciprocal;
 * - the sampled directions follow that density (chi-square goodness of fit);
 * - vf_bsdf_init: what it refuses, and which materials it flags as delta;
 * - the warps of sampling.h (chi-square goodness of fit and moments).
 * Both chi-square families (the BSDF configurations and the five warps) live whole in this
 * file, since each Sidak correction counts its family's members. Sections keep the numbers of
 * the single file they came from (1a-1d, 3 and 4 here; 1e and 1f, energy, in
 * test_bsdf_energy.c; 2, specular geometry, in test_bsdf_specular.c); seeds, tolerances and
 * the configuration table are shared through bsdf_cases.h, which explains the statistical
 * budget. */
#include "check.h"
#include "bsdf_cases.h"
#include "worker/render/sampling.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

static int verbose;

/* ---- 1a. the sampled density is the evaluated density ---- */

#define PDF_REL_TOL 1e-4

static void test_sampled_pdf_matches_evaluated_pdf(void) {
  double worst_overall = 0.0, worst_raw[MATERIAL_COUNT] = {0};
  long nonspecular_total = 0;
  for (int k = 0; k < CONFIG_COUNT; k++) {
    config c;
    make_config(&c, k);
    CHECK(c.ok);
    if (!c.ok) continue;
    const vf_material *m = &c.mc->material;
    double n = m->phong_exponent;
    double pg = c.bsdf.lobe_probability[VF_LOBE_GLOSSY] * c.bsdf.continuation;
    vf_rng r = test_rng(CASE_PDF, (uint64_t)k);
    double worst_pdf = 0.0, worst_rev = 0.0, worst_f = 0.0, worst_cos = 0.0, raw = 0.0;
    long nonspecular = 0;
    for (int i = 0; i < 4000; i++) {
      float rnd[3], pdf, rev, cos_gen;
      vf_vec3 gen;
      unsigned event;
      draw3(&r, rnd);
      vf_vec3 f = vf_bsdf_sample(&c.bsdf, rnd, &gen, &pdf, &rev, &cos_gen, &event);
      if (vf_is_zero(f)) continue;
      if (event & VF_BSDF_SPECULAR) {
        expect_near("specular pdf == reverse pdf", c.label, rev, pdf, 0.0);
        continue;
      }
      nonspecular++;
      float e_cos, e_pdf, e_rev;
      vf_vec3 fe = vf_bsdf_evaluate(&c.bsdf, gen, &e_cos, &e_pdf, &e_rev);
      double cos_a = cos_to_mirror(dv(c.fix), dv(gen), c.up);
      double pdf_allow = glossy_rounding(pg * (n + 1.0) / (2.0 * PI_D), n, cos_a);
      /* the reverse density's glossy term has the same cosine, by the symmetry of the lobe */
      worst_pdf = fmax(worst_pdf, rel_err(pdf, e_pdf, pdf_allow));
      worst_rev = fmax(worst_rev, rel_err(rev, e_rev, pdf_allow));
      for (int ch = 0; ch < 3; ch++) {
        double f_allow = glossy_rounding(vf_vec3_get(m->glossy, ch) * (n + 2.0) / (2.0 * PI_D), n, cos_a);
        worst_f = fmax(worst_f, rel_err(vf_vec3_get(f, ch), vf_vec3_get(fe, ch), f_allow));
      }
      worst_cos = fmax(worst_cos, fabs(cos_gen - e_cos));
      raw = fmax(raw, fmax(rel_err(pdf, e_pdf, 0.0), rel_err(rev, e_rev, 0.0)));
      if (!(pdf > 0.0f) || !(rev > 0.0f)) CHECK_FAIL_("non-positive density [%s]: %g %g", c.label, pdf, rev);
    }
    if (has_nonspecular(m)) expect_ge("non-specular samples drawn", c.label, (double)nonspecular, 1.0);
    else expect_near("non-specular samples of a delta material", c.label, (double)nonspecular, 0.0, 0.0);
    expect_le("sample pdf vs evaluate direct pdf, worst rel. err", c.label, worst_pdf, PDF_REL_TOL);
    expect_le("sample reverse pdf vs evaluate reverse pdf, worst rel. err", c.label, worst_rev, PDF_REL_TOL);
    expect_le("sample f vs evaluate f, worst rel. err", c.label, worst_f, PDF_REL_TOL);
    expect_le("sample cos vs evaluate cos, worst abs. err", c.label, worst_cos, 4.0 * FLT_EPSILON);
    if (verbose)
      printf("  %-36s non-specular %4ld  rel err pdf %.2e rev %.2e f %.2e (raw pdf %.2e = %.3g n eps)\n", c.label,
             nonspecular, worst_pdf, worst_rev, worst_f, raw, n > 0.0 ? raw / (n * FLT_EPSILON) : 0.0);
    worst_overall = fmax(worst_overall, fmax(worst_pdf, fmax(worst_rev, worst_f)));
    worst_raw[c.mc - MATERIALS] = fmax(worst_raw[c.mc - MATERIALS], raw);
    nonspecular_total += nonspecular;
  }
  printf("  info: %ld non-specular samples, worst relative error beyond rounding bound %.2e\n", nonspecular_total,
         worst_overall);
  printf("  info: raw worst relative pdf error:");
  for (int i = 0; i < MATERIAL_COUNT; i++) printf(" %s %.1e", MATERIALS[i].name, worst_raw[i]);
  printf("\n");
}

/* ---- 1b, 1c. reverse density and reciprocity ---- */

static void test_reverse_pdf_is_swapped_direct_pdf_and_f_is_reciprocal(void) {
  double worst = 0.0;
  long pairs_total = 0;
  for (int k = 0; k < CONFIG_COUNT; k++) {
    config c;
    make_config(&c, k);
    if (!c.ok || c.mc->pdf_consistency_only) continue;
    const vf_material *m = &c.mc->material;
    double n = m->phong_exponent;
    double pg = c.bsdf.lobe_probability[VF_LOBE_GLOSSY] * c.bsdf.continuation;
    vf_rng r = test_rng(CASE_REVERSE, (uint64_t)k);
    double worst_rev = 0.0, worst_dir = 0.0, worst_f = 0.0;
    long pairs = 0, nonzero = 0;
    for (int i = 0; i < 2000; i++) {
      swapped_pair q;
      if (!make_swapped_pair(&c, &r, i, &q)) continue;
      pairs++;
      vf_vec3 b = q.b, f_ab = q.f_ab, f_ba = q.f_ba;
      float d_ab = q.d_ab, r_ab = q.r_ab, d_ba = q.d_ba, r_ba = q.r_ba;
      if (d_ab > 0.0f) nonzero++;
      double cos_a = cos_to_mirror(dv(c.fix), dv(b), c.up);
      /* both evaluations round the cosine independently */
      double allow = 2.0 * glossy_rounding(pg * (n + 1.0) / (2.0 * PI_D), n, cos_a);
      worst_rev = fmax(worst_rev, rel_err(r_ab, d_ba, allow));
      worst_dir = fmax(worst_dir, rel_err(r_ba, d_ab, allow));
      for (int ch = 0; ch < 3; ch++) {
        double f_allow = 2.0 * glossy_rounding(vf_vec3_get(m->glossy, ch) * (n + 2.0) / (2.0 * PI_D), n, cos_a);
        worst_f = fmax(worst_f, rel_err(vf_vec3_get(f_ab, ch), vf_vec3_get(f_ba, ch), f_allow));
      }
    }
    expect_le("evaluate(a,b).reverse vs evaluate(b,a).direct, worst rel. err", c.label, worst_rev, PDF_REL_TOL);
    expect_le("evaluate(b,a).reverse vs evaluate(a,b).direct, worst rel. err", c.label, worst_dir, PDF_REL_TOL);
    expect_le("f(a,b) vs f(b,a), worst rel. err", c.label, worst_f, PDF_REL_TOL);
    if (has_nonspecular(m)) expect_ge("pairs with non-zero density", c.label, (double)nonzero, 1.0);
    else expect_near("pairs with non-zero density, delta material", c.label, (double)nonzero, 0.0, 0.0);
    if (verbose)
      printf("  %-36s pairs %4ld (non-zero %4ld)  rel err rev %.2e dir %.2e f %.2e\n", c.label, pairs, nonzero,
             worst_rev, worst_dir, worst_f);
    worst = fmax(worst, fmax(worst_rev, fmax(worst_dir, worst_f)));
    pairs_total += pairs;
  }
  printf("  info: %ld pairs, worst relative error beyond rounding bound %.2e\n", pairs_total, worst);
}

/* ---- 1d. chi-square goodness of fit of the sampled directions ---- */

#define CHI_THETA 10
#define CHI_PHI 20
#define CHI_SAMPLES 200000
#define CHI_SUB 16

typedef struct {
  dframe frame;
  double theta_max;
} chi_grid;

/* Integral of evaluate's direct pdf over one (theta, phi) cell by the midpoint rule on
 * sub x sub points; cells across a discontinuity of the pdf (the horizon) are redone 8x
 * finer, which bounds the quadrature error there by ~1/256 of the cell's mass. */
static double cell_mass(const vf_bsdf *b, const chi_grid *g, int it, int ip, int sub) {
  double dth = g->theta_max / CHI_THETA, dph = 2.0 * PI_D / CHI_PHI;
  double sum = 0.0;
  int zero = 0, positive = 0;
  for (int a = 0; a < sub; a++) {
    double th = (it + (a + 0.5) / sub) * dth;
    for (int q = 0; q < sub; q++) {
      double ph = (ip + (q + 0.5) / sub) * dph;
      float pdf;
      vf_bsdf_evaluate(b, fv(dframe_dir(&g->frame, th, ph)), NULL, &pdf, NULL);
      sum += pdf * sin(th);
      if (pdf > 0.0f) positive++;
      else zero++;
    }
  }
  if (zero && positive && sub == CHI_SUB) return cell_mass(b, g, it, ip, 8 * sub);
  return sum * dth * dph / ((double)sub * sub);
}

static void test_sampled_directions_follow_evaluated_pdf(void) {
  int tests = 0;
  for (int k = 0; k < CONFIG_COUNT; k++) {
    config c;
    make_config(&c, k);
    if (c.ok && !c.mc->pdf_consistency_only && has_nonspecular(&c.mc->material)) tests++;
  }
  chi_family family = chi_family_of(tests);
  for (int k = 0; k < CONFIG_COUNT; k++) {
    config c;
    make_config(&c, k);
    const vf_material *m = &c.mc->material;
    if (!c.ok || c.mc->pdf_consistency_only || !has_nonspecular(m)) continue;
    /* Grid: the hemisphere around the shading normal when the density is broad (its only
     * discontinuity, the horizon, is then a cell edge); a cone of 5 lobe widths around the
     * mirror direction for narrow glossy lobes. */
    chi_grid g;
    double n = m->phong_exponent;
    if (vf_max_component(m->diffuse) > 0.0f || n < 30.0) {
      g.frame = dframe_around(c.up);
      g.theta_max = PI_D / 2.0;
    } else {
      g.frame = dframe_around(dreflect(dv(c.fix), c.up));
      g.theta_max = fmin(PI_D / 2.0, 5.0 / sqrt(n));
    }
    static chi_cell cells[CHI_THETA * CHI_PHI];
    static double mass[CHI_THETA * CHI_PHI];
    double grid_mass = 0.0;
    for (int q = 0; q < CHI_THETA * CHI_PHI; q++) {
      mass[q] = cell_mass(&c.bsdf, &g, q / CHI_PHI, q % CHI_PHI, CHI_SUB);
      grid_mass += mass[q];
      cells[q].observed = 0;
    }

    vf_rng r = test_rng(CASE_CHI2, (uint64_t)k);
    double dth = g.theta_max / CHI_THETA, dph = 2.0 * PI_D / CHI_PHI;
    long in_grid = 0;
    for (int i = 0; i < CHI_SAMPLES; i++) {
      bsdf_draw s = draw_sample(&c.bsdf, &r);
      if (vf_is_zero(s.f) || (s.event & VF_BSDF_SPECULAR)) continue;
      dvec d = dv(s.gen);
      double z = ddot(d, g.frame.n);
      double th = acos(fmax(-1.0, fmin(1.0, z / dlength(d))));
      if (!(th < g.theta_max)) continue;
      double ph = atan2(ddot(d, g.frame.t), ddot(d, g.frame.s));
      if (ph < 0.0) ph += 2.0 * PI_D;
      int it = (int)(th / dth), ip = (int)(ph / dph);
      if (it >= CHI_THETA) it = CHI_THETA - 1;
      if (ip >= CHI_PHI) ip = CHI_PHI - 1;
      cells[it * CHI_PHI + ip].observed++;
      in_grid++;
    }
    /* Allowance of the rate: two deterministic bounds, the midpoint rule's error
     * h^2 / 24 integral |f''|, with |f''| <~ 3 (n + 2) f for these cosine lobes and h the
     * quadrature step in theta; and the float bound of glossy_rounding() on the evaluated pdf,
     * n 8 FLT_EPSILON relative (it matters only for n >= 1e3). */
    double rate = grid_mass / c.bsdf.continuation;
    double h = g.theta_max / (CHI_THETA * CHI_SUB);
    double allowance = 0.5 + CHI_SAMPLES * rate * ((n + 2.0) * h * h / 8.0 + 8.0 * FLT_EPSILON * n);
    chi_family_check(&family, c.label, cells, mass, CHI_THETA * CHI_PHI, grid_mass, c.bsdf.continuation, in_grid,
                     CHI_SAMPLES, allowance, verbose);
  }
  chi_family_report(&family, CHI_SAMPLES);
}

/* ---- 3. vf_bsdf_init ---- */

static void test_init_refuses_black_and_tangent_and_flags_delta(void) {
  vf_vec3 normal, fix;
  dvec up;
  make_fix(0.5, 0.0, 1, &normal, &fix, &up);
  vf_bsdf b;
  static const vf_material black = {.ior = 1.5f, .phong_exponent = 10.0f};
  CHECK_INT_EQ(vf_bsdf_init(&b, &black, normal, fix), 0);
  CHECK_INT_EQ(vf_bsdf_init(&b, &black, normal, vf_neg(fix)), 0);

  static const vf_material grey = {.diffuse = RGB(0.5f, 0.5f, 0.5f)};
  CHECK_INT_EQ(vf_bsdf_init(&b, &grey, vf_vec3_make(0, 0, 1), vf_vec3_make(1, 0, 0)), 0);
  CHECK_INT_EQ(vf_bsdf_init(&b, &grey, vf_vec3_make(0, 0, 1), vf_vec3_make(0, 0, 1)), 1);
  /* a tangent to the tilted normal; its float dot with the normal is within init's 1e-7 */
  dvec tangent = dnormalize(dcross(dv(normal), dmake(0.2, 0.9, 0.1)));
  vf_vec3 tangent_f = fv(tangent);
  double tangent_dot = fabs(vf_dot(normal, tangent_f));
  expect_le("|normal . tangent| (test construction)", "tilted normal", tangent_dot, 1e-7);
  CHECK_INT_EQ(vf_bsdf_init(&b, &grey, normal, tangent_f), 0);

  static const struct {
    const char *name;
    vf_material m;
    int is_delta;
  } delta_cases[] = {
      {"diffuse", {.diffuse = RGB(0.5f, 0.5f, 0.5f)}, 0},
      {"glossy", {.glossy = RGB(0.5f, 0.5f, 0.5f), .phong_exponent = 10.0f}, 0},
      {"diffuse+mirror", {.diffuse = RGB(0.1f, 0.0f, 0.0f), .mirror = RGB(0.5f, 0.5f, 0.5f)}, 0},
      {"glossy+dielectric",
       {.glossy = RGB(0.0f, 0.0f, 0.01f), .phong_exponent = 10.0f, .dielectric = RGB(0.9f, 0.9f, 0.9f), .ior = 1.5f},
       0},
      {"mirror", {.mirror = RGB(0.5f, 0.5f, 0.5f)}, 1},
      {"dielectric", {.dielectric = RGB(1.0f, 1.0f, 1.0f), .ior = 1.5f}, 1},
      {"mirror+dielectric", {.mirror = RGB(0.2f, 0.2f, 0.2f), .dielectric = RGB(0.7f, 0.7f, 0.7f), .ior = 1.3f}, 1},
      {"mirror, black diffuse and glossy", {.mirror = RGB(0.5f, 0.4f, 0.3f), .phong_exponent = 10.0f}, 1},
  };
  vf_rng r = test_rng(CASE_HELPERS, 99);
  for (size_t i = 0; i < sizeof delta_cases / sizeof delta_cases[0]; i++)
    for (int side = 0; side < 2; side++) {
      vf_vec3 f_side = side ? vf_neg(fix) : fix;
      CHECK_INT_EQ(vf_bsdf_init(&b, &delta_cases[i].m, normal, f_side), 1);
      expect_near("is_delta", delta_cases[i].name, b.is_delta, delta_cases[i].is_delta, 0.0);
      double sum = 0.0;
      for (int l = 0; l < VF_LOBE_COUNT; l++) sum += b.lobe_probability[l];
      expect_near("sum of lobe probabilities", delta_cases[i].name, sum, 1.0, 4.0 * FLT_EPSILON);
      expect_le("continuation in (0, 1]", delta_cases[i].name, b.continuation, 1.0);
      expect_ge("continuation in (0, 1]", delta_cases[i].name, b.continuation, FLT_MIN);
      if (delta_cases[i].m.ior > 0.0f)
        expect_near("eta: ior entering, 1 / ior leaving", delta_cases[i].name, b.eta,
                    side ? 1.0f / delta_cases[i].m.ior : delta_cases[i].m.ior, 0.0);
      if (!delta_cases[i].is_delta) continue;
      for (int j = 0; j < 200; j++) {
        float cos_gen, d = -1.0f, rev = -1.0f;
        vf_vec3 f = vf_bsdf_evaluate(&b, fv(uniform_sphere_d(&r)), &cos_gen, &d, &rev);
        if (!vf_is_zero(f) || d != 0.0f || rev != 0.0f)
          CHECK_FAIL_("delta material [%s] evaluates to f %g, pdf %g, reverse %g", delta_cases[i].name, f.x, d, rev);
      }
    }
}

/* ---- 4. sampling.h ---- */

#define WARP_SAMPLES 400000

static void check_uniform_cells(const char *what, const long *counts, int cells, long samples) {
  static chi_cell c[1024];
  for (int i = 0; i < cells; i++) c[i] = (chi_cell){(double)samples / cells, counts[i]};
  double chi2;
  int dof;
  double p = chi_square_p(c, cells, &chi2, &dof);
  double alpha = sidak(5); /* the five warp fits below */
  if (!(p >= alpha)) CHECK_FAIL_("chi-square [%s]: chi2 %.1f with %d dof, p = %.3g < %.3g", what, chi2, dof, p, alpha);
  printf("  info: %s: chi2 %.1f, %d dof, p %.3f\n", what, chi2, dof, p);
}

static int polar_cell(double u, double phi, int nu, int nphi) {
  if (phi < 0.0) phi += 2.0 * PI_D;
  int iu = (int)(u * nu), ip = (int)(phi / (2.0 * PI_D) * nphi);
  if (iu >= nu) iu = nu - 1;
  if (iu < 0) iu = 0;
  if (ip >= nphi) ip = nphi - 1;
  return iu * nphi + ip;
}

static void test_cosine_hemisphere_warp(void) {
  vf_rng r = test_rng(CASE_HELPERS, 1);
  static long counts[200];
  running_mean z = {0}, z2 = {0}, x = {0}, y = {0};
  double worst_pdf = 0.0, worst_norm = 0.0;
  for (long i = 0; i < WARP_SAMPLES; i++) {
    float u1 = vf_rng_float(&r), u2 = vf_rng_float(&r), pdf;
    vf_vec3 d = vf_sample_cosine_hemisphere(u1, u2, &pdf);
    if (!(d.z > 0.0f)) CHECK_FAIL_("cosine hemisphere below the horizon: z = %g (u %g %g)", d.z, u1, u2);
    worst_norm = fmax(worst_norm, fabs(vf_length(d) - 1.0));
    worst_pdf = fmax(worst_pdf, fabs(pdf - d.z / PI_D));
    rm_add(&z, d.z);
    rm_add(&z2, d.z * d.z);
    rm_add(&x, d.x);
    rm_add(&y, d.y);
    /* under p = cos / pi, 1 - z^2 = sin^2 theta is uniform, and so is phi */
    counts[polar_cell(1.0 - (double)d.z * d.z, atan2(d.y, d.x), 10, 20)]++;
  }
  expect_le("|pdf - z / pi|", "cosine hemisphere", worst_pdf, 2.0 * FLT_EPSILON);
  expect_le("| |d| - 1 |", "cosine hemisphere", worst_norm, 4.0 * FLT_EPSILON);
  expect_near("E[z] = 2/3", "cosine hemisphere", rm_mean(&z), 2.0 / 3.0, K_SE * rm_se(&z));
  expect_near("E[z^2] = 1/2", "cosine hemisphere", rm_mean(&z2), 0.5, K_SE * rm_se(&z2));
  expect_near("E[x] = 0", "cosine hemisphere", rm_mean(&x), 0.0, K_SE * rm_se(&x));
  expect_near("E[y] = 0", "cosine hemisphere", rm_mean(&y), 0.0, K_SE * rm_se(&y));
  check_uniform_cells("cosine hemisphere (sin^2 theta, phi)", counts, 200, WARP_SAMPLES);
}

static void test_uniform_sphere_warp(void) {
  vf_rng r = test_rng(CASE_HELPERS, 2);
  static long counts[200];
  double worst_norm = 0.0;
  for (long i = 0; i < WARP_SAMPLES; i++) {
    vf_vec3 d = vf_sample_uniform_sphere(vf_rng_float(&r), vf_rng_float(&r));
    worst_norm = fmax(worst_norm, fabs(vf_length(d) - 1.0));
    counts[polar_cell(0.5 * (1.0 + d.z), atan2(d.y, d.x), 10, 20)]++; /* Archimedes: z is uniform */
  }
  expect_le("| |d| - 1 |", "uniform sphere", worst_norm, 4.0 * FLT_EPSILON);
  expect_near("VF_UNIFORM_SPHERE_PDF_W", "uniform sphere", VF_UNIFORM_SPHERE_PDF_W, 1.0 / (4.0 * PI_D), 1e-7);
  check_uniform_cells("uniform sphere (z, phi)", counts, 200, WARP_SAMPLES);
}

static void test_triangle_sampling_is_uniform(void) {
  /* The triangle cut into 8 x 8 = 64 congruent sub-triangles: a uniform point lands in each
   * with probability 1/64. */
  enum { K = 8 };
  vf_rng r = test_rng(CASE_HELPERS, 3);
  static long counts[K * K];
  running_mean mu = {0}, mv = {0};
  long outside = 0;
  for (long i = 0; i < WARP_SAMPLES; i++) {
    float bu, bv;
    vf_sample_triangle(vf_rng_float(&r), vf_rng_float(&r), &bu, &bv);
    if (bu < 0.0f || bv < 0.0f || bu + bv > 1.0f + FLT_EPSILON) outside++;
    rm_add(&mu, bu);
    rm_add(&mv, bv);
    double su = K * (double)bu, sv = K * (double)bv;
    int iu = (int)su, iv = (int)sv;
    if (iu >= K) iu = K - 1;
    if (iv >= K) iv = K - 1;
    if (iu + iv > K - 1) iv = K - 1 - iu;
    int upper = (su - iu) + (sv - iv) > 1.0 && iu + iv < K - 1;
    /* row iu holds K - iu upright triangles and K - iu - 1 inverted ones */
    int index = 0;
    for (int row = 0; row < iu; row++) index += 2 * (K - row) - 1;
    index += upper ? (K - iu) + iv : iv;
    counts[index]++;
  }
  expect_near("samples outside the triangle", "triangle", (double)outside, 0.0, 0.0);
  expect_near("E[u] = 1/3", "triangle", rm_mean(&mu), 1.0 / 3.0, K_SE * rm_se(&mu));
  expect_near("E[v] = 1/3", "triangle", rm_mean(&mv), 1.0 / 3.0, K_SE * rm_se(&mv));
  check_uniform_cells("triangle (64 sub-triangles)", counts, K * K, WARP_SAMPLES);
}

static void test_concentric_disk_is_uniform(void) {
  vf_rng r = test_rng(CASE_HELPERS, 4);
  static long counts[200];
  running_mean mx = {0}, my = {0}, mx2 = {0}, my2 = {0}, mxy = {0};
  long outside = 0;
  for (long i = 0; i < WARP_SAMPLES; i++) {
    float x, y;
    vf_sample_concentric_disk(vf_rng_float(&r), vf_rng_float(&r), &x, &y);
    double r2 = (double)x * x + (double)y * y;
    if (r2 > 1.0 + 4.0 * FLT_EPSILON) outside++;
    rm_add(&mx, x);
    rm_add(&my, y);
    rm_add(&mx2, (double)x * x);
    rm_add(&my2, (double)y * y);
    rm_add(&mxy, (double)x * y);
    counts[polar_cell(r2, atan2(y, x), 10, 20)]++; /* uniform on the disk: r^2 and phi uniform */
  }
  float x0, y0;
  vf_sample_concentric_disk(0.5f, 0.5f, &x0, &y0);
  expect_near("centre of the square -> centre of the disk", "disk", fabs(x0) + fabs(y0), 0.0, 0.0);
  expect_near("samples outside the unit disk", "disk", (double)outside, 0.0, 0.0);
  expect_near("E[x] = 0", "disk", rm_mean(&mx), 0.0, K_SE * rm_se(&mx));
  expect_near("E[y] = 0", "disk", rm_mean(&my), 0.0, K_SE * rm_se(&my));
  expect_near("E[x^2] = 1/4", "disk", rm_mean(&mx2), 0.25, K_SE * rm_se(&mx2));
  expect_near("E[y^2] = 1/4", "disk", rm_mean(&my2), 0.25, K_SE * rm_se(&my2));
  expect_near("E[xy] = 0", "disk", rm_mean(&mxy), 0.0, K_SE * rm_se(&mxy));
  check_uniform_cells("concentric disk (r^2, phi)", counts, 200, WARP_SAMPLES);
}

static void test_power_cosine_pdf_integrates_to_one(void) {
  static const float exponents[] = {0.0f, 1.0f, 10.0f, 100.0f, 1e4f, 1e5f};
  vf_rng r = test_rng(CASE_HELPERS, 5);
  for (int e = 0; e < 6; e++) {
    double n = exponents[e];
    char label[32];
    snprintf(label, sizeof label, "n = %g", n);
    /* midpoint rule in alpha over the hemisphere, 1e6 steps: ~300 per lobe width at n = 1e5 */
    const int steps = 1000000;
    double h = (PI_D / 2.0) / steps, sum = 0.0;
    for (int i = 0; i < steps; i++) {
      double alpha = (i + 0.5) * h;
      sum += vf_power_cosine_pdf_w((float)cos(alpha), (float)n) * sin(alpha);
    }
    double integral = 2.0 * PI_D * sum * h;
    /* float powf of a rounded cosine: relative error ~ n FLT_EPSILON / 2 per point, unbiased,
     * averaged over ~1e4 points inside the lobe; 1e-4 bounds the rest (midpoint rule O(h^2)) */
    expect_near("integral of the power-cosine pdf", label, integral, 1.0, 1e-4);
    expect_near("pdf below the horizon", label, vf_power_cosine_pdf_w(-0.5f, (float)n), 0.0, 0.0);
    /* the sampler: E[cos] = (n + 1) / (n + 2), and cos^(n + 1) is uniform (its moment 1/2) */
    running_mean c = {0};
    double worst_norm = 0.0;
    for (int i = 0; i < 100000; i++) {
      vf_vec3 d = vf_sample_power_cosine(vf_rng_float(&r), vf_rng_float(&r), (float)n);
      worst_norm = fmax(worst_norm, fabs(vf_length(d) - 1.0));
      rm_add(&c, 1.0 - d.z); /* 1 - cos keeps its precision for narrow lobes */
    }
    double expected = 1.0 - (n + 1.0) / (n + 2.0);
    /* float cosines near 1 are quantised to FLT_EPSILON / 2: a bias of at most that */
    expect_near("E[1 - cos] of the sampler = 1 / (n + 2)", label, rm_mean(&c), expected,
                K_SE * rm_se(&c) + FLT_EPSILON);
    expect_le("| |d| - 1 |", label, worst_norm, 4.0 * FLT_EPSILON);
    printf("  info: %s: pdf integral %.7f, E[1 - cos] %.4g vs %.4g\n", label, integral, rm_mean(&c), expected);
  }
}

/* The chi-square tail every goodness-of-fit test here rests on, against known values. */
static void test_gamma_q_known_values(void) {
  /* chi2 with 2 dof has Q = exp(-x / 2) */
  CHECK_NEAR(gamma_q(1.0, 3.0), exp(-3.0), 1e-12);
  CHECK_NEAR(gamma_q(5.0, 2.0), 0.947346982656289, 1e-12);
  /* integer a: Q(a, x) = exp(-x) sum_{k<a} x^k / k!, evaluated exactly elsewhere */
  CHECK_NEAR(gamma_q(50.0, 80.0), 1.3078397659141e-4, 1e-13);
}

int main(void) {
  const char *v = getenv("VF_TEST_VERBOSE");
  verbose = v && v[0] == '1';
  RUN(test_gamma_q_known_values);
  RUN(test_sampled_pdf_matches_evaluated_pdf);
  RUN(test_reverse_pdf_is_swapped_direct_pdf_and_f_is_reciprocal);
  RUN(test_sampled_directions_follow_evaluated_pdf);
  RUN(test_init_refuses_black_and_tangent_and_flags_delta);
  RUN(test_cosine_hemisphere_warp);
  RUN(test_uniform_sphere_warp);
  RUN(test_triangle_sampling_is_uniform);
  RUN(test_concentric_disk_is_uniform);
  RUN(test_power_cosine_pdf_integrates_to_one);
  return check_finish();
}
