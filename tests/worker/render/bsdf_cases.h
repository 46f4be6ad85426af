/* What the BSDF tests share (test_bsdf.c, test_bsdf_energy.c, test_bsdf_specular.c, and for
 * the rough lobes test_bsdf_rough.c and test_microfacet.c): geometry
 * in double precision, independent of the code under test; the statistics their checks rest
 * on; and the table of materials and incidence configurations that every one of them walks.
 * Compiled into each of those executables (tests/CMakeLists.txt), never into a library, so the
 * names are the short ones of the tests rather than the library's vf_ prefix.
 *
 * Every random number comes from vf_rng_for_path(SEED, case, configuration, VF_STREAM_TEST),
 * so a run is deterministic and any configuration can be replayed alone (VF_TEST_VERBOSE=1
 * prints one line per configuration); a case number belongs to one test whichever executable
 * it lives in. Statistical checks allow K_SE standard errors, a two-sided normal tail of 7e-6
 * per check: the ~1000 of them in the three executables (many have zero variance) fail
 * together by chance with probability < 1%. Goodness-of-fit tests use a family-wise
 * significance of 1e-3, Sidak-corrected per test over their family; each family lives whole
 * in one executable (test_bsdf.c), since the correction counts its members. Floating-point
 * tolerances are derived from FLT_EPSILON and the condition of the quantity checked. A
 * different seed can be compiled in with -DSEED=... to look at the spread of the statistics,
 * never to make a test pass. */
#ifndef VF_TEST_BSDF_CASES_H
#define VF_TEST_BSDF_CASES_H

#include "common/rng.h"
#include "common/vec3.h"
#include "worker/render/bsdf.h"
#include "worker/scene/material.h"

#include <math.h>
#include <stdint.h>

#ifndef SEED
#define SEED 0x0b5df00dULL
#endif
#define K_SE 4.5
#define FAMILY_SIGNIFICANCE 1e-3
#define PI_D 3.14159265358979323846

/* One random stream per test; the numbers are part of every stream's identity. */
enum {
  CASE_PDF = 1,
  CASE_REVERSE,
  CASE_CHI2,
  CASE_INTEGRAL,
  CASE_ALBEDO,
  CASE_SPECULAR,
  CASE_HELPERS,
  CASE_ROUGH_PDF,
  CASE_ROUGH_REVERSE,
  CASE_ROUGH_CHI2,
  CASE_ROUGH_ALBEDO,
  CASE_MICROFACET,
  CASE_FURNACE,
  CASE_LIMIT
};

static inline vf_rng test_rng(uint64_t test_case, uint64_t configuration) {
  return vf_rng_for_path(SEED, test_case, configuration, VF_STREAM_TEST);
}

static inline void draw3(vf_rng *r, float rnd[3]) {
  rnd[0] = vf_rng_float(r);
  rnd[1] = vf_rng_float(r);
  rnd[2] = vf_rng_float(r);
}

/* ---- checks that say what and where ----
 * check.h keeps a case's pass/fail state in file-static variables of the test's own
 * translation unit, where RUN reads it; a check compiled into bsdf_cases.c would set a copy
 * RUN never sees. So the checks are static inline here, defined only after check.h, and
 * bsdf_cases.c checks nothing. */
#ifdef VF_TEST_CHECK_H
static inline void expect_le(const char *what, const char *where, double value, double limit) {
  if (!(value <= limit)) CHECK_FAIL_("%s [%s]: %.9g > limit %.9g", what, where, value, limit);
}

static inline void expect_ge(const char *what, const char *where, double value, double limit) {
  if (!(value >= limit)) CHECK_FAIL_("%s [%s]: %.9g < limit %.9g", what, where, value, limit);
}

static inline void expect_near(const char *what, const char *where, double value, double expected, double tol) {
  if (!(fabs(value - expected) <= tol))
    CHECK_FAIL_("%s [%s]: %.9g vs expected %.9g (|diff| %.3g > tol %.3g)", what, where, value, expected,
                fabs(value - expected), tol);
}
#endif

/* One vf_bsdf_sample() draw from r's next three numbers (f zero: the draw failed). */
typedef struct {
  vf_vec3 f, gen;
  float pdf, rev, cos_gen;
  unsigned event;
} bsdf_draw;

static inline bsdf_draw draw_sample(const vf_bsdf *b, vf_rng *r) {
  float rnd[3];
  bsdf_draw d = {.event = 0};
  draw3(r, rnd);
  d.f = vf_bsdf_sample(b, rnd, &d.gen, &d.pdf, &d.rev, &d.cos_gen, &d.event);
  return d;
}

/* What a path carries past the vertex in channel ch: f cos / pdf times the continuation
 * probability (the caller's Russian roulette); 0 for a failed draw. */
static inline double draw_weight(const vf_bsdf *b, const bsdf_draw *d, int ch) {
  return vf_is_zero(d->f) ? 0.0 : vf_vec3_get(d->f, ch) * d->cos_gen / d->pdf * b->continuation;
}

/* ---- double-precision geometry, independent of the code under test ---- */

