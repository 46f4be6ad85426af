/* Mitsuba 3 XML scenes as JSON scenes (mitsuba.h): shapes and emitters here, sensors and
 * the integrator in mitsuba_sensor.c, BSDFs and textures in mitsuba_bsdf.c. */
#include "mitsuba.h"

#include "../../common/error.h"
#include "mitsuba_bsdf.h"
#include "mitsuba_medium.h"
#include "mitsuba_props.h"
#include "mitsuba_sensor.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#define PI 3.14159265358979323846
/* Segments of the triangulated disk: its area is 0.9999 of the disk's. */
#define DISK_SEGMENTS 256

int vf_mitsuba_is_xml(const char *path) { return vf_mitsuba_has_extension(path, ".xml"); }

int vf_mitsuba_has_extension(const char *path, const char *ext) {
  size_t n = strlen(path), e = strlen(ext);
  return n >= e && strcasecmp(path + n - e, ext) == 0;
}

static int oom(void) { return vf_error_set(VF_ENOMEM, "out of memory"); }

static int add(cJSON *o, const char *key, cJSON *v) {
  if (v == NULL || !cJSON_AddItemToObject(o, key, v)) {
    cJSON_Delete(v);
    return oom();
  }
  return VF_OK;
}

static int check_file(const vf_xml_node *e, const mts_ctx *c, const char *file) {
  char path[8192];
  snprintf(path, sizeof path, "%s%s%s", file[0] == '/' ? "" : c->dir, file[0] == '/' ? "" : "/", file);
  FILE *f = fopen(path, "rb");
  if (f != NULL) return fclose(f), VF_OK;
  mts_fail(e, "cannot open '%s': %s", file, strerror(errno));
  char detail[1024];
  snprintf(detail, sizeof detail, "%s", vf_error_detail(VF_ESCENE));
  return vf_error_set(VF_ENOENT, "%s", detail);
}

/* ---- shapes ---- */

static int emission(mts_ctx *c, vf_xml_node *shape, cJSON *js) {
  for (int i = 0; i < shape->num_children; i++) {
    vf_xml_node *e = shape->children[i];
    if (strcmp(e->name, "emitter") != 0) continue;
    e->used = 1;
    const char *type = vf_xml_attr(e, "type");
    if (type == NULL || strcmp(type, "area") != 0)
      return mts_fail(e, "a shape's emitter must be 'area', not '%s'", type ? type : "");
    vf_vec3 radiance;
    vf_xml_node *t;
    int err = mts_color(c, e, "radiance", vf_vec3_splat(1), &radiance, &t);
    if (err < 0) return err;
    if (err == 2) return mts_fail(t, "a textured radiance is not supported");
    if (radiance.x < 0 || radiance.y < 0 || radiance.z < 0) return mts_fail(e, "radiance must not be negative");
    if ((err = mts_note_unused(c, e)) < 0) return err;
    return add(js, "emission", mts_vec3_json(radiance));
  }
  return VF_OK;
}

static int matrix_json(const vf_affine *m, cJSON *js) {
  double v[16] = {0};
  int identity = 1;
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 4; j++) {
      v[4 * i + j] = m->m[i][j];
      identity &= m->m[i][j] == (i == j ? 1.0 : 0.0);
    }
  v[15] = 1;
  if (identity) return VF_OK;
  cJSON *t = cJSON_CreateObject();
  if (t == NULL || !cJSON_AddItemToObject(js, "transform", t)) return cJSON_Delete(t), oom();
  return add(t, "matrix", cJSON_CreateDoubleArray(v, 16));
}

/* An inline mesh of nv positions (and texture coordinates uv, or NULL) and nt triangles,
 * the winding reversed for flip_normals. */
