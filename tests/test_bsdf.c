/* Tests of worker/bsdf.c and worker/sampling.h against physics and probability, never against
 * numbers copied from an earlier run:
 * - pdf identities: the density vf_bsdf_sample() reports is the one vf_bsdf_evaluate() reports
 *   for the same direction, the reverse density is the direct density of the swapped edge
 *   (tech. rep. sec. 3-5), and f is reciprocal;
 * - the sampled directions follow that density (chi-square goodness of fit), the density
 *   integrates to the probability of a non-specular event, and no material reflects more than
 *   it receives (directional albedo, with the analytic value where there is one);
 * - specular geometry: the mirror law, Snell's law, total internal reflection and the Fresnel
 *   equations, and the reflect/refract frequencies of the dielectric;
 * - the warps of sampling.h.
 *
 * Every random number comes from vf_rng_for_path(SEED, case, configuration, VF_STREAM_TEST),
 * so a run is deterministic and any configuration can be replayed alone (VF_TEST_VERBOSE=1
 * prints one line per configuration). Statistical checks allow K_SE standard errors, a
 * two-sided normal tail of 7e-6 per check: the ~1000 of them (many have zero variance) fail
 * together by chance with probability < 1%. Goodness-of-fit tests use a family-wise
 * significance of 1e-3 (Sidak-corrected per test). Floating-point tolerances are derived from
 * FLT_EPSILON and the condition of the quantity checked. A different seed can be compiled in
 * with -DSEED=... to look at the spread of the statistics, never to make a test pass. */
#include "check.h"
#include "common/rng.h"
#include "common/vec3.h"
#include "worker/bsdf.h"
#include "worker/material.h"
#include "worker/sampling.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#ifndef SEED
#define SEED 0x0b5df00dULL
#endif
#define K_SE 4.5
#define FAMILY_SIGNIFICANCE 1e-3
#define PI_D 3.14159265358979323846

enum { CASE_PDF = 1, CASE_REVERSE, CASE_CHI2, CASE_INTEGRAL, CASE_ALBEDO, CASE_SPECULAR, CASE_HELPERS };

static int verbose;

static vf_rng test_rng(uint64_t test_case, uint64_t configuration) {
  return vf_rng_for_path(SEED, test_case, configuration, VF_STREAM_TEST);
}

static void draw3(vf_rng *r, float rnd[3]) {
  rnd[0] = vf_rng_float(r);
  rnd[1] = vf_rng_float(r);
  rnd[2] = vf_rng_float(r);
}

static void expect_le(const char *what, const char *where, double value, double limit) {
  if (!(value <= limit)) CHECK_FAIL_("%s [%s]: %.9g > limit %.9g", what, where, value, limit);
}

static void expect_ge(const char *what, const char *where, double value, double limit) {
  if (!(value >= limit)) CHECK_FAIL_("%s [%s]: %.9g < limit %.9g", what, where, value, limit);
}

static void expect_near(const char *what, const char *where, double value, double expected, double tol) {
  if (!(fabs(value - expected) <= tol))
    CHECK_FAIL_("%s [%s]: %.9g vs expected %.9g (|diff| %.3g > tol %.3g)", what, where, value, expected,
                fabs(value - expected), tol);
}

/* ---- double-precision geometry, independent of the code under test ---- */

typedef struct {
  double x, y, z;
} dvec;

