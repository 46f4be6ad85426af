/* Scene files: JSON (cJSON) -> validated world-space vf_scene.
 *
 * The format is documented in docs/SCENES.md; this file and the readers it calls (shapes.c,
 * materials.c, media.c) are its only implementation, and the
 * built-in scenes (builtin.c) go through it too. Everything read from the file is
 * untrusted: every field is type-checked, every number must be finite, unknown fields are
 * errors (a misspelt "emision" silently ignored would cost someone a night of rendering),
 * and every error names the file, the field path and the problem.
 *
 * Parsing fills a calloc'ed scene step by step; on any failure vf_scene_destroy() frees
 * whatever was filled so far, which is why every array is counted as soon as it is
 * allocated and zero-filled until used. */
#include "json.h"

#include "../../common/error.h"
#include "fields.h"
#include "import.h"
#include "interfaces.h"
#include "materials.h"
#include "media.h"
#include "parse.h"
#include "shapes.h"
#include "textures.h"

#include <cjson/cJSON.h>

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- camera ------------------------------------------------------------------------------- */

static int parse_resolution(const parse_ctx *c, const cJSON *item, vf_settings *settings) {
  const char *path = "camera.resolution";
  char p[PATH_LEN];
  if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) != 2)
    return vf_scene_fail(c, VF_ESCENE, path, "expected [width, height]");
  double wh[2];
  for (int i = 0; i < 2; i++) {
    int err = vf_scene_to_integer(c, cJSON_GetArrayItem(item, i), vf_scene_join_index(p, path, i), -1e18, 1e18, &wh[i]);
    if (err < 0) return err;
  }
  if (wh[0] < 1 || wh[1] < 1)
    return vf_scene_fail(c, VF_ESCENE, path, "must be positive, found %.0fx%.0f", wh[0], wh[1]);
  if (wh[0] > 65536 || wh[1] > 65536 || wh[0] * wh[1] > (double)(1 << 28))
    return vf_scene_fail(c, VF_ESCENE, path, "%.0fx%.0f is larger than 65536x65536 or 2^28 pixels", wh[0], wh[1]);
  settings->width = (int)wh[0];
  settings->height = (int)wh[1];
  return VF_OK;
}

/* The thin lens: a radius and the distance in focus, by default the target's. */
static int parse_lens(const parse_ctx *c, const cJSON *cam, const vf_vec3 *target, vf_camera_desc *d) {
  int err = vf_scene_float_field(c, cam, "camera", "aperture", OPTIONAL, &d->aperture);
  if (err < 0) return err;
  if (!(d->aperture >= 0.0f))
    return vf_scene_fail(c, VF_ESCENE, "camera.aperture", "the lens radius must be >= 0, found %g", d->aperture);
  int has_focus = vf_scene_float_field(c, cam, "camera", "focus_distance", OPTIONAL, &d->focus_distance);
  if (has_focus < 0) return has_focus;
  if (has_focus && !(d->focus_distance > 0.0f))
    return vf_scene_fail(c, VF_ESCENE, "camera.focus_distance", "must be > 0, found %g", d->focus_distance);
  if (!has_focus && d->aperture > 0.0f) {
    if (target == NULL) return vf_scene_fail(c, VF_ESCENE, "camera", "missing field 'focus_distance' (or 'target')");
    d->focus_distance = vf_length(vf_sub(*target, d->position));
  }
  return VF_OK;
}

/* The projection: "perspective" (the default) with its field of view and optional thin
 * lens, or "orthographic" with the view's width and neither. */
