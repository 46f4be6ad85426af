/* Tests of worker/render/microfacet.h (GGX and the Fresnel reflectances) and of what the rough lobes
 * of worker/render/bsdf.c become at their extremes, against numerical integration and optics, never
 * against numbers copied from an earlier run:
 * 1. D is normalised (int D cos_m = 1) and the visible normals' density integrates to 1 for
 *    every direction (which ties Lambda to D), anisotropic alphas included;
 * 2. the spherical-cap sampler draws that density (chi-square, one Sidak family);
 * 3. the conductor's Fresnel equals the Fresnel equations in complex arithmetic, its k = 0
 *    case the dielectric's, and its hemispherical average a quadrature of it;
 * 4. the white furnace: a rough conductor of Fresnel 1 reflects its numerically integrated
 *    single-scattering albedo, and the energy it loses (multiple scattering between
 *    microfacets, which GGX leaves out) is printed per roughness and angle;
 * 5. roughness -> 0: below VF_GGX_ALPHA_DELTA the lobes are the delta lobes (the smooth
 *    dielectric bit for bit), and above it albedo, directions and estimates converge to
 *    theirs;
 * 6. the scene format's fields for them (docs/SCENES.md): parsed into the material, and
 *    every bad value refused with an error naming its field.
 * Seeds, tolerances and statistics are those of bsdf_cases.h. */
#include "check.h"
#include "bsdf_cases.h"
#include "common/error.h"
#include "worker/render/microfacet.h"
#include "worker/scene/builtin.h"
#include "worker/scene/json.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- 1. normalisation ---- */

/* int over the upper hemisphere of g(m) d omega_m, by the midpoint rule in (t, phi) with
 * tan(theta) = scale t / (1 - t): the lobe's width `scale` gets as many points as its tail. */
typedef double (*hemisphere_fn)(dvec m, const void *ctx);
static double integrate_hemisphere(hemisphere_fn g, const void *ctx, double scale, int steps) {
  double sum = 0.0;
  for (int a = 0; a < steps; a++) {
    double t = (a + 0.5) / steps, x = scale * t / (1.0 - t);
    double theta = atan(x), dtheta = scale / ((1.0 - t) * (1.0 - t)) / (1.0 + x * x) / steps;
    for (int b = 0; b < 2 * steps; b++) {
      double phi = 2.0 * PI_D * (b + 0.5) / (2 * steps);
      dvec m = dmake(sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta));
      sum += g(m, ctx) * sin(theta) * dtheta * (PI_D / steps);
    }
  }
  return sum;
}

typedef struct {
  float ax, ay;
  vf_vec3 w;
} ggx_case;

static double d_cos(dvec m, const void *ctx) {
  const ggx_case *g = ctx;
  return vf_ggx_d(fv(m), g->ax, g->ay) * m.z;
}

static double visible(dvec m, const void *ctx) {
  const ggx_case *g = ctx;
  return vf_ggx_visible_pdf(g->w, fv(m), g->ax, g->ay);
}

static const float ALPHAS[][2] = {{0.01f, 0.01f}, {0.1f, 0.1f}, {0.5f, 0.5f}, {1.0f, 1.0f}, {0.1f, 0.6f}, {0.9f, 0.2f}};
enum { NUM_ALPHAS = sizeof ALPHAS / sizeof ALPHAS[0] };
static const double W_THETA[] = {0.0, 40.0, 75.0, 89.0};
enum { NUM_W = sizeof W_THETA / sizeof W_THETA[0] };

static vf_vec3 direction_at(double theta_deg, double phi) {
  double t = theta_deg * PI_D / 180.0;
  return fv(dmake(sin(t) * cos(phi), sin(t) * sin(phi), cos(t)));
}

