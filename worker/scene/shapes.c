/* The "shapes" of a JSON scene (shapes.h): transforms, inline and file meshes,
 * spheres, all brought into world space and checked. docs/SCENES.md, "shapes". */
#include "shapes.h"

#include "../../common/error.h"
#include "fields.h"
#include "mesh.h"
#include "serialized.h"
#include "../../common/file.h"

#include <cjson/cJSON.h>

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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
    int err = vf_scene_to_double(c, e, vf_scene_join_index(p, path, i), &v[i]);
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
  int err = vf_scene_check_object(c, j, path, fields);
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
      if ((err = vf_scene_to_double(c, sj, vf_scene_join(p, path, "scale"), &s1)) < 0) return err;
      scale[0] = scale[1] = scale[2] = s1;
    } else if (sj != NULL) {
      if ((err = vf_scene_to_vec3(c, sj, vf_scene_join(p, path, "scale"), &sv)) < 0) return err;
      scale[0] = sv.x, scale[1] = sv.y, scale[2] = sv.z;
      a.nonuniform = sv.x != sv.y || sv.y != sv.z;
    }
    const cJSON *rj = cJSON_GetObjectItemCaseSensitive(j, "rotate");
    if (rj != NULL) {
      char rp[PATH_LEN];
      vf_vec3 axis, u;
      float degrees;
      vf_scene_join(rp, path, "rotate");
      if ((err = vf_scene_check_object(c, rj, rp, rotate_fields)) < 0) return err;
      if ((err = vf_scene_vec3_field(c, rj, rp, "axis", REQUIRED, &axis)) < 0) return err;
      if ((err = vf_scene_float_field(c, rj, rp, "degrees", REQUIRED, &degrees)) < 0) return err;
      if (!vf_scene_unit(axis, &u)) return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, rp, "axis"), "zero vector");
      /* Rodrigues' rotation formula. */
      double th = degrees * (M_PI / 180.0), cs = cos(th), sn = sin(th), k = 1.0 - cs;
      double x = u.x, y = u.y, z = u.z;
      double r[3][3] = {{cs + x * x * k, x * y * k - z * sn, x * z * k + y * sn},
                        {y * x * k + z * sn, cs + y * y * k, y * z * k - x * sn},
                        {z * x * k - y * sn, z * y * k + x * sn, cs + z * z * k}};
      memcpy(rot, r, sizeof rot);
      a.rotates = 1;
    }
    if ((err = vf_scene_vec3_field(c, j, path, "translate", OPTIONAL, &t)) < 0) return err;
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

int vf_scene_parse_transform(const parse_ctx *c, const cJSON *j, const char *path, vf_affine *out) {
  affine a;
  int err = parse_transform(c, j, path, &a);
  if (err < 0) return err;
  memcpy(out->m, a.m, sizeof out->m);
  return VF_OK;
}

/* ---- meshes ------------------------------------------------------------------------------ */

