/* The "materials" of a JSON scene (materials.h): the lobes, the glTF metallic-roughness
 * model with its extensions' layers, textures and alpha; docs/SCENES.md, "Materials" and
 * "Textures". Every field is type-checked and range-checked, and an error names the file,
 * the field path and the problem, as everywhere in the JSON reader (json.c). */
#include "materials.h"

#include "../../common/error.h"
#include "fields.h"
#include "parse.h"
#include "textures.h"

#include <cjson/cJSON.h>

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Albedo sums are written in decimal and summed in float: allow the rounding of that. */
#define ALBEDO_SUM_TOLERANCE 1e-5f

/* A number in [0, 1] (roughness, metallic). */
static int unit_field(const parse_ctx *c, const cJSON *obj, const char *path, const char *key, int required,
                      float *out) {
  char p[PATH_LEN];
  int has = vf_scene_float_field(c, obj, path, key, required, out);
  if (has > 0 && !(*out >= 0.0f && *out <= 1.0f))
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, key), "must be in [0, 1], found %g", *out);
  return has;
}

/* ---- textures of a material (docs/SCENES.md, "Textures") ---- */

/* Index = VF_WRAP_* (worker/scene/texture.h). */
static const char *const wrap_names[] = {"repeat", "clamp", "mirror"};

/* The member `key` of obj as a wrap mode: 1 read, 0 absent, < 0 error. */
static int wrap_field(const parse_ctx *c, const cJSON *obj, const char *path, const char *key, int *out) {
  char p[PATH_LEN];
  const char *name;
  int has = vf_scene_string_field(c, obj, path, key, OPTIONAL, &name);
  if (has <= 0) return has;
  for (int i = 0; i < 3; i++)
    if (strcmp(name, wrap_names[i]) == 0) {
      *out = i;
      return 1;
    }
  return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, key), "unknown wrap mode '%s' (expected repeat, clamp or mirror)",
                       name);
}

/* A texture field: a file name, or {"file", "wrap"} or {"file", "wrap_s", "wrap_t"};
 * repeat by default (glTF's default sampler). 1 and *slot set, 0 absent, < 0 error. */
static int texture_field(const parse_ctx *c, const cJSON *obj, const char *path, const char *key, vf_texture_slot *slot) {
  static const char *const fields[] = {"file", "wrap", "wrap_s", "wrap_t", NULL};
  char p[PATH_LEN], fp[PATH_LEN];
  const cJSON *item;
  const char *file;
  int err = vf_scene_member(c, obj, path, key, OPTIONAL, &item);
  if (err <= 0) return err;
  vf_scene_join(p, path, key);
  vf_texture_slot sl = {.wrap_s = VF_WRAP_REPEAT, .wrap_t = VF_WRAP_REPEAT};
  if (cJSON_IsString(item)) {
    file = item->valuestring;
    snprintf(fp, sizeof fp, "%s", p);
  } else if (cJSON_IsObject(item)) {
    int wrap = VF_WRAP_REPEAT;
    if ((err = vf_scene_check_object(c, item, p, fields)) < 0) return err;
    if ((err = vf_scene_string_field(c, item, p, "file", REQUIRED, &file)) < 0) return err;
    vf_scene_join(fp, p, "file");
    int has_wrap = wrap_field(c, item, p, "wrap", &wrap);
    if (has_wrap < 0) return has_wrap;
    sl.wrap_s = sl.wrap_t = wrap;
    int has_s = wrap_field(c, item, p, "wrap_s", &sl.wrap_s);
    int has_t = has_s < 0 ? has_s : wrap_field(c, item, p, "wrap_t", &sl.wrap_t);
    if (has_t < 0) return has_t;
    if (has_wrap && (has_s || has_t)) return vf_scene_fail(c, VF_ESCENE, p, "give 'wrap' or 'wrap_s'/'wrap_t', not both");
  } else {
    return vf_scene_fail(c, VF_ESCENE, p, "expected a file name or an object {\"file\": ...}, found %s", vf_scene_kind(item));
  }
  if ((err = vf_scene_texture_file(c, file, fp, &sl.texture)) < 0) return err;
  *slot = sl;
  return 1;
}