static int parse_projection(const parse_ctx *c, const cJSON *cam, const vf_vec3 *target, vf_camera_desc *d) {
  const char *type = "perspective";
  int err = vf_scene_string_field(c, cam, "camera", "type", OPTIONAL, &type);
  if (err < 0) return err;
  int orthographic = strcmp(type, "orthographic") == 0;
  if (!orthographic && strcmp(type, "perspective") != 0)
    return vf_scene_fail(c, VF_ESCENE, "camera.type", "expected \"perspective\" or \"orthographic\", found \"%.40s\"", type);
  if (orthographic) {
    static const char *const perspective_only[] = {"fov", "aperture", "focus_distance", NULL};
    for (int i = 0; perspective_only[i] != NULL; i++)
      if (cJSON_GetObjectItemCaseSensitive(cam, perspective_only[i]) != NULL)
        return vf_scene_fail(c, VF_ESCENE, "camera", "'%s' is for perspective cameras: an orthographic camera has none",
                             perspective_only[i]);
    if ((err = vf_scene_float_field(c, cam, "camera", "width", REQUIRED, &d->view_width)) < 0) return err;
    if (!(d->view_width > 0.0f))
      return vf_scene_fail(c, VF_ESCENE, "camera.width", "the view's width must be > 0, found %g", d->view_width);
    return VF_OK;
  }
  if (cJSON_GetObjectItemCaseSensitive(cam, "width") != NULL)
    return vf_scene_fail(c, VF_ESCENE, "camera.width", "is for orthographic cameras (\"type\": \"orthographic\")");
  if ((err = vf_scene_float_field(c, cam, "camera", "fov", REQUIRED, &d->vertical_fov_degrees)) < 0) return err;
  if (!(d->vertical_fov_degrees > 0.0f && d->vertical_fov_degrees < 180.0f))
    return vf_scene_fail(c, VF_ESCENE, "camera.fov", "must be in (0, 180) degrees, found %g", d->vertical_fov_degrees);
  return parse_lens(c, cam, target, d);
}

