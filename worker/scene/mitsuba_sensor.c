/* Mitsuba 3 sensors, films and the integrator as a JSON scene's camera and render
 * settings (mitsuba_sensor.h). */
#include "mitsuba_sensor.h"

#include "../../common/error.h"
#include "mitsuba_medium.h"

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

#define PI 3.14159265358979323846
/* Mitsuba's max_depth -1 (no limit, paths ended by Russian roulette) as path segments:
 * light that has bounced 64 times is below 1e-6 of the first bounce in any scene whose
 * albedos stay below 0.8. docs/SCENES.md states it. */
#define UNLIMITED_DEPTH 64

static int oom(void) { return vf_error_set(VF_ENOMEM, "out of memory"); }

static int add(cJSON *o, const char *key, cJSON *v) {
  if (v == NULL || !cJSON_AddItemToObject(o, key, v)) {
    cJSON_Delete(v);
    return oom();
  }
  return VF_OK;
}

/* Mitsuba's parse_fov (src/render/sensor.cpp): the horizontal field of view in degrees. */
static int horizontal_fov(mts_ctx *c, vf_xml_node *s, double aspect, double *out) {
  double fov;
  const char *axis, *focal;
  int err, has_fov = mts_float(c, s, "fov", 0, &fov);
  if (has_fov < 0) return has_fov;
  if ((err = mts_string(c, s, "fov_axis", "x", &axis)) < 0 || (err = mts_string(c, s, "focal_length", NULL, &focal)) < 0)
    return err;
  if (has_fov && focal) return mts_fail(s, "give a fov or a focal_length, not both");
  if (!has_fov) { /* 35 mm film equivalent: the diagonal of 36 x 24 mm */
    double f = 50;
    if (focal != NULL && (sscanf(focal, "%lf", &f) != 1 || !(f > 0)))
      return mts_fail(s, "focal_length '%s' is not of the form <x>mm", focal);
    fov = 2 * atan(sqrt(36.0 * 36.0 + 24.0 * 24.0) / (2 * f)) * 180 / PI;
    axis = "diagonal";
  }
  if (strcasecmp(axis, "smaller") == 0) axis = aspect > 1 ? "y" : "x";
  else if (strcasecmp(axis, "larger") == 0) axis = aspect > 1 ? "x" : "y";
  double t = tan(0.5 * fov * PI / 180);
  if (strcasecmp(axis, "x") == 0) *out = fov;
  else if (strcasecmp(axis, "y") == 0) *out = 2 * atan(t * aspect) * 180 / PI;
  else if (strcasecmp(axis, "diagonal") == 0) *out = 2 * atan(t / sqrt(1 + 1 / (aspect * aspect))) * 180 / PI;
  else return mts_fail(s, "fov_axis '%s' is not x, y, diagonal, smaller or larger", axis);
  if (!(fov > 0 && fov < 180 && *out > 0 && *out < 180)) return mts_fail(s, "the field of view must lie in (0, 180)");
  return VF_OK;
}

static int film(mts_ctx *c, vf_xml_node *s, cJSON *cam, double *aspect) {
  long width = 768, height = 576;
  int err;
  vf_xml_node *f = NULL;
  for (int i = 0; i < s->num_children && f == NULL; i++)
    if (strcmp(s->children[i]->name, "film") == 0) f = s->children[i];
  if (f != NULL) {
    f->used = 1;
    if ((err = mts_int(c, f, "width", 768, &width)) < 0 || (err = mts_int(c, f, "height", 576, &height)) < 0) return err;
    if (width < 1 || height < 1 || width > 65536 || height > 65536)
      return mts_fail(f, "a film of %ldx%ld pixels", width, height);
    for (int i = 0; i < f->num_children; i++)
      if (strcmp(f->children[i]->name, "rfilter") == 0) {
        f->children[i]->used = 1;
        const char *type = vf_xml_attr(f->children[i], "type");
        /* vcmfarm's films are box-filtered over the pixel: Mitsuba's box of radius 0.5. */
        if ((type == NULL || strcmp(type, "box") != 0) &&
            (err = mts_note(c, f->children[i], "reconstruction filter '%s': vcmfarm films are box-filtered", type ? type : "?")) < 0)
          return err;
        for (int k = 0; k < f->children[i]->num_children; k++) f->children[i]->children[k]->used = 1;
      }
    if ((err = mts_note_unused(c, f)) < 0) return err;
  }
  const double res[2] = {(double)width, (double)height};
  *aspect = (double)width / (double)height;
  return add(cam, "resolution", cJSON_CreateDoubleArray(res, 2));
}