static void test_ggx_is_normalised_and_visible_normals_integrate_to_one(void) {
  double worst_d = 0.0, worst_v = 0.0;
  for (int a = 0; a < NUM_ALPHAS; a++) {
    ggx_case g = {ALPHAS[a][0], ALPHAS[a][1], vf_vec3_make(0, 0, 1)};
    char label[64];
    snprintf(label, sizeof label, "alpha %g x %g", g.ax, g.ay);
    /* 1e-5: the quadrature of 600 x 1200 points (its error is O(h^2) in t) */
    double scale = fmin(g.ax, g.ay);
    double d = integrate_hemisphere(d_cos, &g, scale, 600);
    expect_near("int D(m) cos theta_m d omega", label, d, 1.0, 1e-5);
    worst_d = fmax(worst_d, fabs(d - 1.0));
    for (int w = 0; w < NUM_W; w++) {
      g.w = direction_at(W_THETA[w], 0.6);
      double v = integrate_hemisphere(visible, &g, scale, 600);
      snprintf(label, sizeof label, "alpha %g x %g, w at %g deg", g.ax, g.ay, W_THETA[w]);
      expect_near("int D_w(m) d omega (visible normals)", label, v, 1.0, 1e-5);
      worst_v = fmax(worst_v, fabs(v - 1.0));
    }
    /* G1 = 1 / (1 + Lambda) against Walter's closed form for the isotropic GGX, eq. 34 */
    if (g.ax == g.ay)
      for (int w = 0; w < NUM_W; w++) {
        vf_vec3 d3 = direction_at(W_THETA[w], 1.1);
        double t = tan(W_THETA[w] * PI_D / 180.0);
        expect_near("G1 == 2 / (1 + sqrt(1 + alpha^2 tan^2))", label, vf_ggx_g1(d3, g.ax, g.ay),
                    2.0 / (1.0 + sqrt(1.0 + g.ax * g.ax * t * t)), 1e-6);
      }
  }
  printf("  info: worst |int D cos - 1| %.2e, |int D_w - 1| %.2e\n", worst_d, worst_v);
}

/* ---- 2. the visible-normal sampler ---- */

static void test_visible_normal_sampler_follows_its_density(void) {
  enum { NT = 12, NP = 24, SAMPLES = 200000, SUB = 8 };
  double alpha = sidak(NUM_ALPHAS * NUM_W), min_p = 1.0;
  for (int a = 0; a < NUM_ALPHAS; a++)
    for (int w = 0; w < NUM_W; w++) {
      ggx_case g = {ALPHAS[a][0], ALPHAS[a][1], direction_at(W_THETA[w], 2.0)};
      char label[80];
      snprintf(label, sizeof label, "alpha %g x %g, w at %g deg", g.ax, g.ay, W_THETA[w]);
      /* cells in (t, phi) as integrate_hemisphere's: t = x / (scale + x), x = tan theta */
      double scale = fmin(g.ax, g.ay);
      static chi_cell cells[NT * NP];
      for (int c = 0; c < NT * NP; c++) {
        double sum = 0.0;
        int it = c / NP, ip = c % NP;
        for (int i = 0; i < SUB; i++)
          for (int j = 0; j < SUB; j++) {
            double t = (it + (i + 0.5) / SUB) / NT, x = scale * t / (1.0 - t), theta = atan(x);
            double dtheta = scale / ((1.0 - t) * (1.0 - t)) / (1.0 + x * x) / (NT * SUB);
            double phi = 2.0 * PI_D * (ip + (j + 0.5) / SUB) / NP;
            dvec m = dmake(sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta));
            sum += visible(m, &g) * sin(theta) * dtheta * 2.0 * PI_D / (NP * SUB);
          }
        cells[c] = (chi_cell){sum * SAMPLES, 0};
      }
      vf_rng r = test_rng(CASE_MICROFACET, (uint64_t)(a * NUM_W + w));
      double worst_norm = 0.0;
      for (int i = 0; i < SAMPLES; i++) {
        vf_vec3 m = vf_ggx_sample_visible(g.w, g.ax, g.ay, vf_rng_float(&r), vf_rng_float(&r));
        worst_norm = fmax(worst_norm, fabs(vf_length(m) - 1.0));
        double x = sqrt((double)m.x * m.x + (double)m.y * m.y) / m.z, t = x / (scale + x);
        double phi = atan2(m.y, m.x);
        if (phi < 0.0) phi += 2.0 * PI_D;
        int it = (int)(t * NT), ip = (int)(phi / (2.0 * PI_D) * NP);
        cells[(it < NT ? it : NT - 1) * NP + (ip < NP ? ip : NP - 1)].observed++;
      }
      expect_le("| |m| - 1 |", label, worst_norm, 4.0 * FLT_EPSILON);
      double chi2;
      int dof;
      double p = chi_square_p(cells, NT * NP, &chi2, &dof);
      if (!(p >= alpha)) CHECK_FAIL_("chi-square [%s]: chi2 %.1f with %d dof, p = %.3g < %.3g", label, chi2, dof, p, alpha);
      min_p = fmin(min_p, p);
    }
  printf("  info: %d chi-square tests of the visible-normal sampler, per-test significance %.2e, smallest p %.4f\n",
         NUM_ALPHAS * NUM_W, alpha, min_p);
}

