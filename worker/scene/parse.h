/* Private to the scene module: what its files share while parsing a scene file.
 * json.c walks the JSON, mesh.c imports mesh files through Assimp, scene.c
 * loads, scales, bounds and hashes. Not part of the public API (that is scene.h). */
#ifndef VF_SCENE_PARSE_H
#define VF_SCENE_PARSE_H

#include "scene.h"
#include "builtin.h"

#include <cjson/cJSON.h>

#include <stddef.h>

/* Field paths longer than this only come from absurd keys: they end in "...". */
#define PATH_LEN 256

enum { OPTIONAL = 0, REQUIRED = 1 };

typedef struct {
  const char *label;    /* the scene as errors name it: the path given, or "builtin:NAME" */
  const char *base_dir; /* relative "file" paths start here */
  const vf_scene_memfile *memfiles;
  int num_memfiles;
  vf_scene *scene;      /* being filled; owned by vf_scene_parse */
  /* Farm jobs: when set, every "file" comes from here instead of base_dir
   * (worker/scene/files.h). Borrowed. */
  struct vf_scene_files *files;
} parse_ctx;

/* ---- typed field access (fields.c) ----
 * Each reads one value of a JSON object, type-checked and finite, and records an error
 * naming the field path with vf_scene_fail: < 0 on error. */
/* What a JSON value is, for messages: "a number", "an object", ... */
const char *vf_scene_kind(const cJSON *item);
/* obj is an object whose keys are all in `allowed` (NULL-terminated; NULL allows any key)
 * and no key repeats (cJSON keeps duplicates; the first would be read). */
int vf_scene_check_object(const parse_ctx *c, const cJSON *obj, const char *path, const char *const *allowed);
/* 1 and *out set when obj has `key`; 0 when it is absent and optional; < 0 on error. */
int vf_scene_member(const parse_ctx *c, const cJSON *obj, const char *path, const char *key, int required,
                    const cJSON **out);
int vf_scene_to_double(const parse_ctx *c, const cJSON *item, const char *path, double *out);
/* A number that fits a float. */
int vf_scene_to_float(const parse_ctx *c, const cJSON *item, const char *path, float *out);
/* A whole number in [min, max]. */
int vf_scene_to_integer(const parse_ctx *c, const cJSON *item, const char *path, double min, double max,
                        double *out);
/* An array of three floats. */
int vf_scene_to_vec3(const parse_ctx *c, const cJSON *item, const char *path, vf_vec3 *out);
/* The member `key` of obj as a float or a vec3: 1 read, 0 absent and optional, < 0 error. */
int vf_scene_float_field(const parse_ctx *c, const cJSON *obj, const char *path, const char *key, int required,
                         float *out);
int vf_scene_vec3_field(const parse_ctx *c, const cJSON *obj, const char *path, const char *key, int required,
                        vf_vec3 *out);
/* An RGB quantity that must not be negative; `what` names it in the error. */
int vf_scene_rgb_field(const parse_ctx *c, const cJSON *obj, const char *path, const char *key, int required,
                       const char *what, vf_vec3 *out);
int vf_scene_string_field(const parse_ctx *c, const cJSON *obj, const char *path, const char *key, int required,
                          const char **out);
/* A unit vector along v, computed in double so huge but finite inputs still normalise;
 * 0 for the zero vector. */
int vf_scene_unit(vf_vec3 v, vf_vec3 *out);

/* ---- shapes (shapes.c) ----
 * The "shapes" array: transforms, inline and file meshes, spheres, into world space. */
int vf_scene_parse_shapes(const parse_ctx *c, const cJSON *j);

/* The largest coordinate magnitude a scene may have, in world space after every transform
 * (vertices, sphere bounds, the camera, point lights). Embree asserts that ray origins
 * stay below 1.8e18 and the renderer squares distances in floats (3.4e38 at most): 1e15
 * keeps both with a wide margin. docs/SCENES.md states it. */
#define VF_SCENE_MAX_COORDINATE 1e15f