static int inline_mesh(cJSON *js, const double *pos, const double *uv, int nv, const int *idx, int nt, int flip) {
  cJSON *p = cJSON_CreateDoubleArray(pos, 3 * nv), *ix = cJSON_CreateArray();
  if (p == NULL || ix == NULL || !cJSON_AddItemToObject(js, "positions", p)) return cJSON_Delete(p), cJSON_Delete(ix), oom();
  if (uv != NULL && add(js, "uvs", cJSON_CreateDoubleArray(uv, 2 * nv)) < 0) return cJSON_Delete(ix), oom();
  if (!cJSON_AddItemToObject(js, "indices", ix)) return cJSON_Delete(ix), oom();
  for (int t = 0; t < nt; t++)
    for (int k = 0; k < 3; k++) {
      cJSON *n = cJSON_CreateNumber(idx[3 * t + (flip && k > 0 ? 3 - k : k)]);
      if (n == NULL || !cJSON_AddItemToArray(ix, n)) return cJSON_Delete(n), oom();
    }
  return VF_OK;
}

/* Mitsuba's rectangle ([-1, 1]^2 at z = 0, facing +z), cube ([-1, 1]^3, facing out) and
 * disk (radius 1 at z = 0, facing +z), counter-clockwise seen from their fronts. */
static int primitive(cJSON *js, const char *type, int flip) {
  if (strcmp(type, "rectangle") == 0) {
    static const double pos[] = {-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0};
    /* Mitsuba's: uv (0, 0) at (-1, -1); its v = 0 is an image's top row, as vcmfarm's t. */
    static const double uv[] = {0, 0, 1, 0, 1, 1, 0, 1};
    static const int idx[] = {0, 1, 2, 0, 2, 3};
    return inline_mesh(js, pos, uv, 4, idx, 2, flip);
  }
  if (strcmp(type, "cube") == 0) {
    /* Mitsuba's cube: four vertices per face sharing its uv pattern, corner c at (+-1, +-1,
     * +-1) with bit k the sign of axis k; triangles {4s, 4s+1, 4s+2} and {4s+3, 4s, 4s+2}. */
    static const int corner[24] = {1, 5, 4, 0, 3, 2, 6, 7, 1, 3, 7, 5, 5, 7, 6, 4, 4, 6, 2, 0, 3, 1, 0, 2};
    static const double side_uv[8] = {0, 1, 1, 1, 1, 0, 0, 0};
    double pos[72], uv[48];
    int idx[36];
    for (int v = 0; v < 24; v++) {
      for (int k = 0; k < 3; k++) pos[3 * v + k] = (corner[v] >> k) & 1 ? 1 : -1;
      uv[2 * v] = side_uv[2 * (v % 4)];
      uv[2 * v + 1] = side_uv[2 * (v % 4) + 1];
    }
    for (int f = 0; f < 6; f++) {
      const int tri[6] = {4 * f, 4 * f + 1, 4 * f + 2, 4 * f + 3, 4 * f, 4 * f + 2};
      memcpy(&idx[6 * f], tri, sizeof tri);
    }
    return inline_mesh(js, pos, uv, 24, idx, 12, flip);
  }
  double pos[3 * (DISK_SEGMENTS + 1)];
  int idx[3 * DISK_SEGMENTS];
  pos[0] = pos[1] = pos[2] = 0;
  for (int i = 0; i < DISK_SEGMENTS; i++) {
    double phi = 2 * PI * i / DISK_SEGMENTS;
    pos[3 * (i + 1)] = cos(phi);
    pos[3 * (i + 1) + 1] = sin(phi);
    pos[3 * (i + 1) + 2] = 0;
    idx[3 * i] = 0;
    idx[3 * i + 1] = i + 1;
    idx[3 * i + 2] = (i + 1) % DISK_SEGMENTS + 1;
  }
  return inline_mesh(js, pos, NULL, DISK_SEGMENTS + 1, idx, DISK_SEGMENTS, flip);
}

