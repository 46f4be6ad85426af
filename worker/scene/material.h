/* Materials: a sum of lobes, each with its own albedo (RGB weight), or the glTF 2.0
 * metallic-roughness model.
 *
 *   diffuse     Lambertian, f = diffuse / pi
 *   glossy      energy-normalised modified Phong around the mirror direction,
 *               f = glossy (n + 2) / (2 pi) cos^n(alpha), n = phong_exponent
 *   mirror      perfect specular reflection with reflectance `mirror`
 *   dielectric  dielectric interface with index of refraction `ior` (inside over outside),
 *               Fresnel reflection and refraction, tinted by `dielectric`: smooth, or rough
 *               (GGX, Walter et al. 2007) when `roughness` is above the threshold below
 *   conductor   GGX microfacet reflection tinted by `conductor`, with the Fresnel
 *               reflectance of the complex index of refraction conductor_eta + i conductor_k
 *               per channel (both zero: Fresnel 1, the tint alone); smooth below the threshold
 *
 * With `gltf` set the material is instead the glTF 2.0 metallic-roughness BRDF (glTF 2.0
 * specification, appendix B) of base_color, metallic and roughness, and the lobes above are
 * unused (zero): a GGX specular layer with Schlick's Fresnel of
 * F0 = mix(F0_d, base_color, metallic), F90 = mix(F90_d, 1, metallic) over a Lambertian
 * base of (1 - metallic) base_color weighted by 1 - max_rgb(F_d), F_d the dielectric's
 * Fresnel from F0_d (0.04, or KHR_materials_specular's) to F90_d (1, or its specular);
 * optionally under a sheen and a clear coat (KHR_materials_sheen, KHR_materials_clearcoat).
 *
 * roughness is glTF's perceptual roughness in [0, 1] for every GGX lobe of the material:
 * alpha = roughness^2. A lobe with alpha < VF_GGX_ALPHA_DELTA (worker/render/microfacet.h: alpha
 * 1e-3, roughness 0.0316) is its delta limit: the smooth dielectric, or a mirror reflecting
 * tint x Fresnel (the smooth conductor); so is a rough dielectric of ior 1, which only
 * transmits straight on. worker/render/bsdf.h has the formulas and their sources.
 *
 * A scattering event picks a lobe with probability proportional to its albedo (the mean of
 * its RGB weights; for the conductor lobes the weight times the cosine-weighted hemispherical
 * average of its Fresnel reflectance). Every channel of the sum of the lobes' weights must be
 * <= 1 (no surface reflects more energy than it receives); the scene loader enforces it.
 * Single-scattering GGX reflects less than its weight at high roughness (docs/SCENES.md has
 * the figures), and the glTF model more than 1 at grazing angles for a bright base colour:
 * that is the specification's BRDF, measured in tests/worker/render/test_microfacet.c. */
#ifndef VF_MATERIAL_H
#define VF_MATERIAL_H

#include "../../common/vec3.h"

/* Texture slots of a material: what each texture of worker/scene/texture.h multiplies. Colour
 * slots are sRGB-decoded when their texture is 8-bit; the others are read as stored. */
enum {
  VF_TEXTURE_COLOR,              /* RGB multiplies diffuse, or base_color of a glTF material (sRGB) */
  VF_TEXTURE_ROUGHNESS_METALLIC, /* glTF's layout: G multiplies roughness, B metallic (linear) */
  VF_TEXTURE_EMISSION,           /* RGB multiplies the emission of the shapes of this material (sRGB) */
  VF_TEXTURE_ALPHA,              /* channel alpha_channel multiplies alpha (linear) */
  VF_TEXTURE_NORMAL,             /* tangent-space normal map: RGB [0, 1] -> [-1, 1] (linear) */
  VF_TEXTURE_SPECULAR,           /* glTF model: A multiplies specular (KHR_materials_specular's specularTexture, linear) */
  VF_TEXTURE_SPECULAR_COLOR,     /* glTF model: RGB multiplies specular_f0 (specularColorTexture, sRGB) */
  VF_TEXTURE_CLEARCOAT,          /* glTF model: R multiplies clearcoat (clearcoatTexture, linear) */
  VF_TEXTURE_CLEARCOAT_ROUGHNESS, /* glTF model: G multiplies clearcoat_roughness (linear) */
  VF_TEXTURE_CLEARCOAT_NORMAL,   /* glTF model: the coat's tangent-space normal map (linear) */
  VF_TEXTURE_SHEEN_COLOR,        /* glTF model: RGB multiplies sheen_color (sheenColorTexture, sRGB) */
  VF_TEXTURE_SHEEN_ROUGHNESS,    /* glTF model: A multiplies sheen_roughness (sheenRoughnessTexture, linear) */
  VF_TEXTURE_SLOTS
};

