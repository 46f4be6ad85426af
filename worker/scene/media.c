/* The "media" of a JSON scene (media.h): coefficients per unit length of the scene's
 * units, a Henyey-Greenstein g, and optionally a density grid from a VDB file placed in
 * world space by the file's own transform, a "box" or a "transform" (docs/SCENES.md,
 * "Media"). */
#include "media.h"

#include "../../common/error.h"
#include "fields.h"
#include "shapes.h"
#include "vdb.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A coefficient: a number for all three channels or [r, g, b], each finite and >= 0. 1 and
 * *out set, 0 absent, < 0 error. */
static int coefficient_field(const parse_ctx *c, const cJSON *j, const char *path, const char *key, vf_vec3 *out) {
  char p[PATH_LEN];
  const cJSON *item;
  int err = vf_scene_member(c, j, path, key, OPTIONAL, &item);
  if (err <= 0) return err;
  vf_scene_join(p, path, key);
  vf_vec3 v;
  if (cJSON_IsNumber(item)) {
    float f;
    if ((err = vf_scene_to_float(c, item, p, &f)) < 0) return err;
    v = vf_vec3_splat(f);
  } else if (cJSON_IsArray(item)) {
    if ((err = vf_scene_to_vec3(c, item, p, &v)) < 0) return err;
  } else {
    return vf_scene_fail(c, VF_ESCENE, p, "expected a number or [r, g, b] (per unit length), found %s",
                         vf_scene_kind(item));
  }
  if (!(vf_min_component(v) >= 0.0f))
    return vf_scene_fail(c, VF_ESCENE, p, "must be >= 0 per unit length, found [%g, %g, %g]", v.x, v.y, v.z);
  *out = v;
  return 1;
}

/* "box": {"min": [x, y, z], "max": [x, y, z]}, min < max on every axis. */
static int parse_box(const parse_ctx *c, const cJSON *j, const char *path, vf_vec3 *lo, vf_vec3 *hi) {
  static const char *const fields[] = {"min", "max", NULL};
  int err = vf_scene_check_object(c, j, path, fields);
  if (err < 0 || (err = vf_scene_vec3_field(c, j, path, "min", REQUIRED, lo)) < 0 ||
      (err = vf_scene_vec3_field(c, j, path, "max", REQUIRED, hi)) < 0)
    return err;
  if (!(lo->x < hi->x && lo->y < hi->y && lo->z < hi->z))
    return vf_scene_fail(c, VF_ESCENE, path, "'min' must be below 'max' on every axis");
  return VF_OK;
}

/* The grid's box moved by a "transform" of translate and a positive scale per axis: a
 * dense grid stays axis-aligned, so rotations and mirrors are refused. */
static int transform_box(const parse_ctx *c, const cJSON *j, const char *path, vf_density_grid *g) {
  vf_affine a;
  int err = vf_scene_parse_transform(c, j, path, &a);
  if (err < 0) return err;
  for (int r = 0; r < 3; r++)
    for (int k = 0; k < 3; k++)
      if ((r != k && a.m[r][k] != 0.0) || (r == k && !(a.m[r][k] > 0.0)))
        return vf_scene_fail(c, VF_ESCENE, path,
                             "a density grid stays axis-aligned: only 'translate' and a positive 'scale'");
  double lo[3] = {g->box_min.x, g->box_min.y, g->box_min.z}, hi[3] = {g->box_max.x, g->box_max.y, g->box_max.z};
  float out[2][3];
  for (int k = 0; k < 3; k++) {
    out[0][k] = (float)(a.m[k][k] * lo[k] + a.m[k][3]);
    out[1][k] = (float)(a.m[k][k] * hi[k] + a.m[k][3]);
    if (!(fabsf(out[0][k]) <= FLT_MAX && fabsf(out[1][k]) <= FLT_MAX && out[0][k] < out[1][k]))
      return vf_scene_fail(c, VF_ESCENE, path, "moves or scales the grid's box out of range");
  }
  g->box_min = vf_vec3_make(out[0][0], out[0][1], out[0][2]);
  g->box_max = vf_vec3_make(out[1][0], out[1][1], out[1][2]);
  return VF_OK;
}

/* The VDB file `file`: a built-in's in-memory file, else resolved as every file of the
 * scene is (so that a farm job ships it by content hash). */
static int read_grid_file(const parse_ctx *c, const char *file, const char *grid_name, const char *fpath,
                          vf_density_grid *g) {
  char full[4096], detail[768];
  int err = VF_OK, done = 0;
  for (int i = 0; i < c->num_memfiles && !done; i++)
    if (strcmp(c->memfiles[i].name, file) == 0) {
      err = vf_vdb_read_grid_memory(c->memfiles[i].data, c->memfiles[i].size, file, grid_name, g);
      done = 1;
    }
  if (!done) {
    if ((err = vf_scene_resolve(c, file, fpath, full, sizeof full)) < 0) return err;
    err = vf_vdb_read_grid(full, file, grid_name, g);
  }
  if (err == VF_OK) return VF_OK;
  snprintf(detail, sizeof detail, "%s", vf_error_detail(err));
  return vf_scene_fail(c, err, fpath, "%s", detail);
}