static int sphere(mts_ctx *c, vf_xml_node *s, cJSON *js, const vf_affine *m) {
  vf_vec3 center;
  double radius;
  int err;
  if ((err = mts_point(c, s, "center", vf_vec3_splat(0), &center)) < 0 || (err = mts_float(c, s, "radius", 1, &radius)) < 0)
    return err;
  if (!(radius > 0)) return mts_fail(s, "radius must be > 0, found %g", radius);
  /* A sphere stays one under a similarity only: equal, orthogonal columns. */
  double l0 = mts_column_length(m, 0), l1 = mts_column_length(m, 1), l2 = mts_column_length(m, 2);
  double d01 = 0, d02 = 0, d12 = 0;
  for (int i = 0; i < 3; i++) {
    d01 += m->m[i][0] * m->m[i][1];
    d02 += m->m[i][0] * m->m[i][2];
    d12 += m->m[i][1] * m->m[i][2];
  }
  if (fabs(l0 - l1) > 1e-5 * l0 || fabs(l0 - l2) > 1e-5 * l0 || fabs(d01) + fabs(d02) + fabs(d12) > 1e-5 * l0 * l0)
    return mts_fail(s, "to_world scales the sphere unevenly: an ellipsoid is not supported");
  vf_vec3 cw = mts_apply_point(m, center.x, center.y, center.z);
  if ((err = add(js, "center", mts_vec3_json(cw))) < 0) return err;
  return cJSON_AddNumberToObject(js, "radius", radius * l0) ? VF_OK : oom();
}

