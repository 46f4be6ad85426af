/* Typed field access to a scene's JSON: each function reads one value of a JSON object,
 * type-checked and finite, and records an error naming the field path with vf_scene_fail:
 * < 0 on error. Private to worker/scene/. */
#ifndef VF_SCENE_FIELDS_H
#define VF_SCENE_FIELDS_H

#include "parse.h"

#include <cjson/cJSON.h>

/* What a JSON value is, for messages: "a number", "an object", ... */
const char *vf_scene_kind(const cJSON *item);
/* obj is an object whose keys are all in `allowed` (NULL-terminated; NULL allows any key)
 * and no key repeats (cJSON keeps duplicates; the first would be read). */
int vf_scene_check_object(const parse_ctx *c, const cJSON *obj, const char *path, const char *const *allowed);

/* Materials [0, count) of a scene sorted by name, for lookups by name in O(log n). It
 * holds indices, so the scene's materials may grow (move) meanwhile; the scene is
 * borrowed. */
typedef struct {
  int *sorted; /* owned */
  int count;
  const vf_scene *scene;
} vf_name_index;
int vf_name_index_build(const vf_scene *s, int count, vf_name_index *out);
/* The lowest material index named `name`, or -1. */
int vf_name_index_find(const vf_name_index *x, const char *name);
void vf_name_index_release(vf_name_index *x);
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

#endif