/* ---- 3. Fresnel ---- */

static void test_fresnel_matches_complex_arithmetic(void) {
  static const struct {
    const char *name;
    vf_vec3 eta, k;
  } metals[] = {{"gold", {0.143f, 0.374f, 1.442f}, {3.983f, 2.385f, 1.603f}},
                {"copper", {0.200f, 0.924f, 1.102f}, {3.912f, 2.452f, 2.142f}},
                {"aluminium", {1.657f, 0.880f, 0.521f}, {9.224f, 6.270f, 4.837f}},
                {"weak absorber", {1.5f, 1.3f, 2.0f}, {0.1f, 0.01f, 0.5f}}};
  double worst = 0.0, worst_dielectric = 0.0, worst_average = 0.0;
  for (size_t i = 0; i < sizeof metals / sizeof metals[0]; i++) {
    double average[3] = {0};
    for (int a = 0; a <= 1000; a++) {
      double c = a == 0 ? 1e-4 : a / 1000.0;
      vf_vec3 f = vf_fresnel_conductor((float)c, metals[i].eta, metals[i].k);
      for (int ch = 0; ch < 3; ch++) {
        double ref = ref_fresnel((float)c, vf_vec3_get(metals[i].eta, ch), vf_vec3_get(metals[i].k, ch));
        worst = fmax(worst, fabs(vf_vec3_get(f, ch) - ref));
        /* float arithmetic of a few dozen operations on values of order 1..100 */
        if (!(fabs(vf_vec3_get(f, ch) - ref) <= 2e-5))
          CHECK_FAIL_("conductor Fresnel [%s, c %g, ch %d]: %.7f vs complex %.7f", metals[i].name, c, ch,
                      vf_vec3_get(f, ch), ref);
      }
    }
    /* the average by Simpson's rule on 2000 intervals of c, against the module's midpoint rule */
    for (int a = 0; a <= 2000; a++) {
      double c = a / 2000.0, w = (a == 0 || a == 2000) ? 1.0 : (a % 2 ? 4.0 : 2.0);
      for (int ch = 0; ch < 3; ch++)
        average[ch] += w * 2.0 * c * (c > 0.0 ? ref_fresnel(c, vf_vec3_get(metals[i].eta, ch), vf_vec3_get(metals[i].k, ch)) : 1.0) / (3.0 * 2000.0);
    }
    vf_vec3 avg = vf_fresnel_conductor_average(metals[i].eta, metals[i].k);
    for (int ch = 0; ch < 3; ch++) {
      worst_average = fmax(worst_average, fabs(vf_vec3_get(avg, ch) - average[ch]));
      expect_near("hemispherical average of the conductor's Fresnel", metals[i].name, vf_vec3_get(avg, ch), average[ch], 1e-4);
    }
  }
  /* k = 0 is a dielectric: the same as vf_fresnel_dielectric, which works in double (the
   * float form cancels near an index of 1 at grazing angles, which no conductor has) */
  static const float iors[] = {1.33f, 1.5f, 2.4f, 3.0f};
  for (int i = 0; i < 4; i++)
    for (int a = 1; a <= 1000; a++) {
      float c = a / 1000.0f;
      float dielectric = vf_fresnel_dielectric(c, iors[i]);
      float conductor = vf_fresnel_conductor1(c, iors[i], 0.0f);
      worst_dielectric = fmax(worst_dielectric, fabs(dielectric - conductor));
      if (!(fabs(dielectric - conductor) <= 2e-5))
        CHECK_FAIL_("conductor Fresnel with k = 0 [ior %g, c %g]: %.7f vs dielectric %.7f", iors[i], c, conductor,
                    dielectric);
    }
  vf_vec3 f0 = vf_vec3_make(0.04f, 0.5f, 0.9f);
  vf_vec3 at_normal = vf_fresnel_schlick(f0, 1.0f), at_grazing = vf_fresnel_schlick(f0, 0.0f);
  for (int ch = 0; ch < 3; ch++) {
    expect_near("Schlick at normal incidence == F0", "schlick", vf_vec3_get(at_normal, ch), vf_vec3_get(f0, ch), 0.0);
    expect_near("Schlick at grazing incidence == 1", "schlick", vf_vec3_get(at_grazing, ch), 1.0, 4.0 * FLT_EPSILON);
  }
  expect_near("Schlick average of F0 = 0 is 1 / 21", "schlick", vf_fresnel_schlick_average(vf_vec3_splat(0.0f)).x,
              1.0 / 21.0, 1e-7);
  printf("  info: worst |conductor - complex| %.2e, |k = 0 - dielectric| %.2e, |average - Simpson| %.2e\n", worst,
         worst_dielectric, worst_average);
}

