/* The glTF model's layers (worker/render/bsdf.h, the top; worker/render/sheen.h): the clear coat
 * of KHR_materials_clearcoat and the sheen of KHR_materials_sheen, tested on physics and
 * identities:
 * 1. sampling reports the value and densities evaluation gives for the sampled direction
 *    (plain, and with a shading normal and a coat normal of their own, for either sub-path);
 *    a smooth coat's draw carries clearcoat F_c(fix.n);
 * 2. reciprocity f(a, b) = f(b, a) and reverse density = the swapped direct one; with shading
 *    and coat normals, a camera sub-path's vertex gives (a, b) what a light sub-path's gives
 *    (b, a);
 * 3. sampled directions follow the evaluated density (chi-square, and the rate of draws);
 * 4. albedo: the sampled albedo equals the numerical integral of f cos, and is at most one;
 *    the sheen's albedo table equals its integral;
 * 5. upg's bound (worker/render/photon_gathering.h) holds over cones of every size;
 * 6. path tracing, light tracing, BPT, VCM and upg agree per image block on a Cornell box
 *    with a coated ball (a coat normal map), a sheen ball and a rough-coated floor; pt, BPT
 *    and VCM when the floor's coat is smooth (light tracing cannot see its mirror image, upg
 *    would merge caustics through it with merging's bias). */
#include "check.h"
#include "bsdf_cases.h" /* after check.h: its checks are defined only then */
#include "feature_scene.h"
#include "render_util.h"
#include "worker/render/bsdf.h"
#include "worker/render/photon_gathering.h"
#include "worker/render/sheen.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { CASE_LAYERS = 100 }; /* random streams of their own, beyond bsdf_cases.h's */

static int verbose;

static vf_material gltf(vf_vec3 base, float metallic, float roughness) {
  vf_material m;
  memset(&m, 0, sizeof m);
  m.phong_exponent = m.ior = 1.0f;
  m.alpha = m.normal_scale = m.clearcoat_normal_scale = 1.0f;
  m.gltf = 1;
  m.base_color = base;
  m.metallic = metallic;
  m.roughness = roughness;
  return m;
}

typedef struct {
  const char *name;
  vf_material m;
} layer_case;

enum { CASES = 8 };
static layer_case cases[CASES];

static void make_cases(void) {
  layer_case *c = cases;
  c[0] = (layer_case){"coat 1 r0.3 on plastic", gltf(vf_vec3_make(0.8f, 0.6f, 0.4f), 0.0f, 0.5f)};
  c[0].m.clearcoat = 1.0f, c[0].m.clearcoat_roughness = 0.3f;
  c[1] = (layer_case){"smooth coat 0.7 on half metal", gltf(vf_vec3_make(0.5f, 0.5f, 0.6f), 0.5f, 0.2f)};
  c[1].m.clearcoat = 0.7f;
  c[2] = (layer_case){"sheen r0.5 on blue", gltf(vf_vec3_make(0.2f, 0.3f, 0.8f), 0.0f, 0.7f)};
  c[2].m.sheen_color = vf_vec3_make(0.9f, 0.7f, 0.5f), c[2].m.sheen_roughness = 0.5f;
  c[3] = (layer_case){"sheen r0.2 coat r0.4", gltf(vf_vec3_splat(0.7f), 0.2f, 0.4f)};
  c[3].m.sheen_color = vf_vec3_splat(1.0f), c[3].m.sheen_roughness = 0.2f;
  c[3].m.clearcoat = 0.5f, c[3].m.clearcoat_roughness = 0.4f;
  c[4] = (layer_case){"smooth metal, sheen, coat r0.6", gltf(vf_vec3_make(0.9f, 0.8f, 0.5f), 1.0f, 0.0f)};
  c[4].m.sheen_color = vf_vec3_splat(0.8f), c[4].m.sheen_roughness = 0.3f;
  c[4].m.clearcoat = 1.0f, c[4].m.clearcoat_roughness = 0.6f;
  c[5] = (layer_case){"white sheen r1 on black", gltf(vf_vec3_splat(0.0f), 0.0f, 1.0f)};
  c[5].m.sheen_color = vf_vec3_splat(1.0f), c[5].m.sheen_roughness = 1.0f;
  /* where the Charlie sheen alone would reflect more than it receives (E > 1 towards grazing) */
  c[6] = (layer_case){"white sheen r0.1 on black", gltf(vf_vec3_splat(0.0f), 0.0f, 1.0f)};
  c[6].m.sheen_color = vf_vec3_splat(1.0f), c[6].m.sheen_roughness = 0.1f;
  c[7] = (layer_case){"white sheen r0.1, coat, bright base", gltf(vf_vec3_splat(0.8f), 0.0f, 0.5f)};
  c[7].m.sheen_color = vf_vec3_splat(1.0f), c[7].m.sheen_roughness = 0.1f;
  c[7].m.clearcoat = 1.0f, c[7].m.clearcoat_roughness = 0.3f;
}