static dvec dv(vf_vec3 v) { return (dvec){v.x, v.y, v.z}; }
static vf_vec3 fv(dvec v) { return vf_vec3_make((float)v.x, (float)v.y, (float)v.z); }
static dvec dmake(double x, double y, double z) { return (dvec){x, y, z}; }
static dvec dadd(dvec a, dvec b) { return (dvec){a.x + b.x, a.y + b.y, a.z + b.z}; }
static dvec dsub(dvec a, dvec b) { return (dvec){a.x - b.x, a.y - b.y, a.z - b.z}; }
static dvec dscale(dvec a, double s) { return (dvec){a.x * s, a.y * s, a.z * s}; }
static double ddot(dvec a, dvec b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static dvec dcross(dvec a, dvec b) {
  return (dvec){a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
static double dlength(dvec a) { return sqrt(ddot(a, a)); }
static dvec dnormalize(dvec a) { return dscale(a, 1.0 / dlength(a)); }
static dvec dreflect(dvec v, dvec n) { return dsub(dscale(n, 2.0 * ddot(v, n)), v); }

typedef struct {
  dvec s, t, n;
} dframe;

static dframe dframe_around(dvec n) {
  dvec helper = fabs(n.x) < 0.9 ? dmake(1, 0, 0) : dmake(0, 1, 0);
  dframe f;
  f.n = n;
  f.s = dnormalize(dcross(helper, n));
  f.t = dcross(n, f.s);
  return f;
}

static dvec dframe_dir(const dframe *f, double theta, double phi) {
  double st = sin(theta);
  return dadd(dadd(dscale(f->s, st * cos(phi)), dscale(f->t, st * sin(phi))), dscale(f->n, cos(theta)));
}

/* Uniform direction on the sphere, in double (the reference sampler of the integral tests). */
static dvec uniform_sphere_d(vf_rng *r) {
  double z = 1.0 - 2.0 * ((double)vf_rng_float(r) + 0x1p-25);
  double phi = 2.0 * PI_D * vf_rng_float(r);
  double s = sqrt(fmax(0.0, 1.0 - z * z));
  return dmake(s * cos(phi), s * sin(phi), z);
}

/* ---- statistics ---- */

/* Regularised upper incomplete gamma Q(a, x): the chi-square tail is Q(dof / 2, chi2 / 2).
 * Series for P = 1 - Q below x = a + 1, Lentz's continued fraction for Q above (Numerical
 * Recipes, sec. 6.2); main() checks it against closed forms. */
static double gamma_q(double a, double x) {
  if (x <= 0.0) return 1.0;
  double log_prefactor = -x + a * log(x) - lgamma(a);
  if (x < a + 1.0) {
    double ap = a, del = 1.0 / a, sum = del;
    for (int i = 0; i < 10000 && fabs(del) > fabs(sum) * 1e-16; i++) {
      ap += 1.0;
      del *= x / ap;
      sum += del;
    }
    return fmax(0.0, 1.0 - sum * exp(log_prefactor));
  }
  double b = x + 1.0 - a, c = 1e300, d = 1.0 / b, h = d;
  for (int i = 1; i < 10000; i++) {
    double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (fabs(d) < 1e-300) d = 1e-300;
    c = b + an / c;
    if (fabs(c) < 1e-300) c = 1e-300;
    d = 1.0 / d;
    double del = d * c;
    h *= del;
    if (fabs(del - 1.0) < 1e-16) break;
  }
  return exp(log_prefactor) * h;
}

typedef struct {
  double expected;
  long observed;
} chi_cell;

static int compare_expected(const void *a, const void *b) {
  double ea = ((const chi_cell *)a)->expected, eb = ((const chi_cell *)b)->expected;
  return (ea > eb) - (ea < eb);
}

/* Pearson chi-square of observed against expected counts; cells are pooled, smallest expected
 * first, until every pooled cell expects at least 5. Returns the p-value; sorts `cells`. */
static double chi_square_p(chi_cell *cells, int count, double *chi2_out, int *dof_out) {
  qsort(cells, (size_t)count, sizeof *cells, compare_expected);
  double chi2 = 0.0, pool_e = 0.0, last_e = 0.0;
  long pool_o = 0, last_o = 0;
  int bins = 0, have_last = 0;
  for (int i = 0; i < count; i++) {
    pool_e += cells[i].expected;
    pool_o += cells[i].observed;
    if (pool_e >= 5.0) {
      if (have_last) chi2 += (last_o - last_e) * (last_o - last_e) / last_e;
      last_e = pool_e;
      last_o = pool_o;
      have_last = 1;
      bins++;
      pool_e = 0.0;
      pool_o = 0;
    }
  }
  /* A remainder that expects fewer than 5 joins the last bin. */
  last_e += pool_e;
  last_o += pool_o;
  if (have_last || last_e > 0.0) chi2 += (last_o - last_e) * (last_o - last_e) / fmax(last_e, 1e-300);
  if (!have_last) bins = 1;
  int dof = bins - 1;
  *chi2_out = chi2;
  *dof_out = dof;
  return dof > 0 ? gamma_q(0.5 * dof, 0.5 * chi2) : (chi2 == 0.0 ? 1.0 : 0.0);
}

static double sidak(int tests) { return 1.0 - pow(1.0 - FAMILY_SIGNIFICANCE, 1.0 / tests); }

typedef struct {
  double sum, sum_sq;
  long n;
} running_mean;

static void rm_add(running_mean *m, double v) {
  m->sum += v;
  m->sum_sq += v * v;
  m->n++;
}
static double rm_mean(const running_mean *m) { return m->sum / (double)m->n; }
static double rm_se(const running_mean *m) {
  double mean = rm_mean(m);
  double var = fmax(0.0, m->sum_sq / (double)m->n - mean * mean);
  return sqrt(var / (double)(m->n - 1));
}

/* ---- materials and configurations ---- */

typedef struct {
  const char *name;
  vf_material material;
  int pdf_consistency_only; /* exponent 1e5: the float pdf is only good to ~2% (2 n FLT_EPSILON) */
} material_case;

#define RGB(r, g, b) {r, g, b}
static const material_case MATERIALS[] = {
    {"diffuse", {.diffuse = RGB(0.8f, 0.5f, 0.2f)}, 0},
    {"phong1", {.glossy = RGB(0.9f, 0.7f, 0.5f), .phong_exponent = 1.0f}, 0},
    {"phong10", {.glossy = RGB(0.9f, 0.7f, 0.5f), .phong_exponent = 10.0f}, 0},
    {"phong100", {.glossy = RGB(0.9f, 0.7f, 0.5f), .phong_exponent = 100.0f}, 0},
    {"phong1e4", {.glossy = RGB(0.9f, 0.7f, 0.5f), .phong_exponent = 1e4f}, 0},
    {"phong1e5", {.glossy = RGB(0.9f, 0.7f, 0.5f), .phong_exponent = 1e5f}, 1},
    {"diffuse+glossy",
     {.diffuse = RGB(0.4f, 0.3f, 0.2f), .glossy = RGB(0.5f, 0.4f, 0.6f), .phong_exponent = 20.0f},
     0},
    {"diffuse+mirror", {.diffuse = RGB(0.5f, 0.3f, 0.2f), .mirror = RGB(0.4f, 0.5f, 0.3f)}, 0},
    {"glossy+dielectric",
     {.glossy = RGB(0.2f, 0.3f, 0.1f), .phong_exponent = 50.0f, .dielectric = RGB(0.7f, 0.6f, 0.8f), .ior = 1.5f},
     0},
    {"mirror", {.mirror = RGB(0.9f, 0.8f, 0.7f)}, 0},
    {"dielectric1.6", {.dielectric = RGB(1.0f, 1.0f, 1.0f), .ior = 1.6f}, 0},
    {"dielectric1.0001", {.dielectric = RGB(1.0f, 1.0f, 1.0f), .ior = 1.0001f}, 0},
    {"dielectric3", {.dielectric = RGB(1.0f, 1.0f, 1.0f), .ior = 3.0f}, 0},
};
#define MATERIAL_COUNT ((int)(sizeof MATERIALS / sizeof MATERIALS[0]))

static const double ANGLES_DEG[] = {0.0, 45.0, 85.0};
#define ANGLE_COUNT 3
#define CONFIG_COUNT (MATERIAL_COUNT * ANGLE_COUNT * 2)

typedef struct {
  const material_case *mc;
  char label[96];
  vf_vec3 normal; /* geometric, unit */
  vf_vec3 fix;    /* unit, world */
  dvec up;        /* geometric normal turned to the side of fix */
  double theta;   /* angle of fix to up */
  vf_bsdf bsdf;
  int ok;         /* vf_bsdf_init's result */
} config;

/* A normal off every axis so that the shading frames are not trivial. */
static dvec geometric_normal_d(void) { return dnormalize(dmake(0.3, -0.5, 0.81)); }

static void make_fix(double theta, double azimuth, int front, vf_vec3 *normal, vf_vec3 *fix, dvec *up) {
  dvec n = geometric_normal_d();
  dvec u = front ? n : dscale(n, -1.0);
  dframe f = dframe_around(u);
  dvec d = dframe_dir(&f, theta, azimuth);
  *normal = fv(n);
  *fix = vf_normalize(fv(d));
  *up = u;
}

static void make_config(config *c, int index) {
  int side = index % 2, angle = (index / 2) % ANGLE_COUNT, m = index / (2 * ANGLE_COUNT);
  c->mc = &MATERIALS[m];
  c->theta = ANGLES_DEG[angle] * PI_D / 180.0;
  make_fix(c->theta, 0.7, side == 0, &c->normal, &c->fix, &c->up);
  snprintf(c->label, sizeof c->label, "%s, %g deg, %s", c->mc->name, ANGLES_DEG[angle],
           side == 0 ? "front" : "back");
  c->ok = vf_bsdf_init(&c->bsdf, &c->mc->material, c->normal, c->fix);
}

static int has_nonspecular(const vf_material *m) {
  return vf_max_component(m->diffuse) > 0.0f || vf_max_component(m->glossy) > 0.0f;
}

/* cos of the angle between gen and the mirror direction of fix about up (double). */
static double cos_to_mirror(dvec fix, dvec gen, dvec up) { return ddot(dreflect(fix, up), gen); }

/* First-order bound on how far a float evaluation of the glossy term can move when the cosine
 * to the mirror direction carries an absolute rounding error delta: d/dc (c^n) = n c^(n-1).
 * `scale` is (n + 1) / (2 pi) times the lobe weight (pdf) or (n + 2) / (2 pi) times the albedo
 * (f). The directions pass through two float frame changes and a normalisation, a few
 * FLT_EPSILON each; delta = 8 FLT_EPSILON bounds that (the worst relative pdf difference
 * measured at n = 1e4 and 1e5 is 2.0 n FLT_EPSILON, a quarter of the bound). */
static double glossy_rounding(double scale, double n, double cos_a) {
  const double delta = 8.0 * FLT_EPSILON;
  if (n <= 0.0) return 0.0;
  double c = fmin(1.0, fmax(0.0, cos_a) + delta);
  return scale * n * pow(c, n - 1.0) * delta;
}

static double rel_err(double a, double b, double abs_allowance) {
  double diff = fabs(a - b) - abs_allowance;
  if (diff <= 0.0) return 0.0;
  double scale = fmax(fabs(a), fabs(b));
  return scale > 0.0 ? diff / scale : 0.0;
}

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
      /* b: half from the sampler (where the lobes are), half uniform (both sides, edges) */
      vf_vec3 b = fv(uniform_sphere_d(&r));
      if (i % 2 == 0) {
        float rnd[3], pdf, rev, cos_gen;
        vf_vec3 gen;
        unsigned event;
        draw3(&r, rnd);
        vf_vec3 f = vf_bsdf_sample(&c.bsdf, rnd, &gen, &pdf, &rev, &cos_gen, &event);
        if (!vf_is_zero(f) && !(event & VF_BSDF_SPECULAR)) b = vf_normalize(gen);
      }
      vf_bsdf swapped;
      if (!vf_bsdf_init(&swapped, m, c.normal, b)) continue;
      pairs++;
      float d_ab, r_ab, d_ba, r_ba;
      vf_vec3 f_ab = vf_bsdf_evaluate(&c.bsdf, b, NULL, &d_ab, &r_ab);
      vf_vec3 f_ba = vf_bsdf_evaluate(&swapped, c.fix, NULL, &d_ba, &r_ba);
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
  double alpha = sidak(tests), min_p = 1.0, worst_rate_z = 0.0;
  char min_label[96] = "";
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
      float rnd[3], pdf, rev, cos_gen;
      vf_vec3 gen;
      unsigned event;
      draw3(&r, rnd);
      vf_vec3 f = vf_bsdf_sample(&c.bsdf, rnd, &gen, &pdf, &rev, &cos_gen, &event);
      if (vf_is_zero(f) || (event & VF_BSDF_SPECULAR)) continue;
      dvec d = dv(gen);
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
    /* Rate: a draw is a non-specular sample inside the grid with probability
     * grid_mass / continuation (binomial). Two deterministic allowances: the midpoint rule's
     * error h^2 / 24 integral |f''|, with |f''| <~ 3 (n + 2) f for these cosine lobes and h the
     * quadrature step in theta; and the float bound of glossy_rounding() on the evaluated pdf,
     * n 8 FLT_EPSILON relative (it matters only for n >= 1e3). */
    double rate = grid_mass / c.bsdf.continuation;
    double rate_sd = sqrt(CHI_SAMPLES * rate * fmax(0.0, 1.0 - rate));
    double h = g.theta_max / (CHI_THETA * CHI_SUB);
    double allowance = 0.5 + CHI_SAMPLES * rate * ((n + 2.0) * h * h / 8.0 + 8.0 * FLT_EPSILON * n);
    expect_near("non-specular draws inside the grid", c.label, (double)in_grid, CHI_SAMPLES * rate,
                K_SE * rate_sd + allowance);
    double rate_z = rate_sd > 0.0 ? fmax(0.0, fabs(in_grid - CHI_SAMPLES * rate) - allowance) / rate_sd : 0.0;
    worst_rate_z = fmax(worst_rate_z, rate_z);
    /* Shape: given the count inside the grid, the cells are multinomial with probabilities
     * proportional to the integrated pdf. */
    for (int q = 0; q < CHI_THETA * CHI_PHI; q++) cells[q].expected = in_grid * mass[q] / grid_mass;
    double chi2;
    int dof;
    double p = chi_square_p(cells, CHI_THETA * CHI_PHI, &chi2, &dof);
    if (!(p >= alpha))
      CHECK_FAIL_("chi-square [%s]: chi2 %.1f with %d dof, p = %.3g < %.3g", c.label, chi2, dof, p, alpha);
    if (verbose)
      printf("  %-36s chi2 %8.1f dof %3d p %.3f  in grid %6ld expected %8.1f (z %.2f)\n", c.label, chi2, dof, p,
             in_grid, CHI_SAMPLES * rate, rate_z);
    if (p < min_p) {
      min_p = p;
      snprintf(min_label, sizeof min_label, "%s", c.label);
    }
  }
  printf("  info: %d chi-square tests of %d samples, per-test significance %.2e, smallest p %.4f (%s); "
         "largest |z| of the in-grid rate beyond allowances %.2f\n",
         tests, CHI_SAMPLES, alpha, min_p, min_label, worst_rate_z);
}

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
      float rnd[3], pdf, rev, cos_gen;
      vf_vec3 gen;
      unsigned event = 0;
      draw3(&r, rnd);
      vf_vec3 f = vf_bsdf_sample(&c.bsdf, rnd, &gen, &pdf, &rev, &cos_gen, &event);
      int ok = !vf_is_zero(f);
      int spec = ok && (event & VF_BSDF_SPECULAR);
      for (int ch = 0; ch < 3; ch++) {
        /* the caller's Russian roulette survives with probability `continuation` */
        double w = ok ? vf_vec3_get(f, ch) * cos_gen / pdf * c.bsdf.continuation : 0.0;
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

/* ---- 2. specular geometry ---- */

/* Fresnel reflectance of unpolarised light from n1 into n2, from the angle forms of the
 * Fresnel equations (Born and Wolf) rather than the cosine forms bsdf.c uses. */
static double fresnel_reference(double theta_i, double n1, double n2) {
  double s = n1 / n2 * sin(theta_i);
  if (s >= 1.0) return 1.0;
  if (theta_i == 0.0) {
    double r0 = (n1 - n2) / (n1 + n2);
    return r0 * r0;
  }
  double theta_t = asin(s);
  double rs = -sin(theta_i - theta_t) / sin(theta_i + theta_t);
  double rp = tan(theta_i - theta_t) / tan(theta_i + theta_t);
  return 0.5 * (rs * rs + rp * rp);
}

static void test_mirror_reflection_is_exact(void) {
  static const vf_material mirror = {.mirror = RGB(0.9f, 0.8f, 0.7f)};
  static const double angles[] = {0.0, 10.0, 30.0, 45.0, 60.0, 75.0, 85.0, 89.9};
  double worst = 0.0;
  vf_rng r = test_rng(CASE_SPECULAR, 0);
  for (int a = 0; a < 8; a++)
    for (int side = 0; side < 2; side++)
      for (int az = 0; az < 3; az++) {
        vf_vec3 normal, fix;
        dvec up;
        make_fix(angles[a] * PI_D / 180.0, 2.1 * az, side == 0, &normal, &fix, &up);
        char label[64];
        snprintf(label, sizeof label, "%g deg, %s, azimuth %d", angles[a], side == 0 ? "front" : "back", az);
        vf_bsdf b;
        CHECK(vf_bsdf_init(&b, &mirror, normal, fix));
        CHECK(b.is_delta);
        float rnd[3], pdf, rev, cos_gen;
        vf_vec3 gen;
        unsigned event;
        draw3(&r, rnd);
        vf_vec3 f = vf_bsdf_sample(&b, rnd, &gen, &pdf, &rev, &cos_gen, &event);
        CHECK(event & VF_BSDF_SPECULAR);
        dvec expected = dreflect(dv(fix), dv(normal));
        double err = dlength(dsub(dv(gen), expected));
        worst = fmax(worst, err);
        /* a float frame change there and back: a few FLT_EPSILON */
        expect_le("|gen - (2 (n.fix) n - fix)|", label, err, 8.0 * FLT_EPSILON);
        expect_near("cos_gen == |n.gen|", label, cos_gen, fabs(ddot(dv(normal), expected)), 8.0 * FLT_EPSILON);
        expect_near("pdf == continuation (only lobe)", label, pdf, b.continuation, 0.0);
        expect_near("reverse pdf == pdf", label, rev, pdf, 0.0);
        for (int ch = 0; ch < 3; ch++)
          expect_near("throughput f cos / pdf * continuation == reflectance", label,
                      vf_vec3_get(f, ch) * cos_gen / pdf * b.continuation, vf_vec3_get(mirror.mirror, ch), 1e-6);
      }
  printf("  info: worst distance to the mirror direction %.2e\n", worst);
}

/* Draws from a pure dielectric until `want` refractions (or 4000 draws) and checks their
 * geometry; every reflection must be the mirror direction. */
static void check_dielectric_geometry(float ior, double theta, int front, int want, vf_rng *r,
                                      double *worst_snell) {
  vf_material glass = {.dielectric = RGB(1.0f, 1.0f, 1.0f), .ior = ior};
  vf_vec3 normal, fix;
  dvec up;
  make_fix(theta, 1.3, front, &normal, &fix, &up);
  char label[80];
  snprintf(label, sizeof label, "ior %g, %.3f deg, %s", ior, theta * 180.0 / PI_D, front ? "entering" : "leaving");
  vf_bsdf b;
  CHECK(vf_bsdf_init(&b, &glass, normal, fix));
  double n1 = front ? 1.0 : ior, n2 = front ? ior : 1.0;
  expect_near("bsdf.eta == n2 / n1", label, b.eta, (float)(n2 / n1), 0.0);
  dvec fixd = dv(fix), tangent_fix = dsub(fixd, dscale(up, ddot(fixd, up)));
  double sin1 = dlength(tangent_fix);
  int refractions = 0;
  for (int i = 0; i < 4000 && refractions < want; i++) {
    float rnd[3], pdf, rev, cos_gen;
    vf_vec3 gen;
    unsigned event;
    draw3(r, rnd);
    vf_vec3 f = vf_bsdf_sample(&b, rnd, &gen, &pdf, &rev, &cos_gen, &event);
    if (vf_is_zero(f)) {
      CHECK_FAIL_("dielectric sample failed [%s] (rnd %g %g %g)", label, rnd[0], rnd[1], rnd[2]);
      continue;
    }
    CHECK(event & VF_BSDF_SPECULAR);
    dvec g = dv(gen);
    expect_near("|gen|", label, dlength(g), 1.0, 8.0 * FLT_EPSILON);
    expect_near("throughput f cos / pdf * continuation (tint 1)", label, f.x * cos_gen / pdf * b.continuation, 1.0,
                1e-5);
    if (ddot(g, up) > 0.0) {
      expect_le("reflection: |gen - mirror direction|", label, dlength(dsub(g, dreflect(fixd, up))),
                8.0 * FLT_EPSILON);
      continue;
    }
    refractions++;
    dvec tangent_gen = dsub(g, dscale(up, ddot(g, up)));
    double sin2 = dlength(tangent_gen);
    double snell = fabs(n1 * sin1 - n2 * sin2);
    *worst_snell = fmax(*worst_snell, snell);
    /* directions are float (error a few FLT_EPSILON), the sines scaled by an ior up to 3 */
    expect_le("Snell: |n1 sin t1 - n2 sin t2|", label, snell, 16.0 * 3.0 * FLT_EPSILON);
    expect_near("cos_gen == |n.gen|", label, cos_gen, fabs(ddot(g, up)), 8.0 * FLT_EPSILON);
    if (sin1 > 1e-3) {
      dvec plane = dnormalize(dcross(up, fixd));
      expect_le("refracted ray leaves the plane of incidence", label, fabs(ddot(g, plane)), 8.0 * FLT_EPSILON);
      expect_le("refracted ray continues across (tangential parts opposite)", label, ddot(tangent_gen, tangent_fix),
                0.0);
    }
  }
  /* with F < 0.9, 4000 draws expect at least 400 refractions */
  if (fresnel_reference(theta, n1, n2) < 0.9) expect_ge("refractions drawn", label, (double)refractions, want);
}

static void test_dielectric_refraction_obeys_snell(void) {
  static const float iors[] = {1.6f, 3.0f, 1.0001f, 1.5f};
  vf_rng r = test_rng(CASE_SPECULAR, 1);
  double worst = 0.0;
  for (int i = 0; i < 4; i++) {
    static const double entering_deg[] = {0.0, 20.0, 45.0, 70.0, 85.0, 89.0};
    for (int a = 0; a < 6; a++)
      check_dielectric_geometry(iors[i], entering_deg[a] * PI_D / 180.0, 1, 50, &r, &worst);
    double critical = asin(1.0 / iors[i]);
    static const double fractions[] = {0.0, 0.3, 0.6, 0.9, 0.99};
    for (int a = 0; a < 5; a++) check_dielectric_geometry(iors[i], fractions[a] * critical, 0, 50, &r, &worst);
  }
  printf("  info: worst |n1 sin t1 - n2 sin t2| %.2e\n", worst);
}

static void test_total_internal_reflection_beyond_critical_angle(void) {
  static const float iors[] = {1.6f, 3.0f, 1.5f};
  vf_rng r = test_rng(CASE_SPECULAR, 2);
  for (int i = 0; i < 3; i++) {
    double critical = asin(1.0 / iors[i]);
    static const double beyond[] = {1.01, 1.2, 1.5};
    for (int a = 0; a < 3; a++) {
      double theta = fmin(beyond[a] * critical, 89.0 * PI_D / 180.0);
      vf_material glass = {.dielectric = RGB(1.0f, 1.0f, 1.0f), .ior = iors[i]};
      vf_vec3 normal, fix;
      dvec up;
      make_fix(theta, 0.4, 0, &normal, &fix, &up);
      char label[80];
      snprintf(label, sizeof label, "ior %g, leaving at %.2f x critical", iors[i], theta / critical);
      vf_bsdf b;
      CHECK(vf_bsdf_init(&b, &glass, normal, fix));
      expect_near("Fresnel reflectance beyond the critical angle", label, b.fresnel, 1.0, 0.0);
      long reflections = 0, draws = 1000;
      for (long j = 0; j < draws; j++) {
        float rnd[3], pdf, rev, cos_gen;
        vf_vec3 gen;
        unsigned event;
        draw3(&r, rnd);
        vf_vec3 f = vf_bsdf_sample(&b, rnd, &gen, &pdf, &rev, &cos_gen, &event);
        if (!vf_is_zero(f) && ddot(dv(gen), up) > 0.0 &&
            dlength(dsub(dv(gen), dreflect(dv(fix), up))) <= 8.0 * FLT_EPSILON)
          reflections++;
      }
      expect_near("draws that reflect to the mirror direction", label, (double)reflections, (double)draws, 0.0);
    }
  }
}

static void test_dielectric_reflects_with_fresnel_frequency(void) {
  static const float iors[] = {1.6f, 3.0f, 1.0001f};
  static const double fractions_of_limit[] = {0.0, 0.35, 0.7, 0.9, 0.97};
  const long draws = 20000;
  vf_rng r = test_rng(CASE_SPECULAR, 3);
  double worst_z = 0.0;
  for (int i = 0; i < 3; i++)
    for (int side = 0; side < 2; side++)
      for (int a = 0; a < 5; a++) {
        int front = side == 0;
        double limit = front ? PI_D / 2.0 : asin(1.0 / iors[i]);
        double theta = fractions_of_limit[a] * limit;
        vf_material glass = {.dielectric = RGB(1.0f, 1.0f, 1.0f), .ior = iors[i]};
        vf_vec3 normal, fix;
        dvec up;
        make_fix(theta, 2.5, front, &normal, &fix, &up);
        char label[80];
        snprintf(label, sizeof label, "ior %g, %.2f deg, %s", iors[i], theta * 180.0 / PI_D,
                 front ? "entering" : "leaving");
        double n1 = front ? 1.0 : iors[i], n2 = front ? iors[i] : 1.0;
        /* the angle of the float direction actually used */
        double theta_used = acos(fmin(1.0, ddot(dv(fix), up)));
        double fresnel = fresnel_reference(theta_used, n1, n2);
        vf_bsdf b;
        CHECK(vf_bsdf_init(&b, &glass, normal, fix));
        expect_near("bsdf.fresnel vs Fresnel equations", label, b.fresnel, fresnel, 2e-6);
        long reflections = 0;
        for (long j = 0; j < draws; j++) {
          float rnd[3], pdf, rev, cos_gen;
          vf_vec3 gen;
          unsigned event;
          draw3(&r, rnd);
          vf_vec3 f = vf_bsdf_sample(&b, rnd, &gen, &pdf, &rev, &cos_gen, &event);
          if (!vf_is_zero(f) && ddot(dv(gen), up) > 0.0) reflections++;
        }
        double mean = draws * fresnel, sd = sqrt(draws * fresnel * (1.0 - fresnel));
        /* binomial: K_SE standard deviations, plus one half for the integer count */
        expect_near("reflections out of 20000 draws", label, (double)reflections, mean, K_SE * sd + 0.5);
        if (sd > 0.0) worst_z = fmax(worst_z, fabs(reflections - mean) / sd);
        if (verbose) printf("  %-40s F %.6f reflections %6ld expected %9.1f\n", label, fresnel, reflections, mean);
      }
  printf("  info: 30 binomial tests of %ld draws, largest |z| %.2f (limit %.1f)\n", draws, worst_z, K_SE);
}

/* Tolerance for a float Fresnel evaluation at cos_i: the float argument and arithmetic carry a
 * few FLT_EPSILON of relative error, amplified by the slope dF/dcos_i (steep near the critical
 * angle), which a central difference of the double reference gives. */
static double fresnel_float_tol(double cos_i, double n1, double n2) {
  const double h = 1e-7;
  double c_lo = fmax(0.0, cos_i - h), c_hi = fmin(1.0, cos_i + h);
  double slope = (fresnel_reference(acos(c_lo), n1, n2) - fresnel_reference(acos(c_hi), n1, n2)) / (c_hi - c_lo);
  /* Besides the argument's rounding, cos_t^2 = 1 - (1 - cos_i^2) / eta^2 is formed by a
   * subtraction with an absolute error of ~FLT_EPSILON; since d(cos_t^2) / d(cos_i) =
   * 2 cos_i / eta^2, that moves F by slope * eta^2 FLT_EPSILON / (2 cos_i). It dominates for
   * eta near 1 at grazing angles, where cos_t^2 is small. */
  double eta = n2 / n1;
  return 4.0 * FLT_EPSILON * (1.0 + fabs(slope) * cos_i + fabs(slope) * eta * eta / (2.0 * fmax(cos_i, 1e-6)));
}

static void test_fresnel_known_values(void) {
  static const float iors[] = {1.0001f, 1.33f, 1.5f, 1.6f, 2.4f, 3.0f};
  const double tol = 4.0 * FLT_EPSILON; /* float evaluation of a well-conditioned formula */
  char label[64];
  for (int i = 0; i < 6; i++) {
    double n = iors[i];
    snprintf(label, sizeof label, "ior %g", n);
    double r0 = (n - 1.0) / (n + 1.0);
    expect_near("normal incidence from outside: ((n-1)/(n+1))^2", label, vf_fresnel_dielectric(1.0f, iors[i]),
                r0 * r0, tol);
    expect_near("normal incidence from inside: ((n-1)/(n+1))^2", label, vf_fresnel_dielectric(-1.0f, iors[i]),
                r0 * r0, tol);
    /* Brewster's angle: tan theta_B = n2 / n1, the p wave vanishes and theta_i + theta_t = 90 deg,
     * so rs = -sin(theta_i - theta_t) = cos(2 theta_B) up to sign and F = rs^2 / 2. */
    double brewster_out = atan(n), brewster_in = atan(1.0 / n);
    double rs_out = cos(2.0 * brewster_out), rs_in = cos(2.0 * brewster_in);
    expect_near("Brewster from outside: F = rs^2 / 2", label, vf_fresnel_dielectric((float)cos(brewster_out), iors[i]),
                0.5 * rs_out * rs_out, tol);
    expect_near("Brewster from inside: F = rs^2 / 2", label, vf_fresnel_dielectric((float)-cos(brewster_in), iors[i]),
                0.5 * rs_in * rs_in, tol);
    /* across the range, against the angle forms; and Stokes: F(theta_i) from outside equals
     * F(theta_t) from inside */
    for (int a = 1; a < 90; a += 4) {
      double ti = a * PI_D / 180.0;
      float ci = (float)cos(ti);
      double ti_used = acos((double)ci); /* the angle of the float cosine actually passed */
      double tt = asin(sin(ti_used) / n);
      snprintf(label, sizeof label, "ior %g, %d deg", n, a);
      expect_near("F from outside vs angle-form Fresnel equations", label, vf_fresnel_dielectric(ci, iors[i]),
                  fresnel_reference(ti_used, 1.0, n), fresnel_float_tol(ci, 1.0, n));
      expect_near("Stokes: F_out(theta_i) == F_in(theta_t)", label, vf_fresnel_dielectric((float)-cos(tt), iors[i]),
                  vf_fresnel_dielectric(ci, iors[i]),
                  fresnel_float_tol(ci, 1.0, n) + fresnel_float_tol(cos(tt), n, 1.0));
      double critical = asin(1.0 / n);
      if (ti > critical * 1.0001)
        expect_near("total internal reflection from inside", label, vf_fresnel_dielectric(-ci, iors[i]), 1.0, 0.0);
    }
  }
  expect_near("eta == 1: no interface", "ior 1", vf_fresnel_dielectric(0.3f, 1.0f), 0.0, 0.0);
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

int main(void) {
  const char *v = getenv("VF_TEST_VERBOSE");
  verbose = v && v[0] == '1';
  /* the chi-square tail against known values: chi2 with 2 dof has Q = exp(-x / 2) */
  CHECK_NEAR(gamma_q(1.0, 3.0), exp(-3.0), 1e-12);
  CHECK_NEAR(gamma_q(5.0, 2.0), 0.947346982656289, 1e-12);
  /* integer a: Q(a, x) = exp(-x) sum_{k<a} x^k / k!, evaluated exactly elsewhere */
  CHECK_NEAR(gamma_q(50.0, 80.0), 1.3078397659141e-4, 1e-13);

  RUN(test_sampled_pdf_matches_evaluated_pdf);
  RUN(test_reverse_pdf_is_swapped_direct_pdf_and_f_is_reciprocal);
  RUN(test_sampled_directions_follow_evaluated_pdf);
  RUN(test_nonspecular_pdf_integrates_to_nonspecular_probability);
  RUN(test_directional_albedo_is_at_most_one);
  RUN(test_mirror_reflection_is_exact);
  RUN(test_dielectric_refraction_obeys_snell);
  RUN(test_total_internal_reflection_beyond_critical_angle);
  RUN(test_dielectric_reflects_with_fresnel_frequency);
  RUN(test_fresnel_known_values);
  RUN(test_init_refuses_black_and_tangent_and_flags_delta);
  RUN(test_cosine_hemisphere_warp);
  RUN(test_uniform_sphere_warp);
  RUN(test_triangle_sampling_is_uniform);
  RUN(test_concentric_disk_is_uniform);
  RUN(test_power_cosine_pdf_integrates_to_one);
  return check_finish();
}
