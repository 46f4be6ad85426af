/* Scene files: JSON (cJSON) -> validated world-space vf_scene.
 *
 * The format is documented in docs/SCENES.md; this file is its only implementation, and the
 * built-in scenes (scene_builtin.c) go through it too. Everything read from the file is
 * untrusted: every field is type-checked, every number must be finite, unknown fields are
 * errors (a misspelt "emision" silently ignored would cost someone a night of rendering),
 * and every error names the file, the field path and the problem.
 *
 * Parsing fills a calloc'ed scene step by step; on any failure vf_scene_destroy() frees
 * whatever was filled so far, which is why every array is counted as soon as it is
 * allocated and zero-filled until used. */
#include "scene_parse.h"

#include "../common/error.h"

#include <cjson/cJSON.h>

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Albedo sums are written in decimal and summed in float: allow the rounding of that. */
#define ALBEDO_SUM_TOLERANCE 1e-5f

/* ---- errors and field paths ------------------------------------------------------------ */

/* Formats into a local buffer first, so arguments may point into the thread's error detail
 * (vf_error_detail) that vf_error_set is about to overwrite. */
int vf_scene_fail(const parse_ctx *c, int err, const char *path, const char *fmt, ...) {
  char msg[768];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(msg, sizeof msg, fmt, ap);
  va_end(ap);
  if (path != NULL && path[0] != '\0') return vf_error_set(err, "%s: %s: %s", c->label, path, msg);
  return vf_error_set(err, "%s: %s", c->label, msg);
}

/* Field paths longer than PATH_LEN only come from absurd keys: they end in "..." instead. */
const char *vf_scene_join(char *dst, const char *path, const char *key) {
  int w = path[0] == '\0' ? snprintf(dst, PATH_LEN, "%s", key) : snprintf(dst, PATH_LEN, "%s.%s", path, key);
  if (w >= PATH_LEN) memcpy(dst + PATH_LEN - 4, "...", 4);
  return dst;
}

const char *vf_scene_join_index(char *dst, const char *path, long index) {
  if (snprintf(dst, PATH_LEN, "%s[%ld]", path, index) >= PATH_LEN) memcpy(dst + PATH_LEN - 4, "...", 4);
  return dst;
}

static const char *kind(const cJSON *item) {
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
static int check_object(const parse_ctx *c, const cJSON *obj, const char *path, const char *const *allowed) {
  char p[PATH_LEN];
  if (!cJSON_IsObject(obj)) return vf_scene_fail(c, VF_ESCENE, path, "expected an object, found %s", kind(obj));
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
    for (const cJSON *e = obj->child; e != m; e = e->next)
      if (strcmp(e->string, m->string) == 0) return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, m->string), "duplicate field");
  }
  return VF_OK;
}

/* 1 and *out set when obj has `key`; 0 when it is absent and optional; < 0 on error. */
static int member(const parse_ctx *c, const cJSON *obj, const char *path, const char *key, int required,
                  const cJSON **out) {
  const cJSON *m = cJSON_GetObjectItemCaseSensitive(obj, key);
  *out = m;
  if (m == NULL && required) return vf_scene_fail(c, VF_ESCENE, path, "missing field '%s'", key);
  return m != NULL;
}

static int to_double(const parse_ctx *c, const cJSON *item, const char *path, double *out) {
  if (!cJSON_IsNumber(item)) return vf_scene_fail(c, VF_ESCENE, path, "expected a number, found %s", kind(item));
  /* cJSON turns 1e999 into infinity; JSON has no NaN literal, but be explicit anyway. */
  if (!isfinite(item->valuedouble)) return vf_scene_fail(c, VF_ESCENE, path, "not a finite number");
  *out = item->valuedouble;
  return VF_OK;
}

static int to_float(const parse_ctx *c, const cJSON *item, const char *path, float *out) {
  double d = 0.0;
  int err = to_double(c, item, path, &d);
  if (err < 0) return err;
  if (fabs(d) > FLT_MAX) return vf_scene_fail(c, VF_ESCENE, path, "not a finite number in single precision");
  *out = (float)d;
  return VF_OK;
}

static int to_integer(const parse_ctx *c, const cJSON *item, const char *path, double min, double max,
                      double *out) {
  double d = 0.0;
  int err = to_double(c, item, path, &d);
  if (err < 0) return err;
  if (d != floor(d)) return vf_scene_fail(c, VF_ESCENE, path, "expected an integer, found %g", d);
  if (d < min || d > max) return vf_scene_fail(c, VF_ESCENE, path, "must be in [%.0f, %.0f], found %.0f", min, max, d);
  *out = d;
  return VF_OK;
}

static int to_vec3(const parse_ctx *c, const cJSON *item, const char *path, vf_vec3 *out) {
  char p[PATH_LEN];
  if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) != 3)
    return vf_scene_fail(c, VF_ESCENE, path, "expected an array of 3 numbers");
  float v[3];
  int i = 0;
  const cJSON *e;
  cJSON_ArrayForEach(e, item) {
    int err = to_float(c, e, vf_scene_join_index(p, path, i), &v[i]);
    if (err < 0) return err;
    i++;
  }
  *out = vf_vec3_make(v[0], v[1], v[2]);
  return VF_OK;
}

static int float_field(const parse_ctx *c, const cJSON *obj, const char *path, const char *key, int required,
                       float *out) {
  char p[PATH_LEN];
  const cJSON *m;
  int r = member(c, obj, path, key, required, &m);
  if (r <= 0) return r;
  r = to_float(c, m, vf_scene_join(p, path, key), out);
  return r < 0 ? r : 1;
}