/* The smallest alpha of a case's lobes: how sharply its f varies with its half vector. */
static double sharpest(const vf_material *m) {
  double a = fmax(1e-3, (double)m->roughness * m->roughness);
  if (m->clearcoat > 0.0f) a = fmin(a, fmax(1e-3, (double)m->clearcoat_roughness * m->clearcoat_roughness));
  if (!vf_is_zero(m->sheen_color)) a = fmin(a, vf_sheen_alpha(m->sheen_roughness));
  return a;
}

/* Relative rounding of f or a density recomputed from other float directions: see
 * test_bsdf_rough.c's ggx_rounding (the sheen's D varies as sin^(1/r), like GGX's at alpha r). */
static double rounding(const vf_material *m) { return 2e-5 + 64.0 * FLT_EPSILON / sharpest(m); }

static const double ANGLES[4] = {0.0, 45.0, 80.0, 88.0};
enum { PLAIN_CONFIGS = CASES * 4 };

/* Plain configuration k: case k / 4 at angle k % 4, on the front of the tilted normal. */
static int plain_config(int k, vf_bsdf *b, vf_vec3 *normal, vf_vec3 *fix, char *label, size_t n) {
  const layer_case *c = &cases[k / 4];
  dvec up;
  make_fix(ANGLES[k % 4] * PI_D / 180.0, 0.7, 1, normal, fix, &up);
  snprintf(label, n, "%s, %g deg", c->name, ANGLES[k % 4]);
  return vf_bsdf_init(b, &c->m, *normal, *fix);
}

/* A shading configuration: ng tilted, a shading normal 20 degrees off it and a coat normal
 * 15 degrees off it the other way, fix at the angle to ng (and above both). */
typedef struct {
  vf_vec3 ng, ns, nc;
  vf_bsdf_lobes lobes;
  const vf_material *m;
} shading_setup;

static shading_setup shading_of(int k) {
  shading_setup s;
  s.m = &cases[k / 4].m;
  s.ng = vf_normalize(vf_vec3_make(0.2f, -0.1f, 1.0f));
  dframe f = dframe_around(dv(s.ng));
  s.ns = fv(dframe_dir(&f, 20.0 * PI_D / 180.0, 0.3));
  s.nc = fv(dframe_dir(&f, 15.0 * PI_D / 180.0, 0.3 + PI_D));
  vf_bsdf_lobes_of(s.m, &s.lobes);
  return s;
}

static int shading_bsdf(const shading_setup *s, vf_vec3 fix, int radiance, vf_bsdf *b) {
  if (!vf_bsdf_setup_shading(b, s->m, &s->lobes, s->ng, s->ns, fix)) return 0;
  vf_bsdf_set_coat_normal(b, s->nc, fix);
  b->radiance = radiance;
  return 1;
}

static vf_vec3 shading_fix(int k) {
  shading_setup s = shading_of(k);
  dframe f = dframe_around(dv(s.ng));
  return fv(dframe_dir(&f, fmin(ANGLES[k % 4], 60.0) * PI_D / 180.0, 2.0));
}

static double coat_fresnel_d(double c) { return 0.04 + 0.96 * pow(1.0 - c, 5.0); }

/* ---- 1. sampling reports what evaluation gives ---- */