static int parse_camera(const parse_ctx *c, const cJSON *cam) {
  static const char *const fields[] = {"type", "position", "target", "forward", "up", "fov", "width",
                                       "resolution", "aperture", "focus_distance", "mirror", NULL};
  vf_scene *s = c->scene;
  vf_camera_desc d = {.aperture = 0.0f, .focus_distance = 0.0f, .view_width = 0.0f};
  vf_vec3 target, forward, up = vf_vec3_make(0.0f, 1.0f, 0.0f);
  int err = vf_scene_check_object(c, cam, "camera", fields);
  if (err < 0) return err;
  if ((err = vf_scene_vec3_field(c, cam, "camera", "position", REQUIRED, &d.position)) < 0) return err;
  int has_target = vf_scene_vec3_field(c, cam, "camera", "target", OPTIONAL, &target);
  if (has_target < 0) return has_target;
  int has_forward = vf_scene_vec3_field(c, cam, "camera", "forward", OPTIONAL, &forward);
  if (has_forward < 0) return has_forward;
  if (has_target && has_forward)
    return vf_scene_fail(c, VF_ESCENE, "camera", "give either 'target' or 'forward', not both");
  if (!has_target && !has_forward)
    return vf_scene_fail(c, VF_ESCENE, "camera", "missing field 'target' (or 'forward')");
  if (has_target && !vf_scene_unit(vf_sub(target, d.position), &d.forward))
    return vf_scene_fail(c, VF_ESCENE, "camera.target", "equals camera.position: no viewing direction");
  if (has_forward && !vf_scene_unit(forward, &d.forward))
    return vf_scene_fail(c, VF_ESCENE, "camera.forward", "zero vector");
  if ((err = vf_scene_vec3_field(c, cam, "camera", "up", OPTIONAL, &up)) < 0) return err;
  /* Gram-Schmidt: the up the user gives only picks the roll; a nearly parallel one would
   * make the roll numerically meaningless, so it is refused rather than guessed. */
  vf_vec3 up_orth = vf_sub(up, vf_scale(d.forward, vf_dot(up, d.forward)));
  if (!(vf_length(up_orth) > 1e-4f * vf_length(up)) || !vf_scene_unit(up_orth, &d.up))
    return vf_scene_fail(c, VF_ESCENE, "camera.up", "zero or parallel to the viewing direction");
  if ((err = parse_projection(c, cam, has_target ? &target : NULL, &d)) < 0) return err;
  const cJSON *mirror = cJSON_GetObjectItemCaseSensitive(cam, "mirror");
  if (mirror != NULL && !cJSON_IsBool(mirror))
    return vf_scene_fail(c, VF_ESCENE, "camera.mirror", "expected true or false, found %s", vf_scene_kind(mirror));
  d.mirror = cJSON_IsTrue(mirror);
  const cJSON *res;
  int has_resolution = vf_scene_member(c, cam, "camera", "resolution", OPTIONAL, &res);
  if (has_resolution) {
    if ((err = parse_resolution(c, res, &s->settings)) < 0) return err;
    s->settings_given |= VF_SET_RESOLUTION;
  }
  s->camera = d;
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
/* "rotation": 9 numbers, the rows of the rotation that turns the map's directions into the
 * world's; orthonormal with determinant +1 (within float rounding of written decimals). */
static int parse_envmap_rotation(const parse_ctx *c, const cJSON *j, const char *path) {
  const cJSON *r = cJSON_GetObjectItemCaseSensitive(j, "rotation"), *e;
  char p[PATH_LEN], ep[PATH_LEN];
  double m[3][3];
  int i = 0, err;
  if (r == NULL) return VF_OK;
  vf_scene_join(p, path, "rotation");
  if (!cJSON_IsArray(r) || cJSON_GetArraySize(r) != 9)
    return vf_scene_fail(c, VF_ESCENE, p, "expected 9 numbers, the rows of a rotation matrix");
  cJSON_ArrayForEach(e, r) {
    if ((err = vf_scene_to_double(c, e, vf_scene_join_index(ep, p, i), &m[i / 3][i % 3])) < 0) return err;
    i++;
  }
  for (int a = 0; a < 3; a++)
    for (int b = 0; b < 3; b++) {
      double dot = m[a][0] * m[b][0] + m[a][1] * m[b][1] + m[a][2] * m[b][2];
      if (fabs(dot - (a == b)) > 1e-5) return vf_scene_fail(c, VF_ESCENE, p, "is not a rotation (rows not orthonormal)");
    }
  double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
               m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  if (det < 0) return vf_scene_fail(c, VF_ESCENE, p, "is a mirror (determinant -1), not a rotation");
  int identity = 1;
  for (int a = 0; a < 3; a++)
    for (int b = 0; b < 3; b++) {
      c->scene->envmap_rotation[a][b] = (float)m[a][b];
      identity &= m[a][b] == (a == b);
    }
  c->scene->envmap_rotated = !identity;
  if (identity) memset(c->scene->envmap_rotation, 0, sizeof c->scene->envmap_rotation);
  return VF_OK;
}

static int parse_spot(const parse_ctx *c, const cJSON *j, const char *path, vf_point_light_desc *l) {
  char p[PATH_LEN];
  vf_vec3 d;
  float inner = 0.0f, outer = 45.0f; /* KHR_lights_punctual's defaults */
  int err = vf_scene_vec3_field(c, j, path, "direction", REQUIRED, &d);
  if (err < 0) return err;
  if (!vf_scene_unit(d, &l->direction))
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "direction"), "zero vector");
  if ((err = vf_scene_float_field(c, j, path, "inner_cone_angle", OPTIONAL, &inner)) < 0) return err;
  if ((err = vf_scene_float_field(c, j, path, "outer_cone_angle", OPTIONAL, &outer)) < 0) return err;
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
  static const char *const environment_fields[] = {"type", "file", "scale", "rotation", NULL};
  vf_scene *s = c->scene;
  char path[PATH_LEN], p[PATH_LEN];
  const char *type, *file;
  int err;
  vf_scene_join_index(path, "lights", index);
  if (!cJSON_IsObject(j)) return vf_scene_fail(c, VF_ESCENE, path, "expected an object, found %s", vf_scene_kind(j));
  if ((err = vf_scene_string_field(c, j, path, "type", REQUIRED, &type)) < 0) return err;
  if (strcmp(type, "point") == 0 || strcmp(type, "spot") == 0) {
    vf_point_light_desc *l = &s->point_lights[s->num_point_lights];
    int spot = type[0] == 's';
    if ((err = vf_scene_check_object(c, j, path, spot ? spot_fields : point_fields)) < 0) return err;
    if ((err = vf_scene_vec3_field(c, j, path, "position", REQUIRED, &l->position)) < 0) return err;
    if ((err = vf_scene_rgb_field(c, j, path, "intensity", REQUIRED, "intensity", &l->intensity)) < 0) return err;
    if (spot && (err = parse_spot(c, j, path, l)) < 0) return err;
    s->num_point_lights++;
  } else if (strcmp(type, "directional") == 0) {
    vf_directional_light_desc *l = &s->directional_lights[s->num_directional_lights];
    vf_vec3 d;
    if ((err = vf_scene_check_object(c, j, path, directional_fields)) < 0) return err;
    if ((err = vf_scene_vec3_field(c, j, path, "direction", REQUIRED, &d)) < 0) return err;
    if (!vf_scene_unit(d, &l->direction))
      return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "direction"), "zero vector");
    if ((err = vf_scene_rgb_field(c, j, path, "irradiance", REQUIRED, "irradiance", &l->irradiance)) < 0) return err;
    s->num_directional_lights++;
  } else if (strcmp(type, "background") == 0 || strcmp(type, "environment") == 0) {
    /* One distant light at infinity keeps the renderer's emission-at-miss term unambiguous. */
    if ((*num_distant)++ > 0)
      return vf_scene_fail(c, VF_ESCENE, path, "only one background or environment light is allowed");
    if (type[0] == 'b') {
      if ((err = vf_scene_check_object(c, j, path, background_fields)) < 0) return err;
      if ((err = vf_scene_rgb_field(c, j, path, "radiance", REQUIRED, "radiance", &s->background)) < 0) return err;
    } else {
      vf_vec3 scale = vf_vec3_splat(1.0f);
      if ((err = vf_scene_check_object(c, j, path, environment_fields)) < 0) return err;
      if ((err = vf_scene_rgb_field(c, j, path, "scale", OPTIONAL, "scale", &scale)) < 0) return err;
      if ((err = vf_scene_string_field(c, j, path, "file", REQUIRED, &file)) < 0) return err;
      if ((err = load_envmap(c, file, path)) < 0) return err;
      s->envmap_scale = scale;
      if ((err = parse_envmap_rotation(c, j, path)) < 0) return err;
    }
  } else {
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "type"),
                "unknown light type '%s' (expected point, spot, directional, background or environment)", type);
  }
  return VF_OK;
}