/* Float (EXR) texels a slot would read out of its range: colour and roughness-metallic
 * multiply albedos and parameters bounded by 1, so they must lie in [0, 1] (the albedo-sum
 * rule of worker/scene/material.h then still holds at every texel; 8-bit texels always do);
 * emission and the specular colour (its F0 is clamped to 1) must not be negative; alpha,
 * specular (clamped to [0, 1]) and normal maps take any finite value. Refused at
 * load rather than clamped at lookup, which stays one code path for every slot. */
static int check_texel_range(const parse_ctx *c, const char *path, int slot, const vf_texture *t) {
  if (!t->is_float || slot == VF_TEXTURE_ALPHA || slot == VF_TEXTURE_NORMAL || slot == VF_TEXTURE_SPECULAR ||
      slot == VF_TEXTURE_CLEARCOAT_NORMAL)
    return VF_OK;
  const int n = t->channels, colour = n < 3 ? 1 : 3;
  const int first = slot == VF_TEXTURE_ROUGHNESS_METALLIC && n >= 3 ? 1 : 0; /* G and B */
  const float hi = slot == VF_TEXTURE_EMISSION || slot == VF_TEXTURE_SPECULAR_COLOR ? FLT_MAX : 1.0f; /* F0 is min(.., 1) */
  const float *v = t->texels;
  for (size_t i = 0; i < (size_t)t->width * t->height; i++)
    for (int k = first; k < colour; k++)
      if (!(v[i * (size_t)n + (size_t)k] >= 0.0f && v[i * (size_t)n + (size_t)k] <= hi))
        return vf_scene_fail(c, VF_ESCENE, path, "texel (%zu, %zu) of '%s' is %g in channel %d, outside %s",
                             i % t->width, i / t->width, t->name, v[i * (size_t)n + (size_t)k], k,
                             hi == 1.0f ? "[0, 1] (it multiplies a value bounded by 1)" : "[0, inf)");
  return VF_OK;
}

/* Texture field `key` into slot `slot` of m, its texels checked for the slot. */
static int slot_field(const parse_ctx *c, const cJSON *j, const char *path, const char *key, int slot, vf_material *m) {
  char p[PATH_LEN];
  int has = texture_field(c, j, path, key, &m->textures[slot]);
  if (has <= 0) return has;
  int err = check_texel_range(c, vf_scene_join(p, path, key), slot, &c->scene->textures[m->textures[slot].texture - 1]);
  return err < 0 ? err : 1;
}

/* alpha, alpha_cutoff and alpha_channel, once the alpha texture (if any) is known.
 * alpha_channel indexes the RGBA the lookup returns: by default the texture's alpha when
 * it has one (2 or 4 channels), else its first channel (grey, or red). */