static int vec3_field(const parse_ctx *c, const cJSON *obj, const char *path, const char *key, int required,
                      vf_vec3 *out) {
  char p[PATH_LEN];
  const cJSON *m;
  int r = member(c, obj, path, key, required, &m);
  if (r <= 0) return r;
  r = to_vec3(c, m, vf_scene_join(p, path, key), out);
  return r < 0 ? r : 1;
}

/* An RGB quantity that must not be negative; `what` names it in the error. */
static int rgb_field(const parse_ctx *c, const cJSON *obj, const char *path, const char *key, int required,
                     const char *what, vf_vec3 *out) {
  char p[PATH_LEN];
  vf_vec3 v;
  int r = vec3_field(c, obj, path, key, required, &v);
  if (r <= 0) return r;
  if (vf_min_component(v) < 0.0f) return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, key), "negative %s", what);
  *out = v;
  return 1;
}

static int string_field(const parse_ctx *c, const cJSON *obj, const char *path, const char *key, int required,
                        const char **out) {
  char p[PATH_LEN];
  const cJSON *m;
  int r = member(c, obj, path, key, required, &m);
  if (r <= 0) return r;
  if (!cJSON_IsString(m)) return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, key), "expected a string, found %s", kind(m));
  *out = m->valuestring;
  return 1;
}

/* A unit vector along v, computed in double so huge but finite inputs still normalise. */
static int unit(vf_vec3 v, vf_vec3 *out) {
  double x = v.x, y = v.y, z = v.z, len = sqrt(x * x + y * y + z * z);
  if (!(len > 0.0)) return 0;
  *out = vf_vec3_make((float)(x / len), (float)(y / len), (float)(z / len));
  return 1;
}

/* ---- camera ------------------------------------------------------------------------------- */

static int parse_resolution(const parse_ctx *c, const cJSON *item, vf_settings *settings) {
  const char *path = "camera.resolution";
  char p[PATH_LEN];
  if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) != 2)
    return vf_scene_fail(c, VF_ESCENE, path, "expected [width, height]");
  double wh[2];
  for (int i = 0; i < 2; i++) {
    int err = to_integer(c, cJSON_GetArrayItem(item, i), vf_scene_join_index(p, path, i), -1e18, 1e18, &wh[i]);
    if (err < 0) return err;
  }
  if (wh[0] < 1 || wh[1] < 1) return vf_scene_fail(c, VF_ESCENE, path, "must be positive, found %.0fx%.0f", wh[0], wh[1]);
  if (wh[0] > 65536 || wh[1] > 65536 || wh[0] * wh[1] > (double)(1 << 28))
    return vf_scene_fail(c, VF_ESCENE, path, "%.0fx%.0f is larger than 65536x65536 or 2^28 pixels", wh[0], wh[1]);
  settings->width = (int)wh[0];
  settings->height = (int)wh[1];
  return VF_OK;
}

/* The thin lens: a radius and the distance in focus, by default the target's. */
static int parse_lens(const parse_ctx *c, const cJSON *cam, const vf_vec3 *target, vf_camera_desc *d) {
  int err = float_field(c, cam, "camera", "aperture", OPTIONAL, &d->aperture);
  if (err < 0) return err;
  if (!(d->aperture >= 0.0f))
    return vf_scene_fail(c, VF_ESCENE, "camera.aperture", "the lens radius must be >= 0, found %g", d->aperture);
  int has_focus = float_field(c, cam, "camera", "focus_distance", OPTIONAL, &d->focus_distance);
  if (has_focus < 0) return has_focus;
  if (has_focus && !(d->focus_distance > 0.0f))
    return vf_scene_fail(c, VF_ESCENE, "camera.focus_distance", "must be > 0, found %g", d->focus_distance);
  if (!has_focus && d->aperture > 0.0f) {
    if (target == NULL) return vf_scene_fail(c, VF_ESCENE, "camera", "missing field 'focus_distance' (or 'target')");
    d->focus_distance = vf_length(vf_sub(*target, d->position));
  }
  return VF_OK;
}

static int parse_camera(const parse_ctx *c, const cJSON *cam) {
  static const char *const fields[] = {"position", "target", "forward", "up", "fov", "resolution", "aperture", "focus_distance", NULL};
  vf_scene *s = c->scene;
  vf_camera_desc d = {.aperture = 0.0f, .focus_distance = 0.0f};
  vf_vec3 target, forward, up = vf_vec3_make(0.0f, 1.0f, 0.0f);
  int err = check_object(c, cam, "camera", fields);
  if (err < 0) return err;
  if ((err = vec3_field(c, cam, "camera", "position", REQUIRED, &d.position)) < 0) return err;
  int has_target = vec3_field(c, cam, "camera", "target", OPTIONAL, &target);
  if (has_target < 0) return has_target;
  int has_forward = vec3_field(c, cam, "camera", "forward", OPTIONAL, &forward);
  if (has_forward < 0) return has_forward;
  if (has_target && has_forward) return vf_scene_fail(c, VF_ESCENE, "camera", "give either 'target' or 'forward', not both");
  if (!has_target && !has_forward) return vf_scene_fail(c, VF_ESCENE, "camera", "missing field 'target' (or 'forward')");
  if (has_target && !unit(vf_sub(target, d.position), &d.forward))
    return vf_scene_fail(c, VF_ESCENE, "camera.target", "equals camera.position: no viewing direction");
  if (has_forward && !unit(forward, &d.forward)) return vf_scene_fail(c, VF_ESCENE, "camera.forward", "zero vector");
  if ((err = vec3_field(c, cam, "camera", "up", OPTIONAL, &up)) < 0) return err;
  /* Gram-Schmidt: the up the user gives only picks the roll; a nearly parallel one would
   * make the roll numerically meaningless, so it is refused rather than guessed. */
  vf_vec3 up_orth = vf_sub(up, vf_scale(d.forward, vf_dot(up, d.forward)));
  if (!(vf_length(up_orth) > 1e-4f * vf_length(up)) || !unit(up_orth, &d.up))
    return vf_scene_fail(c, VF_ESCENE, "camera.up", "zero or parallel to the viewing direction");
  if ((err = float_field(c, cam, "camera", "fov", REQUIRED, &d.vertical_fov_degrees)) < 0) return err;
  if (!(d.vertical_fov_degrees > 0.0f && d.vertical_fov_degrees < 180.0f))
    return vf_scene_fail(c, VF_ESCENE, "camera.fov", "must be in (0, 180) degrees, found %g", d.vertical_fov_degrees);
  if ((err = parse_lens(c, cam, has_target ? &target : NULL, &d)) < 0) return err;
  const cJSON *res;
  int has_resolution = member(c, cam, "camera", "resolution", OPTIONAL, &res);
  if (has_resolution) {
    if ((err = parse_resolution(c, res, &s->settings)) < 0) return err;
    s->settings_given |= VF_SET_RESOLUTION;
  }
  s->camera = d;
  return VF_OK;
}

