/* The sheen of KHR_materials_sheen: the "Charlie" microfibre distribution and its masking
 * [Conty17], and the sheen's directional albedo, which the glTF model scales the layer below
 * with (worker/render/bsdf.h composes them).
 *
 * Directions are local, z the normal; r = alpha is the sheen roughness squared
 * [KHR_materials_sheen: "the mapping r = sheenRoughness^2"].
 *   D(h)      = (2 + 1/r) sin(theta_h)^(1/r) / (2 pi)                      [Conty17, eq. 2]
 *   Lambda(c) = exp(L(c)) for c < 1/2, exp(2 L(1/2) - L(1 - c)) above,
 *               L(x) = a / (1 + b x^c) + d x + e, (a..e) interpolated by (1 - r)^2 between the
 *               paper's two fits                                           [Conty17, sec. 3]
 *   f(o, i)   = D(h) / (4 cos_o cos_i (1 + Lambda(cos_o) + Lambda(cos_i)))  (height-correlated)
 * The albedo E(cos_o) = int f cos_i d omega_i has no closed form: vf_sheen_albedo reads a
 * table integrated here, once per process, on first use (nothing is shipped); its rows are
 * sheen roughnesses from VF_SHEEN_ROUGHNESS_MIN to 1, its columns cos_o from 0 to 1, read
 * bilinearly, within 0.02 of the integral (0.008 from 87 degrees to normal incidence;
 * tests/worker/render/test_bsdf_layers.c). The table is part of the BRDF's definition: f uses the same value wherever it
 * is evaluated, so every technique sees one function.
 *
 *   [Conty17] A. Conty Estevez, C. Kulla, "Production Friendly Microfacet Sheen BRDF",
 *             SIGGRAPH 2017 course "Physically Based Shading in Theory and Practice".
 *   [KHR_materials_sheen] the glTF extension's specification, "Implementation Notes". */
#ifndef VF_SHEEN_H
#define VF_SHEEN_H

/* Sheen roughness below this is rendered as this (alpha 0.0025): at roughness 0 the
 * distribution is a delta at the horizon, whose lobe would reflect nothing at any angle but
 * grazing. */
#define VF_SHEEN_ROUGHNESS_MIN 0.05f

/* r for a sheen roughness in [0, 1] (clamped to the minimum above). */
float vf_sheen_alpha(float roughness);

/* D of a microfibre normal at cos_h to the normal (>= 0). */
float vf_sheen_d(float cos_h, float r);

/* Lambda at |cos| c of a direction to the normal. */
float vf_sheen_lambda(float c, float r);

/* f of unit colour for local o, i above the surface (cos_o, cos_i > 0), r = alpha. */
float vf_sheen_brdf(float cos_o, float cos_i, float cos_h, float r);

/* The directional albedo E(cos) of the unit-colour sheen of roughness `roughness` (the
 * table's, bilinear), and its cosine-weighted average 2 int E(c) c dc. Thread-safe. */
float vf_sheen_albedo(float cos, float roughness);
float vf_sheen_albedo_average(float roughness);

/* The same integral in double, computed afresh by the midpoint rule on `steps` x `steps`
 * points in the distribution's CDF coordinates (sin(theta_h)^(2 + 1/r) and the azimuth),
 * as the table's entries are: tests compare it with the table between the nodes. */
double vf_sheen_albedo_integral(double cos_o, double r, int steps);

#endif
