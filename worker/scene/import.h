/* Whole-scene import (import.c, import_material.c): the "import" entries of a JSON scene,
 * each a model file whose meshes, materials, lights and cameras join the scene
 * (docs/SCENES.md, "import"). Private to worker/scene/. */
#ifndef VF_SCENE_IMPORT_H
#define VF_SCENE_IMPORT_H

#include "gltf.h"
#include "parse.h"

#include <cjson/cJSON.h>

struct aiScene;

/* A file being imported, as its material and light readers see it. All borrowed. */
typedef struct {
  const parse_ctx *c;
  const char *file;            /* as the scene names it: notes start with it */
  const char *what;            /* the file in errors ("import[0] (model.gltf)"); NULL: the scene is the file */
  const char *dir;             /* its directory as the scene names it ("" for the scene's own): textures are relative to it */
  int gltf_file;               /* a glTF file: its materials are glTF's */
  const struct aiScene *ai;
  vf_gltf_info gltf;           /* glTF files only */
  float *kd_ks_largest;        /* borrowed, written: the largest Kd + Ks above 1 that a material
                                * of the file had scaled down (0: none), noted once per file */
} vf_import_file;

/* Material `index` of the file as a vf_material (docs/SCENES.md, "import"), with its
 * textures loaded (vf_scene_texture_file / _bytes), the radiance its shapes emit in
 * *emission, and in *interior the medium it makes for its meshes' inside (glTF's
 * KHR_materials_volume: an absorbing medium named after the material, appended to the
 * scene's media) or -1. Notes what it cannot render. Errors name the file and the material. */
int vf_scene_import_material(const parse_ctx *c, const vf_import_file *f, unsigned index, vf_material *m,
                             vf_vec3 *emission, int *interior);

/* The JSON's "import" array: every file's meshes, materials and lights added to the scene.
 * Materials [0, json_materials) are the JSON's and replace the file's of the same name.
 * With *camera_wanted set (the JSON has no "camera"), the entry with a "camera" field, or
 * else the first file with a perspective camera, sets the scene's camera and clears it. */
int vf_scene_parse_imports(const parse_ctx *c, const cJSON *j, int json_materials, int *camera_wanted);
/* For a scene with no camera after its imports: one looking at the bounds from the side of
 * their largest projected area, with a note naming the side. */
int vf_scene_default_camera(const parse_ctx *c);
/* The radiance a white Lambertian surface reaches on average over the scene's
 * non-emitting surfaces from its emitters (one-sided, occlusion ignored), below which an
 * imported scene lit by nothing else is warned of. */
#define VF_DIM_LIGHT_LEVEL 0.01
/* For an imported scene lit by its emissive surfaces alone that give it almost no light
 * (VF_DIM_LIGHT_LEVEL): with may_light (the JSON scene has no "lights" field) a white
 * background of radiance 1 besides them, else a warning saying why the image will be dark;
 * a note either way. */
int vf_scene_dim_emitters(const parse_ctx *c, int may_light);
/* For an imported scene with no light at all: a white background, with a note. */
int vf_scene_default_light(const parse_ctx *c);

#endif