static int shape(mts_ctx *c, vf_xml_node *s) {
  const char *type = vf_xml_attr(s, "type");
  int err, flip;
  s->used = 1;
  if (type == NULL) return mts_fail(s, "has no type");
  if (strcmp(type, "shapegroup") == 0 || strcmp(type, "instance") == 0)
    return mts_fail(s, "shape '%s' is not supported", type);
  int mesh_file = strcmp(type, "obj") == 0 || strcmp(type, "ply") == 0, serialized = strcmp(type, "serialized") == 0;
  if (!mesh_file && !serialized && strcmp(type, "rectangle") != 0 && strcmp(type, "cube") != 0 &&
      strcmp(type, "disk") != 0 && strcmp(type, "sphere") != 0) {
    for (int i = 0; i < s->num_children; i++) s->children[i]->used = 1;
    return mts_note(c, s, "shape '%s' is not supported: left out", type);
  }
  cJSON *js = cJSON_CreateObject();
  if (js == NULL || !cJSON_AddItemToArray(c->shapes, js)) return cJSON_Delete(js), oom();
  const char *id = vf_xml_attr(s, "id");
  if (id != NULL && strlen(id) < 64 && !cJSON_AddStringToObject(js, "name", id)) return oom();
  if (!cJSON_AddStringToObject(js, "type", strcmp(type, "sphere") == 0 ? "sphere" : "mesh")) return oom();
  vf_affine m;
  if ((err = mts_transform(c, s, "to_world", &m)) < 0 || (err = mts_bool(c, s, "flip_normals", 0, &flip)) < 0) return err;
  /* The BSDF: a child <bsdf>, or a <ref> to one. */
  vf_xml_node *bsdf = NULL;
  for (int i = 0; i < s->num_children && bsdf == NULL; i++) {
    vf_xml_node *ch = s->children[i];
    const char *role = vf_xml_attr(ch, "name");
    if (role != NULL && (strcmp(role, "interior") == 0 || strcmp(role, "exterior") == 0)) continue; /* media: below */
    if (strcmp(ch->name, "bsdf") == 0) bsdf = ch;
    else if (strcmp(ch->name, "ref") == 0) {
      vf_xml_node *d = mts_deref(c, ch, &err);
      if (d == NULL) return err;
      if (strcmp(d->name, "bsdf") == 0) bsdf = d;
      else return mts_fail(ch, "a shape's <ref> must name a <bsdf>, not a <%s>", d->name);
    }
    if (bsdf != NULL) ch->used = 1;
  }
  /* Media: the interior by name; a null BSDF around one is an index-matched boundary (no
   * material). Exteriors follow from how the shapes nest (docs/SCENES.md, "Media"). */
  const char *interior = NULL, *exterior = NULL;
  vf_xml_node *inner = mts_child(c, s, "interior", &err), *outer;
  if (err < 0 || (inner != NULL && (err = mts_medium(c, inner, &interior)) < 0)) return err;
  if ((outer = mts_child(c, s, "exterior", &err)) == NULL && err < 0) return err;
  if (outer != NULL && ((err = mts_medium(c, outer, &exterior)) < 0 ||
                        (err = mts_note(c, s, "the exterior medium is not read: a shape's outside is the medium of the "
                                        "shape that contains it, else the scene's")) < 0))
    return err;
  if (interior != NULL && !cJSON_AddStringToObject(js, "interior", interior)) return oom();
  const char *bsdf_type = bsdf != NULL ? vf_xml_attr(bsdf, "type") : NULL;
  if (interior != NULL && bsdf_type != NULL && strcmp(bsdf_type, "null") == 0) {
    bsdf->used = 1;
    for (int i = 0; i < bsdf->num_children; i++) bsdf->children[i]->used = 1;
    if ((err = emission(c, s, js)) < 0) return err;
  } else {
    const char *material;
    if ((err = mts_material(c, bsdf, &material)) < 0 || !cJSON_AddStringToObject(js, "material", material) ||
        (err = emission(c, s, js)) < 0)
      return err < 0 ? err : oom();
  }
  if (mesh_file) {
    const char *file;
    int face_normals;
    if ((err = mts_string(c, s, "filename", NULL, &file)) < 0) return err;
    if (file == NULL) return mts_fail(s, "has no filename");
    if ((err = check_file(s, c, file)) < 0) return err;
    if (!cJSON_AddStringToObject(js, "file", file)) return oom();
    if ((err = mts_bool(c, s, "face_normals", 0, &face_normals)) < 0) return err;
    if (face_normals && (err = mts_note(c, s, "face_normals: the file's vertex normals are used where it has them")) < 0)
      return err;
    if (flip && !cJSON_AddTrueToObject(js, "flip")) return oom();
    /* Mitsuba flips an OBJ's v by default and keeps a PLY's (flip_tex_coords); vcmfarm
     * flips both (t = 1 - v): a file Mitsuba does not flip is flipped back. */
    int flip_tex;
    if ((err = mts_bool(c, s, "flip_tex_coords", strcmp(type, "obj") == 0, &flip_tex)) < 0) return err;
    if (!flip_tex && !cJSON_AddTrueToObject(js, "flip_t")) return oom();
    if ((err = matrix_json(&m, js)) < 0) return err;
  } else if (serialized) {
    const char *file;
    long index;
    int face_normals;
    if ((err = mts_string(c, s, "filename", NULL, &file)) < 0 || (err = mts_int(c, s, "shape_index", 0, &index)) < 0 ||
        (err = mts_bool(c, s, "face_normals", 0, &face_normals)) < 0)
      return err;
    if (file == NULL) return mts_fail(s, "has no filename");
    if (!vf_mitsuba_has_extension(file, ".serialized"))
      return mts_fail(s, "filename '%s' does not end in .serialized", file);
    if ((err = check_file(s, c, file)) < 0) return err;
    if (index < 0) return mts_fail(s, "shape_index %ld is negative", index);
    if (!cJSON_AddStringToObject(js, "file", file) || (index > 0 && !cJSON_AddNumberToObject(js, "shape_index", (double)index)) ||
        (flip && !cJSON_AddTrueToObject(js, "flip")))
      return oom();
    if ((err = matrix_json(&m, js)) < 0) return err;
    if (face_normals && (err = mts_note(c, s, "face_normals: the file's vertex normals are used where it has them")) < 0)
      return err;
  } else if (strcmp(type, "sphere") == 0) {
    if ((err = sphere(c, s, js, &m)) < 0) return err;
    if (flip && (err = mts_note(c, s, "flip_normals on a sphere is not supported: it emits outwards")) < 0) return err;
  } else {
    if ((err = primitive(js, type, flip)) < 0 || (err = matrix_json(&m, js)) < 0) return err;
    if (strcmp(type, "disk") == 0 &&
        (err = mts_note(c, s, "the disk is a polygon of %d triangles (area 0.9999 of the disk's)", DISK_SEGMENTS)) < 0)
      return err;
  }
  return mts_note_unused(c, s);
}

