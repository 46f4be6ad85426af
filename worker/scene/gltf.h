/* What a glTF file's own JSON says beyond what Assimp reads (gltf.c). Private to
 * worker/scene/. */
#ifndef VF_SCENE_GLTF_H
#define VF_SCENE_GLTF_H

#include "parse.h"

/* What a glTF file's own JSON says beyond Assimp (gltf.c). */
typedef struct {
  float *emissive_strength; /* per glTF material: KHR_materials_emissive_strength, else 1; owned */
  int num_materials;
  int has_occlusion;        /* some material has an occlusionTexture */
} vf_gltf_info;

/* 1 if file ends in .gltf or .glb (any case). */
int vf_gltf_is_gltf(const char *file);
/* Reads the JSON of glTF file `file` (resolved as mesh files are) into *out (release with
 * vf_gltf_info_release) and notes each extension of extensionsUsed that vcmfarm does not
 * implement, light ranges, occlusion textures and extra scenes. Errors name `what`. */
int vf_gltf_read_info(const parse_ctx *c, const char *file, const char *what, vf_gltf_info *out);
void vf_gltf_info_release(vf_gltf_info *info);

#endif
