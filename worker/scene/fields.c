/* Typed access to the fields of a JSON scene, for the scene parser (fields.h): every
 * value type-checked and finite, every error naming the field path. */
#include "fields.h"

#include "../../common/error.h"

#include <cjson/cJSON.h>

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *vf_scene_kind(const cJSON *item) {
  if (cJSON_IsNumber(item)) return "a number";
  if (cJSON_IsString(item)) return "a string";
  if (cJSON_IsArray(item)) return "an array";
  if (cJSON_IsObject(item)) return "an object";
  if (cJSON_IsBool(item)) return "a boolean";
  return "null";
}

/* ---- typed field access ---------------------------------------------------------------- */

/* Checks that obj is an object whose keys are all in `allowed` (NULL-terminated; NULL
 * allows any key) and that no key repeats: cJSON keeps duplicates, we would read the first. */
/* Keys of a large object, sorted by name then position, so that a repeated key is found
 * in O(n log n): a "materials" object of 200,000 names compared pairwise took minutes. */
typedef struct {
  const char *key;
  long position;
} key_at;

static int compare_keys(const void *a, const void *b) {
  const key_at *x = a, *y = b;
  int c = strcmp(x->key, y->key);
  return c != 0 ? c : (x->position > y->position) - (x->position < y->position);
}

/* Objects up to this many members are checked pairwise (no allocation). */
#define SMALL_OBJECT 32

/* The member of obj whose key repeats an earlier member's (the first such in the file's
 * order), or NULL; *failed on allocation failure. */
static const cJSON *repeated_key(const cJSON *obj, int *failed) {
  long n = 0;
  const cJSON *m;
  *failed = 0;
  for (m = obj->child; m != NULL; m = m->next) n++;
  if (n <= SMALL_OBJECT) {
    for (m = obj->child; m != NULL; m = m->next)
      for (const cJSON *e = obj->child; e != m; e = e->next)
        if (strcmp(e->string, m->string) == 0) return m;
    return NULL;
  }
  key_at *keys = malloc((size_t)n * sizeof *keys);
  const cJSON **members = malloc((size_t)n * sizeof *members);
  if (keys == NULL || members == NULL) {
    free(keys);
    free(members);
    *failed = 1;
    return NULL;
  }
  long i = 0;
  for (m = obj->child; m != NULL; m = m->next, i++) keys[i] = (key_at){m->string, i}, members[i] = m;
  qsort(keys, (size_t)n, sizeof *keys, compare_keys);
  long first = -1;
  for (i = 1; i < n; i++)
    if (strcmp(keys[i - 1].key, keys[i].key) == 0 && (first < 0 || keys[i].position < first)) first = keys[i].position;
  const cJSON *found = first >= 0 ? members[first] : NULL;
  free(keys);
  free(members);
  return found;
}

int vf_scene_check_object(const parse_ctx *c, const cJSON *obj, const char *path, const char *const *allowed) {
  char p[PATH_LEN];
  if (!cJSON_IsObject(obj))
    return vf_scene_fail(c, VF_ESCENE, path, "expected an object, found %s", vf_scene_kind(obj));
  const cJSON *m;
  cJSON_ArrayForEach(m, obj) {
    int known = allowed == NULL;
    for (int i = 0; !known && allowed[i] != NULL; i++) known = strcmp(allowed[i], m->string) == 0;
    if (!known) {
      char list[256] = "";
      for (int i = 0; allowed[i] != NULL; i++)
        snprintf(list + strlen(list), sizeof list - strlen(list), "%s%s", i ? ", " : "", allowed[i]);
      return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, m->string), "unknown field (expected one of: %s)", list);
    }
  }
  int failed;
  const cJSON *dup = repeated_key(obj, &failed);
  if (failed) return vf_error_set(VF_ENOMEM, "out of memory");
  if (dup != NULL) return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, dup->string), "duplicate field");
  return VF_OK;
}

/* ---- material names ------------------------------------------------------------------- */

/* qsort has no context argument: the scene being indexed, for the comparison (per thread:
 * scenes may load on several threads at once). */
static _Thread_local const vf_scene *sorting;

static int compare_names(const void *a, const void *b) {
  int x = *(const int *)a, y = *(const int *)b, c = strcmp(sorting->materials[x].name, sorting->materials[y].name);
  return c != 0 ? c : (x > y) - (x < y);
}