/* "density": {"file", "grid", "scale", "box" | "transform"}: the grid in g. */
static int parse_density(const parse_ctx *c, const cJSON *j, const char *path, vf_density_grid *g) {
  static const char *const fields[] = {"file", "grid", "scale", "box", "transform", NULL};
  char p[PATH_LEN];
  const char *file, *grid_name = "density";
  float scale = 1.0f;
  const cJSON *box, *transform;
  int err = vf_scene_check_object(c, j, path, fields);
  if (err < 0 || (err = vf_scene_string_field(c, j, path, "file", REQUIRED, &file)) < 0 ||
      (err = vf_scene_string_field(c, j, path, "grid", OPTIONAL, &grid_name)) < 0 ||
      (err = vf_scene_float_field(c, j, path, "scale", OPTIONAL, &scale)) < 0)
    return err;
  if (!(scale > 0.0f)) return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "scale"), "must be > 0, found %g", scale);
  int has_box = vf_scene_member(c, j, path, "box", OPTIONAL, &box);
  int has_transform = vf_scene_member(c, j, path, "transform", OPTIONAL, &transform);
  if (has_box && has_transform)
    return vf_scene_fail(c, VF_ESCENE, path, "give 'box' or 'transform', not both (both place the grid)");
  vf_vec3 lo, hi;
  if (has_box && (err = parse_box(c, box, vf_scene_join(p, path, "box"), &lo, &hi)) < 0) return err;
  if ((err = read_grid_file(c, file, grid_name, vf_scene_join(p, path, "file"), g)) < 0) return err;
  if (has_box) g->box_min = lo, g->box_max = hi;
  if (has_transform && (err = transform_box(c, transform, vf_scene_join(p, path, "transform"), g)) < 0) return err;
  const size_t n = (size_t)g->nx * g->ny * g->nz;
  for (size_t i = 0; i < n; i++) g->density[i] *= scale;
  g->max_density *= scale;
  if (!(g->max_density <= FLT_MAX))
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "scale"), "makes a density of '%s' overflow", file);
  return VF_OK;
}

static int parse_medium(const parse_ctx *c, const cJSON *j, vf_medium *m) {
  static const char *const fields[] = {"sigma_a", "sigma_s", "g", "density", NULL};
  char path[PATH_LEN], p[PATH_LEN];
  const cJSON *density;
  vf_scene_join(path, "media", j->string);
  int err = vf_scene_check_object(c, j, path, fields);
  if (err < 0) return err;
  if (j->string[0] == '\0' || strlen(j->string) >= sizeof m->name)
    return vf_scene_fail(c, VF_ESCENE, path, "a medium name must have 1 to %zu bytes", sizeof m->name - 1);
  snprintf(m->name, sizeof m->name, "%s", j->string);
  int has_a = coefficient_field(c, j, path, "sigma_a", &m->sigma_a);
  if (has_a < 0) return has_a;
  int has_s = coefficient_field(c, j, path, "sigma_s", &m->sigma_s);
  if (has_s < 0) return has_s;
  if (!has_a && !has_s) return vf_scene_fail(c, VF_ESCENE, path, "needs 'sigma_a' or 'sigma_s' (or both)");
  if ((err = vf_scene_float_field(c, j, path, "g", OPTIONAL, &m->g)) < 0) return err;
  if (!(m->g > -1.0f && m->g < 1.0f))
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "g"), "the phase function's asymmetry must be in (-1, 1), found %g",
                         m->g);
  if ((err = vf_scene_member(c, j, path, "density", OPTIONAL, &density)) <= 0) return err;
  if ((m->grid = calloc(1, sizeof *m->grid)) == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  if ((err = parse_density(c, density, vf_scene_join(p, path, "density"), m->grid)) < 0) return err;
  /* The renderer's majorant is sigma_t times the largest density: it must be finite. */
  float sigma_t = vf_max_component(vf_add(m->sigma_a, m->sigma_s));
  if (!((double)sigma_t * m->grid->max_density <= FLT_MAX))
    return vf_scene_fail(c, VF_ESCENE, path, "sigma_a + sigma_s times the largest density overflows");
  return VF_OK;
}

int vf_scene_parse_media(const parse_ctx *c, const cJSON *j) {
  vf_scene *s = c->scene;
  int err = vf_scene_check_object(c, j, "media", NULL);
  if (err < 0) return err;
  int n = cJSON_GetArraySize(j);
  if (n == 0) return VF_OK;
  if ((s->media = calloc((size_t)n, sizeof *s->media)) == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  const cJSON *m;
  cJSON_ArrayForEach(m, j) {
    /* Counted before parsing: a failure frees the medium's grid with the scene. */
    vf_medium *medium = &s->media[s->num_media++];
    if ((err = parse_medium(c, m, medium)) < 0) return err;
  }
  return VF_OK;
}

int vf_scene_parse_scene_medium(const parse_ctx *c, const cJSON *j) {
  if (!cJSON_IsString(j)) return vf_scene_fail(c, VF_ESCENE, "medium", "expected a medium's name, found %s", vf_scene_kind(j));
  int index = vf_scene_medium_index(c, j->valuestring);
  if (index < 0)
    return vf_scene_fail(c, VF_ESCENE, "medium", "unknown medium '%s'%s", j->valuestring,
                         c->scene->num_media == 0 ? " (the scene has no \"media\")" : "");
  c->scene->medium = index;
  return VF_OK;
}
