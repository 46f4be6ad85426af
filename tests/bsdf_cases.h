/* What the BSDF tests share (test_bsdf.c, test_bsdf_energy.c, test_bsdf_specular.c): geometry
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
#include "worker/bsdf.h"
#include "worker/material.h"

#include <math.h>
#include <stdint.h>

#ifndef SEED
#define SEED 0x0b5df00dULL
#endif
#define K_SE 4.5
#define FAMILY_SIGNIFICANCE 1e-3
#define PI_D 3.14159265358979323846

/* One random stream per test; the numbers are part of every stream's identity. */
enum { CASE_PDF = 1, CASE_REVERSE, CASE_CHI2, CASE_INTEGRAL, CASE_ALBEDO, CASE_SPECULAR, CASE_HELPERS };

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

int has_nonspecular(const vf_material *m);

/* cos of the angle between gen and the mirror direction of fix about up (double). */
double cos_to_mirror(dvec fix, dvec gen, dvec up);

/* First-order bound on how far a float evaluation of the glossy term can move when the cosine
 * to the mirror direction carries an absolute rounding error (bsdf_cases.c explains it). */
double glossy_rounding(double scale, double n, double cos_a);

/* |a - b| beyond abs_allowance, relative to the larger magnitude (0 when within it). */
double rel_err(double a, double b, double abs_allowance);

#endif
