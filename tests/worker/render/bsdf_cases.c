/* The shared part of the BSDF tests (bsdf_cases.h): reference geometry, statistics and the
 * material and configuration table. Nothing here checks; the tests do. */
#include "bsdf_cases.h"

#include <complex.h>
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

static void config_of(config *c, const material_case *table, int index) {
  int side = index % 2, angle = (index / 2) % ANGLE_COUNT, m = index / (2 * ANGLE_COUNT);
  c->mc = &table[m];
  c->theta = ANGLES_DEG[angle] * PI_D / 180.0;
  make_fix(c->theta, 0.7, side == 0, &c->normal, &c->fix, &c->up);
  snprintf(c->label, sizeof c->label, "%s, %g deg, %s", c->mc->name, ANGLES_DEG[angle],
           side == 0 ? "front" : "back");
  c->ok = vf_bsdf_init(&c->bsdf, &c->mc->material, c->normal, c->fix);
}

void make_config(config *c, int index) { config_of(c, MATERIALS, index); }

#define GOLD_ETA RGB(0.143f, 0.374f, 1.442f)
#define GOLD_K RGB(3.983f, 2.385f, 1.603f)
#define COPPER_ETA RGB(0.200f, 0.924f, 1.102f)
#define COPPER_K RGB(3.912f, 2.452f, 2.142f)

const material_case ROUGH_MATERIALS[] = {
    {"conductor F=1 r0.3", {.conductor = RGB(1.0f, 1.0f, 1.0f), .roughness = 0.3f}, 0},
    {"gold r0.5", {.conductor = RGB(1.0f, 1.0f, 1.0f), .conductor_eta = GOLD_ETA, .conductor_k = GOLD_K, .roughness = 0.5f}, 0},
    {"copper r0.1",
     {.conductor = RGB(0.9f, 0.9f, 0.9f), .conductor_eta = COPPER_ETA, .conductor_k = COPPER_K, .roughness = 0.1f},
     0},
    {"conductor r1", {.conductor = RGB(0.8f, 0.6f, 0.4f), .roughness = 1.0f}, 0},
    {"glass1.5 r0.3", {.dielectric = RGB(1.0f, 1.0f, 1.0f), .ior = 1.5f, .roughness = 0.3f}, 0},
    {"glass1.5 r0.1", {.dielectric = RGB(0.9f, 0.8f, 0.7f), .ior = 1.5f, .roughness = 0.1f}, 0},
    {"water1.33 r0.7", {.dielectric = RGB(1.0f, 1.0f, 1.0f), .ior = 1.33f, .roughness = 0.7f}, 0},
    {"diamond2.4 r0.05", {.dielectric = RGB(1.0f, 1.0f, 1.0f), .ior = 2.4f, .roughness = 0.05f}, 0},
    {"gltf plastic", {.gltf = 1, .base_color = RGB(0.8f, 0.3f, 0.2f), .metallic = 0.0f, .roughness = 0.4f}, 0},
    {"gltf metal", {.gltf = 1, .base_color = RGB(0.95f, 0.65f, 0.3f), .metallic = 1.0f, .roughness = 0.3f}, 0},
    {"gltf half-metal", {.gltf = 1, .base_color = RGB(0.5f, 0.7f, 0.9f), .metallic = 0.5f, .roughness = 0.8f}, 0},
    {"gltf smooth", {.gltf = 1, .base_color = RGB(0.7f, 0.7f, 0.7f), .metallic = 0.2f, .roughness = 0.02f}, 0},
    /* KHR_materials_specular: a coloured F0 (blue above 1, clamped), F90 0.6 */
    {"gltf specular colour",
     {.gltf = 1, .base_color = RGB(0.6f, 0.5f, 0.4f), .metallic = 0.3f, .roughness = 0.35f, .specular_set = 1,
      .specular = 0.6f, .specular_f0 = RGB(0.2f, 0.06f, 1.5f)},
     0},
    {"diffuse+conductor",
     {.diffuse = RGB(0.3f, 0.2f, 0.1f), .conductor = RGB(0.6f, 0.6f, 0.6f), .roughness = 0.4f},
     0},
    {"diffuse+rough glass",
     {.diffuse = RGB(0.2f, 0.2f, 0.2f), .dielectric = RGB(0.7f, 0.7f, 0.7f), .ior = 1.5f, .roughness = 0.2f},
     0},
    {"mirror+conductor", {.mirror = RGB(0.3f, 0.3f, 0.3f), .conductor = RGB(0.6f, 0.5f, 0.4f), .roughness = 0.2f}, 0},
};