/* ---- 4. the white furnace ---- */

static double sampled_albedo(const vf_material *m, double theta, uint64_t stream, int samples, double *se) {
  vf_vec3 normal, fix;
  dvec up;
  make_fix(theta, 0.3, 1, &normal, &fix, &up);
  vf_bsdf b;
  *se = NAN;
  if (!vf_bsdf_init(&b, m, normal, fix)) return NAN;
  vf_rng r = test_rng(CASE_FURNACE, stream);
  running_mean e = {0};
  for (int i = 0; i < samples; i++) {
    bsdf_draw s = draw_sample(&b, &r);
    rm_add(&e, draw_weight(&b, &s, 0));
  }
  *se = rm_se(&e);
  return rm_mean(&e);
}

static void test_white_furnace_energy_loss_of_single_scattering_ggx(void) {
  static const float roughness[] = {0.05f, 0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f, 0.7f, 0.8f, 0.9f, 1.0f};
  static const double angles[] = {0.0, 30.0, 60.0, 75.0, 85.0};
  enum { NR = sizeof roughness / sizeof roughness[0], NA = sizeof angles / sizeof angles[0] };
  printf("  energy lost by a rough conductor of Fresnel 1 (1 - directional albedo; sampled, reference):\n");
  printf("  roughness alpha  ");
  for (int a = 0; a < NA; a++) printf("   %4.0f deg        ", angles[a]);
  printf(" uniform light\n");
  double previous = -1.0;
  for (int i = 0; i < NR; i++) {
    vf_material m = {.conductor = vf_vec3_splat(1.0f), .roughness = roughness[i]};
    printf("  %9.2f %6.4f ", roughness[i], (double)roughness[i] * roughness[i]);
    for (int a = 0; a < NA; a++) {
      double theta = angles[a] * PI_D / 180.0, se;
      double e = sampled_albedo(&m, theta, (uint64_t)(i * NA + a), 100000, &se);
      ref_albedo ref;
      ref_rough_albedo(&m, theta, 1.0, 500, &ref);
      char label[64];
      snprintf(label, sizeof label, "roughness %g, %g deg", roughness[i], angles[a]);
      expect_near("furnace albedo, sampled == reference", label, e, ref.reflect[0], K_SE * se + 2e-5);
      expect_le("furnace albedo <= 1", label, ref.reflect[0], 1.0);
      printf(" %.4f (%.4f)   ", 1.0 - e, 1.0 - ref.reflect[0]);
      if (a == 0) {
        /* rougher loses more at normal incidence */
        expect_ge("loss grows with roughness", label, 1.0 - ref.reflect[0], previous);
        previous = 1.0 - ref.reflect[0];
      }
    }
    /* under uniform light, 1 - 2 int E(mu) mu d mu (Simpson on 32 intervals of mu) */
    double avg = 0.0;
    for (int q = 0; q <= 32; q++) {
      double mu = q / 32.0, w = (q == 0 || q == 32) ? 1.0 : (q % 2 ? 4.0 : 2.0);
      ref_albedo ref;
      if (mu > 0.0) ref_rough_albedo(&m, acos(mu), 1.0, 120, &ref);
      avg += w * 2.0 * mu * (mu > 0.0 ? ref.reflect[0] : 0.0) / (3.0 * 32.0);
    }
    printf(" %.4f\n", 1.0 - avg);
  }
}