static int parse_inline_mesh(const parse_ctx *c, const cJSON *j, const char *path, vf_shape *s) {
  char p[PATH_LEN], ip[PATH_LEN], ep[PATH_LEN];
  const cJSON *pos, *idx, *e;
  int err;
  if ((err = vf_scene_member(c, j, path, "positions", REQUIRED, &pos)) < 0) return err;
  if ((err = vf_scene_member(c, j, path, "indices", REQUIRED, &idx)) < 0) return err;
  vf_scene_join(p, path, "positions");
  vf_scene_join(ip, path, "indices");
  int np = cJSON_IsArray(pos) ? cJSON_GetArraySize(pos) : -1, ni = cJSON_IsArray(idx) ? cJSON_GetArraySize(idx) : -1;
  if (np <= 0 || np % 3 != 0)
    return vf_scene_fail(c, VF_ESCENE, p, "expected a non-empty flat array of numbers, 3 per vertex");
  if (ni <= 0 || ni % 3 != 0)
    return vf_scene_fail(c, VF_ESCENE, ip, "expected a non-empty flat array of vertex indices, 3 per triangle");
  float *positions = malloc((size_t)np * sizeof *positions);
  uint32_t *indices = malloc((size_t)ni * sizeof *indices);
  float *uvs = NULL, *normals = NULL;
  if (positions == NULL || indices == NULL) {
    err = vf_error_set(VF_ENOMEM, "out of memory");
    goto fail;
  }
  long i = 0;
  cJSON_ArrayForEach(e, pos) {
    /* Fast path; the element's path is only built to report it. */
    if (!cJSON_IsNumber(e) || !(fabs(e->valuedouble) <= FLT_MAX)) {
      err = vf_scene_to_float(c, e, vf_scene_join_index(ep, p, i), &positions[i]);
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
  /* Optional texture coordinates, 2 per vertex, t = 0 the top row of an image. */
  const cJSON *uv = cJSON_GetObjectItemCaseSensitive(j, "uvs");
  if (uv != NULL) {
    char up[PATH_LEN];
    vf_scene_join(up, path, "uvs");
    if (!cJSON_IsArray(uv) || cJSON_GetArraySize(uv) != 2 * (int)num_vertices) {
      err = vf_scene_fail(c, VF_ESCENE, up, "expected a flat array of numbers, 2 per vertex (%u)", 2 * num_vertices);
      goto fail;
    }
    if ((uvs = malloc(2 * (size_t)num_vertices * sizeof *uvs)) == NULL) {
      err = vf_error_set(VF_ENOMEM, "out of memory");
      goto fail;
    }
    i = 0;
    cJSON_ArrayForEach(e, uv) {
      if ((err = vf_scene_to_float(c, e, vf_scene_join_index(ep, up, i), &uvs[i])) < 0) goto fail;
      i++;
    }
  }
  /* Optional shading normals, 3 per vertex, non-zero (normalised here). */
  const cJSON *nj = cJSON_GetObjectItemCaseSensitive(j, "normals");
  if (nj != NULL) {
    char np_[PATH_LEN];
    vf_scene_join(np_, path, "normals");
    if (!cJSON_IsArray(nj) || cJSON_GetArraySize(nj) != 3 * (int)num_vertices) {
      err = vf_scene_fail(c, VF_ESCENE, np_, "expected a flat array of numbers, 3 per vertex (%u)", 3 * num_vertices);
      goto fail;
    }
    if ((normals = malloc(3 * (size_t)num_vertices * sizeof *normals)) == NULL) {
      err = vf_error_set(VF_ENOMEM, "out of memory");
      goto fail;
    }
    i = 0;
    cJSON_ArrayForEach(e, nj) {
      if ((err = vf_scene_to_float(c, e, vf_scene_join_index(ep, np_, i), &normals[i])) < 0) goto fail;
      i++;
    }
    for (uint32_t v = 0; v < num_vertices; v++) {
      vf_vec3 n = vf_vec3_make(normals[3 * v], normals[3 * v + 1], normals[3 * v + 2]), u;
      if (!vf_scene_unit(n, &u)) {
        err = vf_scene_fail(c, VF_ESCENE, vf_scene_join_index(ep, np_, 3 * (long)v), "normal of vertex %u is zero", v);
        goto fail;
      }
      normals[3 * v] = u.x;
      normals[3 * v + 1] = u.y;
      normals[3 * v + 2] = u.z;
    }
  }
  s->positions = positions;
  s->indices = indices;
  s->uvs = uvs;
  s->normals = normals;
  s->num_vertices = num_vertices;
  s->num_triangles = (uint32_t)(ni / 3);
  return VF_OK;
fail:
  free(normals);
  free(uvs);
  free(indices);
  free(positions);
  return err;
}

/* A mesh of a Mitsuba serialized file: resolved as every file is (so a farm job ships it by
 * content hash), the mesh of "shape_index" (default 0) decoded (serialized.h). */
static int load_serialized(const parse_ctx *c, const cJSON *j, const char *file, const char *path, vf_shape *s) {
  char fpath[PATH_LEN], ipath[PATH_LEN], resolved[4096], what[PATH_LEN + 600];
  double index = 0;
  int err;
  const cJSON *ij = cJSON_GetObjectItemCaseSensitive(j, "shape_index");
  if (ij != NULL && (err = vf_scene_to_integer(c, ij, vf_scene_join(ipath, path, "shape_index"), 0, 1e9, &index)) < 0)
    return err;
  vf_scene_join(fpath, path, "file");
  if ((err = vf_scene_resolve(c, file, fpath, resolved, sizeof resolved)) < 0) return err;
  uint8_t *data = NULL;
  size_t n = 0;
  if ((err = vf_file_read_all(resolved, (size_t)1 << 31, &data, &n)) != VF_OK) {
    char detail[512];
    snprintf(detail, sizeof detail, "%s", vf_error_detail(err));
    return vf_scene_fail(c, err, fpath, "%s", detail);
  }
  snprintf(what, sizeof what, "%s: %s (%s)", c->label, path, file);
  int colors = 0;
  err = vf_serialized_decode(data, n, (long)index, what, s, &colors);
  free(data);
  if (err == VF_OK && colors) err = vf_scene_note(c, "%s: vertex colours are not supported: ignored", file);
  return err;
}

/* ---- shapes ------------------------------------------------------------------------------ */

double vf_scene_mesh_area(const vf_shape *s) {
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

/* Positions, normals and tangents, and the winding under a mirror (mesh.c). */
static int transform_mesh(const parse_ctx *c, const affine *a, const char *path, vf_shape *s) {
  vf_affine m;
  memcpy(m.m, a->m, sizeof m.m);
  return vf_scene_transform_range(c, path, &m, s, 0, 0);
}

static int parse_sphere(const parse_ctx *c, const cJSON *j, const char *path, const affine *a, int has_transform,
                        vf_shape *s) {
  char p[PATH_LEN];
  int err;
  if ((err = vf_scene_vec3_field(c, j, path, "center", REQUIRED, &s->center)) < 0) return err;
  if ((err = vf_scene_float_field(c, j, path, "radius", REQUIRED, &s->radius)) < 0) return err;
  if (!(s->radius > 0.0f))
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "radius"), "must be > 0, found %g", s->radius);
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

static int parse_shape(const parse_ctx *c, const cJSON *j, int index, const vf_name_index *names, vf_shape *s) {
  static const char *const mesh_fields[] = {"type", "name", "material", "interior", "emission", "transform",
                                            "file", "shape_index", "positions", "indices", "uvs", "normals", "flip", "flip_t", NULL};
  static const char *const sphere_fields[] = {"type", "name", "material", "interior", "emission", "transform",
                                              "center", "radius", NULL};
  char path[PATH_LEN], p[PATH_LEN];
  const char *type, *name = NULL, *material, *file = NULL;
  const cJSON *tj;
  affine a;
  int err;
  vf_scene_join_index(path, "shapes", index);
  if (!cJSON_IsObject(j)) return vf_scene_fail(c, VF_ESCENE, path, "expected an object, found %s", vf_scene_kind(j));
  if ((err = vf_scene_string_field(c, j, path, "type", REQUIRED, &type)) < 0) return err;
  if (strcmp(type, "mesh") == 0) s->kind = VF_SHAPE_MESH;
  else if (strcmp(type, "sphere") == 0) s->kind = VF_SHAPE_SPHERE;
  else
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "type"), "unknown shape type '%s' (expected mesh or sphere)", type);
  if ((err = vf_scene_check_object(c, j, path, s->kind == VF_SHAPE_MESH ? mesh_fields : sphere_fields)) < 0) return err;
  if ((err = vf_scene_string_field(c, j, path, "name", OPTIONAL, &name)) < 0) return err;
  if (name != NULL && strlen(name) >= sizeof s->name)
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "name"), "longer than %zu bytes", sizeof s->name - 1);
  /* "interior": the medium inside the closed shape (worker/scene/interfaces.c checks that
   * it is closed). With one, "material" may be left out: an index-matched boundary. */
  const char *interior = NULL;
  if ((err = vf_scene_string_field(c, j, path, "interior", OPTIONAL, &interior)) < 0) return err;
  s->interior = s->exterior = -1;
  if (interior != NULL && (s->interior = vf_scene_medium_index(c, interior)) < 0)
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "interior"), "unknown medium '%s'%s", interior,
                         c->scene->num_media == 0 ? " (the scene has no \"media\")" : "");
  if (interior == NULL && !cJSON_HasObjectItem(j, "material"))
    return vf_scene_fail(c, VF_ESCENE, path, "missing field 'material' (only a shape with an 'interior' may have none: "
                         "an index-matched medium boundary)");
  int has_material = vf_scene_string_field(c, j, path, "material", interior ? OPTIONAL : REQUIRED, &material);
  if (has_material < 0) return has_material;
  s->material = has_material ? vf_name_index_find(names, material) : -1;
  if (has_material && s->material < 0)
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "material"), "unknown material '%s'", material);
  if ((err = vf_scene_rgb_field(c, j, path, "emission", OPTIONAL, "radiance", &s->emission)) < 0) return err;
  if (!has_material && !vf_is_zero(s->emission))
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "emission"),
                         "an index-matched boundary (a shape without 'material') cannot emit");
  int has_transform = vf_scene_member(c, j, path, "transform", OPTIONAL, &tj);
  if (has_transform && (err = parse_transform(c, tj, vf_scene_join(p, path, "transform"), &a)) < 0) return err;
  if (s->kind == VF_SHAPE_SPHERE) {
    if ((err = parse_sphere(c, j, path, &a, has_transform, s)) < 0) return err;
  } else {
    if ((err = vf_scene_string_field(c, j, path, "file", OPTIONAL, &file)) < 0) return err;
    int inline_mesh = cJSON_HasObjectItem(j, "positions") || cJSON_HasObjectItem(j, "indices");
    if (file != NULL && inline_mesh)
      return vf_scene_fail(c, VF_ESCENE, path, "give either 'file' or 'positions' and 'indices', not both");
    if (file == NULL && !inline_mesh)
      return vf_scene_fail(c, VF_ESCENE, path, "missing field 'file' (or 'positions' and 'indices')");
    if (file != NULL && (cJSON_HasObjectItem(j, "uvs") || cJSON_HasObjectItem(j, "normals")))
      return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, cJSON_HasObjectItem(j, "uvs") ? "uvs" : "normals"),
                           "only for inline meshes (a file brings its own)");
    int serialized = file != NULL && vf_serialized_is_serialized(file);
    if (!serialized && cJSON_HasObjectItem(j, "shape_index"))
      return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "shape_index"), "only for a .serialized file");
    err = serialized ? load_serialized(c, j, file, path, s)
                     : file ? vf_scene_load_mesh_file(c, file, path, s) : parse_inline_mesh(c, j, path, s);
    if (err < 0) return err;
    if (has_transform && (err = transform_mesh(c, &a, vf_scene_join(p, path, "transform"), s)) < 0) return err;
    /* "flip": the other side is the front (Mitsuba's flip_normals): every triangle's
     * winding reversed, and with it the tangent frames' handedness, as under a mirror. */
    const cJSON *flip = cJSON_GetObjectItemCaseSensitive(j, "flip");
    if (flip != NULL && !cJSON_IsBool(flip))
      return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "flip"), "expected true or false, found %s", vf_scene_kind(flip));
    if (cJSON_IsTrue(flip)) {
      for (uint32_t t = 0; t < s->num_triangles; t++) {
        uint32_t k = s->indices[3 * t + 1];
        s->indices[3 * t + 1] = s->indices[3 * t + 2];
        s->indices[3 * t + 2] = k;
      }
      for (uint32_t v = 0; s->tangents != NULL && v < s->num_vertices; v++) s->tangents[4 * v + 3] = -s->tangents[4 * v + 3];
    }
    /* "flip_t": a file whose texture v counts from the image's top row (Mitsuba reads PLY
     * files so): t = 1 - t undoes the loader's flip. The uv frame is mirrored with it. */
    const cJSON *flip_t = cJSON_GetObjectItemCaseSensitive(j, "flip_t");
    if (flip_t != NULL && !cJSON_IsBool(flip_t))
      return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "flip_t"), "expected true or false, found %s",
                           vf_scene_kind(flip_t));
    if (cJSON_IsTrue(flip_t) && s->uvs != NULL) {
      for (uint32_t v = 0; v < s->num_vertices; v++) s->uvs[2 * v + 1] = 1.0f - s->uvs[2 * v + 1];
      for (uint32_t v = 0; s->tangents != NULL && v < s->num_vertices; v++) s->tangents[4 * v + 3] = -s->tangents[4 * v + 3];
    }
    /* Degenerate triangles are kept (real meshes have them and the renderer copes), but an
     * emitter with no area would have infinite radiance per unit power: refuse it. */
    if (!vf_is_zero(s->emission) && !(vf_scene_mesh_area(s) > 0.0))
      return vf_scene_fail(c, VF_ESCENE, path, "emissive shape has zero area");
  }
  /* Default names are only for messages: a long file name may be cut short. */
  if (snprintf(s->name, sizeof s->name, "%s", name ? name : file ? file : path) >= (int)sizeof s->name)
    memcpy(s->name + sizeof s->name - 4, "...", 4);
  return VF_OK;
}

int vf_scene_parse_shapes(const parse_ctx *c, const cJSON *j) {
  vf_scene *s = c->scene;
  if (!cJSON_IsArray(j)) return vf_scene_fail(c, VF_ESCENE, "shapes", "expected an array, found %s", vf_scene_kind(j));
  int n = cJSON_GetArraySize(j);
  if (n == 0) return vf_scene_fail(c, VF_ESCENE, "shapes", "a scene needs at least one shape");
  if ((s->shapes = calloc((size_t)n, sizeof *s->shapes)) == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  s->num_shapes = n; /* zero-filled entries are safe to destroy */
  int i = 0, err;
  const cJSON *e;
  vf_name_index names;
  if ((err = vf_name_index_build(s, s->num_materials, &names)) < 0) return err;
  cJSON_ArrayForEach(e, j) {
    if ((err = parse_shape(c, e, i, &names, &s->shapes[i])) < 0) break;
    i++;
  }
  vf_name_index_release(&names);
  return err < 0 ? err : VF_OK;
}