static int parse_lights(const parse_ctx *c, const cJSON *j) {
  vf_scene *s = c->scene;
  if (!cJSON_IsArray(j)) return vf_scene_fail(c, VF_ESCENE, "lights", "expected an array, found %s", vf_scene_kind(j));
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
  static const char *const fields[] = {"algorithm", "max_path_length", "radius_factor", "alpha", "seed", "sampler",
                                       "mis_beta",  "gather",        "radius",        NULL};
  vf_scene *s = c->scene;
  vf_settings *st = &s->settings;
  const cJSON *m;
  const char *algorithm;
  double d = 0.0;
  int err = vf_scene_check_object(c, j, "render", fields);
  if (err < 0) return err;
  if ((err = vf_scene_string_field(c, j, "render", "algorithm", OPTIONAL, &algorithm)) < 0) return err;
  if (err > 0) {
    if (vf_algorithm_parse(algorithm, &st->algorithm) < 0)
      return vf_scene_fail(c, VF_ESCENE, "render.algorithm", "unknown algorithm '%s' (expected vcm, upg, bpt, pt, lt, ppm, bpm, auto or auto-unbiased)",
                  algorithm);
    s->settings_given |= VF_SET_ALGORITHM;
  }
  const char *sampler;
  if ((err = vf_scene_string_field(c, j, "render", "sampler", OPTIONAL, &sampler)) < 0) return err;
  if (err > 0) {
    if (vf_sampler_parse(sampler, &st->sampler) < 0)
      return vf_scene_fail(c, VF_ESCENE, "render.sampler", "unknown sampler '%s' (expected independent or sobol)", sampler);
    s->settings_given |= VF_SET_SAMPLER;
  }
  const char *gather;
  if ((err = vf_scene_string_field(c, j, "render", "gather", OPTIONAL, &gather)) < 0) return err;
  if (err > 0) {
    if (vf_gather_parse(gather, &st->gather) < 0)
      return vf_scene_fail(c, VF_ESCENE, "render.gather", "unknown side '%s' (expected light, camera or auto)", gather);
    s->settings_given |= VF_SET_GATHER;
  }
  const char *radius;
  if ((err = vf_scene_string_field(c, j, "render", "radius", OPTIONAL, &radius)) < 0) return err;
  if (err > 0) {
    if (vf_radius_mode_parse(radius, &st->radius) < 0)
      return vf_scene_fail(c, VF_ESCENE, "render.radius", "unknown merge radius '%s' (expected global or per-pixel)", radius);
    s->settings_given |= VF_SET_RADIUS;
  }
  if ((m = cJSON_GetObjectItemCaseSensitive(j, "max_path_length")) != NULL) {
    if ((err = vf_scene_to_integer(c, m, "render.max_path_length", 1, 1000, &d)) < 0) return err;
    st->max_path_length = (int)d;
    s->settings_given |= VF_SET_MAX_PATH_LENGTH;
  }
  if ((m = cJSON_GetObjectItemCaseSensitive(j, "radius_factor")) != NULL) {
    if ((err = vf_scene_to_double(c, m, "render.radius_factor", &st->radius_factor)) < 0) return err;
    if (!(st->radius_factor > 0.0)) return vf_scene_fail(c, VF_ESCENE, "render.radius_factor", "must be > 0");
    s->settings_given |= VF_SET_RADIUS_FACTOR;
  }
  if ((m = cJSON_GetObjectItemCaseSensitive(j, "alpha")) != NULL) {
    if ((err = vf_scene_to_double(c, m, "render.alpha", &st->alpha)) < 0) return err;
    if (!(st->alpha > 0.0 && st->alpha <= 1.0)) return vf_scene_fail(c, VF_ESCENE, "render.alpha", "must be in (0, 1]");
    s->settings_given |= VF_SET_ALPHA;
  }
  if ((m = cJSON_GetObjectItemCaseSensitive(j, "mis_beta")) != NULL) {
    if ((err = vf_scene_to_double(c, m, "render.mis_beta", &st->mis_beta)) < 0) return err;
    if (!(st->mis_beta >= 1.0 && st->mis_beta <= VF_MAX_MIS_BETA))
      return vf_scene_fail(c, VF_ESCENE, "render.mis_beta", "must be in [1, %g]", VF_MAX_MIS_BETA);
    s->settings_given |= VF_SET_MIS_BETA;
  }
  if ((m = cJSON_GetObjectItemCaseSensitive(j, "seed")) != NULL) {
    /* JSON numbers are doubles: integers beyond 2^53 would silently change. */
    if ((err = vf_scene_to_integer(c, m, "render.seed", 0, 9007199254740992.0, &d)) < 0) return err;
    st->seed = (uint64_t)d;
    s->settings_given |= VF_SET_SEED;
  }
  return VF_OK;
}