/* The glTF model's albedo under uniform light, 2 int E(mu) mu d mu (Simpson on 32
 * intervals of mu, the reference's quadrature for E, its delta specular layer below the
 * threshold in closed form): printed, since the specification's BRDF exceeds 1 for bright
 * base colours (docs/SCENES.md); checked to exceed 1 only above base colour 0.9. */
static void test_gltf_furnace_albedo_is_reported(void) {
  static const float roughness[] = {0.02f, 0.1f, 0.3f, 0.5f, 1.0f};
  static const float base[] = {0.9f, 1.0f};
  printf("  glTF model, metallic 0, albedo under uniform light (base colour: roughness ...):\n");
  for (int c = 0; c < 2; c++) {
    printf("    %.1f:", base[c]);
    for (int i = 0; i < 5; i++) {
      vf_material m = {.gltf = 1, .base_color = vf_vec3_splat(base[c]), .metallic = 0.0f, .roughness = roughness[i]};
      int delta = vf_ggx_alpha(roughness[i]) < VF_GGX_ALPHA_DELTA;
      double avg = 0.0;
      for (int q = 1; q <= 32; q++) {
        double mu = q / 32.0, w = q == 32 ? 1.0 : (q % 2 ? 4.0 : 2.0);
        ref_albedo ref;
        ref_rough_albedo(&m, acos(mu), 1.0, 120, &ref);
        double e = ref.reflect[0] + (delta ? 0.04 + 0.96 * pow(1.0 - mu, 5.0) : 0.0);
        avg += w * 2.0 * mu * e / (3.0 * 32.0);
      }
      printf(" %.2f %.4f", roughness[i], avg);
      if (base[c] <= 0.9f) expect_le("uniform-light albedo of the glTF model", "base colour 0.9", avg, 1.0);
    }
    printf("\n");
  }
}

/* ---- 5. roughness -> 0 ---- */

static const vf_material GOLD = {.conductor = {1.0f, 1.0f, 1.0f}, .conductor_eta = {0.143f, 0.374f, 1.442f},
                                 .conductor_k = {3.983f, 2.385f, 1.603f}};
static const vf_material GLASS = {.dielectric = {1.0f, 1.0f, 1.0f}, .ior = 1.5f};