void make_rough_config(config *c, int index) { config_of(c, ROUGH_MATERIALS, index); }

int has_nonspecular(const vf_material *m) {
  return vf_max_component(m->diffuse) > 0.0f || vf_max_component(m->glossy) > 0.0f;
}

int make_swapped_pair(const config *c, vf_rng *r, int i, swapped_pair *p) {
  p->b = fv(uniform_sphere_d(r));
  if (i % 2 == 0) {
    bsdf_draw s = draw_sample(&c->bsdf, r);
    if (!vf_is_zero(s.f) && !(s.event & VF_BSDF_SPECULAR)) p->b = vf_normalize(s.gen);
  }
  vf_bsdf swapped;
  if (!vf_bsdf_init(&swapped, &c->mc->material, c->normal, p->b)) return 0;
  p->f_ab = vf_bsdf_evaluate(&c->bsdf, p->b, NULL, &p->d_ab, &p->r_ab);
  p->f_ba = vf_bsdf_evaluate(&swapped, c->fix, NULL, &p->d_ba, &p->r_ba);
  return 1;
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

/* ---- a double-precision reference of the rough lobes ---- */

double ref_fresnel(double cos_i, double n_re, double n_im) {
  double complex n = n_re + n_im * I;
  double sin2 = 1.0 - cos_i * cos_i;
  double complex cos_t = csqrt(1.0 - sin2 / (n * n));
  double complex rs = (cos_i - n * cos_t) / (cos_i + n * cos_t);
  double complex rp = (n * cos_i - cos_t) / (n * cos_i + cos_t);
  double as = cabs(rs), ap = cabs(rp);
  return 0.5 * (as * as + ap * ap);
}

double ref_ggx_lambda(dvec w, double alpha) {
  double tan2 = (w.x * w.x + w.y * w.y) / (w.z * w.z);
  return 0.5 * (sqrt(1.0 + alpha * alpha * tan2) - 1.0);
}

/* The glTF model's dielectric Fresnel F_d in channel ch at c (KHR_materials_specular,
 * "Implementation": from min(F0 colour, 1) specular to specular; without the extension
 * from 0.04 to 1). */
static double ref_gltf_dielectric(const vf_material *m, double c, int ch) {
  double f0 = 0.04, f90 = 1.0;
  if (m->specular_set) {
    f0 = fmin(vf_vec3_get(m->specular_f0, ch), 1.0) * m->specular;
    f90 = m->specular;
  }
  return f0 + (f90 - f0) * pow(1.0 - c, 5.0);
}

double ref_conductor_reflectance(const vf_material *m, double c, int ch) {
  if (m->gltf) { /* mix(F_d, the metal's Schlick of base_color, metallic) */
    double base = vf_vec3_get(m->base_color, ch), metal = base + (1.0 - base) * pow(1.0 - c, 5.0);
    return ref_gltf_dielectric(m, c, ch) + m->metallic * (metal - ref_gltf_dielectric(m, c, ch));
  }
  double tint = vf_vec3_get(m->conductor, ch);
  if (vf_is_zero(m->conductor_eta) && vf_is_zero(m->conductor_k)) return tint;
  return tint * ref_fresnel(c, vf_vec3_get(m->conductor_eta, ch), vf_vec3_get(m->conductor_k, ch));
}

void ref_rough_albedo(const vf_material *m, double theta, double eta, int steps, ref_albedo *out) {
  *out = (ref_albedo){{0}, {0}};
  double alpha = (double)m->roughness * m->roughness;
  int rough = alpha >= VF_GGX_ALPHA_DELTA;
  int conductor = rough && (m->gltf || !vf_is_zero(m->conductor));
  int dielectric = rough && !vf_is_zero(m->dielectric) && m->ior != 1.0f;
  dvec i = dmake(sin(theta), 0.0, cos(theta));
  double lambda_i = ref_ggx_lambda(i, alpha);
  if (conductor || dielectric)
    for (int a = 0; a < steps; a++) {
      /* u = 1 - s^2 takes the integrable 1 / sqrt(1 - u) of grazing normals out */
      double s = (a + 0.5) / steps, u = 1.0 - s * s, du = 2.0 * s / steps;
      double tan_m = alpha * sqrt(u / (1.0 - u)), cos_m = 1.0 / sqrt(1.0 + tan_m * tan_m);
      for (int b = 0; b < 2 * steps; b++) {
        double phi = 2.0 * PI_D * (b + 0.5) / (2 * steps), dphi = 1.0 / (2 * steps); /* d phi / (2 pi) */
        dvec mn = dmake(tan_m * cos_m * cos(phi), tan_m * cos_m * sin(phi), cos_m);
        double c = ddot(i, mn);
        if (!(c > 0.0)) continue;
        /* f cos_o d omega_o = F G |i.m| / (cos_i cos_m) du d phi / (2 pi), by Walter's
         * eq. 14 and 17 for either event */
        double w = c / (i.z * cos_m) * du * dphi;
        dvec o = dsub(dscale(mn, 2.0 * c), i);
        double g2 = o.z > 0.0 ? 1.0 / (1.0 + lambda_i + ref_ggx_lambda(o, alpha)) : 0.0;
        double fr = dielectric ? ref_fresnel(c, eta, 0.0) : 0.0;
        for (int ch = 0; ch < 3; ch++) {
          if (conductor) out->reflect[ch] += ref_conductor_reflectance(m, c, ch) * g2 * w;
          if (dielectric) out->reflect[ch] += vf_vec3_get(m->dielectric, ch) * fr * g2 * w;
        }
        /* Walter's eq. 40 with his eta = 1 / ours: o = (e c - s) m - e i, s^2 = 1 + e^2 (c^2 - 1)
         * the cosine of the refracted direction to m (Snell's law) */
        double e = 1.0 / eta, root = 1.0 + e * e * (c * c - 1.0);
        if (!dielectric || root <= 0.0) continue;
        dvec t = dsub(dscale(mn, e * c - sqrt(root)), dscale(i, e));
        if (!(t.z < 0.0)) continue;
        double g = 1.0 / ((1.0 + lambda_i) * (1.0 + ref_ggx_lambda(t, alpha)));
        for (int ch = 0; ch < 3; ch++) out->transmit[ch] += vf_vec3_get(m->dielectric, ch) * (1.0 - fr) * g * w;
      }
    }
  if (!m->gltf || m->metallic >= 1.0f) return;
  for (int a = 0; a < steps; a++)
    for (int b = 0; b < steps; b++) {
      double u1 = (a + 0.5) / steps, u2 = (b + 0.5) / steps, r = sqrt(u2);
      dvec o = dmake(r * cos(2.0 * PI_D * u1), r * sin(2.0 * PI_D * u1), sqrt(1.0 - u2));
      double c = ddot(i, dnormalize(dadd(i, o)));
      double coat = 1.0 - fmax(ref_gltf_dielectric(m, c, 0), fmax(ref_gltf_dielectric(m, c, 1), ref_gltf_dielectric(m, c, 2)));
      for (int ch = 0; ch < 3; ch++)
        out->reflect[ch] += (1.0 - m->metallic) * vf_vec3_get(m->base_color, ch) * coat / ((double)steps * steps);
    }
}