/* ---- emitters and the integrator ---- */

static int light(mts_ctx *c, const char *type, cJSON **out) {
  cJSON *l = cJSON_CreateObject();
  if (l == NULL || !cJSON_AddItemToArray(c->lights, l) || !cJSON_AddStringToObject(l, "type", type))
    return oom();
  *out = l;
  return VF_OK;
}

static int emitter(mts_ctx *c, vf_xml_node *e) {
  const char *type = vf_xml_attr(e, "type");
  vf_affine m;
  vf_vec3 v, pos;
  vf_xml_node *t;
  cJSON *l = NULL;
  int err;
  e->used = 1;
  if (type == NULL) return mts_fail(e, "has no type");
  if ((err = mts_transform(c, e, "to_world", &m)) < 0) return err;
  if (strcmp(type, "point") == 0 || strcmp(type, "spot") == 0) {
    if ((err = mts_color(c, e, "intensity", vf_vec3_splat(1), &v, &t)) < 0) return err;
    if (err == 2) return mts_fail(t, "a textured intensity is not supported");
    int has_pos = mts_point(c, e, "position", vf_vec3_splat(0), &pos);
    if (has_pos < 0) return has_pos;
    if ((err = light(c, type, &l)) < 0 || (err = add(l, "intensity", mts_vec3_json(v))) < 0 ||
        (err = add(l, "position", mts_vec3_json(has_pos ? pos : mts_apply_point(&m, 0, 0, 0)))) < 0)
      return err;
    if (strcmp(type, "spot") == 0) {
      double cutoff, beam;
      if ((err = mts_float(c, e, "cutoff_angle", 20, &cutoff)) < 0 || (err = mts_float(c, e, "beam_width", cutoff * 0.75, &beam)) < 0)
        return err;
      if (!(cutoff > 0 && cutoff <= 90 && beam >= 0 && beam < cutoff))
        return mts_fail(e, "needs 0 <= beam_width < cutoff_angle <= 90 (found %g and %g)", beam, cutoff);
      if ((err = add(l, "direction", mts_vec3_json(mts_apply_vector(&m, 0, 0, 1)))) < 0 ||
          !cJSON_AddNumberToObject(l, "inner_cone_angle", beam) || !cJSON_AddNumberToObject(l, "outer_cone_angle", cutoff))
        return oom();
      if ((err = mts_note(c, e, "spot falloff: Mitsuba's is linear in angle from beam_width to cutoff_angle, vcmfarm's "
                          "KHR_lights_punctual's smooth ramp in cosine between the same angles")) < 0)
        return err;
    }
  } else if (strcmp(type, "directional") == 0) {
    vf_vec3 dir;
    if ((err = mts_color(c, e, "irradiance", vf_vec3_splat(1), &v, &t)) < 0) return err;
    if (err == 2) return mts_fail(t, "a textured irradiance is not supported");
    int has_dir = mts_point(c, e, "direction", vf_vec3_splat(0), &dir);
    if (has_dir < 0) return has_dir;
    if ((err = light(c, "directional", &l)) < 0 || (err = add(l, "irradiance", mts_vec3_json(v))) < 0 ||
        (err = add(l, "direction", mts_vec3_json(has_dir ? dir : mts_apply_vector(&m, 0, 0, 1)))) < 0)
      return err;
  } else if (strcmp(type, "constant") == 0) {
    if ((err = mts_color(c, e, "radiance", vf_vec3_splat(1), &v, &t)) < 0) return err;
    if (err == 2) return mts_fail(t, "a textured radiance is not supported");
    if ((err = light(c, "background", &l)) < 0 || (err = add(l, "radiance", mts_vec3_json(v))) < 0) return err;
  } else if (strcmp(type, "envmap") == 0) {
    const char *file;
    double scale;
    if ((err = mts_string(c, e, "filename", NULL, &file)) < 0 || (err = mts_float(c, e, "scale", 1, &scale)) < 0) return err;
    if (file == NULL) return mts_fail(e, "has no filename");
    if ((err = check_file(e, c, file)) < 0) return err;
    /* Mitsuba looks a world direction d up at u = atan2(d'.x, -d'.z) / 2pi, v = acos(d'.y)
     * / pi with d' = to_world^-1 d; vcmfarm at u + 0.5 of R^T d (scene.h). u + 0.5 of x is
     * u of H x, H the half turn about +y = diag(-1, 1, -1), so R = to_world H. */
    double q[9];
    for (int i = 0; i < 3; i++)
      for (int k = 0; k < 3; k++) q[3 * i + k] = (k == 1 ? 1 : -1) * m.m[i][k];
    for (int a = 0; a < 3; a++)
      for (int b = 0; b < 3; b++) {
        double dot = m.m[0][a] * m.m[0][b] + m.m[1][a] * m.m[1][b] + m.m[2][a] * m.m[2][b];
        if (fabs(dot - (a == b)) > 1e-5 || vf_affine_det(&m) < 0)
          return mts_fail(e, "to_world must be a rotation (an envmap cannot be scaled or mirrored)");
      }
    if ((err = light(c, "environment", &l)) < 0 || !cJSON_AddStringToObject(l, "file", file) ||
        (err = add(l, "scale", mts_vec3_json(vf_vec3_splat((float)scale)))) < 0 ||
        (err = add(l, "rotation", cJSON_CreateDoubleArray(q, 9))) < 0)
      return err < 0 ? err : oom();
  } else {
    return mts_fail(e, "emitter type '%s' is not supported (area, point, spot, directional, constant, envmap)", type);
  }
  return mts_note_unused(c, e);
}