static void test_below_threshold_lobes_are_the_delta_lobes(void) {
  float r_delta = sqrtf(VF_GGX_ALPHA_DELTA) * 0.99f;
  vf_vec3 normal, fix;
  dvec up;
  make_fix(0.6, 1.0, 1, &normal, &fix, &up);
  /* rough dielectric below the threshold == the smooth dielectric, bit for bit; both sides */
  vf_material glass_r = GLASS, gold_r = GOLD;
  glass_r.roughness = gold_r.roughness = r_delta;
  vf_rng r = test_rng(CASE_LIMIT, 0);
  for (int side = 0; side < 2; side++) {
    vf_vec3 f_side = side ? vf_neg(fix) : fix;
    vf_bsdf smooth, rough, gold;
    CHECK(vf_bsdf_init(&smooth, &GLASS, normal, f_side) && vf_bsdf_init(&rough, &glass_r, normal, f_side));
    CHECK(vf_bsdf_init(&gold, &gold_r, normal, f_side));
    /* the glass is the older lobe itself; the gold a delta of the extended lobes */
    CHECK(rough.is_delta && !rough.extended && gold.is_delta && gold.extended && !gold.rough);
    for (int i = 0; i < 1000; i++) {
      float rnd[3], p[2], q[2], cg[2];
      vf_vec3 g[2];
      unsigned e[2];
      draw3(&r, rnd);
      vf_vec3 fs = vf_bsdf_sample(&smooth, rnd, &g[0], &p[0], &q[0], &cg[0], &e[0]);
      vf_vec3 fr = vf_bsdf_sample(&rough, rnd, &g[1], &p[1], &q[1], &cg[1], &e[1]);
      if (memcmp(&fs, &fr, sizeof fs) || memcmp(&g[0], &g[1], sizeof g[0]) || p[0] != p[1] || q[0] != q[1] ||
          e[0] != e[1] || cg[0] != cg[1])
        CHECK_FAIL_("dielectric of roughness %g differs from the smooth one (draw %d)", r_delta, i);
      /* the smooth conductor: the mirror direction, tint x Fresnel at the angle of fix */
      vf_vec3 f = vf_bsdf_sample(&gold, rnd, &g[0], &p[0], &q[0], &cg[0], &e[0]);
      CHECK(e[0] == VF_BSDF_SPECULAR);
      expect_le("smooth conductor: |gen - mirror|", "gold", dlength(dsub(dv(g[0]), dreflect(dv(f_side), dv(normal)))),
                8.0 * FLT_EPSILON);
      for (int ch = 0; ch < 3; ch++)
        expect_near("smooth conductor: throughput == Fresnel (complex)", "gold",
                    vf_vec3_get(f, ch) * cg[0] / p[0] * gold.continuation,
                    ref_fresnel(fabs(ddot(dv(f_side), dv(normal))), vf_vec3_get(GOLD.conductor_eta, ch),
                                vf_vec3_get(GOLD.conductor_k, ch)),
                    2e-5);
    }
  }
}

/* Above the threshold, as alpha falls, a rough lobe's albedo tends to its delta lobe's, its
 * directions gather around the delta direction within a few alpha, and the estimate of a
 * smooth function of the direction tends to the delta lobe's. */
static void test_rough_lobes_converge_to_delta_lobes(void) {
  static const float roughness[] = {0.3f, 0.1f, 0.05f, 0.04f, 0.0317f};
  enum { NR = sizeof roughness / sizeof roughness[0], SAMPLES = 100000 };
  static const double theta = 0.6;
  vf_vec3 normal, fix;
  dvec up;
  make_fix(theta, 1.0, 1, &normal, &fix, &up);
  dvec mirror = dreflect(dv(fix), up);
  double ci = cos(theta), st2 = (1.0 - ci * ci) / (1.5 * 1.5);
  dvec refracted = dsub(dscale(up, ci / 1.5 - sqrt(1.0 - st2)), dscale(dv(fix), 1.0 / 1.5));
  double fr = ref_fresnel(ci, 1.5, 0.0);
  dvec axis = dnormalize(dmake(0.3, 0.9, -0.2));
  for (int which = 0; which < 2; which++) {
    const char *name = which ? "glass 1.5" : "gold";
    printf("  %s at %.0f deg: roughness, |albedo - delta|, mean angle to the delta direction / alpha, "
           "|E[f cos/pdf g] - delta's| (g = exp(d.a))\n",
           name, theta * 180.0 / PI_D);
    double previous_gap = INFINITY;
    for (int i = 0; i < NR; i++) {
      vf_material m = which ? GLASS : GOLD;
      m.roughness = roughness[i];
      double alpha = (double)roughness[i] * roughness[i];
      vf_bsdf b;
      CHECK(vf_bsdf_init(&b, &m, normal, fix) && !b.is_delta);
      vf_rng r = test_rng(CASE_LIMIT, (uint64_t)(1 + which * NR + i));
      running_mean est = {0}, angle = {0};
      for (int s = 0; s < SAMPLES; s++) {
        bsdf_draw d = draw_sample(&b, &r);
        double w = draw_weight(&b, &d, 0);
        rm_add(&est, w * exp(ddot(dv(d.gen), axis)));
        if (w > 0.0) {
          dvec target = ddot(dv(d.gen), up) > 0.0 ? mirror : refracted;
          rm_add(&angle, acos(fmin(1.0, ddot(dnormalize(dv(d.gen)), dnormalize(target)))) / alpha);
        }
      }
      /* the delta lobe: gold reflects F(theta) along the mirror; glass F along the mirror and
       * 1 - F along the refraction (flux) */
      double f_gold = ref_fresnel(ci, GOLD.conductor_eta.x, GOLD.conductor_k.x);
      double delta_est = which ? fr * exp(ddot(mirror, axis)) + (1.0 - fr) * exp(ddot(refracted, axis))
                               : f_gold * exp(ddot(mirror, axis));
      ref_albedo ref;
      ref_rough_albedo(&m, theta, 1.5, 500, &ref);
      double gap = fabs(ref.reflect[0] + ref.transmit[0] - (which ? 1.0 : f_gold));
      double est_gap = fabs(rm_mean(&est) - delta_est);
      printf("    %6.4f  %.2e  %.2f  %.2e (se %.1e)\n", roughness[i], gap, rm_mean(&angle), est_gap, rm_se(&est));
      char label[64];
      snprintf(label, sizeof label, "%s, roughness %g", name, roughness[i]);
      /* the albedo's gap shrinks with alpha: single-scattering loss ~ alpha at most here */
      expect_le("|albedo - delta lobe's|", label, gap, fmin(previous_gap, 2.0 * alpha) + 1e-6);
      previous_gap = gap;
      /* GGX's mean angle to the centre is a few alpha (its long tail included) */
      expect_le("mean angle to the delta direction / alpha", label, rm_mean(&angle), 6.0);
      /* g has a gradient of order 1: the estimate moves by ~ the angle, a few alpha */
      expect_le("|estimate - delta lobe's|", label, est_gap, 8.0 * alpha + K_SE * rm_se(&est));
    }
  }
}