static int parse_alpha(const parse_ctx *c, const cJSON *j, const char *path, vf_material *m) {
  char p[PATH_LEN];
  const int tex = m->textures[VF_TEXTURE_ALPHA].texture;
  const vf_texture *t = tex ? &c->scene->textures[tex - 1] : NULL;
  m->alpha = 1.0f;
  int has_alpha = unit_field(c, j, path, "alpha", OPTIONAL, &m->alpha);
  if (has_alpha < 0) return has_alpha;
  m->alpha_cutoff = t != NULL || has_alpha ? 0.5f : 0.0f; /* glTF's alphaCutoff default */
  int err = unit_field(c, j, path, "alpha_cutoff", OPTIONAL, &m->alpha_cutoff);
  if (err < 0) return err;
  if (err > 0 && t == NULL && !has_alpha)
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "alpha_cutoff"), "needs 'alpha_texture' or 'alpha'");
  const cJSON *item;
  if ((err = vf_scene_member(c, j, path, "alpha_channel", OPTIONAL, &item)) < 0) return err;
  m->alpha_channel = t != NULL && (t->channels == 2 || t->channels == 4) ? 3 : 0;
  if (err == 0) return VF_OK;
  vf_scene_join(p, path, "alpha_channel");
  double channel;
  if (t == NULL) return vf_scene_fail(c, VF_ESCENE, p, "needs 'alpha_texture'");
  if ((err = vf_scene_to_integer(c, item, p, 0, 3, &channel)) < 0) return err;
  if (channel == 3 && t->channels != 2 && t->channels != 4)
    return vf_scene_fail(c, VF_ESCENE, p, "'%s' has no alpha channel (%d channels)", t->name, t->channels);
  m->alpha_channel = (int)channel;
  return VF_OK;
}

/* The texture fields both material models share, and their parameters. */
static int parse_shared_textures(const parse_ctx *c, const cJSON *j, const char *path, vf_material *m) {
  char p[PATH_LEN];
  int err;
  if ((err = slot_field(c, j, path, "emission_texture", VF_TEXTURE_EMISSION, m)) < 0) return err;
  if ((err = slot_field(c, j, path, "alpha_texture", VF_TEXTURE_ALPHA, m)) < 0) return err;
  if ((err = parse_alpha(c, j, path, m)) < 0) return err;
  int has_normal = slot_field(c, j, path, "normal_texture", VF_TEXTURE_NORMAL, m);
  if (has_normal < 0) return has_normal;
  m->normal_scale = 1.0f;
  if ((err = vf_scene_float_field(c, j, path, "normal_scale", OPTIONAL, &m->normal_scale)) < 0) return err;
  if (err > 0 && !has_normal)
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "normal_scale"), "needs 'normal_texture'");
  return VF_OK;
}

/* KHR_materials_specular and KHR_materials_ior of the glTF model: "specular" (specularFactor,
 * [0, 1], default 1), "specular_color" (specularColorFactor, >= 0, default 1), "ior"
 * (>= 0, default 1.5) and their textures; any of them sets specular_set with
 * specular_f0 = ((ior - 1) / (ior + 1))^2 specular_color (material.h). */
static int parse_gltf_specular(const parse_ctx *c, const cJSON *j, const char *path, vf_material *m) {
  char p[PATH_LEN];
  float specular = 1.0f, ior = 1.5f;
  vf_vec3 colour = vf_vec3_splat(1.0f);
  int has[5];
  if ((has[0] = unit_field(c, j, path, "specular", OPTIONAL, &specular)) < 0) return has[0];
  if ((has[1] = vf_scene_rgb_field(c, j, path, "specular_color", OPTIONAL, "colour", &colour)) < 0) return has[1];
  if ((has[2] = vf_scene_float_field(c, j, path, "ior", OPTIONAL, &ior)) < 0) return has[2];
  if (has[2] && !(ior >= 0.0f))
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "ior"), "must be >= 0, found %g", ior);
  if ((has[3] = slot_field(c, j, path, "specular_texture", VF_TEXTURE_SPECULAR, m)) < 0) return has[3];
  if ((has[4] = slot_field(c, j, path, "specular_color_texture", VF_TEXTURE_SPECULAR_COLOR, m)) < 0) return has[4];
  if (!(has[0] || has[1] || has[2] || has[3] || has[4])) return VF_OK;
  double r = ((double)ior - 1.0) / ((double)ior + 1.0);
  m->specular_set = 1;
  m->specular = specular;
  m->specular_f0 = vf_scale(colour, (float)(r * r));
  return VF_OK;
}