/* Mitsuba 3's upgrade of a scene written for version 0.x or 1.x (src/core/parser.cpp,
 * upgrade_from_v1): property names from camelCase to underscore_case ("toWorld" ->
 * "to_world", "intIOR" -> "int_ior"), and a diffuse BSDF's "diffuse_reflectance" read as
 * its "reflectance". */
static int upgrade_v1(vf_xml_node *e, const char *plugin) {
  for (int i = 0; i < e->num_attrs; i++) {
    if (strcmp(e->attrs[2 * i], "name") != 0) continue;
    const char *in = e->attrs[2 * i + 1];
    size_t n = strlen(in), k = 0;
    char *out = malloc(2 * n + 1);
    if (out == NULL) return oom();
    for (size_t j = 0; j < n; j++) {
      if (j > 0 && islower((unsigned char)in[j - 1]) && isupper((unsigned char)in[j])) {
        out[k++] = '_';
        out[k++] = (char)tolower((unsigned char)in[j]);
        while (j + 1 < n && isupper((unsigned char)in[j + 1])) out[k++] = (char)tolower((unsigned char)in[++j]);
      } else {
        out[k++] = in[j];
      }
    }
    out[k] = '\0';
    if (plugin != NULL && strcmp(plugin, "diffuse") == 0 && strcmp(out, "diffuse_reflectance") == 0)
      snprintf(out, 2 * n + 1, "reflectance");
    free(e->attrs[2 * i + 1]);
    e->attrs[2 * i + 1] = out;
  }
  const char *type = strcmp(e->name, "bsdf") == 0 ? vf_xml_attr(e, "type") : NULL;
  for (int i = 0; i < e->num_children; i++) {
    int err = upgrade_v1(e->children[i], type);
    if (err < 0) return err;
  }
  return VF_OK;
}