static void check_draws(const vf_bsdf *b, const char *label, vf_rng *r, long *nonspecular, long *specular) {
  for (int i = 0; i < 4000; i++) {
    bsdf_draw s = draw_sample(b, r);
    if (vf_is_zero(s.f)) continue;
    if (s.event & VF_BSDF_SPECULAR) {
      expect_near("specular pdf == reverse pdf", label, s.rev, s.pdf, 0.0);
      (*specular)++;
      continue;
    }
    float e_cos, e_pdf, e_rev;
    vf_vec3 fe = vf_bsdf_evaluate(b, s.gen, &e_cos, &e_pdf, &e_rev);
    expect_near("sample pdf == evaluate direct pdf", label, s.pdf, e_pdf, 0.0);
    expect_near("sample reverse pdf == evaluate reverse pdf", label, s.rev, e_rev, 0.0);
    expect_near("sample cos == evaluate cos", label, s.cos_gen, e_cos, 0.0);
    for (int ch = 0; ch < 3; ch++) expect_near("sample f == evaluate f", label, vf_vec3_get(s.f, ch), vf_vec3_get(fe, ch), 0.0);
    if (!(s.pdf > 0.0f) || !(s.rev > 0.0f)) CHECK_FAIL_("non-positive density [%s]: %g %g", label, s.pdf, s.rev);
    (*nonspecular)++;
  }
}

static void test_sampling_reports_the_evaluated_value_and_densities(void) {
  long nonspecular = 0, specular = 0;
  double worst_coat = 0.0;
  for (int k = 0; k < PLAIN_CONFIGS; k++) {
    vf_bsdf b;
    vf_vec3 n, fix;
    char label[96];
    CHECK(plain_config(k, &b, &n, &fix, label, sizeof label));
    vf_rng r = test_rng(CASE_LAYERS + 1, (uint64_t)k);
    long before = nonspecular;
    check_draws(&b, label, &r, &nonspecular, &specular);
    expect_ge("non-specular samples drawn", label, (double)(nonspecular - before), 100.0);
    /* A smooth coat's draw: the mirror direction, carrying clearcoat F_c(fix.n). */
    const vf_material *m = &cases[k / 4].m;
    if (m->clearcoat > 0.0f && m->clearcoat_roughness == 0.0f) {
      long coat_draws = 0;
      double c = vf_dot(n, fix);
      for (int i = 0; i < 4000; i++) {
        bsdf_draw s = draw_sample(&b, &r);
        if (vf_is_zero(s.f) || !(s.event & VF_BSDF_SPECULAR)) continue;
        double w = vf_vec3_get(s.f, 0) * s.cos_gen / s.pdf * b.continuation;
        /* f cos / pdf x continuation is the weight over the coat's selection probability */
        double expect = m->clearcoat * coat_fresnel_d(c) / b.lobe_probability[VF_LOBE_COAT];
        double cos_mirror = ddot(dv(s.gen), dreflect(dv(fix), dv(n)));
        if (fabs(w - expect) < 1e-5 * expect + 1e-7) { /* the coat's (the metal's carries another weight) */
          coat_draws++;
          worst_coat = fmax(worst_coat, fabs(w - expect) / expect);
          expect_near("smooth coat's direction is the mirror's (cos)", label, cos_mirror, 1.0, 1e-5);
        }
      }
      expect_ge("smooth coat draws carrying clearcoat F_c(fix.n)", label, (double)coat_draws, 100.0);
    }
  }
  for (int k = 0; k < PLAIN_CONFIGS; k++)
    for (int radiance = 0; radiance < 2; radiance++) {
      shading_setup s = shading_of(k);
      vf_bsdf b;
      char label[128];
      snprintf(label, sizeof label, "%s, shading, %s", cases[k / 4].name, radiance ? "radiance" : "importance");
      CHECK(shading_bsdf(&s, shading_fix(k), radiance, &b));
      vf_rng r = test_rng(CASE_LAYERS + 2, (uint64_t)(2 * k + radiance));
      long before = nonspecular;
      check_draws(&b, label, &r, &nonspecular, &specular);
      expect_ge("non-specular samples drawn", label, (double)(nonspecular - before), 100.0);
    }
  printf("  info: %ld non-specular and %ld specular draws; smooth coat weight worst rel. err %.2e\n", nonspecular,
         specular, worst_coat);
}

/* ---- 2. reciprocity and reverse densities ---- */

static vf_vec3 upper_direction(vf_rng *r, vf_vec3 n) {
  dframe f = dframe_around(dv(n));
  double z = vf_rng_float(r), phi = 2.0 * PI_D * vf_rng_float(r);
  return fv(dframe_dir(&f, acos(fmin(1.0, z)), phi));
}