/* ---- whole scene ------------------------------------------------------------------------- */

/* The files of "import" and what a scene made of them lacks: a camera, a light. */
static int parse_import(const parse_ctx *c, const cJSON *root, int camera_wanted) {
  vf_scene *s = c->scene;
  int err = vf_scene_parse_imports(c, cJSON_GetObjectItemCaseSensitive(root, "import"), s->num_materials,
                                   &camera_wanted);
  if (err < 0) return err;
  if (s->num_shapes == 0) return vf_scene_fail(c, VF_ESCENE, NULL, "the scene has no shape (its files have no triangles)");
  if (camera_wanted && (err = vf_scene_default_camera(c)) < 0) return err;
  int lights_given = cJSON_HasObjectItem(root, "lights");
  if (!has_light(s) && !lights_given && (err = vf_scene_default_light(c)) < 0) return err;
  return vf_scene_dim_emitters(c, !lights_given);
}

/* "notes": what the file a scene was converted from asks for that the conversion
 * approximated (a Mitsuba scene's, mitsuba.h), kept with the scene's own notes. */
static int parse_notes(const parse_ctx *c, const cJSON *root) {
  const cJSON *notes = cJSON_GetObjectItemCaseSensitive(root, "notes"), *n;
  char p[PATH_LEN];
  long i = 0;
  if (notes == NULL) return VF_OK;
  if (!cJSON_IsArray(notes)) return vf_scene_fail(c, VF_ESCENE, "notes", "must be an array of strings");
  cJSON_ArrayForEach(n, notes) {
    if (!cJSON_IsString(n)) return vf_scene_fail(c, VF_ESCENE, vf_scene_join_index(p, "notes", i), "must be a string");
    int err = vf_scene_note(c, "%s", n->valuestring);
    if (err < 0) return err;
    i++;
  }
  return VF_OK;
}