/* ---- materials ---------------------------------------------------------------------------- */

static int parse_material(const parse_ctx *c, const cJSON *j, vf_material *m) {
  static const char *const fields[] = {"diffuse", "glossy", "exponent", "mirror", "dielectric", "ior", NULL};
  char path[PATH_LEN];
  vf_scene_join(path, "materials", j->string);
  int err = check_object(c, j, path, fields);
  if (err < 0) return err;
  if (j->string[0] == '\0' || strlen(j->string) >= sizeof m->name)
    return vf_scene_fail(c, VF_ESCENE, path, "a material name must have 1 to %zu bytes", sizeof m->name - 1);
  memset(m, 0, sizeof *m);
  snprintf(m->name, sizeof m->name, "%s", j->string);
  if ((err = rgb_field(c, j, path, "diffuse", OPTIONAL, "albedo", &m->diffuse)) < 0) return err;
  if ((err = rgb_field(c, j, path, "glossy", OPTIONAL, "albedo", &m->glossy)) < 0) return err;
  if ((err = rgb_field(c, j, path, "mirror", OPTIONAL, "albedo", &m->mirror)) < 0) return err;
  if ((err = rgb_field(c, j, path, "dielectric", OPTIONAL, "albedo", &m->dielectric)) < 0) return err;
  char p[PATH_LEN];
  /* Unused parameters get harmless values (1), so no consumer ever divides by zero. */
  m->phong_exponent = 1.0f;
  int has = float_field(c, j, path, "exponent", vf_is_zero(m->glossy) ? OPTIONAL : REQUIRED, &m->phong_exponent);
  if (has < 0) return has;
  if (has && !(m->phong_exponent >= 1.0f))
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "exponent"), "must be >= 1, found %g", m->phong_exponent);
  m->ior = 1.0f;
  has = float_field(c, j, path, "ior", vf_is_zero(m->dielectric) ? OPTIONAL : REQUIRED, &m->ior);
  if (has < 0) return has;
  if (has && !(m->ior > 0.0f)) return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "ior"), "must be > 0, found %g", m->ior);
  vf_vec3 sum = vf_add(vf_add(m->diffuse, m->glossy), vf_add(m->mirror, m->dielectric));
  for (int i = 0; i < 3; i++)
    if (vf_vec3_get(sum, i) > 1.0f + ALBEDO_SUM_TOLERANCE)
      return vf_scene_fail(c, VF_ESCENE, path, "albedo sum of the lobes exceeds 1 (channel %c: %g)", "rgb"[i],
                  vf_vec3_get(sum, i));
  return VF_OK;
}

