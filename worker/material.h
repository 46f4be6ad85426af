/* Materials: a sum of up to four lobes, each with its own albedo (RGB weight).
 *
 *   diffuse     Lambertian, f = diffuse / pi
 *   glossy      energy-normalised modified Phong around the mirror direction,
 *               f = glossy (n + 2) / (2 pi) cos^n(alpha), n = phong_exponent
 *   mirror      perfect specular reflection with reflectance `mirror`
 *   dielectric  smooth dielectric interface with index of refraction `ior` (inside over
 *               outside), Fresnel reflection and refraction, tinted by `dielectric`
 *
 * A scattering event picks a lobe with probability proportional to its albedo (the mean of
 * its RGB weights). Every channel of the sum of albedos must be <= 1 (no surface reflects more
 * energy than it receives); the scene loader enforces it. */
#ifndef VF_MATERIAL_H
#define VF_MATERIAL_H

#include "../common/vec3.h"

typedef struct {
  char name[64];
  vf_vec3 diffuse;
  vf_vec3 glossy;
  float phong_exponent; /* >= 1 when glossy is non-zero */
  vf_vec3 mirror;
  vf_vec3 dielectric;
  float ior;            /* > 0 when dielectric is non-zero */
} vf_material;

#endif