static void compare_pair(const char *label, double tol, vf_vec3 f_ab, float d_ab, float r_ab, vf_vec3 f_ba, float d_ba,
                         float r_ba, double *worst_f, double *worst_pdf) {
  double e = fmax(rel_err(r_ab, d_ba, 0.0), rel_err(r_ba, d_ab, 0.0));
  *worst_pdf = fmax(*worst_pdf, e);
  if (!(e <= tol)) CHECK_FAIL_("reverse pdf [%s]: (a,b) %g %g vs (b,a) %g %g", label, d_ab, r_ab, d_ba, r_ba);
  for (int ch = 0; ch < 3; ch++) {
    double ef = rel_err(vf_vec3_get(f_ab, ch), vf_vec3_get(f_ba, ch), 0.0);
    *worst_f = fmax(*worst_f, ef);
    if (!(ef <= tol)) CHECK_FAIL_("reciprocity [%s]: f(a,b) %.9g vs f(b,a) %.9g", label, vf_vec3_get(f_ab, ch), vf_vec3_get(f_ba, ch));
  }
}

static void test_reciprocity_and_reverse_densities(void) {
  double worst_f = 0.0, worst_pdf = 0.0;
  long pairs = 0;
  for (int k = 0; k < PLAIN_CONFIGS; k++) {
    vf_bsdf b;
    vf_vec3 n, fix;
    char label[96];
    if (!plain_config(k, &b, &n, &fix, label, sizeof label)) continue;
    double tol = rounding(&cases[k / 4].m);
    vf_rng r = test_rng(CASE_LAYERS + 3, (uint64_t)k);
    long nonzero = 0;
    for (int i = 0; i < 2000; i++) {
      vf_vec3 g;
      if (i % 2 == 0) {
        bsdf_draw s = draw_sample(&b, &r);
        if (vf_is_zero(s.f) || (s.event & VF_BSDF_SPECULAR)) continue;
        g = s.gen;
      } else {
        g = upper_direction(&r, n);
      }
      vf_bsdf back;
      if (!vf_bsdf_init(&back, &cases[k / 4].m, n, g)) continue;
      float d_ab, r_ab, d_ba, r_ba;
      vf_vec3 f_ab = vf_bsdf_evaluate(&b, g, NULL, &d_ab, &r_ab), f_ba = vf_bsdf_evaluate(&back, fix, NULL, &d_ba, &r_ba);
      compare_pair(label, tol, f_ab, d_ab, r_ab, f_ba, d_ba, r_ba, &worst_f, &worst_pdf);
      nonzero += d_ab > 0.0f;
      pairs++;
    }
    expect_ge("pairs with non-zero density", label, (double)nonzero, 500.0);
  }
  /* Shading and coat normals: the camera sub-path's vertex (a, b) against the light
   * sub-path's (b, a). */
  for (int k = 0; k < PLAIN_CONFIGS; k++) {
    shading_setup s = shading_of(k);
    vf_vec3 a = shading_fix(k);
    vf_bsdf cam;
    char label[128];
    snprintf(label, sizeof label, "%s, shading", cases[k / 4].name);
    if (!shading_bsdf(&s, a, 1, &cam)) continue;
    double tol = rounding(s.m);
    vf_rng r = test_rng(CASE_LAYERS + 4, (uint64_t)k);
    long nonzero = 0;
    for (int i = 0; i < 2000; i++) {
      vf_vec3 g;
      if (i % 2 == 0) {
        bsdf_draw d = draw_sample(&cam, &r);
        if (vf_is_zero(d.f) || (d.event & VF_BSDF_SPECULAR)) continue;
        g = d.gen;
      } else {
        g = upper_direction(&r, s.ng);
      }
      vf_bsdf light;
      if (!shading_bsdf(&s, g, 0, &light)) continue;
      float d_ab, r_ab, d_ba, r_ba;
      vf_vec3 f_ab = vf_bsdf_evaluate(&cam, g, NULL, &d_ab, &r_ab), f_ba = vf_bsdf_evaluate(&light, a, NULL, &d_ba, &r_ba);
      compare_pair(label, tol, f_ab, d_ab, r_ab, f_ba, d_ba, r_ba, &worst_f, &worst_pdf);
      nonzero += d_ab > 0.0f;
      pairs++;
    }
    expect_ge("pairs with non-zero density", label, (double)nonzero, 500.0);
  }
  printf("  info: %ld pairs; worst rel. err: f %.2e, reverse pdf %.2e\n", pairs, worst_f, worst_pdf);
}