static int parse_materials(const parse_ctx *c, const cJSON *j) {
  vf_scene *s = c->scene;
  int err = check_object(c, j, "materials", NULL);
  if (err < 0) return err;
  int n = cJSON_GetArraySize(j);
  if (n == 0) return VF_OK;
  if ((s->materials = calloc((size_t)n, sizeof *s->materials)) == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  const cJSON *m;
  cJSON_ArrayForEach(m, j) {
    if ((err = parse_material(c, m, &s->materials[s->num_materials])) < 0) return err;
    s->num_materials++;
  }
  return VF_OK;
}

/* ---- transforms --------------------------------------------------------------------------- */

typedef struct {
  double m[3][4]; /* rows of the affine map p' = M p + t, translation in column 3 */
  int rotates;    /* "rotate" or "matrix" given */
  int nonuniform; /* "scale" with unequal components */
} affine;

static double affine_det(const affine *a) {
  const double(*m)[4] = a->m;
  return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
         m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

static void affine_apply(const affine *a, const float in[3], double out[3]) {
  for (int i = 0; i < 3; i++)
    out[i] = a->m[i][0] * in[0] + a->m[i][1] * in[1] + a->m[i][2] * in[2] + a->m[i][3];
}

static int parse_matrix(const parse_ctx *c, const cJSON *j, const char *path, affine *a) {
  char p[PATH_LEN];
  if (!cJSON_IsArray(j) || cJSON_GetArraySize(j) != 16)
    return vf_scene_fail(c, VF_ESCENE, path, "expected 16 numbers (4x4, row-major)");
  double v[16];
  int i = 0;
  const cJSON *e;
  cJSON_ArrayForEach(e, j) {
    int err = to_double(c, e, vf_scene_join_index(p, path, i), &v[i]);
    if (err < 0) return err;
    i++;
  }
  if (v[12] != 0.0 || v[13] != 0.0 || v[14] != 0.0 || v[15] != 1.0)
    return vf_scene_fail(c, VF_ESCENE, path, "last row must be [0, 0, 0, 1]: only affine transforms are allowed");
  for (i = 0; i < 12; i++) a->m[i / 4][i % 4] = v[i];
  a->rotates = 1;
  return VF_OK;
}

/* scale, then rotate (right-hand rule about the axis), then translate. */
static int parse_transform(const parse_ctx *c, const cJSON *j, const char *path, affine *out) {
  static const char *const fields[] = {"translate", "scale", "rotate", "matrix", NULL};
  static const char *const rotate_fields[] = {"axis", "degrees", NULL};
  char p[PATH_LEN];
  affine a = {{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}}, 0, 0};
  int err = check_object(c, j, path, fields);
  if (err < 0) return err;
  const cJSON *matrix = cJSON_GetObjectItemCaseSensitive(j, "matrix");
  if (matrix != NULL) {
    if (cJSON_GetArraySize(j) != 1)
      return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "matrix"), "cannot be combined with translate, scale or rotate");
    if ((err = parse_matrix(c, matrix, vf_scene_join(p, path, "matrix"), &a)) < 0) return err;
  } else {
    double scale[3] = {1, 1, 1}, rot[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    vf_vec3 t = vf_vec3_splat(0.0f), sv;
    const cJSON *sj = cJSON_GetObjectItemCaseSensitive(j, "scale");
    if (cJSON_IsNumber(sj)) {
      double s1;
      if ((err = to_double(c, sj, vf_scene_join(p, path, "scale"), &s1)) < 0) return err;
      scale[0] = scale[1] = scale[2] = s1;
    } else if (sj != NULL) {
      if ((err = to_vec3(c, sj, vf_scene_join(p, path, "scale"), &sv)) < 0) return err;
      scale[0] = sv.x, scale[1] = sv.y, scale[2] = sv.z;
      a.nonuniform = sv.x != sv.y || sv.y != sv.z;
    }
    const cJSON *rj = cJSON_GetObjectItemCaseSensitive(j, "rotate");
    if (rj != NULL) {
      char rp[PATH_LEN];
      vf_vec3 axis, u;
      float degrees;
      vf_scene_join(rp, path, "rotate");
      if ((err = check_object(c, rj, rp, rotate_fields)) < 0) return err;
      if ((err = vec3_field(c, rj, rp, "axis", REQUIRED, &axis)) < 0) return err;
      if ((err = float_field(c, rj, rp, "degrees", REQUIRED, &degrees)) < 0) return err;
      if (!unit(axis, &u)) return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, rp, "axis"), "zero vector");
      /* Rodrigues' rotation formula. */
      double th = degrees * (M_PI / 180.0), cs = cos(th), sn = sin(th), k = 1.0 - cs;
      double x = u.x, y = u.y, z = u.z;
      double r[3][3] = {{cs + x * x * k, x * y * k - z * sn, x * z * k + y * sn},
                        {y * x * k + z * sn, cs + y * y * k, y * z * k - x * sn},
                        {z * x * k - y * sn, z * y * k + x * sn, cs + z * z * k}};
      memcpy(rot, r, sizeof rot);
      a.rotates = 1;
    }
    if ((err = vec3_field(c, j, path, "translate", OPTIONAL, &t)) < 0) return err;
    for (int i = 0; i < 3; i++) {
      for (int k = 0; k < 3; k++) a.m[i][k] = rot[i][k] * scale[k];
      a.m[i][3] = vf_vec3_get(t, i);
    }
  }
  double det = affine_det(&a);
  if (!(fabs(det) > 0.0) || !isfinite(det))
    return vf_scene_fail(c, VF_ESCENE, path, "singular (a zero scale flattens the shape)");
  *out = a;
  return VF_OK;
}

/* ---- meshes ------------------------------------------------------------------------------ */

static int parse_inline_mesh(const parse_ctx *c, const cJSON *j, const char *path, vf_shape *s) {
  char p[PATH_LEN], ip[PATH_LEN], ep[PATH_LEN];
  const cJSON *pos, *idx, *e;
  int err;
  if ((err = member(c, j, path, "positions", REQUIRED, &pos)) < 0) return err;
  if ((err = member(c, j, path, "indices", REQUIRED, &idx)) < 0) return err;
  vf_scene_join(p, path, "positions");
  vf_scene_join(ip, path, "indices");
  int np = cJSON_IsArray(pos) ? cJSON_GetArraySize(pos) : -1, ni = cJSON_IsArray(idx) ? cJSON_GetArraySize(idx) : -1;
  if (np <= 0 || np % 3 != 0)
    return vf_scene_fail(c, VF_ESCENE, p, "expected a non-empty flat array of numbers, 3 per vertex");
  if (ni <= 0 || ni % 3 != 0)
    return vf_scene_fail(c, VF_ESCENE, ip, "expected a non-empty flat array of vertex indices, 3 per triangle");
  float *positions = malloc((size_t)np * sizeof *positions);
  uint32_t *indices = malloc((size_t)ni * sizeof *indices);
  if (positions == NULL || indices == NULL) {
    err = vf_error_set(VF_ENOMEM, "out of memory");
    goto fail;
  }
  long i = 0;
  cJSON_ArrayForEach(e, pos) {
    /* Fast path; the element's path is only built to report it. */
    if (!cJSON_IsNumber(e) || !(fabs(e->valuedouble) <= FLT_MAX)) {
      err = to_float(c, e, vf_scene_join_index(ep, p, i), &positions[i]);
      goto fail;
    }
    positions[i++] = (float)e->valuedouble;
  }
  uint32_t num_vertices = (uint32_t)(np / 3);
  i = 0;
  cJSON_ArrayForEach(e, idx) {
    double d = cJSON_IsNumber(e) ? e->valuedouble : -1.0;
    if (!(d >= 0.0 && d == floor(d))) {
      err = vf_scene_fail(c, VF_ESCENE, vf_scene_join_index(ep, ip, i), "expected a non-negative integer vertex index");
      goto fail;
    }
    if (d >= num_vertices) {
      err = vf_scene_fail(c, VF_ESCENE, vf_scene_join_index(ep, ip, i), "index %.0f out of range (the mesh has %u vertices)", d,
                 num_vertices);
      goto fail;
    }
    indices[i++] = (uint32_t)d;
  }
  s->positions = positions;
  s->indices = indices;
  s->num_vertices = num_vertices;
  s->num_triangles = (uint32_t)(ni / 3);
  return VF_OK;
fail:
  free(indices);
  free(positions);
  return err;
}

