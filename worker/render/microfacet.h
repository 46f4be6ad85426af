/* The GGX (Trowbridge-Reitz) microfacet distribution and the Fresnel reflectances of the
 * rough lobes (worker/render/bsdf.h composes them into BSDFs).
 *
 * Directions and microfacet normals are unit vectors in a local frame whose z axis is the
 * macro-surface normal; alpha_x and alpha_y are the roughnesses along x and y. The
 * materials use alpha_x = alpha_y (isotropic): the shading frame (vf_frame_from_normal) has
 * no tangent tied to the surface, so an anisotropic lobe would have no meaningful
 * orientation until meshes bring tangents; the functions here are anisotropic already and
 * are tested so.
 *
 * Sources, cited at each formula:
 *   [Walter07]  B. Walter, S. Marschner, H. Li, K. Torrance, "Microfacet Models for
 *               Refraction through Rough Surfaces", EGSR 2007.
 *   [Heitz14]   E. Heitz, "Understanding the Masking-Shadowing Function in Microfacet-Based
 *               BRDFs", JCGT 3(2), 2014.
 *   [Heitz18]   E. Heitz, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4), 2018.
 *   [Dupuy23]   J. Dupuy, A. Benyoub, "Sampling Visible GGX Normals with Spherical Caps",
 *               HPG 2023 (Computer Graphics Forum 42(8)).
 *   [Schlick94] C. Schlick, "An Inexpensive BRDF Model for Physically-based Rendering",
 *               Computer Graphics Forum 13(3), 1994.
 *   [Lagarde13] S. Lagarde, "Memo on Fresnel equations", 2013 (the exact unpolarised
 *               reflectance of a conductor in real arithmetic).
 *   [glTF]      The glTF 2.0 specification, appendix B (BRDF implementation). */
#ifndef VF_MICROFACET_H
#define VF_MICROFACET_H

#include "../../common/vec3.h"
#include "sampling.h"

#include <math.h>

/* Below this alpha (roughness 0.0316) a GGX lobe is its delta limit (the threshold of
 * pbrt-v4's TrowbridgeReitzDistribution::EffectivelySmooth): the lobe is then narrower than
 * a thousandth of a radian, its density above 3e5 per steradian, and float directions
 * (rounded to ~1e-7 per frame change) resolve it to no better than a few percent. */
#define VF_GGX_ALPHA_DELTA 1e-3f

/* Fresnel reflectance of the conductor lobes. */
enum { VF_FRESNEL_ONE, VF_FRESNEL_COMPLEX, VF_FRESNEL_SCHLICK };

/* The glTF dielectric's normal-incidence reflectance, ((1 - ior) / (1 + ior))^2 for ior 1.5
 * [glTF, B.3.4]. */
#define VF_GLTF_DIELECTRIC_F0 0.04f

static inline float vf_ggx_alpha(float roughness) { return roughness * roughness; }

/* D(m) = 1 / (pi ax ay (mx^2 / ax^2 + my^2 / ay^2 + mz^2)^2) for unit m: Walter07 eq. 33,
 * made anisotropic by the stretch of Heitz14 (sec. 5), with cos^4 theta (1 + tan^2 theta
 * (...))^2 multiplied out so that nothing cancels at small alpha. Zero below the horizon. */
static inline float vf_ggx_d(vf_vec3 m, float ax, float ay) {
  if (!(m.z > 0.0f)) return 0.0f;
  float x = m.x / ax, y = m.y / ay;
  float s = x * x + y * y + m.z * m.z;
  return 1.0f / (VF_PI * ax * ay * s * s);
}

/* Smith's Lambda(w) = (sqrt(1 + (ax^2 wx^2 + ay^2 wy^2) / wz^2) - 1) / 2 of GGX (Heitz14,
 * sec. 5; with G1 = 1 / (1 + Lambda) it is Walter07 eq. 34), written q / (2 (sqrt(1 + q) + 1)) so that it keeps its precision where q is small. Even in
 * w.z: the same on both sides of the surface. */
static inline float vf_ggx_lambda(vf_vec3 w, float ax, float ay) {
  float x = ax * w.x, y = ay * w.y;
  float q = (x * x + y * y) / (w.z * w.z);
  return q / (2.0f * (sqrtf(1.0f + q) + 1.0f));
}

/* Smith's masking G1(w) = 1 / (1 + Lambda(w)) (Heitz14, sec. 5.1). */
static inline float vf_ggx_g1(vf_vec3 w, float ax, float ay) { return 1.0f / (1.0f + vf_ggx_lambda(w, ax, ay)); }