/* ---- 3, 4. chi-square of sampled directions; albedo ---- *
 * A grid over the sphere around the mirror direction of fix (where the specular layers and
 * the coat have their lobes, at any incidence) in (t, phi) with the polar angle
 * theta = 2 atan(S t / (1 - t)), t in [0, 1): a lobe of width ~S gets as many cells as the
 * rest of the sphere (test_bsdf_rough.c's grids); directions below the surface have no mass.
 * Cells are integrated by the midpoint rule on SUB x SUB points; the same at SUB / 2 bounds
 * the rule's error. */
#define GT 24
#define GP 48
#define SUB 16
#define GRID_S 0.25
#define DRAWS 200000

typedef struct {
  dframe frame;
} hemi_grid;

static double theta_of(double t) { return 2.0 * atan(GRID_S * t / (1.0 - t)); }

static dvec grid_dir(const hemi_grid *g, double t, double phi) { return dframe_dir(&g->frame, theta_of(t), phi); }

static int cell_of(const hemi_grid *g, dvec d) {
  double c = fmax(-1.0, fmin(1.0, ddot(d, g->frame.n))), theta = acos(c);
  double u = tan(theta / 2.0) / GRID_S, t = u / (1.0 + u); /* theta_of's inverse */
  double phi = atan2(ddot(d, g->frame.t), ddot(d, g->frame.s));
  if (phi < 0.0) phi += 2.0 * PI_D;
  int it = (int)(t * GT), ip = (int)(phi / (2.0 * PI_D) * GP);
  if (it >= GT) it = GT - 1;
  if (ip >= GP) ip = GP - 1;
  return it * GP + ip;
}

/* The integrals of the direct pdf and of f cos (per channel) over a cell with sub x sub
 * points: d omega = sin(theta) (d theta / dt) dt d phi, d theta / dt = 2 S / ((1 - t)^2 + S^2 t^2). */
static void cell_integrals(const vf_bsdf *b, const hemi_grid *g, int cell, int sub, double *pdf, double fcos[3]) {
  int it = cell / GP, ip = cell % GP;
  double dt = 1.0 / GT / sub, dp = 2.0 * PI_D / GP / sub;
  *pdf = 0.0;
  fcos[0] = fcos[1] = fcos[2] = 0.0;
  for (int a = 0; a < sub; a++)
    for (int q = 0; q < sub; q++) {
      double t = (it + (a + 0.5) / sub) / GT, phi = (ip + (q + 0.5) / sub) * 2.0 * PI_D / GP;
      float c, d;
      vf_vec3 f = vf_bsdf_evaluate(b, fv(grid_dir(g, t, phi)), &c, &d, NULL);
      double w = sin(theta_of(t)) * 2.0 * GRID_S / ((1.0 - t) * (1.0 - t) + GRID_S * GRID_S * t * t) * dt * dp;
      *pdf += d * w;
      for (int ch = 0; ch < 3; ch++) fcos[ch] += vf_vec3_get(f, ch) * c * w;
    }
}

