/* The shared part of the BSDF tests (bsdf_cases.h): reference geometry, statistics and the
 * material and configuration table. Nothing here checks; the tests do. */
#include "bsdf_cases.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

/* ---- double-precision geometry, independent of the code under test ---- */

dframe dframe_around(dvec n) {
  dvec helper = fabs(n.x) < 0.9 ? dmake(1, 0, 0) : dmake(0, 1, 0);
  dframe f;
  f.n = n;
  f.s = dnormalize(dcross(helper, n));
  f.t = dcross(n, f.s);
  return f;
}

dvec dframe_dir(const dframe *f, double theta, double phi) {
  double st = sin(theta);
  return dadd(dadd(dscale(f->s, st * cos(phi)), dscale(f->t, st * sin(phi))), dscale(f->n, cos(theta)));
}

/* Uniform direction on the sphere, in double (the reference sampler of the integral tests). */
dvec uniform_sphere_d(vf_rng *r) {
  double z = 1.0 - 2.0 * ((double)vf_rng_float(r) + 0x1p-25);
  double phi = 2.0 * PI_D * vf_rng_float(r);
  double s = sqrt(fmax(0.0, 1.0 - z * z));
  return dmake(s * cos(phi), s * sin(phi), z);
}

/* ---- statistics ---- */

/* Regularised upper incomplete gamma Q(a, x): the chi-square tail is Q(dof / 2, chi2 / 2).
 * Series for P = 1 - Q below x = a + 1, Lentz's continued fraction for Q above (Numerical
 * Recipes, sec. 6.2); test_bsdf.c's main() checks it against closed forms. */
double gamma_q(double a, double x) {
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

static int compare_expected(const void *a, const void *b) {
  double ea = ((const chi_cell *)a)->expected, eb = ((const chi_cell *)b)->expected;
  return (ea > eb) - (ea < eb);
}

/* Pearson chi-square of observed against expected counts; cells are pooled, smallest expected
 * first, until every pooled cell expects at least 5. Returns the p-value; sorts `cells`. */
double chi_square_p(chi_cell *cells, int count, double *chi2_out, int *dof_out) {
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

double sidak(int tests) { return 1.0 - pow(1.0 - FAMILY_SIGNIFICANCE, 1.0 / tests); }

/* ---- materials and configurations ---- */

const material_case MATERIALS[] = {
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

static const double ANGLES_DEG[] = {0.0, 45.0, 85.0};
_Static_assert(sizeof ANGLES_DEG / sizeof ANGLES_DEG[0] == ANGLE_COUNT, "ANGLE_COUNT in bsdf_cases.h");

/* A normal off every axis so that the shading frames are not trivial. */
static dvec geometric_normal_d(void) { return dnormalize(dmake(0.3, -0.5, 0.81)); }

void make_fix(double theta, double azimuth, int front, vf_vec3 *normal, vf_vec3 *fix, dvec *up) {
  dvec n = geometric_normal_d();
  dvec u = front ? n : dscale(n, -1.0);
  dframe f = dframe_around(u);
  dvec d = dframe_dir(&f, theta, azimuth);
  *normal = fv(n);
  *fix = vf_normalize(fv(d));
  *up = u;
}

void make_config(config *c, int index) {
  int side = index % 2, angle = (index / 2) % ANGLE_COUNT, m = index / (2 * ANGLE_COUNT);
  c->mc = &MATERIALS[m];
  c->theta = ANGLES_DEG[angle] * PI_D / 180.0;
  make_fix(c->theta, 0.7, side == 0, &c->normal, &c->fix, &c->up);
  snprintf(c->label, sizeof c->label, "%s, %g deg, %s", c->mc->name, ANGLES_DEG[angle],
           side == 0 ? "front" : "back");
  c->ok = vf_bsdf_init(&c->bsdf, &c->mc->material, c->normal, c->fix);
}

int has_nonspecular(const vf_material *m) {
  return vf_max_component(m->diffuse) > 0.0f || vf_max_component(m->glossy) > 0.0f;
}

/* cos of the angle between gen and the mirror direction of fix about up (double). */
double cos_to_mirror(dvec fix, dvec gen, dvec up) { return ddot(dreflect(fix, up), gen); }

/* First-order bound on how far a float evaluation of the glossy term can move when the cosine
 * to the mirror direction carries an absolute rounding error delta: d/dc (c^n) = n c^(n-1).
 * `scale` is (n + 1) / (2 pi) times the lobe weight (pdf) or (n + 2) / (2 pi) times the albedo
 * (f). The directions pass through two float frame changes and a normalisation, a few
 * FLT_EPSILON each; delta = 8 FLT_EPSILON bounds that (the worst relative pdf difference
 * measured at n = 1e4 and 1e5 is 2.0 n FLT_EPSILON, a quarter of the bound). */
double glossy_rounding(double scale, double n, double cos_a) {
  const double delta = 8.0 * FLT_EPSILON;
  if (n <= 0.0) return 0.0;
  double c = fmin(1.0, fmax(0.0, cos_a) + delta);
  return scale * n * pow(c, n - 1.0) * delta;
}

double rel_err(double a, double b, double abs_allowance) {
  double diff = fabs(a - b) - abs_allowance;
  if (diff <= 0.0) return 0.0;
  double scale = fmax(fabs(a), fabs(b));
  return scale > 0.0 ? diff / scale : 0.0;
}
