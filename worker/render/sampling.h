/* Warping of uniform random numbers to the distributions the renderer samples, with their
 * densities. Local directions are in a frame whose z axis is the surface normal. */
#ifndef VF_SAMPLING_H
#define VF_SAMPLING_H

#include "../../common/vec3.h"

#include <math.h>
#include <stdint.h>

#define VF_PI 3.14159265358979323846f
#define VF_INV_PI 0.31830988618379067154f

/* fmaxf(0.0f, x), inline. Baseline x86-64 has no instruction with fmaxf's NaN rule, so GCC
 * calls libm for fmaxf, once or twice per sampled direction. This returns glibc's value for
 * every x but a signalling NaN, which arithmetic never produces: a quiet NaN gives 0, and
 * -0 stays -0. */
static inline float vf_fmaxf_zero(float x) { return x >= 0.0f ? x : 0.0f; }

/* Cosine-weighted hemisphere around +z; pdf cos(theta) / pi. */
static inline vf_vec3 vf_sample_cosine_hemisphere(float u1, float u2, float *pdf_w) {
  float phi = 2.0f * VF_PI * u1;
  float r = sqrtf(u2);
  float z = sqrtf(vf_fmaxf_zero(1.0f - u2));
  if (pdf_w) *pdf_w = z * VF_INV_PI;
  return vf_vec3_make(r * cosf(phi), r * sinf(phi), z);
}

/* Uniform over the unit sphere; pdf 1 / (4 pi). */
static inline vf_vec3 vf_sample_uniform_sphere(float u1, float u2) {
  float z = 1.0f - 2.0f * u2;
  float r = sqrtf(vf_fmaxf_zero(1.0f - z * z));
  float phi = 2.0f * VF_PI * u1;
  return vf_vec3_make(r * cosf(phi), r * sinf(phi), z);
}
#define VF_UNIFORM_SPHERE_PDF_W (1.0f / (4.0f * VF_PI))

/* cos_a^n for the Phong lobe, evaluated about five times per vertex. Exponents are
 * integers in practice (our scenes: 40 to 5000); those are taken by repeated squaring, a
 * few multiplications where powf is a libm call that showed in vcm's profile, and
 * within (log2 n + popcount n) float roundings of the exact power: 2e-6 relative at most
 * for n = 5000. Other exponents go to powf. */
static inline float vf_phong_power(float cos_a, float n) {
  if (!(n >= 1.0f && n <= 65536.0f) || n != (float)(uint32_t)n) return powf(cos_a, n);
  uint32_t k = (uint32_t)n;
  float r = 1.0f, x = cos_a;
  for (;;) {
    if (k & 1u) r *= x;
    k >>= 1;
    if (k == 0) return r;
    x *= x;
  }
}

/* Power-cosine lobe around +z: pdf (n + 1) / (2 pi) cos^n(alpha). */
static inline vf_vec3 vf_sample_power_cosine(float u1, float u2, float n) {
  float cos_a = powf(u2, 1.0f / (n + 1.0f));
  float sin_a = sqrtf(vf_fmaxf_zero(1.0f - cos_a * cos_a));
  float phi = 2.0f * VF_PI * u1;
  return vf_vec3_make(sin_a * cosf(phi), sin_a * sinf(phi), cos_a);
}
static inline float vf_power_cosine_pdf_w(float cos_a, float n) {
  return cos_a > 0.0f ? (n + 1.0f) * (0.5f * VF_INV_PI) * vf_phong_power(cos_a, n) : 0.0f;
}

/* Uniform barycentric coordinates (u, v) on a triangle (Turk 1990 square-root warp). */
static inline void vf_sample_triangle(float u1, float u2, float *bu, float *bv) {
  float s = sqrtf(u1);
  *bu = 1.0f - s;
  *bv = u2 * s;
}

/* Concentric map of the unit square to the unit disk (Shirley and Chiu 1997); pdf 1 / pi. */
static inline void vf_sample_concentric_disk(float u1, float u2, float *x, float *y) {
  float a = 2.0f * u1 - 1.0f, b = 2.0f * u2 - 1.0f;
  if (a == 0.0f && b == 0.0f) {
    *x = *y = 0.0f;
    return;
  }
  float r, phi;
  if (a * a > b * b) {
    r = a;
    phi = (VF_PI / 4.0f) * (b / a);
  } else {
    r = b;
    phi = (VF_PI / 2.0f) - (VF_PI / 4.0f) * (a / b);
  }
  *x = r * cosf(phi);
  *y = r * sinf(phi);
}

#endif