static int parse_root(const parse_ctx *c, const cJSON *root) {
  static const char *const fields[] = {"camera", "materials", "media", "medium", "shapes", "lights", "render",
                                       "import", "notes", NULL};
  const cJSON *m;
  int err = vf_scene_check_object(c, root, "", fields);
  if (err < 0) return err;
  if ((err = parse_notes(c, root)) < 0) return err;
  /* A scene that imports files may take all of camera, materials and shapes from them. */
  int imports = cJSON_HasObjectItem(root, "import"), need = imports ? OPTIONAL : REQUIRED;
  int has_camera = vf_scene_member(c, root, "", "camera", need, &m);
  if (has_camera < 0 || (has_camera && (err = parse_camera(c, m)) < 0)) return has_camera < 0 ? has_camera : err;
  if ((err = vf_scene_member(c, root, "", "materials", need, &m)) < 0 || (err > 0 && (err = vf_scene_parse_materials(c, m)) < 0))
    return err;
  /* Media before shapes, which name them as their interiors. */
  if ((err = vf_scene_member(c, root, "", "media", OPTIONAL, &m)) < 0 || (err > 0 && (err = vf_scene_parse_media(c, m)) < 0))
    return err;
  if ((err = vf_scene_member(c, root, "", "medium", OPTIONAL, &m)) < 0 ||
      (err > 0 && (err = vf_scene_parse_scene_medium(c, m)) < 0))
    return err;
  if ((err = vf_scene_member(c, root, "", "shapes", need, &m)) < 0 || (err > 0 && (err = vf_scene_parse_shapes(c, m)) < 0))
    return err;
  const int file_shapes = c->scene->num_shapes; /* the imports' follow */
  if ((err = vf_scene_member(c, root, "", "lights", OPTIONAL, &m)) < 0 || (err > 0 && (err = parse_lights(c, m)) < 0))
    return err;
  if (imports && (err = parse_import(c, root, !has_camera)) < 0) return err;
  /* Which shapes bound media and what lies outside each: the file's own shapes must be
   * closed where they have an interior; an imported one that is not loses it, with a note. */
  if ((err = vf_scene_resolve_interfaces(c, file_shapes)) < 0) return err;
  if ((err = vf_scene_member(c, root, "", "render", OPTIONAL, &m)) < 0 || (err > 0 && (err = parse_render(c, m)) < 0))
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
  if (n == 0)
    return vf_error_set(VF_ESCENE, "%s: line %d: JSON syntax error near the end of the line or file", label, line);
  return vf_error_set(VF_ESCENE, "%s: line %d: JSON syntax error near '%s'", label, line, near);
}

static int parse(const char *text, size_t length, const char *label, const char *base_dir,
                 const vf_scene_memfile *memfiles, int num_memfiles, struct vf_scene_files *files, vf_scene **out) {
  const char *end = NULL;
  if (memchr(text, '\0', length) != NULL) return vf_error_set(VF_ESCENE, "%s: contains a NUL byte", label);
  /* cJSON reads a NUL after the text (the length below includes it, so that
   * require_null_terminated rejects anything but whitespace after the top-level value):
   * the text is given in a copy that has one, whatever the caller's buffer holds after
   * its `length` bytes (every caller had one there; tests/fuzz/fuzz_scene.c's buffers,
   * which do not, made cJSON read past them). */
  char *terminated = malloc(length + 1);
  if (terminated == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  memcpy(terminated, text, length);
  terminated[length] = '\0';
  cJSON *root = cJSON_ParseWithLengthOpts(terminated, length + 1, &end, 1);
  if (root == NULL) {
    int err = syntax_error(label, terminated, length, end);
    free(terminated);
    return err;
  }
  free(terminated);
  int err = VF_OK;
  vf_scene *scene = calloc(1, sizeof *scene);
  if (scene == NULL) {
    err = vf_error_set(VF_ENOMEM, "out of memory");
    goto fail;
  }
  scene->medium = -1; /* vacuum until the file says otherwise */
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
