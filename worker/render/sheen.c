/* The Charlie sheen and its albedo table: sheen.h. */
#include "sheen.h"

#include "sampling.h"

#include <math.h>
#include <pthread.h>

float vf_sheen_alpha(float roughness) {
  float s = roughness > VF_SHEEN_ROUGHNESS_MIN ? (roughness < 1.0f ? roughness : 1.0f) : VF_SHEEN_ROUGHNESS_MIN;
  return s * s;
}

float vf_sheen_d(float cos_h, float r) {
  float sin2 = 1.0f - cos_h * cos_h;
  if (!(sin2 > 0.0f)) return 0.0f;
  return (2.0f + 1.0f / r) * powf(sin2, 0.5f / r) * (0.5f * VF_INV_PI);
}

/* L(x) of [Conty17, sec. 3]: the fits at r = 0 and r = 1 mixed by (1 - r)^2, as the
 * extension's "Sheen visibility" writes them. */
static float sheen_l(float x, float r) {
  float t = (1.0f - r) * (1.0f - r);
  float a = 21.5473f + (25.3245f - 21.5473f) * t, b = 3.82987f + (3.32435f - 3.82987f) * t;
  float c = 0.19823f + (0.16801f - 0.19823f) * t, d = -1.97760f + (-1.27393f + 1.97760f) * t;
  float e = -4.32054f + (-4.85967f + 4.32054f) * t;
  return a / (1.0f + b * powf(x, c)) + d * x + e;
}

float vf_sheen_lambda(float c, float r) {
  c = fabsf(c);
  return c < 0.5f ? expf(sheen_l(c, r)) : expf(2.0f * sheen_l(0.5f, r) - sheen_l(1.0f - c, r));
}

float vf_sheen_brdf(float cos_o, float cos_i, float cos_h, float r) {
  float g = 1.0f + vf_sheen_lambda(cos_o, r) + vf_sheen_lambda(cos_i, r);
  return vf_sheen_d(cos_h, r) / (4.0f * cos_o * cos_i * g);
}

/* ---- the albedo ---------------------------------------------------------------------------- *
 * With D cos(theta_h) d omega_h = du d phi / (2 pi) for u = sin(theta_h)^(2 + 1/r) (D is
 * normalised so), and d omega_i = 4 (o.h) d omega_h for the mirror direction i of o about h,
 *   E(cos_o) = int f cos_i d omega_i = (1 / 2 pi) int int (o.h) / (cos_h cos_o (1 + L_o + L_i)) du d phi
 * over the h whose mirror direction is above the surface: bounded (i above needs
 * cos_h > cos_o / (2 o.h)) and smooth, since Lambda grows without bound at the horizon. The
 * integrand is even in phi: [0, pi] is integrated. */
double vf_sheen_albedo_integral(double cos_o, double r, int steps) {
  if (cos_o < 1e-4) cos_o = 1e-4;
  double sin_o = sqrt(fmax(0.0, 1.0 - cos_o * cos_o)), k = 2.0 + 1.0 / r;
  double lambda_o = vf_sheen_lambda((float)cos_o, (float)r), sum = 0.0;
  for (int a = 0; a < steps; a++) {
    double u = (a + 0.5) / steps, sin_h = pow(u, 1.0 / k), cos_h = sqrt(fmax(0.0, 1.0 - sin_h * sin_h));
    for (int b = 0; b < steps; b++) {
      double phi = M_PI * (b + 0.5) / steps;
      double oh = sin_o * sin_h * cos(phi) + cos_o * cos_h;
      if (!(oh > 0.0)) continue;
      double cos_i = 2.0 * oh * cos_h - cos_o;
      if (!(cos_i > 0.0)) continue;
      sum += oh / (cos_h * cos_o * (1.0 + lambda_o + vf_sheen_lambda((float)cos_i, (float)r)));
    }
  }
  return sum / ((double)steps * steps); /* (1 / 2 pi) x 2 pi / steps^2, phi over half the circle doubled */
}

/* Rows uniform in the square root of the sheen roughness above its minimum, columns uniform
 * in sqrt(cos): E varies fastest at low roughness and towards grazing incidence (to 2 at
 * 89.7 degrees for roughness 0.1), where they are dense. */
enum { ROWS = 24, COLUMNS = 49, STEPS = 96 };
static float table[ROWS][COLUMNS], average[ROWS];
static pthread_once_t table_once = PTHREAD_ONCE_INIT;

static void build_table(void) {
  for (int i = 0; i < ROWS; i++) {
    float q = (float)i / (ROWS - 1), s = VF_SHEEN_ROUGHNESS_MIN + (1.0f - VF_SHEEN_ROUGHNESS_MIN) * q * q;
    double r = (double)s * s, avg = 0.0;
    for (int j = 0; j < COLUMNS; j++) {
      double x = (double)j / (COLUMNS - 1);
      table[i][j] = (float)vf_sheen_albedo_integral(x * x, r, STEPS);
    }
    /* 2 int E(c) c dc = 4 int E(x^2) x^3 dx by the trapezoid rule over the columns */
    for (int j = 0; j + 1 < COLUMNS; j++) {
      double x0 = (double)j / (COLUMNS - 1), x1 = (double)(j + 1) / (COLUMNS - 1);
      avg += 2.0 * (table[i][j] * x0 * x0 * x0 + table[i][j + 1] * x1 * x1 * x1) * (x1 - x0);
    }
    average[i] = (float)avg;
  }
}

/* The row coordinate of a roughness: index and fraction. */
static int row_of(float roughness, float *frac) {
  float s = roughness > VF_SHEEN_ROUGHNESS_MIN ? (roughness < 1.0f ? roughness : 1.0f) : VF_SHEEN_ROUGHNESS_MIN;
  float x = sqrtf((s - VF_SHEEN_ROUGHNESS_MIN) / (1.0f - VF_SHEEN_ROUGHNESS_MIN)) * (ROWS - 1);
  int i = (int)x;
  if (i > ROWS - 2) i = ROWS - 2;
  *frac = x - (float)i;
  return i;
}

float vf_sheen_albedo(float cos, float roughness) {
  pthread_once(&table_once, build_table);
  float fr, fc;
  int i = row_of(roughness, &fr);
  float y = sqrtf(cos > 0.0f ? (cos < 1.0f ? cos : 1.0f) : 0.0f) * (COLUMNS - 1);
  int j = (int)y;
  if (j > COLUMNS - 2) j = COLUMNS - 2;
  fc = y - (float)j;
  float lo = table[i][j] + (table[i][j + 1] - table[i][j]) * fc;
  float hi = table[i + 1][j] + (table[i + 1][j + 1] - table[i + 1][j]) * fc;
  return lo + (hi - lo) * fr;
}

float vf_sheen_albedo_average(float roughness) {
  pthread_once(&table_once, build_table);
  float fr;
  int i = row_of(roughness, &fr);
  return average[i] + (average[i + 1] - average[i]) * fr;
}