/* Refuses (VF_ESCENE naming the scene, what and where) a scene with a coordinate beyond
 * VF_SCENE_MAX_COORDINATE: the renderer could not trace it. */
int vf_scene_check_extent(const vf_scene *scene, const char *label);

/* Records "LABEL: PATH: message" (or "LABEL: message" without a path) and returns err. */
int vf_scene_fail(const parse_ctx *c, int err, const char *path, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

/* path + "." + key, and path + "[index]", into dst (PATH_LEN bytes); return dst. */
const char *vf_scene_join(char *dst, const char *path, const char *key);
const char *vf_scene_join_index(char *dst, const char *path, long index);

/* The path of `file` as the scene names it: absolute, or relative to the scene's directory. */
int vf_scene_resolve(const parse_ctx *c, const char *file, const char *path, char *out, size_t n);

/* Imports mesh `file` (relative to the scene's directory, or a memfile) into shape s, which
 * the field at `path` describes: every mesh of the file merged, node transforms applied,
 * with the vertex attributes every mesh has (scene.h). VF_ENOENT, VF_EMESH or VF_ENOMEM
 * with a detail. */
int vf_scene_load_mesh_file(const parse_ctx *c, const char *file, const char *path, vf_shape *s);

/* ---- Assimp files (mesh.c), shared by mesh files and whole-scene imports ---- */
struct aiScene;
struct aiMesh;
struct aiNode;
struct aiMatrix4x4;

/* Imports `file` (memfile, farm job file or relative to the scene's directory) through
 * Assimp, triangulated; every position, normal, tangent and channel-0 texture coordinate
 * checked finite and every normal non-zero before identical vertices are joined. Errors
 * name `fpath` (the field naming the file) for opening and reading, `what` (the file) for
 * its content; either may be NULL (then only the scene label). *out (aiReleaseImport) on
 * success only. */
int vf_scene_import_file(const parse_ctx *c, const char *file, const char *fpath, const char *what,
                         const struct aiScene **out);

/* An affine map in double: rows of p' = M p + t, the translation in column 3. */
typedef struct {
  double m[3][4];
} vf_affine;
void vf_affine_identity(vf_affine *a);
void vf_affine_from_ai(const struct aiMatrix4x4 *t, vf_affine *a);
/* out = a b (b applied first); out may alias either. */
void vf_affine_mul(const vf_affine *a, const vf_affine *b, vf_affine *out);
double vf_affine_det(const vf_affine *a);
void vf_affine_point(const vf_affine *a, const double in[3], double out[3]);
void vf_affine_vector(const vf_affine *a, const double in[3], double out[3]);

/* Moves vertices [v0, num_vertices) and triangles [t0, num_triangles) of s by a: positions
 * and tangents by M, normals by M^-T (renormalised), and a mirroring M swaps two corners of
 * each triangle and negates the tangents' bitangent sign, so fronts stay the file's.
 * VF_ESCENE naming `path` when a vertex leaves float range or a normal or tangent is
 * flattened (a singular M). */
int vf_scene_transform_range(const parse_ctx *c, const char *path, const vf_affine *a, vf_shape *s, uint32_t v0,
                             uint32_t t0);

/* Vertex attributes, as bits: what vf_scene_append_mesh had to drop. */
enum { VF_ATTR_NORMALS = 1u, VF_ATTR_UVS = 2u, VF_ATTR_TANGENTS = 4u };

/* Appends Assimp mesh `mesh_index` of a file, through `a` (its node's world transform), to
 * shape s: positions, triangles (points and lines left out), and normals, texture
 * coordinates of channel 0 (t = 1 - Assimp's v, so t = 0 is an image's top row) and
 * tangents (w from Assimp's bitangent) while every mesh appended to s has them; the
 * VF_ATTR_* bits of those lost in merging go into *dropped. Errors name `what`. */
int vf_scene_append_mesh(const parse_ctx *c, const char *what, const struct aiMesh *mesh, unsigned mesh_index,
                         const vf_affine *a, vf_shape *s, unsigned *dropped);
/* Notes once per file what merging dropped (the bits of vf_scene_append_mesh). */
int vf_scene_note_dropped(const parse_ctx *c, const char *file, unsigned dropped);

/* Calls fn for every (node, mesh) of the file's hierarchy, depth first, with the node's
 * world transform: root x the product of the node transforms from the file's root down.
 * Stops at and returns fn's first error; errors of its own (a hierarchy deeper than 256, a
 * node naming a missing mesh) name `what`. */
typedef int (*vf_scene_instance_fn)(void *user, const struct aiNode *node, unsigned mesh, const vf_affine *world);
int vf_scene_walk_nodes(const parse_ctx *c, const char *what, const struct aiScene *ai, const vf_affine *root,
                        vf_scene_instance_fn fn, void *user);
/* The world transform of node: the product of its and its parents' transforms. */
void vf_scene_node_world(const struct aiNode *node, vf_affine *out);

/* ---- whole-scene import (import.c, import_material.c, gltf.c) ---- */

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

/* A file being imported, as its material and light readers see it. All borrowed. */
typedef struct {
  const parse_ctx *c;
  const char *file;            /* as the scene names it: notes start with it */
  const char *what;            /* the file in errors ("import[0] (model.gltf)"); NULL: the scene is the file */
  const char *dir;             /* its directory as the scene names it ("" for the scene's own): textures are relative to it */
  int gltf_file;               /* a glTF file: its materials are glTF's */
  const struct aiScene *ai;
  vf_gltf_info gltf;           /* glTF files only */
} vf_import_file;

/* Material `index` of the file as a vf_material (docs/SCENES.md, "import"), with its
 * textures loaded (vf_scene_texture_file / _bytes) and the radiance its shapes emit in
 * *emission. Notes what it cannot render. Errors name the file and the material. */
int vf_scene_import_material(const parse_ctx *c, const vf_import_file *f, unsigned index, vf_material *m,
                             vf_vec3 *emission);

/* The JSON's "import" array: every file's meshes, materials and lights added to the scene.
 * Materials [0, json_materials) are the JSON's and replace the file's of the same name.
 * With *camera_wanted set (the JSON has no "camera"), the entry with a "camera" field, or
 * else the first file with a perspective camera, sets the scene's camera and clears it. */
int vf_scene_parse_imports(const parse_ctx *c, const cJSON *j, int json_materials, int *camera_wanted);
/* For a scene with no camera after its imports: one looking at the bounds, with a note. */
int vf_scene_default_camera(const parse_ctx *c);
/* For an imported scene with no light at all: a white background, with a note. */
int vf_scene_default_light(const parse_ctx *c);

/* A JSON "transform" object (shapes.c, docs/SCENES.md) as an affine map. */
int vf_scene_parse_transform(const parse_ctx *c, const cJSON *j, const char *path, vf_affine *out);

/* ---- textures (textures.c) ----
 * Texture `file`, resolved as mesh files are (so a farm job ships it by content hash, and
 * a recording load records it), decoded into the scene's textures once per name: its
 * 1-based index (vf_texture_slot.texture) into *index. Errors as vf_texture_read, the
 * detail naming the scene, the field at `path` and the file. */
int vf_scene_texture_file(const parse_ctx *c, const char *file, const char *path, int *index);
/* An image embedded in a file (a glTF binary's buffer view, a data URI), named `name`
 * ("model.glb#2"): decoded once per name as above. */
int vf_scene_texture_bytes(const parse_ctx *c, const char *name, const void *bytes, size_t size, const char *path,
                           int *index);

/* Adds a line to scene->notes (worker/scene/scene.h) unless the same line is there already.
 * VF_ENOMEM only. */
int vf_scene_note(const parse_ctx *c, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* The total area of mesh s, in double (an emitter's must be > 0). */
double vf_scene_mesh_area(const vf_shape *s);

/* Sets the scene's bounds from its shapes. */
void vf_scene_compute_bounds(vf_scene *s);

#endif