/* A material's use of a texture. memset to zero is "no texture". */
typedef struct {
  int texture;        /* 1 + index into vf_scene.textures; 0: none */
  int wrap_s, wrap_t; /* VF_WRAP_* of worker/scene/texture.h */
  int uv_set;         /* 0 or 1: the shape's uvs or uvs1 (glTF's texCoord) */
  /* KHR_texture_transform: the texture is read at (s', t') = M (s, t, 1), M's rows
   * transform[0..2] and transform[3..5]; has_transform 0: the identity. */
  int has_transform;
  float transform[6];
} vf_texture_slot;

typedef struct {
  char name[64];
  vf_vec3 diffuse;
  vf_vec3 glossy;
  float phong_exponent; /* >= 1 when glossy is non-zero */
  vf_vec3 mirror;
  vf_vec3 dielectric;
  float ior;            /* > 0 when dielectric is non-zero */
  float roughness;      /* [0, 1]: of the dielectric, the conductor and the glTF specular layer */
  vf_vec3 conductor;
  vf_vec3 conductor_eta, conductor_k; /* >= 0; both zero: no Fresnel factor */
  int gltf;             /* the glTF model of base_color, metallic and roughness */
  vf_vec3 base_color;   /* [0, 1] per channel */
  float metallic;       /* [0, 1] */
  /* glTF model, KHR_materials_specular and KHR_materials_ior: with specular_set, the
   * dielectric layer's Schlick Fresnel goes from F0 = min(specular_f0, 1) x specular at
   * normal incidence to F90 = specular at grazing incidence; specular_f0 is
   * ((ior - 1) / (ior + 1))^2 x specularColorFactor (>= 0), specular in [0, 1]. Without
   * specular_set (zero, as a memset material has it): F0 = 0.04 and F90 = 1, the core
   * specification's dielectric. */
  int specular_set;
  float specular;
  vf_vec3 specular_f0;
  /* glTF model, KHR_materials_clearcoat: a GGX coat of F0 0.04 (ior 1.5), weight clearcoat in
   * [0, 1] (0: none), roughness clearcoat_roughness in [0, 1] (perceptual, alpha its square),
   * over the rest; its normal the mesh's (not the base's normal map), or its own normal map
   * scaled by clearcoat_normal_scale. KHR_materials_sheen: a Charlie sheen of sheen_color in
   * [0, 1] (zero: none) and sheen_roughness in [0, 1], between the coat and the base.
   * worker/render/bsdf.h has the formulas. */
  float clearcoat, clearcoat_roughness, clearcoat_normal_scale;
  vf_vec3 sheen_color;
  float sheen_roughness;
  /* Textures (memset to zero: none). Coverage = alpha x the ALPHA texture's channel; where
   * it is below alpha_cutoff the surface is a hole for every ray. alpha_cutoff 0: opaque
   * (alpha is then unused). normal_scale scales the normal map's x and y (glTF). */
  vf_texture_slot textures[VF_TEXTURE_SLOTS];
  float alpha, alpha_cutoff;
  int alpha_channel;    /* 0..3 */
  float normal_scale;
} vf_material;

/* Whether m has any texture. */
static inline int vf_material_textured(const vf_material *m) {
  for (int i = 0; i < VF_TEXTURE_SLOTS; i++)
    if (m->textures[i].texture != 0) return 1;
  return 0;
}

#endif