int mts_sensor(mts_ctx *c, vf_xml_node *s) {
  const char *type = vf_xml_attr(s, "type");
  int err;
  s->used = 1;
  if (type == NULL || (strcmp(type, "perspective") != 0 && strcmp(type, "thinlens") != 0 && strcmp(type, "orthographic") != 0))
    return mts_fail(s, "sensor type '%s' is not supported (perspective, thinlens, orthographic)", type ? type : "");
  cJSON *cam = cJSON_CreateObject();
  if (cam == NULL || !cJSON_AddItemToObject(c->root, "camera", cam)) return cJSON_Delete(cam), oom();
  double aspect = 1;
  vf_affine m;
  if ((err = film(c, s, cam, &aspect)) < 0 || (err = mts_transform(c, s, "to_world", &m)) < 0) return err;
  /* Camera space: +z looks forward, +y is up in the image. */
  vf_vec3 forward = mts_apply_vector(&m, 0, 0, 1), up = mts_apply_vector(&m, 0, 1, 0);
  /* A mirroring to_world (negative determinant) keeps Mitsuba's mapping of camera space
   * (+x to the image's left) and so mirrors the image: the image's right is -to_world (1, 0, 0),
   * which is up x forward where forward x up would be. */
  if (vf_affine_det(&m) < 0 && !cJSON_AddBoolToObject(cam, "mirror", 1)) return oom();
  if ((err = add(cam, "position", mts_vec3_json(mts_apply_point(&m, 0, 0, 0)))) < 0 ||
      (err = add(cam, "forward", mts_vec3_json(forward))) < 0 || (err = add(cam, "up", mts_vec3_json(up))) < 0)
    return err;
  double near_clip, far_clip;
  if ((err = mts_float(c, s, "near_clip", 0.01, &near_clip)) < 0 || (err = mts_float(c, s, "far_clip", 1e4, &far_clip)) < 0)
    return err;
  if (near_clip != 0.01 || far_clip != 1e4)
    if ((err = mts_note(c, s, "near_clip and far_clip are not supported: nothing is clipped")) < 0) return err;
  if (strcmp(type, "orthographic") == 0) {
    /* The view spans camera-space x in [-1, 1], y in [-1/aspect, 1/aspect]. */
    double sx = mts_column_length(&m, 0), sy = mts_column_length(&m, 1);
    if (fabs(sx - sy) > 1e-6 * sx &&
        (err = mts_note(c, s, "to_world scales x by %g and y by %g: the view's height follows the image's aspect ratio", sx, sy)) < 0)
      return err;
    if (!cJSON_AddStringToObject(cam, "type", "orthographic") || !cJSON_AddNumberToObject(cam, "width", 2 * sx)) return oom();
  } else {
    double fx = 0;
    if ((err = horizontal_fov(c, s, aspect, &fx)) < 0) return err;
    double vertical = 2 * atan(tan(0.5 * fx * PI / 180) / aspect) * 180 / PI;
    if (!cJSON_AddNumberToObject(cam, "fov", vertical)) return oom();
    if (strcmp(type, "thinlens") == 0) {
      double aperture, focus;
      if ((err = mts_float(c, s, "aperture_radius", 0, &aperture)) < 0) return err;
      if (err == 0) return mts_fail(s, "a thinlens needs an aperture_radius");
      if ((err = mts_float(c, s, "focus_distance", far_clip, &focus)) < 0) return err;
      if (!(aperture >= 0) || !(focus > 0)) return mts_fail(s, "aperture_radius must be >= 0 and focus_distance > 0");
      if (!cJSON_AddNumberToObject(cam, "aperture", aperture) || !cJSON_AddNumberToObject(cam, "focus_distance", focus))
        return oom();
    }
  }
  /* The sensor's medium is the one around it: the scene's medium, around every shape. */
  vf_xml_node *medium = mts_child(c, s, "medium", &err);
  if (err < 0) return err;
  if (medium != NULL) {
    const char *name;
    if ((err = mts_medium(c, medium, &name)) < 0) return err;
    if (name != NULL && (!cJSON_AddStringToObject(c->root, "medium", name) ||
                         (err = mts_note(c, s, "the sensor's medium '%s' is the scene's medium, around every shape", name)) < 0))
      return err < 0 ? err : oom();
  }
  for (int i = 0; i < s->num_children; i++)
    if (strcmp(s->children[i]->name, "sampler") == 0) {
      long spp;
      s->children[i]->used = 1;
      if ((err = mts_int(c, s->children[i], "sample_count", 4, &spp)) < 0) return err;
      if ((err = mts_note(c, s->children[i], "sample_count %ld: the number of iterations is the job's (--iterations)", spp)) < 0)
        return err;
      for (int j = 0; j < s->children[i]->num_children; j++) s->children[i]->children[j]->used = 1;
    }
  return mts_note_unused(c, s);
}

int mts_integrator(mts_ctx *c, vf_xml_node *e) {
  const char *type = vf_xml_attr(e, "type");
  long depth;
  int err;
  e->used = 1;
  if ((err = mts_int(c, e, "max_depth", -1, &depth)) < 0) return err;
  if (depth == 0 || depth < -1) return mts_fail(e, "max_depth %ld: vcmfarm renders paths of 1 or more segments", depth);
  /* Mitsuba's depth counts segments: 1 sees emitters, 2 adds direct light. */
  long segments = depth == -1 ? UNLIMITED_DEPTH : depth > 1000 ? 1000 : depth;
  cJSON *r = cJSON_CreateObject();
  if (r == NULL || !cJSON_AddItemToObject(c->root, "render", r) || !cJSON_AddNumberToObject(r, "max_path_length", (double)segments))
    return oom();
  if (depth == -1 && (err = mts_note(c, e, "max_depth -1 (unlimited) is %d path segments", UNLIMITED_DEPTH)) < 0) return err;
  if (depth > 1000 && (err = mts_note(c, e, "max_depth %ld is capped at 1000 path segments", depth)) < 0) return err;
  if (type != NULL && strcmp(type, "path") != 0 && strcmp(type, "volpath") != 0 && strcmp(type, "ptracer") != 0 &&
      strcmp(type, "volpathmis") != 0 &&
      (err = mts_note(c, e, "integrator '%s': rendered with vcmfarm's algorithm (the full light transport)", type)) < 0)
    return err;
  long rr;
  int hide;
  if ((err = mts_int(c, e, "rr_depth", 5, &rr)) < 0 || (err = mts_bool(c, e, "hide_emitters", 0, &hide)) < 0) return err;
  if (hide && (err = mts_note(c, e, "hide_emitters is not supported: emitters are seen")) < 0) return err;
  return mts_note_unused(c, e);
}
