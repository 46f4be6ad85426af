/* What a glTF file's own JSON says beyond what Assimp reads (gltf.c). Private to
 * worker/scene/. */
#ifndef VF_SCENE_GLTF_H
#define VF_SCENE_GLTF_H

#include "parse.h"

#include <cjson/cJSON.h>
#include <stdint.h>

/* A material's textureInfo as the JSON has it: the image, the uv set and
 * KHR_texture_transform. */
typedef struct {
  int image;          /* index into the file's images; -1: no texture */
  int sampler;        /* -1: the default (repeat) */
  int uv_set;         /* texCoord, or KHR_texture_transform's texCoord override */
  int has_transform;  /* KHR_texture_transform given */
  float transform[6]; /* its 2x3 matrix T R S, rows (s' = t0 s + t1 t + t2, t' = t3 s + t4 t + t5) */
} vf_gltf_texture_ref;

/* What the file's JSON says of a material that Assimp 5.2.5 does not read. */
typedef struct {
  float emissive_strength;  /* KHR_materials_emissive_strength, else 1 */
  int has_specular;         /* KHR_materials_specular given */
  float specular;           /* specularFactor (default 1) */
  float specular_color[3];  /* specularColorFactor (default 1) */
  float ior;                /* KHR_materials_ior (default 1.5) */
  /* KHR_materials_volume: the medium inside a transmissive material's meshes. */
  int has_volume;           /* the extension given */
  float thickness;          /* thicknessFactor (default 0: thin-walled, no interior) */
  float attenuation_distance; /* attenuationDistance (default +inf: no absorption) */
  float attenuation_color[3]; /* attenuationColor (default 1) */
  int has_thickness_texture; /* thicknessTexture given (not supported) */
  /* KHR_materials_clearcoat and KHR_materials_sheen, as given (their defaults otherwise: 0,
   * the normal texture's scale 1) */
  float clearcoat, clearcoat_roughness, clearcoat_normal_scale;
  float sheen_color[3], sheen_roughness;
  /* Indexed by VF_TEXTURE_* (material.h): the core slots (ALPHA unused: the base colour's),
   * KHR_materials_specular's two, KHR_materials_clearcoat's three and KHR_materials_sheen's two. */
  vf_gltf_texture_ref textures[VF_TEXTURE_SLOTS];
} vf_gltf_material;

/* What a glTF file's own JSON says beyond Assimp (gltf.c). */
typedef struct {
  vf_gltf_material *materials; /* per glTF material, in the file's order; owned */
  int num_materials;
  /* Assimp 5.2.5 numbers a glTF file's materials in the order the default scene first
   * references them (its reader loads them lazily, nodes' children before their mesh),
   * not the file's: assimp_order[k] is the file's index of Assimp's material k. Owned. */
  int *assimp_order;
  int num_assimp_order;
  int has_occlusion;        /* some material has an occlusionTexture */
  int uses_draco;           /* some primitive has KHR_draco_mesh_compression */
  /* Images and what embeds them, for the textures Assimp does not load (specular). */
  cJSON *root;              /* the file's JSON; owned */
  char full[4096];          /* the file as opened */
  uint32_t bin_offset, bin_length; /* a .glb's BIN chunk in the file; length 0: none */
} vf_gltf_info;

/* 1 if file ends in .gltf or .glb (any case). */
int vf_gltf_is_gltf(const char *file);
/* Reads the JSON of glTF file `file` (resolved as mesh files are) into *out (release with
 * vf_gltf_info_release) and notes each extension of extensionsUsed that vcmfarm does not
 * implement, light ranges, occlusion textures and extra scenes. Errors name `what`. */
int vf_gltf_read_info(const parse_ctx *c, const char *file, const char *what, vf_gltf_info *out);
void vf_gltf_info_release(vf_gltf_info *info);

/* The file's material behind Assimp's material `index` named `name` ("" when unnamed):
 * by assimp_order when the names agree, else the one material of that name; NULL when
 * neither finds it (Assimp's default material). */
const vf_gltf_material *vf_gltf_material_of(const vf_gltf_info *info, unsigned index, const char *name);

/* Image `image` of the file: its URI relative to the file's directory in *uri (decoded
 * by the caller), or the encoded bytes embedded in the file (a bufferView of the .glb's
 * BIN chunk or of a buffer file, or a base64 data URI) in *bytes (malloc'd, the caller
 * frees) and *size. Errors name `where`. */
int vf_gltf_image(const parse_ctx *c, const vf_gltf_info *info, const char *dir, int image, const char *where,
                  const char **uri, void **bytes, size_t *size);

#endif