static void test_sampled_directions_and_albedo(void) {
  chi_family family = chi_family_of(PLAIN_CONFIGS);
  static chi_cell cells[GT * GP];
  static double mass[GT * GP];
  double worst_albedo_z = 0.0, largest_albedo = 0.0;
  for (int k = 0; k < PLAIN_CONFIGS; k++) {
    vf_bsdf b;
    vf_vec3 n, fix;
    char label[96];
    if (!plain_config(k, &b, &n, &fix, label, sizeof label)) continue;
    hemi_grid g = {dframe_around(dreflect(dv(fix), dv(n)))};
    double grid_mass = 0.0, error = 0.0, albedo[3] = {0, 0, 0}, albedo_error[3] = {0, 0, 0};
    for (int q = 0; q < GT * GP; q++) {
      double p, p2, fc[3], fc2[3];
      cell_integrals(&b, &g, q, SUB, &p, fc);
      cell_integrals(&b, &g, q, SUB / 2, &p2, fc2);
      mass[q] = p;
      grid_mass += p;
      error += fabs(p - p2);
      for (int ch = 0; ch < 3; ch++) albedo[ch] += fc[ch], albedo_error[ch] += fabs(fc[ch] - fc2[ch]);
      cells[q].observed = 0;
    }
    vf_rng r = test_rng(CASE_LAYERS + 5, (uint64_t)k);
    long in_grid = 0;
    running_mean nondelta[3] = {{0}}, delta[3] = {{0}};
    for (long i = 0; i < DRAWS; i++) {
      bsdf_draw s = draw_sample(&b, &r);
      int specular = (s.event & VF_BSDF_SPECULAR) != 0;
      for (int ch = 0; ch < 3; ch++) {
        double w = draw_weight(&b, &s, ch);
        rm_add(&nondelta[ch], specular ? 0.0 : w);
        rm_add(&delta[ch], specular ? w : 0.0);
      }
      if (vf_is_zero(s.f) || specular) continue;
      int cell = cell_of(&g, dv(s.gen));
      if (cell < 0) continue;
      cells[cell].observed++;
      in_grid++;
    }
    chi_family_check(&family, label, cells, mass, GT * GP, grid_mass, b.continuation, in_grid, DRAWS,
                     DRAWS * error / b.continuation, verbose);
    /* albedo: the non-delta lobes' integral against their draws; the whole at most one */
    for (int ch = 0; ch < 3; ch++) {
      double m = rm_mean(&nondelta[ch]), se = rm_se(&nondelta[ch]);
      expect_near("sampled albedo of the non-delta lobes == integral", label, m, albedo[ch], K_SE * se + albedo_error[ch]);
      if (se > 0.0) worst_albedo_z = fmax(worst_albedo_z, fmax(0.0, fabs(m - albedo[ch]) - albedo_error[ch]) / se);
      double total = albedo[ch] + rm_mean(&delta[ch]);
      largest_albedo = fmax(largest_albedo, total);
      expect_le("albedo (integral + delta lobes' draws)", label, total, 1.0 + albedo_error[ch] + K_SE * rm_se(&delta[ch]));
      if (verbose) printf("    ch %d: albedo %.5f (non-delta %.5f +- %.1e, delta %.5f)\n", ch, total, albedo[ch], albedo_error[ch], rm_mean(&delta[ch]));
    }
  }
  chi_family_report(&family, DRAWS);
  printf("  info: albedo, largest %.4f; sampled vs integrated worst |z| beyond the quadrature's error %.2f\n",
         largest_albedo, worst_albedo_z);
}

/* The sheen's albedo table against its integral between the nodes (sheen.h states its
 * accuracy), and the integral against an independent quadrature of vf_sheen_brdf over
 * directions where that quadrature resolves the lobe (roughness 0.2 and up). */
static void test_sheen_albedo_table(void) {
  double worst = 0.0, worst_away = 0.0, worst_quadrature = 0.0;
  for (int i = 0; i <= 16; i++)
    for (int j = 0; j <= 24; j++) {
      double s = fmin(1.0, 0.05 + 0.95 * i / 16.0 + 0.0123), c = fmax(0.01, fmin(1.0, j / 24.0 + 0.0071)), r = s * s;
      double exact = vf_sheen_albedo_integral(c, r, 256), table = vf_sheen_albedo((float)c, (float)s);
      char where[64];
      snprintf(where, sizeof where, "roughness %.4f, cos %.4f", s, c);
      worst = fmax(worst, fabs(table - exact));
      expect_near("sheen albedo: table vs integral", where, table, exact, 0.02);
      if (c >= 0.05) {
        worst_away = fmax(worst_away, fabs(table - exact));
        expect_near("sheen albedo: table vs integral, cos >= 0.05", where, table, exact, 0.008);
      }
      if (j % 6 == 3 && s >= 0.2) { /* the midpoint rule in (cos^2 theta_i, phi): cos d omega = d(cos^2) d phi / 2 */
        enum { N = 400 };
        double sum = 0.0, so = sqrt(1.0 - c * c);
        for (int a = 0; a < N; a++)
          for (int q = 0; q < N; q++) {
            double ci = sqrt((a + 0.5) / N), si = sqrt(1.0 - ci * ci), phi = PI_D * (q + 0.5) / N;
            dvec o = dmake(so, 0, c), in = dmake(si * cos(phi), si * sin(phi), ci), h = dnormalize(dadd(o, in));
            sum += vf_sheen_brdf((float)c, (float)ci, (float)h.z, (float)r);
          }
        double e = sum * (1.0 / N) * (PI_D / N); /* phi over half the circle, doubled, halved */
        worst_quadrature = fmax(worst_quadrature, fabs(e - exact));
        expect_near("sheen albedo: CDF-coordinate integral vs direction quadrature", where, exact, e, 2e-3);
      }
    }
  printf("  info: sheen albedo table worst |table - integral| %.2e (%.2e for cos >= 0.05); integral vs direction "
         "quadrature %.2e\n",
         worst, worst_away, worst_quadrature);
}