typedef struct {
  double x, y, z;
} dvec;

static inline dvec dv(vf_vec3 v) { return (dvec){v.x, v.y, v.z}; }
static inline vf_vec3 fv(dvec v) { return vf_vec3_make((float)v.x, (float)v.y, (float)v.z); }
static inline dvec dmake(double x, double y, double z) { return (dvec){x, y, z}; }
static inline dvec dadd(dvec a, dvec b) { return (dvec){a.x + b.x, a.y + b.y, a.z + b.z}; }
static inline dvec dsub(dvec a, dvec b) { return (dvec){a.x - b.x, a.y - b.y, a.z - b.z}; }
static inline dvec dscale(dvec a, double s) { return (dvec){a.x * s, a.y * s, a.z * s}; }
static inline double ddot(dvec a, dvec b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline dvec dcross(dvec a, dvec b) {
  return (dvec){a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
static inline double dlength(dvec a) { return sqrt(ddot(a, a)); }
static inline dvec dnormalize(dvec a) { return dscale(a, 1.0 / dlength(a)); }
static inline dvec dreflect(dvec v, dvec n) { return dsub(dscale(n, 2.0 * ddot(v, n)), v); }

typedef struct {
  dvec s, t, n;
} dframe;

/* An orthonormal frame with the unit n as its third axis. */
dframe dframe_around(dvec n);

/* The unit direction at polar angle theta from f->n and azimuth phi from f->s. */
dvec dframe_dir(const dframe *f, double theta, double phi);

/* Uniform direction on the sphere, in double (the reference sampler of the integral tests). */
dvec uniform_sphere_d(vf_rng *r);

/* ---- statistics ---- */

/* Regularised upper incomplete gamma Q(a, x): the chi-square tail is Q(dof / 2, chi2 / 2).
 * test_bsdf.c checks it against closed forms. */
double gamma_q(double a, double x);

typedef struct {
  double expected;
  long observed;
} chi_cell;

/* Pearson chi-square of observed against expected counts; cells are pooled, smallest expected
 * first, until every pooled cell expects at least 5. Returns the p-value and writes the
 * statistic and its degrees of freedom; sorts `cells`. */
double chi_square_p(chi_cell *cells, int count, double *chi2_out, int *dof_out);

/* Per-test significance that keeps a family of `tests` independent tests at
 * FAMILY_SIGNIFICANCE: the count must be the whole family's. */
double sidak(int tests);

typedef struct {
  double sum, sum_sq;
  long n;
} running_mean;

static inline void rm_add(running_mean *m, double v) {
  m->sum += v;
  m->sum_sq += v * v;
  m->n++;
}
static inline double rm_mean(const running_mean *m) { return m->sum / (double)m->n; }
static inline double rm_se(const running_mean *m) {
  double mean = rm_mean(m);
  double var = fmax(0.0, m->sum_sq / (double)m->n - mean * mean);
  return sqrt(var / (double)(m->n - 1));
}

#ifdef VF_TEST_CHECK_H
/* A family of chi-square tests of sampled directions (test_bsdf.c, test_bsdf_rough.c):
 * each configuration's draws inside its grid against the grid's integrated density, and the
 * cells' shape. */
typedef struct {
  int tests;
  double alpha, min_p, worst_rate_z;
  char min_label[96];
} chi_family;

static inline chi_family chi_family_of(int tests) { return (chi_family){tests, sidak(tests), 1.0, 0.0, ""}; }

/* Rate: a draw is a non-specular one inside the grid with probability
 * rate = grid_mass / continuation, so in_grid of `samples` is binomial, up to the
 * deterministic `allowance` of the quadrature. Shape: given the count inside the grid, the
 * `count` cells are multinomial with probabilities proportional to their masses. */
static inline void chi_family_check(chi_family *f, const char *label, chi_cell *cells, const double *mass, int count,
                                    double grid_mass, double continuation, long in_grid, long samples,
                                    double allowance, int verbose) {
  double rate = grid_mass / continuation;
  double rate_sd = sqrt(samples * rate * fmax(0.0, 1.0 - rate));
  expect_near("non-specular draws inside the grid", label, (double)in_grid, samples * rate, K_SE * rate_sd + allowance);
  double rate_z = rate_sd > 0.0 ? fmax(0.0, fabs(in_grid - samples * rate) - allowance) / rate_sd : 0.0;
  f->worst_rate_z = fmax(f->worst_rate_z, rate_z);
  for (int q = 0; q < count; q++) cells[q].expected = in_grid * mass[q] / grid_mass;
  double chi2;
  int dof;
  double p = chi_square_p(cells, count, &chi2, &dof);
  if (!(p >= f->alpha)) CHECK_FAIL_("chi-square [%s]: chi2 %.1f with %d dof, p = %.3g < %.3g", label, chi2, dof, p, f->alpha);
  if (verbose)
    printf("  %-36s chi2 %8.1f dof %3d p %.3f  in grid %6ld expected %8.1f (z %.2f)\n", label, chi2, dof, p, in_grid,
           samples * rate, rate_z);
  if (p < f->min_p) {
    f->min_p = p;
    snprintf(f->min_label, sizeof f->min_label, "%s", label);
  }
}

static inline void chi_family_report(const chi_family *f, long samples) {
  printf("  info: %d chi-square tests of %ld samples, per-test significance %.2e, smallest p %.4f (%s); "
         "largest |z| of the in-grid rate beyond allowances %.2f\n",
         f->tests, samples, f->alpha, f->min_p, f->min_label, f->worst_rate_z);
}
#endif

/* ---- materials and configurations ---- */

typedef struct {
  const char *name;
  vf_material material;
  int pdf_consistency_only; /* exponent 1e5: the float pdf is only good to ~2% (2 n FLT_EPSILON) */
} material_case;

#define RGB(r, g, b) {r, g, b}

/* The materials every configuration loop walks, in a fixed order (the configuration index,
 * and so the random stream, of a case depends on it). The compiler holds the definition in
 * bsdf_cases.c to this count. */
enum { MATERIAL_COUNT = 13 };
extern const material_case MATERIALS[MATERIAL_COUNT];

#define ANGLE_COUNT 3 /* incidence at 0, 45 and 85 degrees */
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

/* A fix direction at theta from the (tilted, off-axis) geometric normal, on its front or back
 * side: writes the float normal and fix and the double normal turned to the side of fix. */
void make_fix(double theta, double azimuth, int front, vf_vec3 *normal, vf_vec3 *fix, dvec *up);

/* Configuration `index` in [0, CONFIG_COUNT): material index / 6, angle (index / 2) % 3,
 * front when index is even; its BSDF initialised. */
void make_config(config *c, int index);

/* The rough lobes' materials (test_bsdf_rough.c), a table of their own so that the
 * configurations above keep their indices and random streams; configuration `index` in
 * [0, ROUGH_CONFIG_COUNT) as make_config's. */
enum { ROUGH_MATERIAL_COUNT = 16 };
extern const material_case ROUGH_MATERIALS[ROUGH_MATERIAL_COUNT];
#define ROUGH_CONFIG_COUNT (ROUGH_MATERIAL_COUNT * ANGLE_COUNT * 2)
void make_rough_config(config *c, int index);

int has_nonspecular(const vf_material *m);

/* A pair of the reverse-density and reciprocity tests: a direction b, from c's sampler for
 * even i (where the lobes are) and uniform on the sphere otherwise (both sides, the edges),
 * and both evaluations, of c's BSDF for b (a -> b) and of the BSDF at b for c's fix
 * (b -> a). 0 when nothing scatters at b. */
typedef struct {
  vf_vec3 b, f_ab, f_ba;
  float d_ab, r_ab, d_ba, r_ba;
} swapped_pair;
int make_swapped_pair(const config *c, vf_rng *r, int i, swapped_pair *p);

/* cos of the angle between gen and the mirror direction of fix about up (double). */
double cos_to_mirror(dvec fix, dvec gen, dvec up);

/* First-order bound on how far a float evaluation of the glossy term can move when the cosine
 * to the mirror direction carries an absolute rounding error (bsdf_cases.c explains it). */
double glossy_rounding(double scale, double n, double cos_a);

/* |a - b| beyond abs_allowance, relative to the larger magnitude (0 when within it). */
double rel_err(double a, double b, double abs_allowance);

/* ---- a double-precision reference of the rough lobes ----
 * Written from the papers apart from worker/render/bsdf.c and worker/render/microfacet.h, in other forms:
 * the Fresnel equations in complex arithmetic (Born and Wolf), GGX through its slope-space
 * CDF (Walter et al. 2007 eq. 35), refraction by Walter's eq. 40. */

/* Unpolarised Fresnel reflectance for cos_i > 0 into a medium of relative index n (complex
 * for a conductor; real below 1 for leaving a dielectric, total internal reflection
 * included). */
double ref_fresnel(double cos_i, double n_re, double n_im);

/* The GGX masking Lambda(w) = (sqrt(1 + alpha^2 tan^2 theta) - 1) / 2 (Walter et al. eq. 34). */
double ref_ggx_lambda(dvec w, double alpha);

/* Directional albedo of a material's rough and base lobes (not its diffuse, Phong or delta
 * lobes), as a light sub-path's flux, for fix at theta to the shading normal, a dielectric
 * being entered with ior ratio eta: reflected and transmitted per channel. By the midpoint
 * rule on steps x 2 steps points over the microfacet normals in GGX's CDF coordinates,
 * where D(m) cos(theta_m) d omega_m = du d phi / (2 pi): a smooth integrand at any alpha
 * (the glTF base, steps^2 points over cosine-distributed directions). */
typedef struct {
  double reflect[3], transmit[3];
} ref_albedo;
void ref_rough_albedo(const vf_material *m, double theta, double eta, int steps, ref_albedo *out);

/* The reflectance of a material's conductor lobe for cos c to the microfacet normal, channel
 * ch: tint x Fresnel, or the glTF model's Schlick. */
double ref_conductor_reflectance(const vf_material *m, double c, int ch);

#endif