/* ---- shapes ------------------------------------------------------------------------------ */

static double mesh_area(const vf_shape *s) {
  double area = 0.0;
  for (uint32_t t = 0; t < s->num_triangles; t++) {
    const float *a = &s->positions[3 * s->indices[3 * t]], *b = &s->positions[3 * s->indices[3 * t + 1]],
                *d = &s->positions[3 * s->indices[3 * t + 2]];
    double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
    double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    area += 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  }
  return area;
}

static int transform_mesh(const parse_ctx *c, const affine *a, const char *path, vf_shape *s) {
  for (uint32_t v = 0; v < s->num_vertices; v++) {
    double w[3];
    affine_apply(a, &s->positions[3 * v], w);
    for (int k = 0; k < 3; k++) {
      if (!(fabs(w[k]) <= FLT_MAX)) return vf_scene_fail(c, VF_ESCENE, path, "moves vertex %u out of range", v);
      s->positions[3 * v + k] = (float)w[k];
    }
  }
  /* A mirroring transform turns counter-clockwise into clockwise; swapping two corners keeps
   * every triangle facing the side it faced in the file, which is what emission refers to. */
  if (affine_det(a) < 0.0)
    for (uint32_t t = 0; t < s->num_triangles; t++) {
      uint32_t tmp = s->indices[3 * t + 1];
      s->indices[3 * t + 1] = s->indices[3 * t + 2];
      s->indices[3 * t + 2] = tmp;
    }
  return VF_OK;
}

static int parse_sphere(const parse_ctx *c, const cJSON *j, const char *path, const affine *a, int has_transform,
                        vf_shape *s) {
  char p[PATH_LEN];
  int err;
  if ((err = vec3_field(c, j, path, "center", REQUIRED, &s->center)) < 0) return err;
  if ((err = float_field(c, j, path, "radius", REQUIRED, &s->radius)) < 0) return err;
  if (!(s->radius > 0.0f)) return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "radius"), "must be > 0, found %g", s->radius);
  if (!has_transform) return VF_OK;
  vf_scene_join(p, path, "transform");
  if (a->rotates || a->nonuniform)
    return vf_scene_fail(c, VF_ESCENE, p, "a sphere accepts only translate and a uniform scale");
  const float center[3] = {s->center.x, s->center.y, s->center.z};
  double w[3], r = s->radius * fabs(a->m[0][0]);
  affine_apply(a, center, w);
  if (!(fabs(w[0]) <= FLT_MAX && fabs(w[1]) <= FLT_MAX && fabs(w[2]) <= FLT_MAX && r <= FLT_MAX && (float)r > 0.0f))
    return vf_scene_fail(c, VF_ESCENE, p, "moves the sphere out of range");
  s->center = vf_vec3_make((float)w[0], (float)w[1], (float)w[2]);
  s->radius = (float)r;
  return VF_OK;
}