/* ---- 5. upg's bound ---- */

static void test_upg_bound_holds_over_cones(void) {
  long checked = 0, exceeded = 0;
  double tightest = 0.0;
  const double half_angles[] = {1e-3, 0.02, 0.2, 0.8, 2.0};
  for (int k = 0; k < 2 * PLAIN_CONFIGS; k++) {
    vf_bsdf b;
    vf_vec3 n, fix;
    char label[128];
    int ok;
    if (k < PLAIN_CONFIGS) {
      ok = plain_config(k, &b, &n, &fix, label, sizeof label);
    } else {
      shading_setup s = shading_of(k - PLAIN_CONFIGS);
      ok = shading_bsdf(&s, shading_fix(k - PLAIN_CONFIGS), 0, &b);
      snprintf(label, sizeof label, "%s, shading", cases[(k - PLAIN_CONFIGS) / 4].name);
    }
    if (!ok) continue;
    vf_upg_source src = {&b, NULL, vf_vec3_splat(0.0f)};
    vf_rng r = test_rng(CASE_LAYERS + 6, (uint64_t)k);
    for (int i = 0; i < 300; i++) {
      bsdf_draw s = draw_sample(&b, &r);
      vf_vec3 axis = !vf_is_zero(s.f) && !(s.event & VF_BSDF_SPECULAR) ? s.gen : fv(uniform_sphere_d(&r));
      double theta = half_angles[i % 5];
      float ch = (float)cos(theta), omc = (float)(2.0 * sin(theta / 2) * sin(theta / 2));
      float bound = vf_upg_bound(&src, axis, ch, omc);
      dframe f = dframe_around(dv(axis));
      for (int j = 0; j < 50; j++) {
        double c = 1.0 - vf_rng_float(&r) * omc, phi = 2.0 * PI_D * vf_rng_float(&r);
        vf_vec3 d = fv(dframe_dir(&f, acos(fmax(-1.0, fmin(1.0, c))), phi));
        float pdf = vf_upg_density(&src, d);
        checked++;
        if (pdf > bound) {
          exceeded++;
          if (exceeded <= 5) CHECK_FAIL_("upg bound [%s]: density %g > bound %g (half-angle %g)", label, pdf, bound, theta);
        } else if (bound > 0.0f && isfinite(bound)) {
          tightest = fmax(tightest, pdf / bound);
        }
      }
    }
  }
  CHECK_INT_EQ((int)exceeded, 0);
  printf("  info: %ld directions in cones, none above the bound; largest density / bound %.3f\n", checked, tightest);
}

/* ---- 6. independent algorithms agree ---- */

enum { RES = 64, BLOCKS = 8, NB = BLOCKS * BLOCKS, ITERATIONS = 128 };

/* cornell-diffuse with smooth-normal balls: the left one coated (roughness 0.25) over a red
 * plastic with a coat normal map of its own, the right one blue under a sheen, the floor a
 * glTF plastic under a coat, smooth (a delta) or of roughness 0.3. */