/* KHR_materials_clearcoat and KHR_materials_sheen of the glTF model (material.h):
 * "clearcoat" and "clearcoat_roughness" in [0, 1] (default 0), "clearcoat_texture" (R
 * multiplies clearcoat), "clearcoat_roughness_texture" (G), "clearcoat_normal_texture" with
 * "clearcoat_normal_scale" (default 1); "sheen_color" [r, g, b] in [0, 1] (default 0),
 * "sheen_roughness" in [0, 1] (default 0), "sheen_color_texture" (RGB, sRGB),
 * "sheen_roughness_texture" (A). A coat's or sheen's other fields need its non-zero weight:
 * glTF's factor 0 disables its layer, and a field that changes nothing is a typo here. */
static int parse_gltf_layers(const parse_ctx *c, const cJSON *j, const char *path, vf_material *m) {
  char p[PATH_LEN];
  int err, has_coat, has_sheen;
  if ((has_coat = unit_field(c, j, path, "clearcoat", OPTIONAL, &m->clearcoat)) < 0) return has_coat;
  m->clearcoat_normal_scale = 1.0f;
  static const char *const coat_fields[] = {"clearcoat_roughness", "clearcoat_texture", "clearcoat_roughness_texture",
                                            "clearcoat_normal_texture", "clearcoat_normal_scale"};
  static const char *const sheen_fields[] = {"sheen_roughness", "sheen_color_texture", "sheen_roughness_texture"};
  for (size_t i = 0; i < sizeof coat_fields / sizeof coat_fields[0]; i++)
    if (cJSON_GetObjectItemCaseSensitive(j, coat_fields[i]) != NULL && !(m->clearcoat > 0.0f))
      return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, coat_fields[i]), "needs a non-zero 'clearcoat'%s",
                           has_coat ? " (0 is no coat)" : "");
  if ((err = unit_field(c, j, path, "clearcoat_roughness", OPTIONAL, &m->clearcoat_roughness)) < 0) return err;
  if ((err = slot_field(c, j, path, "clearcoat_texture", VF_TEXTURE_CLEARCOAT, m)) < 0) return err;
  if ((err = slot_field(c, j, path, "clearcoat_roughness_texture", VF_TEXTURE_CLEARCOAT_ROUGHNESS, m)) < 0) return err;
  int has_normal = slot_field(c, j, path, "clearcoat_normal_texture", VF_TEXTURE_CLEARCOAT_NORMAL, m);
  if (has_normal < 0) return has_normal;
  if ((err = vf_scene_float_field(c, j, path, "clearcoat_normal_scale", OPTIONAL, &m->clearcoat_normal_scale)) < 0)
    return err;
  if (err > 0 && !has_normal)
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "clearcoat_normal_scale"), "needs 'clearcoat_normal_texture'");
  if ((has_sheen = vf_scene_rgb_field(c, j, path, "sheen_color", OPTIONAL, "colour", &m->sheen_color)) < 0)
    return has_sheen;
  if (vf_max_component(m->sheen_color) > 1.0f)
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "sheen_color"), "exceeds 1 in a channel");
  for (size_t i = 0; i < sizeof sheen_fields / sizeof sheen_fields[0]; i++)
    if (cJSON_GetObjectItemCaseSensitive(j, sheen_fields[i]) != NULL && vf_is_zero(m->sheen_color))
      return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, sheen_fields[i]), "needs a non-zero 'sheen_color'%s",
                           has_sheen ? " (black is no sheen)" : "");
  if ((err = unit_field(c, j, path, "sheen_roughness", OPTIONAL, &m->sheen_roughness)) < 0) return err;
  if ((err = slot_field(c, j, path, "sheen_color_texture", VF_TEXTURE_SHEEN_COLOR, m)) < 0) return err;
  if ((err = slot_field(c, j, path, "sheen_roughness_texture", VF_TEXTURE_SHEEN_ROUGHNESS, m)) < 0) return err;
  return VF_OK;
}

/* The glTF 2.0 metallic-roughness model. A factor whose texture is given defaults to 1,
 * as glTF's baseColorFactor, metallicFactor and roughnessFactor do. */