static int parse_shape(const parse_ctx *c, const cJSON *j, int index, vf_shape *s) {
  static const char *const mesh_fields[] = {"type", "name", "material", "emission", "transform",
                                            "file", "positions", "indices", NULL};
  static const char *const sphere_fields[] = {"type", "name", "material", "emission", "transform",
                                              "center", "radius", NULL};
  char path[PATH_LEN], p[PATH_LEN];
  const char *type, *name = NULL, *material, *file = NULL;
  const cJSON *tj;
  affine a;
  int err;
  vf_scene_join_index(path, "shapes", index);
  if (!cJSON_IsObject(j)) return vf_scene_fail(c, VF_ESCENE, path, "expected an object, found %s", kind(j));
  if ((err = string_field(c, j, path, "type", REQUIRED, &type)) < 0) return err;
  if (strcmp(type, "mesh") == 0) s->kind = VF_SHAPE_MESH;
  else if (strcmp(type, "sphere") == 0) s->kind = VF_SHAPE_SPHERE;
  else return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "type"), "unknown shape type '%s' (expected mesh or sphere)", type);
  if ((err = check_object(c, j, path, s->kind == VF_SHAPE_MESH ? mesh_fields : sphere_fields)) < 0) return err;
  if ((err = string_field(c, j, path, "name", OPTIONAL, &name)) < 0) return err;
  if (name != NULL && strlen(name) >= sizeof s->name)
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "name"), "longer than %zu bytes", sizeof s->name - 1);
  if ((err = string_field(c, j, path, "material", REQUIRED, &material)) < 0) return err;
  s->material = -1;
  for (int m = 0; m < c->scene->num_materials; m++)
    if (strcmp(c->scene->materials[m].name, material) == 0) s->material = m;
  if (s->material < 0) return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "material"), "unknown material '%s'", material);
  if ((err = rgb_field(c, j, path, "emission", OPTIONAL, "radiance", &s->emission)) < 0) return err;
  int has_transform = member(c, j, path, "transform", OPTIONAL, &tj);
  if (has_transform && (err = parse_transform(c, tj, vf_scene_join(p, path, "transform"), &a)) < 0) return err;
  if (s->kind == VF_SHAPE_SPHERE) {
    if ((err = parse_sphere(c, j, path, &a, has_transform, s)) < 0) return err;
  } else {
    if ((err = string_field(c, j, path, "file", OPTIONAL, &file)) < 0) return err;
    int inline_mesh = cJSON_HasObjectItem(j, "positions") || cJSON_HasObjectItem(j, "indices");
    if (file != NULL && inline_mesh)
      return vf_scene_fail(c, VF_ESCENE, path, "give either 'file' or 'positions' and 'indices', not both");
    if (file == NULL && !inline_mesh)
      return vf_scene_fail(c, VF_ESCENE, path, "missing field 'file' (or 'positions' and 'indices')");
    err = file ? vf_scene_load_mesh_file(c, file, path, s) : parse_inline_mesh(c, j, path, s);
    if (err < 0) return err;
    if (has_transform && (err = transform_mesh(c, &a, vf_scene_join(p, path, "transform"), s)) < 0) return err;
    /* Degenerate triangles are kept (real meshes have them and the renderer copes), but an
     * emitter with no area would have infinite radiance per unit power: refuse it. */
    if (!vf_is_zero(s->emission) && !(mesh_area(s) > 0.0))
      return vf_scene_fail(c, VF_ESCENE, path, "emissive shape has zero area");
  }
  /* Default names are only for messages: a long file name may be cut short. */
  if (snprintf(s->name, sizeof s->name, "%s", name ? name : file ? file : path) >= (int)sizeof s->name)
    memcpy(s->name + sizeof s->name - 4, "...", 4);
  return VF_OK;
}

static int parse_shapes(const parse_ctx *c, const cJSON *j) {
  vf_scene *s = c->scene;
  if (!cJSON_IsArray(j)) return vf_scene_fail(c, VF_ESCENE, "shapes", "expected an array, found %s", kind(j));
  int n = cJSON_GetArraySize(j);
  if (n == 0) return vf_scene_fail(c, VF_ESCENE, "shapes", "a scene needs at least one shape");
  if ((s->shapes = calloc((size_t)n, sizeof *s->shapes)) == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  s->num_shapes = n; /* zero-filled entries are safe to destroy */
  int i = 0;
  const cJSON *e;
  cJSON_ArrayForEach(e, j) {
    int err = parse_shape(c, e, i, &s->shapes[i]);
    if (err < 0) return err;
    i++;
  }
  return VF_OK;
}

/* ---- lights ------------------------------------------------------------------------------ */

static int load_envmap(const parse_ctx *c, const char *file, const char *path) {
  char fpath[PATH_LEN], full[4096];
  vf_image img;
  vf_scene_join(fpath, path, "file");
  int err = vf_scene_resolve(c, file, fpath, full, sizeof full);
  if (err < 0) return err;
  FILE *f = fopen(full, "rb");
  if (f == NULL) return vf_scene_fail(c, VF_ENOENT, fpath, "cannot open '%s': %s", file, strerror(errno));
  fclose(f);
  if ((err = vf_image_read_exr(full, &img)) < 0)
    return vf_scene_fail(c, err == VF_ENOMEM ? VF_ENOMEM : VF_ESCENE, fpath, "%s", vf_error_detail(err));
  for (long i = 0; i < 3L * img.width * img.height; i++)
    if (!(img.rgb[i] >= 0.0f && img.rgb[i] <= FLT_MAX)) {
      long x = (i / 3) % img.width, y = (i / 3) / img.width;
      vf_image_destroy(&img);
      return vf_scene_fail(c, VF_ESCENE, fpath, "pixel (%ld, %ld) of '%s' is negative or not finite", x, y, file);
    }
  c->scene->envmap = img;
  return VF_OK;
}

/* A spot's axis and cone, given in degrees (the format's angles) and kept in radians. */
static int parse_spot(const parse_ctx *c, const cJSON *j, const char *path, vf_point_light_desc *l) {
  char p[PATH_LEN];
  vf_vec3 d;
  float inner = 0.0f, outer = 45.0f; /* KHR_lights_punctual's defaults */
  int err = vec3_field(c, j, path, "direction", REQUIRED, &d);
  if (err < 0) return err;
  if (!unit(d, &l->direction)) return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "direction"), "zero vector");
  if ((err = float_field(c, j, path, "inner_cone_angle", OPTIONAL, &inner)) < 0) return err;
  if ((err = float_field(c, j, path, "outer_cone_angle", OPTIONAL, &outer)) < 0) return err;
  if (!(outer > 0.0f && outer <= 90.0f))
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "outer_cone_angle"), "must be in (0, 90] degrees, found %g", outer);
  if (!(inner >= 0.0f && inner < outer))
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "inner_cone_angle"),
                         "must be in [0, outer_cone_angle = %g) degrees, found %g", outer, inner);
  l->is_spot = 1;
  l->inner_cone_angle = inner * (float)(M_PI / 180.0);
  l->outer_cone_angle = outer * (float)(M_PI / 180.0);
  return VF_OK;
}