static vf_scene *layered_scene(int smooth_floor) {
  vf_scene *s = feature_scene(FEATURE_SMOOTH);
  if (s == NULL || check_failed_in_case) return s;
  int left = find_shape(s, "white ball ball"), right = find_shape(s, "blue ball ball"), floor = find_shape(s, "floor");
  if (left < 0) left = find_shape(s, "white ball");
  if (right < 0) right = find_shape(s, "blue ball");
  CHECK(left >= 0 && right >= 0 && floor >= 0);
  if (check_failed_in_case) return s;
  s->materials = realloc(s->materials, (size_t)(s->num_materials + 3) * sizeof *s->materials);
  vf_material *coat = &s->materials[s->num_materials], *sheen = coat + 1, *lacquer = coat + 2;
  *coat = gltf(vf_vec3_make(0.7f, 0.2f, 0.15f), 0.0f, 0.6f);
  snprintf(coat->name, sizeof coat->name, "coated");
  coat->clearcoat = 1.0f;
  coat->clearcoat_roughness = 0.25f;
  coat->clearcoat_normal_scale = 1.0f;
  coat->textures[VF_TEXTURE_CLEARCOAT_NORMAL].texture = add_texture(s, 8, 8, 3, 1, bumps);
  *sheen = gltf(vf_vec3_make(0.1f, 0.15f, 0.6f), 0.0f, 0.8f);
  snprintf(sheen->name, sizeof sheen->name, "velvet");
  sheen->sheen_color = vf_vec3_make(0.9f, 0.8f, 0.6f);
  sheen->sheen_roughness = 0.4f;
  *lacquer = gltf(vf_vec3_splat(0.6f), 0.0f, 0.7f);
  snprintf(lacquer->name, sizeof lacquer->name, "lacquered floor");
  lacquer->clearcoat = 0.8f;
  lacquer->clearcoat_roughness = smooth_floor ? 0.0f : 0.3f;
  s->shapes[left].material = s->num_materials;
  s->shapes[right].material = s->num_materials + 1;
  s->shapes[floor].material = s->num_materials + 2;
  s->num_materials += 3;
  return s;
}

static void check_agreement(const char *what, int smooth_floor, const vf_algorithm *algorithms, int n) {
  vf_scene *scene = layered_scene(smooth_floor);
  if (scene == NULL || check_failed_in_case) return;
  static double mean[5][NB], se[5][NB];
  for (int a = 0; a < n; a++) {
    vf_settings st = scene->settings;
    st.algorithm = algorithms[a];
    st.width = st.height = RES;
    st.max_path_length = 6;
    st.seed = 4000 + (uint64_t)algorithms[a];
    vf_vcm_stats stats = {0};
    CHECK_INT_EQ(render_block_estimates(scene, &st, 2, ITERATIONS, BLOCKS, mean[a], se[a], &stats), VF_OK);
    CHECK_INT_EQ(stats.nonfinite, 0);
    if (algorithms[a] == VF_ALGO_UPG) { /* the layers' bound held, and no path needed merging's bias */
      CHECK_INT_EQ((int)stats.upg_bound_exceeded, 0);
      CHECK_INT_EQ((int)stats.upg_fallbacks, 0);
      CHECK(stats.upg_gatherings > 0);
    }
  }
  for (int i = 0; i < n; i++)
    for (int j = i + 1; j < n; j++)
      CHECK(blocks_agree(what, vf_algorithm_name(algorithms[i]), vf_algorithm_name(algorithms[j]), mean[i], se[i],
                         mean[j], se[j], NB));
  vf_scene_destroy(scene);
}

/* Light tracing cannot see the smooth coat's mirror image (a delta vertex next to the
 * camera), and upg falls back to merging there: both join on the rough floor only. */
static void test_algorithms_agree_on_coat_and_sheen(void) {
  const vf_algorithm all[] = {VF_ALGO_PT, VF_ALGO_LT, VF_ALGO_BPT, VF_ALGO_VCM, VF_ALGO_UPG};
  check_agreement("rough floor coat", 0, all, 5);
}
static void test_algorithms_agree_on_a_smooth_coat(void) {
  const vf_algorithm some[] = {VF_ALGO_PT, VF_ALGO_BPT, VF_ALGO_VCM};
  check_agreement("smooth floor coat", 1, some, 3);
}

int main(void) {
  verbose = getenv("VF_TEST_VERBOSE") != NULL;
  make_cases();
  RUN(test_sampling_reports_the_evaluated_value_and_densities);
  RUN(test_reciprocity_and_reverse_densities);
  RUN(test_sampled_directions_and_albedo);
  RUN(test_sheen_albedo_table);
  RUN(test_upg_bound_holds_over_cones);
  RUN(test_algorithms_agree_on_coat_and_sheen);
  RUN(test_algorithms_agree_on_a_smooth_coat);
  return check_finish();
}