static int parse_gltf_material(const parse_ctx *c, const cJSON *j, const char *path, vf_material *m) {
  char p[PATH_LEN];
  int err, has_color, has_rm;
  if ((has_color = slot_field(c, j, path, "base_color_texture", VF_TEXTURE_COLOR, m)) < 0) return has_color;
  if ((has_rm = slot_field(c, j, path, "roughness_metallic_texture", VF_TEXTURE_ROUGHNESS_METALLIC, m)) < 0) return has_rm;
  m->base_color = vf_vec3_splat(1.0f);
  m->metallic = m->roughness = 1.0f;
  if ((err = vf_scene_rgb_field(c, j, path, "base_color", has_color ? OPTIONAL : REQUIRED, "colour", &m->base_color)) < 0 ||
      (err = unit_field(c, j, path, "metallic", has_rm ? OPTIONAL : REQUIRED, &m->metallic)) < 0 ||
      (err = unit_field(c, j, path, "roughness", has_rm ? OPTIONAL : REQUIRED, &m->roughness)) < 0)
    return err;
  if (vf_max_component(m->base_color) > 1.0f)
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "base_color"), "exceeds 1 in a channel");
  if ((err = parse_gltf_specular(c, j, path, m)) < 0) return err;
  if ((err = parse_gltf_layers(c, j, path, m)) < 0) return err;
  return parse_shared_textures(c, j, path, m);
}

/* The classic lobes. diffuse_texture multiplies `diffuse`, 1 when absent. */
static int parse_lobes(const parse_ctx *c, const cJSON *j, const char *path, vf_material *m) {
  char p[PATH_LEN];
  int err;
  int has_diffuse = vf_scene_rgb_field(c, j, path, "diffuse", OPTIONAL, "albedo", &m->diffuse);
  if (has_diffuse < 0) return has_diffuse;
  int has_texture = slot_field(c, j, path, "diffuse_texture", VF_TEXTURE_COLOR, m);
  if (has_texture < 0) return has_texture;
  if (has_texture && !has_diffuse) m->diffuse = vf_vec3_splat(1.0f);
  if (has_texture && vf_is_zero(m->diffuse))
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "diffuse_texture"),
                         "multiplies 'diffuse', which is zero: the material has no diffuse lobe");
  if ((err = vf_scene_rgb_field(c, j, path, "glossy", OPTIONAL, "albedo", &m->glossy)) < 0) return err;
  if ((err = vf_scene_rgb_field(c, j, path, "mirror", OPTIONAL, "albedo", &m->mirror)) < 0) return err;
  if ((err = vf_scene_rgb_field(c, j, path, "dielectric", OPTIONAL, "albedo", &m->dielectric)) < 0) return err;
  if ((err = vf_scene_rgb_field(c, j, path, "conductor", OPTIONAL, "albedo", &m->conductor)) < 0) return err;
  int has = vf_scene_float_field(c, j, path, "exponent", vf_is_zero(m->glossy) ? OPTIONAL : REQUIRED, &m->phong_exponent);
  if (has < 0) return has;
  if (has && !(m->phong_exponent >= 1.0f))
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "exponent"), "must be >= 1, found %g", m->phong_exponent);
  has = vf_scene_float_field(c, j, path, "ior", vf_is_zero(m->dielectric) ? OPTIONAL : REQUIRED, &m->ior);
  if (has < 0) return has;
  if (has && !(m->ior > 0.0f))
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "ior"), "must be > 0, found %g", m->ior);
  /* The conductor's complex index of refraction eta + i k, per channel. */
  int has_eta = vf_scene_rgb_field(c, j, path, "eta", OPTIONAL, "index of refraction", &m->conductor_eta);
  int has_k = has_eta < 0 ? has_eta
                          : vf_scene_rgb_field(c, j, path, "k", OPTIONAL, "extinction coefficient", &m->conductor_k);
  if (has_k < 0) return has_k;
  if (has_eta != has_k || (has_eta && vf_is_zero(m->conductor)))
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, has_eta ? "eta" : "k"), "needs 'eta', 'k' and 'conductor'");
  if ((has = unit_field(c, j, path, "roughness", OPTIONAL, &m->roughness)) < 0) return has;
  if (has && vf_is_zero(m->conductor) && vf_is_zero(m->dielectric))
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(p, path, "roughness"), "needs a 'conductor' or 'dielectric' lobe");
  vf_vec3 sum = vf_add(vf_add(vf_add(m->diffuse, m->glossy), vf_add(m->mirror, m->dielectric)), m->conductor);
  for (int i = 0; i < 3; i++)
    if (vf_vec3_get(sum, i) > 1.0f + ALBEDO_SUM_TOLERANCE)
      return vf_scene_fail(c, VF_ESCENE, path, "albedo sum of the lobes exceeds 1 (channel %c: %g)%s", "rgb"[i],
                           vf_vec3_get(sum, i),
                           has_texture && !has_diffuse ? "; 'diffuse' is 1 by default with a 'diffuse_texture'" : "");
  return parse_shared_textures(c, j, path, m);
}