/* ---- 6. the scene format ---- */

/* A scene of one emissive quad whose material `name` is `material` (JSON). */
static int parse_material_scene(const char *material, vf_scene **out) {
  char text[1024];
  snprintf(text, sizeof text,
           "{\"camera\": {\"position\": [0, 0, 3], \"target\": [0, 0, 0], \"fov\": 40},"
           " \"materials\": {\"m\": %s},"
           " \"shapes\": [{\"type\": \"mesh\", \"material\": \"m\", \"emission\": [1, 1, 1],"
           "   \"positions\": [0,0,0, 1,0,0, 0,1,0], \"indices\": [0, 1, 2]}]}",
           material);
  return vf_scene_parse(text, strlen(text), "rough.json", ".", NULL, 0, out);
}

static void test_scene_format_reads_and_checks_the_rough_fields(void) {
  vf_scene *scene = NULL;
  CHECK_INT_EQ(parse_material_scene("{\"conductor\": [1, 0.9, 0.8], \"eta\": [0.2, 0.9, 1.1], \"k\": [3.9, 2.4, 2.1],"
                                    " \"roughness\": 0.25}",
                                    &scene),
               VF_OK);
  if (scene) {
    const vf_material *m = &scene->materials[0];
    CHECK(m->conductor.y == 0.9f && m->conductor_eta.z == 1.1f && m->conductor_k.x == 3.9f && m->roughness == 0.25f);
    CHECK(!m->gltf);
    vf_scene_destroy(scene);
  }
  scene = NULL;
  CHECK_INT_EQ(parse_material_scene("{\"base_color\": [0.5, 0.6, 0.7], \"metallic\": 0.3, \"roughness\": 0.8}", &scene),
               VF_OK);
  if (scene) {
    const vf_material *m = &scene->materials[0];
    CHECK(m->gltf && m->base_color.z == 0.7f && m->metallic == 0.3f && m->roughness == 0.8f);
    CHECK(vf_is_zero(m->diffuse) && vf_is_zero(m->conductor) && vf_is_zero(m->dielectric));
    vf_scene_destroy(scene);
  }
  static const struct {
    const char *material, *detail;
  } bad[] = {
      {"{\"conductor\": [1, 1, 1], \"roughness\": -0.1}", "materials.m.roughness: must be in [0, 1], found -0.1"},
      {"{\"dielectric\": [1, 1, 1], \"ior\": 1.5, \"roughness\": 1.5}", "materials.m.roughness: must be in [0, 1], found 1.5"},
      {"{\"conductor\": [1, 1, 1], \"roughness\": 1e999}", "materials.m.roughness: not a finite number"},
      {"{\"conductor\": [1, 1, 1], \"eta\": [1e999, 1, 1], \"k\": [1, 1, 1]}", "materials.m.eta[0]: not a finite number"},
      {"{\"conductor\": [1, 1, 1], \"eta\": [-0.2, 1, 1], \"k\": [1, 1, 1]}", "materials.m.eta: negative index of refraction"},
      {"{\"conductor\": [1, 1, 1], \"eta\": [0.2, 1, 1]}", "materials.m.eta: needs 'eta', 'k' and 'conductor'"},
      {"{\"conductor\": [1, 1, 1], \"k\": [3, 2, 1]}", "materials.m.k: needs 'eta', 'k' and 'conductor'"},
      {"{\"diffuse\": [0.5, 0.5, 0.5], \"eta\": [0.2, 1, 1], \"k\": [3, 2, 1]}", "materials.m.eta: needs 'eta', 'k' and 'conductor'"},
      {"{\"diffuse\": [0.5, 0.5, 0.5], \"roughness\": 0.3}", "materials.m.roughness: needs a 'conductor' or 'dielectric' lobe"},
      {"{\"conductor\": [0.6, 0.6, 0.6], \"diffuse\": [0.5, 0.2, 0.2]}", "materials.m: albedo sum of the lobes exceeds 1 (channel r"},
      {"{\"conductor\": [-1, 1, 1]}", "materials.m.conductor: negative albedo"},
      {"{\"base_color\": [0.5, 0.5, 0.5], \"metallic\": 0, \"roughness\": 0.5, \"diffuse\": [0.1, 0.1, 0.1]}",
       "materials.m.diffuse: unknown field (expected one of: base_color, metallic, roughness, base_color_texture,"},
      {"{\"base_color\": [0.5, 0.5, 0.5], \"roughness\": 0.5}", "materials.m: missing field 'metallic'"},
      {"{\"metallic\": 1, \"roughness\": 0.5}", "materials.m: missing field 'base_color'"},
      {"{\"base_color\": [0.5, 0.5, 0.5], \"metallic\": 0}", "materials.m: missing field 'roughness'"},
      {"{\"base_color\": [1.2, 0.5, 0.5], \"metallic\": 0, \"roughness\": 0.5}", "materials.m.base_color: exceeds 1 in a channel"},
      {"{\"base_color\": [0.5, 0.5, 0.5], \"metallic\": 1.01, \"roughness\": 0.5}", "materials.m.metallic: must be in [0, 1], found 1.01"},
      {"{\"base_color\": [0.5, 0.5, 0.5], \"metallic\": 0, \"roughness\": -1}", "materials.m.roughness: must be in [0, 1], found -1"},
  };
  for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
    scene = NULL;
    int err = parse_material_scene(bad[i].material, &scene);
    if (err != VF_ESCENE) CHECK_FAIL_("%s: code %d, expected VF_ESCENE (%d)", bad[i].material, err, VF_ESCENE);
    CHECK(scene == NULL);
    CHECK_STR_CONTAINS(vf_error_detail(err), bad[i].detail);
    vf_scene_destroy(scene);
  }
}

int main(void) {
  RUN(test_ggx_is_normalised_and_visible_normals_integrate_to_one);
  RUN(test_visible_normal_sampler_follows_its_density);
  RUN(test_fresnel_matches_complex_arithmetic);
  RUN(test_white_furnace_energy_loss_of_single_scattering_ggx);
  RUN(test_gltf_furnace_albedo_is_reported);
  RUN(test_below_threshold_lobes_are_the_delta_lobes);
  RUN(test_rough_lobes_converge_to_delta_lobes);
  RUN(test_scene_format_reads_and_checks_the_rough_fields);
  return check_finish();
}