/* Density of the visible normals seen from w (w.z > 0), D_w(m) = G1(w) max(0, w.m) D(m) / w.z
 * [Heitz18, eq. 1; Heitz14, sec. 3]: what vf_ggx_sample_visible() draws, per steradian of m. */
static inline float vf_ggx_visible_pdf(vf_vec3 w, vf_vec3 m, float ax, float ay) {
  float c = vf_dot(w, m);
  if (!(c > 0.0f)) return 0.0f;
  return vf_ggx_g1(w, ax, ay) * c * vf_ggx_d(m, ax, ay) / w.z;
}

/* A visible normal seen from w (w.z > 0), drawn with density vf_ggx_visible_pdf() from
 * (u1, u2): the spherical-cap method [Dupuy23, listing 3]. In the configuration where alpha
 * is 1 the visible normals are w plus a uniform point on the spherical cap of the unit
 * sphere with z > -w.z; the stretch by alpha maps that configuration to this one (the
 * stretch invariance of [Heitz18, sec. 2]). */
static inline vf_vec3 vf_ggx_sample_visible(vf_vec3 w, float ax, float ay, float u1, float u2) {
  vf_vec3 ws = vf_normalize(vf_vec3_make(ax * w.x, ay * w.y, w.z));
  float phi = 2.0f * VF_PI * u1;
  float z = (1.0f - u2) * (1.0f + ws.z) - ws.z;
  float sin_theta = sqrtf(vf_fmaxf_zero(1.0f - z * z));
  vf_vec3 h = vf_add(ws, vf_vec3_make(sin_theta * cosf(phi), sin_theta * sinf(phi), z));
  return vf_normalize(vf_vec3_make(ax * h.x, ay * h.y, vf_fmaxf_zero(h.z)));
}

/* Schlick's approximation F0 + (1 - F0) (1 - c)^5 [Schlick94, eq. 15], c = cos of the angle
 * to the microfacet normal. */
static inline float vf_fresnel_schlick_weight(float c) {
  float m = 1.0f - c, m2 = m * m;
  return m2 * m2 * m;
}
static inline vf_vec3 vf_fresnel_schlick(vf_vec3 f0, float c) {
  float w = vf_fresnel_schlick_weight(c);
  return vf_add(f0, vf_scale(vf_sub(vf_vec3_splat(1.0f), f0), w));
}

/* Unpolarised Fresnel reflectance of a conductor of complex index of refraction eta + i k
 * (relative to the outside) for cos c of the angle of incidence, c in (0, 1] [Lagarde13,
 * "Fresnel conductor", the real-arithmetic form of the Fresnel equations with
 * a^2 + b^2 = |(eta + i k)^2 - sin^2|]: R_s and R_p, averaged. */
static inline float vf_fresnel_conductor1(float c, float eta, float k) {
  float c2 = c * c, s2 = 1.0f - c2;
  float t0 = eta * eta - k * k - s2;
  float a2b2 = sqrtf(t0 * t0 + 4.0f * eta * eta * k * k);
  float a = sqrtf(vf_fmaxf_zero(0.5f * (a2b2 + t0)));
  float t1 = a2b2 + c2, t2 = 2.0f * c * a;
  float rs = (t1 - t2) / (t1 + t2);
  float t3 = c2 * a2b2 + s2 * s2, t4 = t2 * s2;
  float rp = rs * (t3 - t4) / (t3 + t4);
  return 0.5f * (rs + rp);
}
static inline vf_vec3 vf_fresnel_conductor(float c, vf_vec3 eta, vf_vec3 k) {
  return vf_vec3_make(vf_fresnel_conductor1(c, eta.x, k.x), vf_fresnel_conductor1(c, eta.y, k.y),
                      vf_fresnel_conductor1(c, eta.z, k.z));
}

/* The cosine-weighted hemispherical averages 2 int_0^1 F(c) c dc of the reflectances above,
 * the albedo of a smooth surface under uniform light: Schlick's is F0 + (1 - F0) / 21
 * exactly; the conductor's is integrated numerically (microfacet.c: the midpoint rule on 64
 * points, within 1e-4). The BSDF selects its lobes in proportion to these, so their
 * precision matters to variance only. */
static inline vf_vec3 vf_fresnel_schlick_average(vf_vec3 f0) {
  return vf_add(f0, vf_scale(vf_sub(vf_vec3_splat(1.0f), f0), 1.0f / 21.0f));
}
vf_vec3 vf_fresnel_conductor_average(vf_vec3 eta, vf_vec3 k);

#endif