int vf_name_index_build(const vf_scene *s, int count, vf_name_index *out) {
  int *e = malloc(((size_t)count + 1) * sizeof *e);
  if (e == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  for (int i = 0; i < count; i++) e[i] = i;
  sorting = s;
  qsort(e, (size_t)count, sizeof *e, compare_names);
  out->sorted = e;
  out->count = count;
  out->scene = s;
  return VF_OK;
}

int vf_name_index_find(const vf_name_index *x, const char *name) {
  int lo = 0, hi = x->count; /* the first entry not below name */
  while (lo < hi) {
    int mid = lo + (hi - lo) / 2;
    if (strcmp(x->scene->materials[x->sorted[mid]].name, name) < 0) lo = mid + 1;
    else hi = mid;
  }
  return lo < x->count && strcmp(x->scene->materials[x->sorted[lo]].name, name) == 0 ? x->sorted[lo] : -1;
}

void vf_name_index_release(vf_name_index *x) {
  free(x->sorted);
  x->sorted = NULL;
  x->count = 0;
}

/* 1 and *out set when obj has `key`; 0 when it is absent and optional; < 0 on error. */
int vf_scene_member(const parse_ctx *c, const cJSON *obj, const char *path, const char *key, int required,
                    const cJSON **out) {
  const cJSON *m = cJSON_GetObjectItemCaseSensitive(obj, key);
  *out = m;
  if (m == NULL && required) return vf_scene_fail(c, VF_ESCENE, path, "missing field '%s'", key);
  return m != NULL;
}

int vf_scene_to_double(const parse_ctx *c, const cJSON *item, const char *path, double *out) {
  if (!cJSON_IsNumber(item))
    return vf_scene_fail(c, VF_ESCENE, path, "expected a number, found %s", vf_scene_kind(item));
  /* cJSON turns 1e999 into infinity; JSON has no NaN literal, but be explicit anyway. */
  if (!isfinite(item->valuedouble)) return vf_scene_fail(c, VF_ESCENE, path, "not a finite number");
  *out = item->valuedouble;
  return VF_OK;
}

int vf_scene_to_float(const parse_ctx *c, const cJSON *item, const char *path, float *out) {
  double d = 0.0;
  int err = vf_scene_to_double(c, item, path, &d);
  if (err < 0) return err;
  if (fabs(d) > FLT_MAX) return vf_scene_fail(c, VF_ESCENE, path, "not a finite number in single precision");
  *out = (float)d;
  return VF_OK;
}

int vf_scene_to_integer(const parse_ctx *c, const cJSON *item, const char *path, double min, double max,
                        double *out) {
  double d = 0.0;
  int err = vf_scene_to_double(c, item, path, &d);
  if (err < 0) return err;
  if (d != floor(d)) return vf_scene_fail(c, VF_ESCENE, path, "expected an integer, found %g", d);
  if (d < min || d > max) return vf_scene_fail(c, VF_ESCENE, path, "must be in [%.0f, %.0f], found %.0f", min, max, d);
  *out = d;
  return VF_OK;
}

int vf_scene_to_vec3(const parse_ctx *c, const cJSON *item, const char *path, vf_vec3 *out) {
  char p[PATH_LEN];
  if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) != 3)
    return vf_scene_fail(c, VF_ESCENE, path, "expected an array of 3 numbers");
  float v[3];
  int i = 0;
  const cJSON *e;
  cJSON_ArrayForEach(e, item) {
    int err = vf_scene_to_float(c, e, vf_scene_join_index(p, path, i), &v[i]);
    if (err < 0) return err;
    i++;
  }
  *out = vf_vec3_make(v[0], v[1], v[2]);
  return VF_OK;
}

int vf_scene_float_field(const parse_ctx *c, const cJSON *obj, const char *path, const char *key, int required,
                         float *out) {
  char p[PATH_LEN];
  const cJSON *m;
  int r = vf_scene_member(c, obj, path, key, required, &m);
  if (r <= 0) return r;
  r = vf_scene_to_float(c, m, vf_scene_join(p, path, key), out);
  return r < 0 ? r : 1;
}

int vf_scene_vec3_field(const parse_ctx *c, const cJSON *obj, const char *path, const char *key, int required,
                        vf_vec3 *out) {
  char p[PATH_LEN];
  const cJSON *m;
  int r = vf_scene_member(c, obj, path, key, required, &m);
  if (r <= 0) return r;
  r = vf_scene_to_vec3(c, m, vf_scene_join(p, path, key), out);
  return r < 0 ? r : 1;
}

/* An RGB quantity that must not be negative; `what` names it in the error. */
int vf_scene_rgb_field(const parse_ctx *c, const cJSON *obj, const char *path, const char *key, int required,
                       const char *what, vf_vec3 *out) {
  char p[PATH_LEN];
  vf_vec3 v;
  int r = vf_scene_vec3_field(c, obj, path, key, required, &v);
  if (r <= 0) return r;
  if (vf_min_component(v) < 0.0f) return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, key), "negative %s", what);
  *out = v;
  return 1;
}

int vf_scene_string_field(const parse_ctx *c, const cJSON *obj, const char *path, const char *key, int required,
                          const char **out) {
  char p[PATH_LEN];
  const cJSON *m;
  int r = vf_scene_member(c, obj, path, key, required, &m);
  if (r <= 0) return r;
  if (!cJSON_IsString(m))
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, key), "expected a string, found %s", vf_scene_kind(m));
  *out = m->valuestring;
  return 1;
}

/* A unit vector along v, computed in double so huge but finite inputs still normalise. */
int vf_scene_unit(vf_vec3 v, vf_vec3 *out) {
  double x = v.x, y = v.y, z = v.z, len = sqrt(x * x + y * y + z * z);
  if (!(len > 0.0)) return 0;
  *out = vf_vec3_make((float)(x / len), (float)(y / len), (float)(z / len));
  return 1;
}
