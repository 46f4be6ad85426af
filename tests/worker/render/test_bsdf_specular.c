/* Tests of worker/render/bsdf.c's specular lobes against optics, never against numbers copied from
 * an earlier run: the mirror law, Snell's law, total internal reflection and the Fresnel
 * equations (against the angle forms, known values and Stokes' relation), and the
 * reflect/refract frequencies of the dielectric.
 * Sections keep the numbers of the single file they came from (2 here; 1a-1d, 3 and 4 in
 * test_bsdf.c, 1e and 1f in test_bsdf_energy.c); seeds, tolerances and the statistical budget
 * are those of bsdf_cases.h. */
#include "check.h"
#include "bsdf_cases.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

static int verbose;

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

int main(void) {
  const char *v = getenv("VF_TEST_VERBOSE");
  verbose = v && v[0] == '1';
  RUN(test_mirror_reflection_is_exact);
  RUN(test_dielectric_refraction_obeys_snell);
  RUN(test_total_internal_reflection_beyond_critical_angle);
  RUN(test_dielectric_reflects_with_fresnel_frequency);
  RUN(test_fresnel_known_values);
  return check_finish();
}