static int parse_light(const parse_ctx *c, const cJSON *j, int index, int *num_distant) {
  static const char *const point_fields[] = {"type", "position", "intensity", NULL};
  static const char *const spot_fields[] = {"type", "position", "intensity", "direction", "inner_cone_angle", "outer_cone_angle", NULL};
  static const char *const directional_fields[] = {"type", "direction", "irradiance", NULL};
  static const char *const background_fields[] = {"type", "radiance", NULL};
  static const char *const environment_fields[] = {"type", "file", "scale", NULL};
  vf_scene *s = c->scene;
  char path[PATH_LEN], p[PATH_LEN];
  const char *type, *file;
  int err;
  vf_scene_join_index(path, "lights", index);
  if (!cJSON_IsObject(j)) return vf_scene_fail(c, VF_ESCENE, path, "expected an object, found %s", kind(j));
  if ((err = string_field(c, j, path, "type", REQUIRED, &type)) < 0) return err;
  if (strcmp(type, "point") == 0 || strcmp(type, "spot") == 0) {
    vf_point_light_desc *l = &s->point_lights[s->num_point_lights];
    int spot = type[0] == 's';
    if ((err = check_object(c, j, path, spot ? spot_fields : point_fields)) < 0) return err;
    if ((err = vec3_field(c, j, path, "position", REQUIRED, &l->position)) < 0) return err;
    if ((err = rgb_field(c, j, path, "intensity", REQUIRED, "intensity", &l->intensity)) < 0) return err;
    if (spot && (err = parse_spot(c, j, path, l)) < 0) return err;
    s->num_point_lights++;
  } else if (strcmp(type, "directional") == 0) {
    vf_directional_light_desc *l = &s->directional_lights[s->num_directional_lights];
    vf_vec3 d;
    if ((err = check_object(c, j, path, directional_fields)) < 0) return err;
    if ((err = vec3_field(c, j, path, "direction", REQUIRED, &d)) < 0) return err;
    if (!unit(d, &l->direction)) return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "direction"), "zero vector");
    if ((err = rgb_field(c, j, path, "irradiance", REQUIRED, "irradiance", &l->irradiance)) < 0) return err;
    s->num_directional_lights++;
  } else if (strcmp(type, "background") == 0 || strcmp(type, "environment") == 0) {
    /* One distant light at infinity keeps the renderer's emission-at-miss term unambiguous. */
    if ((*num_distant)++ > 0) return vf_scene_fail(c, VF_ESCENE, path, "only one background or environment light is allowed");
    if (type[0] == 'b') {
      if ((err = check_object(c, j, path, background_fields)) < 0) return err;
      if ((err = rgb_field(c, j, path, "radiance", REQUIRED, "radiance", &s->background)) < 0) return err;
    } else {
      vf_vec3 scale = vf_vec3_splat(1.0f);
      if ((err = check_object(c, j, path, environment_fields)) < 0) return err;
      if ((err = rgb_field(c, j, path, "scale", OPTIONAL, "scale", &scale)) < 0) return err;
      if ((err = string_field(c, j, path, "file", REQUIRED, &file)) < 0) return err;
      if ((err = load_envmap(c, file, path)) < 0) return err;
      s->envmap_scale = scale;
    }
  } else {
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "type"),
                "unknown light type '%s' (expected point, spot, directional, background or environment)", type);
  }
  return VF_OK;
}

