/* A scene's background replaced after loading: background.h. */
#include "background.h"

#include "../../common/error.h"
#include "../../common/image.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* "R,G,B" or "V" into *out: 1 when spec is such a colour, 0 when it is not one at all (a
 * file name), < 0 when it looks like one but is malformed or out of range. */
static int parse_colour(const char *spec, vf_vec3 *out) {
  double v[3];
  int n = 0;
  const char *p = spec;
  if (!(*p == '.' || (*p >= '0' && *p <= '9') || *p == '-' || *p == '+')) return 0;
  while (n < 3) {
    char *end;
    v[n++] = strtod(p, &end);
    if (end == p) return vf_error_set(VF_EUSAGE, "--background: '%s' is neither R,G,B, a grey value nor an .exr file", spec);
    p = end;
    if (*p == '\0') break;
    if (*p != ',') return vf_error_set(VF_EUSAGE, "--background: '%s' is neither R,G,B, a grey value nor an .exr file", spec);
    p++;
  }
  if (*p != '\0' || n == 2)
    return vf_error_set(VF_EUSAGE, "--background: '%s': give one value (grey) or three (R,G,B)", spec);
  if (n == 1) v[1] = v[2] = v[0];
  for (int k = 0; k < 3; k++)
    if (!(v[k] >= 0.0 && v[k] <= FLT_MAX))
      return vf_error_set(VF_EUSAGE, "--background: '%s': radiances must be finite and >= 0", spec);
  *out = vf_vec3_make((float)v[0], (float)v[1], (float)v[2]);
  return 1;
}

int vf_scene_set_background(vf_scene *scene, const char *spec) {
  vf_vec3 colour;
  int is_colour = parse_colour(spec, &colour);
  if (is_colour < 0) return is_colour;
  if (is_colour) {
    vf_image_destroy(&scene->envmap);
    memset(&scene->envmap, 0, sizeof scene->envmap);
    scene->envmap_scale = vf_vec3_splat(0.0f);
    scene->background = colour;
    vf_scene_hash(scene);
    return VF_OK;
  }
  size_t n = strlen(spec);
  if (!(n > 4 && strcasecmp(spec + n - 4, ".exr") == 0))
    return vf_error_set(VF_EUSAGE, "--background: '%s' is neither R,G,B, a grey value nor an .exr file", spec);
  vf_image img;
  int err = vf_image_read_exr(spec, &img);
  if (err != VF_OK) return err;
  for (long i = 0; i < 3L * img.width * img.height; i++)
    if (!(img.rgb[i] >= 0.0f && img.rgb[i] <= FLT_MAX)) {
      long x = (i / 3) % img.width, y = (i / 3) / img.width;
      vf_image_destroy(&img);
      return vf_error_set(VF_ESCENE, "--background: pixel (%ld, %ld) of '%s' is negative or not finite", x, y, spec);
    }
  vf_image_destroy(&scene->envmap);
  scene->envmap = img;
  scene->envmap_scale = vf_vec3_splat(1.0f);
  scene->background = vf_vec3_splat(0.0f);
  vf_scene_hash(scene);
  return VF_OK;
}