static int convert(mts_ctx *c, const char *camera) {
  vf_xml_node *s = c->scene, *chosen = NULL;
  const char *version = vf_xml_attr(s, "version");
  int err, sensors = 0;
  if (version == NULL) return mts_fail(s, "has no version");
  if (atoi(version) < 2) {
    if ((err = upgrade_v1(s, NULL)) < 0 ||
        (err = mts_note(c, s, "version %s: upgraded as Mitsuba 3 does (camelCase names), read with Mitsuba 3's defaults",
                        version)) < 0)
      return err;
  }
  for (int i = 0; i < s->num_children; i++) {
    vf_xml_node *e = s->children[i];
    if (strcmp(e->name, "sensor") != 0) continue;
    const char *id = vf_xml_attr(e, "id");
    char index[16];
    snprintf(index, sizeof index, "%d", sensors++);
    if (chosen == NULL && (camera == NULL || strcmp(camera, index) == 0 || (id && strcmp(camera, id) == 0))) chosen = e;
    else e->used = 1;
  }
  if (chosen == NULL)
    return camera ? vf_error_set(VF_ESCENE, "%s: no sensor '%s' (it has %d)", s->file, camera, sensors)
                  : mts_fail(s, "has no <sensor>");
  if (sensors > 1 && camera == NULL && (err = mts_note(c, chosen, "the first of %d sensors is rendered (--camera chooses)", sensors)) < 0)
    return err;
  if ((err = mts_sensor(c, chosen)) < 0) return err;
  for (int i = 0; i < s->num_children; i++) {
    vf_xml_node *e = s->children[i];
    if (strcmp(e->name, "shape") == 0) err = shape(c, e);
    else if (strcmp(e->name, "emitter") == 0) err = emitter(c, e);
    else if (strcmp(e->name, "integrator") == 0) err = mts_integrator(c, e);
    else if (strcmp(e->name, "bsdf") == 0 || strcmp(e->name, "texture") == 0 || strcmp(e->name, "medium") == 0)
      err = VF_OK; /* used through <ref> */
    else if (!e->used) {
      e->used = 1;
      const char *name = vf_xml_attr(e, "type");
      err = mts_note(c, e, "<%s%s%s> is not supported: ignored", e->name, name ? " type " : "", name ? name : "");
    }
    if (err < 0) return err;
  }
  for (int i = 0; i < s->num_children; i++) {
    vf_xml_node *e = s->children[i];
    if ((strcmp(e->name, "bsdf") == 0 || strcmp(e->name, "texture") == 0 || strcmp(e->name, "medium") == 0) && !e->used &&
        (err = mts_note(c, e, "defined but used by no shape")) < 0)
      return err;
  }
  return VF_OK;
}

int vf_mitsuba_scene_text(const char *path, const char *camera, char **text, size_t *len) {
  mts_ctx c = {0};
  const char *slash = strrchr(path, '/');
  if (slash == NULL) snprintf(c.dir, sizeof c.dir, ".");
  else if (slash == path) snprintf(c.dir, sizeof c.dir, "/");
  else snprintf(c.dir, sizeof c.dir, "%.*s", (int)(slash - path), path);
  int err = vf_xml_read(path, &c.scene);
  if (err != VF_OK) return err;
  c.root = cJSON_CreateObject();
  if (c.root == NULL || (c.materials = cJSON_AddObjectToObject(c.root, "materials")) == NULL ||
      (c.shapes = cJSON_AddArrayToObject(c.root, "shapes")) == NULL ||
      (c.lights = cJSON_AddArrayToObject(c.root, "lights")) == NULL ||
      (c.notes = cJSON_AddArrayToObject(c.root, "notes")) == NULL) {
    err = oom();
    goto done;
  }
  if ((err = convert(&c, camera)) < 0) goto done;
  if (cJSON_GetArraySize(c.shapes) == 0) {
    err = mts_fail(c.scene, "has no shape vcmfarm can render");
    goto done;
  }
  char *out = cJSON_Print(c.root);
  if (out == NULL) {
    err = oom();
    goto done;
  }
  *text = out;
  *len = strlen(out);
  err = VF_OK;
done:
  cJSON_Delete(c.root);
  vf_xml_free(c.scene);
  return err;
}