static int parse_lights(const parse_ctx *c, const cJSON *j) {
  vf_scene *s = c->scene;
  if (!cJSON_IsArray(j)) return vf_scene_fail(c, VF_ESCENE, "lights", "expected an array, found %s", kind(j));
  int n = cJSON_GetArraySize(j);
  if (n == 0) return VF_OK;
  /* Sized for the worst case of every light being of one type; a few bytes per light. */
  s->point_lights = calloc((size_t)n, sizeof *s->point_lights);
  s->directional_lights = calloc((size_t)n, sizeof *s->directional_lights);
  if (s->point_lights == NULL || s->directional_lights == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  int i = 0, num_distant = 0;
  const cJSON *e;
  cJSON_ArrayForEach(e, j) {
    int err = parse_light(c, e, i++, &num_distant);
    if (err < 0) return err;
  }
  return VF_OK;
}

static int has_light(const vf_scene *s) {
  for (int i = 0; i < s->num_shapes; i++)
    if (!vf_is_zero(s->shapes[i].emission)) return 1;
  for (int i = 0; i < s->num_point_lights; i++)
    if (!vf_is_zero(s->point_lights[i].intensity)) return 1;
  for (int i = 0; i < s->num_directional_lights; i++)
    if (!vf_is_zero(s->directional_lights[i].irradiance)) return 1;
  return !vf_is_zero(s->background) || (s->envmap.width > 0 && !vf_is_zero(s->envmap_scale));
}

/* ---- render settings --------------------------------------------------------------------- */

static int parse_render(const parse_ctx *c, const cJSON *j) {
  static const char *const fields[] = {"algorithm", "max_path_length", "radius_factor", "alpha", "seed", NULL};
  vf_scene *s = c->scene;
  vf_settings *st = &s->settings;
  const cJSON *m;
  const char *algorithm;
  double d = 0.0;
  int err = check_object(c, j, "render", fields);
  if (err < 0) return err;
  if ((err = string_field(c, j, "render", "algorithm", OPTIONAL, &algorithm)) < 0) return err;
  if (err > 0) {
    if (vf_algorithm_parse(algorithm, &st->algorithm) < 0)
      return vf_scene_fail(c, VF_ESCENE, "render.algorithm", "unknown algorithm '%s' (expected vcm, bpt, pt, lt, ppm, bpm or auto)",
                  algorithm);
    s->settings_given |= VF_SET_ALGORITHM;
  }
  if ((m = cJSON_GetObjectItemCaseSensitive(j, "max_path_length")) != NULL) {
    if ((err = to_integer(c, m, "render.max_path_length", 1, 1000, &d)) < 0) return err;
    st->max_path_length = (int)d;
    s->settings_given |= VF_SET_MAX_PATH_LENGTH;
  }
  if ((m = cJSON_GetObjectItemCaseSensitive(j, "radius_factor")) != NULL) {
    if ((err = to_double(c, m, "render.radius_factor", &st->radius_factor)) < 0) return err;
    if (!(st->radius_factor > 0.0)) return vf_scene_fail(c, VF_ESCENE, "render.radius_factor", "must be > 0");
    s->settings_given |= VF_SET_RADIUS_FACTOR;
  }
  if ((m = cJSON_GetObjectItemCaseSensitive(j, "alpha")) != NULL) {
    if ((err = to_double(c, m, "render.alpha", &st->alpha)) < 0) return err;
    if (!(st->alpha > 0.0 && st->alpha <= 1.0)) return vf_scene_fail(c, VF_ESCENE, "render.alpha", "must be in (0, 1]");
    s->settings_given |= VF_SET_ALPHA;
  }
  if ((m = cJSON_GetObjectItemCaseSensitive(j, "seed")) != NULL) {
    /* JSON numbers are doubles: integers beyond 2^53 would silently change. */
    if ((err = to_integer(c, m, "render.seed", 0, 9007199254740992.0, &d)) < 0) return err;
    st->seed = (uint64_t)d;
    s->settings_given |= VF_SET_SEED;
  }
  return VF_OK;
}

/* ---- whole scene ------------------------------------------------------------------------- */

static int parse_root(const parse_ctx *c, const cJSON *root) {
  static const char *const fields[] = {"camera", "materials", "shapes", "lights", "render", NULL};
  const cJSON *m;
  int err = check_object(c, root, "", fields);
  if (err < 0) return err;
  if ((err = member(c, root, "", "camera", REQUIRED, &m)) < 0 || (err = parse_camera(c, m)) < 0) return err;
  if ((err = member(c, root, "", "materials", REQUIRED, &m)) < 0 || (err = parse_materials(c, m)) < 0) return err;
  if ((err = member(c, root, "", "shapes", REQUIRED, &m)) < 0 || (err = parse_shapes(c, m)) < 0) return err;
  if ((err = member(c, root, "", "lights", OPTIONAL, &m)) < 0 || (err > 0 && (err = parse_lights(c, m)) < 0))
    return err;
  if ((err = member(c, root, "", "render", OPTIONAL, &m)) < 0 || (err > 0 && (err = parse_render(c, m)) < 0))
    return err;
  if (!has_light(c->scene))
    return vf_scene_fail(c, VF_ESCENE, NULL, "the scene has no light (no emissive shape and nothing in 'lights' emits)");
  if ((err = vf_settings_validate(&c->scene->settings)) < 0)
    return vf_scene_fail(c, VF_ESCENE, "render", "%s", vf_error_detail(err));
  return VF_OK;
}

static int syntax_error(const char *label, const char *text, size_t length, const char *at) {
  if (at == NULL || at < text || at > text + length) at = text + length;
  int line = 1;
  for (const char *p = text; p < at; p++) line += *p == '\n';
  char near[32];
  size_t n = 0;
  for (const char *p = at; p < text + length && *p != '\n' && n < 24; p++)
    near[n++] = (*p >= 0x20 && *p < 0x7f) ? *p : '?';
  near[n] = '\0';
  if (n == 0) return vf_error_set(VF_ESCENE, "%s: line %d: JSON syntax error near the end of the line or file", label, line);
  return vf_error_set(VF_ESCENE, "%s: line %d: JSON syntax error near '%s'", label, line, near);
}

static int parse(const char *text, size_t length, const char *label, const char *base_dir,
                 const vf_scene_memfile *memfiles, int num_memfiles, struct vf_scene_files *files, vf_scene **out) {
  const char *end = NULL;
  if (memchr(text, '\0', length) != NULL) return vf_error_set(VF_ESCENE, "%s: contains a NUL byte", label);
  /* The length includes the terminating NUL so that require_null_terminated rejects
   * anything but whitespace after the top-level value. */
  cJSON *root = cJSON_ParseWithLengthOpts(text, length + 1, &end, 1);
  if (root == NULL) return syntax_error(label, text, length, end);
  int err = VF_OK;
  vf_scene *scene = calloc(1, sizeof *scene);
  if (scene == NULL) {
    err = vf_error_set(VF_ENOMEM, "out of memory");
    goto fail;
  }
  snprintf(scene->source, sizeof scene->source, "%s", label);
  vf_settings_default(&scene->settings);
  parse_ctx c = {label, base_dir, memfiles, num_memfiles, scene, files};
  if ((err = parse_root(&c, root)) < 0 || (err = vf_scene_check_extent(scene, label)) < 0) goto fail;
  vf_scene_compute_bounds(scene);
  vf_scene_hash(scene);
  cJSON_Delete(root);
  *out = scene;
  return VF_OK;
fail:
  vf_scene_destroy(scene);
  cJSON_Delete(root);
  return err;
}

int vf_scene_parse(const char *text, size_t length, const char *label, const char *base_dir,
                   const vf_scene_memfile *memfiles, int num_memfiles, vf_scene **out) {
  return parse(text, length, label, base_dir, memfiles, num_memfiles, NULL, out);
}

int vf_scene_parse_files(const char *text, size_t length, const char *label, struct vf_scene_files *files,
                         vf_scene **out) {
  return parse(text, length, label, "", NULL, 0, files, out);
}