static int parse_material(const parse_ctx *c, const cJSON *j, vf_material *m) {
#define TEXTURE_FIELDS "emission_texture", "alpha_texture", "alpha", "alpha_cutoff", "alpha_channel", "normal_texture", "normal_scale"
  static const char *const fields[] = {"diffuse", "glossy", "exponent",  "mirror", "dielectric", "ior",
                                       "conductor", "eta",  "k", "roughness", "diffuse_texture", TEXTURE_FIELDS, NULL};
  /* The glTF 2.0 metallic-roughness model has these fields and none of the lobes'. */
  static const char *const gltf_fields[] = {"base_color", "metallic", "roughness", "base_color_texture",
                                            "roughness_metallic_texture", "specular", "specular_color", "ior",
                                            "specular_texture", "specular_color_texture", "clearcoat",
                                            "clearcoat_roughness", "clearcoat_texture", "clearcoat_roughness_texture",
                                            "clearcoat_normal_texture", "clearcoat_normal_scale", "sheen_color",
                                            "sheen_roughness", "sheen_color_texture", "sheen_roughness_texture",
                                            TEXTURE_FIELDS, NULL};
#undef TEXTURE_FIELDS
  char path[PATH_LEN];
  vf_scene_join(path, "materials", j->string);
  /* Fields only the glTF model has ("roughness" both have) tell the models apart. */
  static const char *const gltf_markers[] = {"base_color", "metallic", "base_color_texture", "roughness_metallic_texture"};
  int gltf = 0;
  for (size_t i = 0; i < sizeof gltf_markers / sizeof gltf_markers[0]; i++)
    gltf |= cJSON_GetObjectItemCaseSensitive(j, gltf_markers[i]) != NULL;
  int err = vf_scene_check_object(c, j, path, gltf ? gltf_fields : fields);
  if (err < 0) return err;
  if (j->string[0] == '\0' || strlen(j->string) >= sizeof m->name)
    return vf_scene_fail(c, VF_ESCENE, path, "a material name must have 1 to %zu bytes", sizeof m->name - 1);
  memset(m, 0, sizeof *m);
  snprintf(m->name, sizeof m->name, "%s", j->string);
  /* Unused parameters get harmless values (1), so no consumer ever divides by zero. */
  m->phong_exponent = m->ior = 1.0f;
  m->gltf = gltf;
  return gltf ? parse_gltf_material(c, j, path, m) : parse_lobes(c, j, path, m);
}

int vf_scene_parse_materials(const parse_ctx *c, const cJSON *j) {
  vf_scene *s = c->scene;
  int err = vf_scene_check_object(c, j, "materials", NULL);
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
