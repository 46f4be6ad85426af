/* Materials of imported files: Assimp's aiMaterial -> vf_material (docs/SCENES.md, "glTF
 * materials" and "OBJ materials"). A glTF file's materials become the glTF
 * metallic-roughness model (or a rough dielectric when they transmit); every other
 * format's, an OBJ's .mtl above all, the classic lobes: Kd diffuse, Ks and Ns a Phong
 * lobe, glass a dielectric. Whatever a material asks for that has no counterpart is noted
 * once (vf_scene_note), never dropped silently. */
#include "import.h"

#include "../../common/error.h"
#include "assimp_api.h"
#include "textures.h"

#include <assimp/GltfMaterial.h>
#include <assimp/ObjMaterial.h>
#include <assimp/material.h>
#include <assimp/scene.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* glTF's default index of refraction (KHR_materials_ior), also for OBJ glass without Ni. */
#define DEFAULT_IOR 1.5f

static float get_float(const struct aiMaterial *m, const char *key, unsigned type, unsigned index, float fallback) {
  ai_real v;
  unsigned n = 1;
  return vf_assimp()->aiGetMaterialFloatArray(m, key, type, index, &v, &n) == aiReturn_SUCCESS && n == 1 && isfinite(v)
             ? (float)v : fallback;
}

static int get_color(const struct aiMaterial *m, const char *key, unsigned type, unsigned index, struct aiColor4D *out) {
  return vf_assimp()->aiGetMaterialColor(m, key, type, index, out) == aiReturn_SUCCESS && isfinite(out->r) && isfinite(out->g) &&
         isfinite(out->b) && isfinite(out->a);
}

static vf_vec3 rgb_of(const struct aiColor4D *c) { return vf_vec3_make(c->r, c->g, c->b); }

static vf_vec3 clamp01(vf_vec3 v) {
  return vf_vec3_make(fminf(fmaxf(v.x, 0.0f), 1.0f), fminf(fmaxf(v.y, 0.0f), 1.0f), fminf(fmaxf(v.z, 0.0f), 1.0f));
}

static int wrap_of(int mode) {
  return mode == aiTextureMapMode_Clamp || mode == aiTextureMapMode_Decal ? VF_WRAP_CLAMP
         : mode == aiTextureMapMode_Mirror                                ? VF_WRAP_MIRROR
                                                                          : VF_WRAP_REPEAT;
}

/* ---- textures ------------------------------------------------------------------------------ */

static int hex_digit(char h) {
  return h >= '0' && h <= '9' ? h - '0' : h >= 'a' && h <= 'f' ? h - 'a' + 10 : h >= 'A' && h <= 'F' ? h - 'A' + 10 : -1;
}

/* A glTF file names its images by URI, whose reserved characters are percent-encoded
 * (glTF 2.0, "URIs"; RFC 3986 section 2.1: Blender writes "wood%20floor.png"); Assimp
 * hands the URI over as it is. Decoded in place; a '%' that starts no escape is kept, and
 * an escape of a NUL (no file name holds one) is refused. */
static int uri_decode(const parse_ctx *c, const char *where, char *uri) {
  char *out = uri;
  for (const char *in = uri; *in; in++) {
    int hi = in[0] == '%' ? hex_digit(in[1]) : -1, lo = hi >= 0 ? hex_digit(in[2]) : -1;
    if (lo < 0) {
      *out++ = *in;
      continue;
    }
    if (hi == 0 && lo == 0) return vf_scene_fail(c, VF_ETEXTURE, where, "image URI '%s' encodes a NUL byte", uri);
    *out++ = (char)(hi * 16 + lo);
    in += 2;
  }
  *out = '\0';
  return 0;
}

/* The texture of `type` (slot 0) into *slot: an image embedded in the file ("*N", glTF
 * binaries and data URIs) by its bytes, else a file relative to the model's directory (so
 * farm jobs ship it). 0: the material has none; 1: loaded; < 0: error. */
static int load_texture(const parse_ctx *c, const vf_import_file *f, const char *where, const struct aiMaterial *am,
                        enum aiTextureType type, vf_texture_slot *slot) {
  struct aiString path;
  unsigned uv = 0;
  if (vf_assimp()->aiGetMaterialTexture(am, type, 0, &path, NULL, &uv, NULL, NULL, NULL, NULL) != aiReturn_SUCCESS ||
      path.length == 0)
    return 0;
  int err, index = 0;
  /* A glTF file's uv sets and transforms come from its JSON (gltf_texture_refs). */
  if (!f->gltf_file && uv != 0 &&
      (err = vf_scene_note(c, "%s: %s: textures read at uv set %u are read at set 0", f->file, where, uv)) < 0)
    return err;
  struct aiUVTransform tr;
  unsigned n = sizeof tr / sizeof(ai_real);
  if (!f->gltf_file && vf_assimp()->aiGetMaterialFloatArray(am, _AI_MATKEY_UVTRANSFORM_BASE, type, 0, (ai_real *)&tr, &n) == aiReturn_SUCCESS &&
      (err = vf_scene_note(c, "%s: texture transforms are ignored: textures are read at the mesh's own coordinates",
                           f->file)) < 0)
    return err;
  if (path.data[0] == '*') {
    char *end, name[PATH_LEN + 16];
    unsigned long k = strtoul(path.data + 1, &end, 10);
    if (*end != '\0' || k >= f->ai->mNumTextures)
      return vf_scene_fail(c, VF_EMESH, where, "names embedded texture '%s', which the file lacks", path.data);
    const struct aiTexture *t = f->ai->mTextures[k];
    if (t->mHeight != 0) /* texels Assimp decoded itself: no encoded file to hash and decode */
      return vf_scene_fail(c, VF_ETEXTURE, where, "embedded texture %lu is not an encoded image", k);
    snprintf(name, sizeof name, "%s#%lu", f->file, k);
    if ((err = vf_scene_texture_bytes(c, name, t->pcData, t->mWidth, where, &index)) < 0) return err;
  } else {
    char file[2 * sizeof path.data + 8];
    if (f->gltf_file && (err = uri_decode(c, where, path.data)) < 0) return err;
    for (char *p = path.data; *p; p++)
      if (*p == '\\') *p = '/'; /* .mtl files written on Windows */
    if (path.data[0] == '/' || f->dir[0] == '\0') snprintf(file, sizeof file, "%s", path.data);
    else snprintf(file, sizeof file, "%s/%s", f->dir, path.data);
    if ((err = vf_scene_texture_file(c, file, where, &index)) < 0) return err;
  }
  int u = aiTextureMapMode_Wrap, v = aiTextureMapMode_Wrap;
  unsigned one = 1;
  vf_assimp()->aiGetMaterialIntegerArray(am, _AI_MATKEY_MAPPINGMODE_U_BASE, type, 0, &u, &one);
  one = 1;
  vf_assimp()->aiGetMaterialIntegerArray(am, _AI_MATKEY_MAPPINGMODE_V_BASE, type, 0, &v, &one);
  slot->texture = index;
  slot->wrap_s = wrap_of(u);
  slot->wrap_t = wrap_of(v);
  return 1;
}

/* Texture types a format's reader fills that vcmfarm does not use: noted when present. */
static int note_unused_textures(const parse_ctx *c, const vf_import_file *f, const struct aiMaterial *am,
                                const enum aiTextureType *types, const char *const *names, int count) {
  for (int i = 0; i < count; i++)
    if (vf_assimp()->aiGetMaterialTextureCount(am, types[i]) > 0) {
      int err = vf_scene_note(c, "%s: %s textures are not supported: ignored", f->file, names[i]);
      if (err < 0) return err;
    }
  return VF_OK;
}

/* ---- glTF 2.0 ------------------------------------------------------------------------------- */

static int gltf_alpha(const parse_ctx *c, const vf_import_file *f, const struct aiMaterial *am, vf_material *m) {
  struct aiString mode;
  if (vf_assimp()->aiGetMaterialString(am, AI_MATKEY_GLTF_ALPHAMODE, &mode) != aiReturn_SUCCESS || strcmp(mode.data, "OPAQUE") == 0)
    return VF_OK;
  if (strcmp(mode.data, "BLEND") == 0) {
    int err = vf_scene_note(c, "%s: alpha mode BLEND is rendered as MASK with cutoff 0.5 (no partial coverage)", f->file);
    if (err < 0) return err;
    m->alpha_cutoff = 0.5f;
  } else {
    m->alpha_cutoff = fminf(fmaxf(get_float(am, AI_MATKEY_GLTF_ALPHACUTOFF, 0.5f), 0.0f), 1.0f);
  }
  /* Coverage is the base colour's alpha times its texture's alpha (glTF 2.0, 3.9.2). */
  m->textures[VF_TEXTURE_ALPHA] = m->textures[VF_TEXTURE_COLOR];
  m->alpha_channel = 3;
  return VF_OK;
}

/* A glTF sampler's wrap code (glTF 2.0, "samplers") as VF_WRAP_*. */
static int gltf_wrap(int code) {
  return code == 33071 ? VF_WRAP_CLAMP : code == 33648 ? VF_WRAP_MIRROR : VF_WRAP_REPEAT;
}

/* A texture Assimp 5.2.5 does not read (KHR_materials_specular's) from the file's JSON. */
static int gltf_extra_texture(const parse_ctx *c, const vf_import_file *f, const char *where,
                              const vf_gltf_texture_ref *ref, vf_texture_slot *slot) {
  if (ref->image < 0) return 0;
  const char *uri;
  void *bytes;
  size_t size;
  int err = vf_gltf_image(c, &f->gltf, f->dir, ref->image, where, &uri, &bytes, &size), index = 0;
  if (err < 0) return err;
  if (uri != NULL) {
    char decoded[PATH_LEN], file[2 * PATH_LEN + 8];
    snprintf(decoded, sizeof decoded, "%s", uri);
    if ((err = uri_decode(c, where, decoded)) < 0) return err;
    if (decoded[0] == '/' || f->dir[0] == '\0') snprintf(file, sizeof file, "%s", decoded);
    else snprintf(file, sizeof file, "%s/%s", f->dir, decoded);
    if ((err = vf_scene_texture_file(c, file, where, &index)) < 0) return err;
  } else {
    char name[PATH_LEN + 24];
    snprintf(name, sizeof name, "%s#image%d", f->file, ref->image);
    err = vf_scene_texture_bytes(c, name, bytes, size, where, &index);
    free(bytes);
    if (err < 0) return err;
  }
  const cJSON *sampler = cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(f->gltf.root, "samplers"), ref->sampler);
  const cJSON *ws = cJSON_GetObjectItemCaseSensitive(sampler, "wrapS"), *wt = cJSON_GetObjectItemCaseSensitive(sampler, "wrapT");
  slot->texture = index;
  slot->wrap_s = gltf_wrap(cJSON_IsNumber(ws) ? ws->valueint : 10497);
  slot->wrap_t = gltf_wrap(cJSON_IsNumber(wt) ? wt->valueint : 10497);
  return 1;
}

/* Each texture's uv set (TEXCOORD_n) and KHR_texture_transform, from the file's JSON. A
 * set above 1 is read at set 0, noted. */
static int gltf_texture_refs(const parse_ctx *c, const vf_import_file *f, const vf_gltf_material *g, vf_material *m) {
  for (int k = 0; k < VF_TEXTURE_SLOTS; k++) {
    vf_texture_slot *ts = &m->textures[k];
    const vf_gltf_texture_ref *ref = &g->textures[k == VF_TEXTURE_ALPHA ? VF_TEXTURE_COLOR : k]; /* glTF: the alpha is the base colour's */
    if (ts->texture == 0 || ref->image < 0) continue;
    ts->uv_set = ref->uv_set == 1 ? 1 : 0;
    if (ref->uv_set > 1) {
      int err = vf_scene_note(c, "%s: textures of uv set %d are read at set 0 (sets 0 and 1 are read)", f->file,
                              ref->uv_set);
      if (err < 0) return err;
    }
    ts->has_transform = ref->has_transform;
    memcpy(ts->transform, ref->transform, sizeof ts->transform);
  }
  return VF_OK;
}

/* KHR_materials_specular and KHR_materials_ior on the opaque model: the dielectric's F0
 * colour ((ior - 1) / (ior + 1))^2 specularColorFactor and its specularFactor (material.h);
 * left unset (F0 0.04, F90 1) when the file gives neither or only their defaults. */
static int gltf_specular(const parse_ctx *c, const vf_import_file *f, const char *where, const vf_gltf_material *g,
                         vf_material *m) {
  double ior = g->ior >= 0.0f ? g->ior : 1.5, r = (ior - 1.0) / (ior + 1.0), f0 = r * r;
  if (!g->has_specular && ior == 1.5) return VF_OK;
  m->specular_set = 1;
  m->specular = fminf(fmaxf(g->specular, 0.0f), 1.0f);
  m->specular_f0 = vf_vec3_make((float)(f0 * fmax(g->specular_color[0], 0.0)), (float)(f0 * fmax(g->specular_color[1], 0.0)),
                                (float)(f0 * fmax(g->specular_color[2], 0.0)));
  int err;
  if ((err = gltf_extra_texture(c, f, where, &g->textures[VF_TEXTURE_SPECULAR], &m->textures[VF_TEXTURE_SPECULAR])) < 0 ||
      (err = gltf_extra_texture(c, f, where, &g->textures[VF_TEXTURE_SPECULAR_COLOR],
                                &m->textures[VF_TEXTURE_SPECULAR_COLOR])) < 0)
    return err;
  return VF_OK;
}

/* KHR_materials_clearcoat and KHR_materials_sheen on the opaque model (material.h): the
 * factors clamped to [0, 1] and their textures, from the file's JSON. */
static int gltf_layers(const parse_ctx *c, const vf_import_file *f, const char *where, const vf_gltf_material *g,
                       vf_material *m) {
  static const int slots[] = {VF_TEXTURE_CLEARCOAT, VF_TEXTURE_CLEARCOAT_ROUGHNESS, VF_TEXTURE_CLEARCOAT_NORMAL,
                              VF_TEXTURE_SHEEN_COLOR, VF_TEXTURE_SHEEN_ROUGHNESS};
  m->clearcoat = fminf(fmaxf(g->clearcoat, 0.0f), 1.0f);
  m->clearcoat_roughness = fminf(fmaxf(g->clearcoat_roughness, 0.0f), 1.0f);
  m->clearcoat_normal_scale = g->clearcoat_normal_scale;
  m->sheen_color = clamp01(vf_vec3_make(g->sheen_color[0], g->sheen_color[1], g->sheen_color[2]));
  m->sheen_roughness = fminf(fmaxf(g->sheen_roughness, 0.0f), 1.0f);
  for (size_t k = 0; k < sizeof slots / sizeof slots[0]; k++) {
    int coat_slot = slots[k] <= VF_TEXTURE_CLEARCOAT_NORMAL;
    if (coat_slot ? m->clearcoat == 0.0f : vf_is_zero(m->sheen_color)) continue; /* the layer is disabled */
    int err = gltf_extra_texture(c, f, where, &g->textures[slots[k]], &m->textures[slots[k]]);
    if (err < 0) return err;
  }
  return VF_OK;
}

/* KHR_materials_volume: the attenuation of a transmissive, not thin-walled material as an
 * absorbing interior of its meshes, sigma_a = -ln(attenuationColor) / attenuationDistance
 * per channel (Beer-Lambert: light that travels attenuationDistance keeps
 * attenuationColor of itself); none for a colour of 1 or an infinite distance. */
static int gltf_volume(const parse_ctx *c, const vf_import_file *f, const vf_gltf_material *g, vf_material *m,
                       int *interior) {
  int err;
  if (!g->has_volume) return VF_OK;
  if (m->gltf)
    return vf_scene_note(c, "%s: material '%s': KHR_materials_volume without transmission: ignored", f->file, m->name);
  if (g->has_thickness_texture &&
      (err = vf_scene_note(c, "%s: thickness textures (KHR_materials_volume) are not supported: ignored", f->file)) < 0)
    return err;
  if (!(g->thickness > 0.0f) || !(g->attenuation_distance > 0.0f) || isinf(g->attenuation_distance)) return VF_OK;
  /* A colour of 0 would absorb everything at once: its channel keeps 1e-6 of the light
   * over the distance instead. */
  const float floor_colour = 1e-6f;
  float sigma[3];
  int clamped = 0;
  for (int k = 0; k < 3; k++) {
    float colour = g->attenuation_color[k];
    clamped |= colour < floor_colour;
    colour = fminf(fmaxf(colour, floor_colour), 1.0f);
    sigma[k] = (float)(-log((double)colour) / g->attenuation_distance);
  }
  if (clamped && (err = vf_scene_note(c, "%s: material '%s': attenuationColor below %g read as %g", f->file, m->name,
                                      (double)floor_colour, (double)floor_colour)) < 0)
    return err;
  if (sigma[0] == 0.0f && sigma[1] == 0.0f && sigma[2] == 0.0f) return VF_OK;
  vf_medium medium;
  memset(&medium, 0, sizeof medium);
  snprintf(medium.name, sizeof medium.name, "%s", m->name);
  medium.sigma_a = vf_vec3_make(sigma[0], sigma[1], sigma[2]);
  return vf_scene_add_medium(c, &medium, interior);
}

static int gltf_material(const parse_ctx *c, const vf_import_file *f, unsigned index, const char *where,
                         const struct aiMaterial *am, vf_material *m, vf_vec3 *emission, int *interior) {
  struct aiColor4D base = {1, 1, 1, 1}, emit = {0, 0, 0, 1};
  get_color(am, AI_MATKEY_BASE_COLOR, &base);
  m->base_color = clamp01(rgb_of(&base));
  m->alpha = fminf(fmaxf(base.a, 0.0f), 1.0f);
  m->metallic = fminf(fmaxf(get_float(am, AI_MATKEY_METALLIC_FACTOR, 1.0f), 0.0f), 1.0f);
  m->roughness = fminf(fmaxf(get_float(am, AI_MATKEY_ROUGHNESS_FACTOR, 1.0f), 0.0f), 1.0f);
  float transmission = get_float(am, AI_MATKEY_TRANSMISSION_FACTOR, 0.0f);
  int err;
  if ((err = load_texture(c, f, where, am, aiTextureType_BASE_COLOR, &m->textures[VF_TEXTURE_COLOR])) < 0 ||
      (err = load_texture(c, f, where, am, aiTextureType_UNKNOWN, &m->textures[VF_TEXTURE_ROUGHNESS_METALLIC])) < 0 ||
      (err = load_texture(c, f, where, am, aiTextureType_NORMALS, &m->textures[VF_TEXTURE_NORMAL])) < 0 ||
      (err = load_texture(c, f, where, am, aiTextureType_EMISSIVE, &m->textures[VF_TEXTURE_EMISSION])) < 0)
    return err;
  m->normal_scale = get_float(am, AI_MATKEY_GLTF_TEXTURE_SCALE(aiTextureType_NORMALS, 0), 1.0f);
  if ((err = gltf_alpha(c, f, am, m)) < 0) return err;
  if (transmission > 0.0f) {
    /* KHR_materials_transmission: a thin-walled or volumetric transmitter whose Fresnel
     * comes from KHR_materials_ior. vcmfarm's closest is the rough dielectric tinted by
     * the base colour; partial transmission has no counterpart. */
    m->gltf = 0;
    m->dielectric = m->base_color;
    m->ior = get_float(am, AI_MATKEY_REFRACTI, DEFAULT_IOR);
    if (!(m->ior > 0.0f)) m->ior = DEFAULT_IOR;
    m->base_color = vf_vec3_splat(0.0f);
    m->metallic = 0.0f;
    memset(&m->textures[VF_TEXTURE_COLOR], 0, sizeof m->textures[0]);
    if (transmission < 1.0f &&
        (err = vf_scene_note(c, "%s: transmission factors below 1 are rendered as 1 (a rough dielectric)", f->file)) < 0)
      return err;
    if (vf_assimp()->aiGetMaterialTextureCount(am, aiTextureType_TRANSMISSION) > 0 &&
        (err = vf_scene_note(c, "%s: transmission textures are not supported: ignored", f->file)) < 0)
      return err;
  } else {
    m->gltf = 1;
  }
  struct aiString name;
  if (vf_assimp()->aiGetMaterialString(am, AI_MATKEY_NAME, &name) != aiReturn_SUCCESS) name.data[0] = '\0';
  const vf_gltf_material *g = f->gltf.materials ? vf_gltf_material_of(&f->gltf, index, name.data) : NULL;
  if (g != NULL && m->gltf && (err = gltf_specular(c, f, where, g, m)) < 0) return err;
  if (g != NULL && m->gltf && (err = gltf_layers(c, f, where, g, m)) < 0) return err;
  if (g != NULL && !m->gltf && (g->clearcoat > 0.0f || g->sheen_color[0] > 0.0f || g->sheen_color[1] > 0.0f ||
                                g->sheen_color[2] > 0.0f) &&
      (err = vf_scene_note(c, "%s: clearcoat and sheen on a transmitting material are not supported: ignored",
                           f->file)) < 0)
    return err;
  if (g != NULL && (err = gltf_texture_refs(c, f, g, m)) < 0) return err;
  if (g != NULL && (err = gltf_volume(c, f, g, m, interior)) < 0) return err;
  get_color(am, AI_MATKEY_COLOR_EMISSIVE, &emit);
  float strength = g != NULL ? g->emissive_strength : 1.0f;
  *emission = vf_scale(vf_vec3_make(fmaxf(emit.r, 0.0f), fmaxf(emit.g, 0.0f), fmaxf(emit.b, 0.0f)), fmaxf(strength, 0.0f));
  return VF_OK;
}

/* ---- OBJ .mtl and other formats --------------------------------------------------------------- */

/* Whether a bump map's texels look like a tangent-space normal map: three or more
 * channels, blue high and red and green centred on average. A height map is grey. */
static int looks_like_normal_map(const vf_texture *t) {
  if (t->channels < 3 || t->is_float) return 0;
  const uint8_t *p = t->texels;
  double sum[3] = {0, 0, 0};
  size_t n = (size_t)t->width * t->height;
  for (size_t i = 0; i < n; i++)
    for (int k = 0; k < 3; k++) sum[k] += p[i * (size_t)t->channels + k] / 255.0;
  for (int k = 0; k < 3; k++) sum[k] /= (double)n;
  return sum[2] > 0.6 && fabs(sum[0] - 0.5) < 0.15 && fabs(sum[1] - 0.5) < 0.15;
}

static int classic_textures(const parse_ctx *c, const vf_import_file *f, const char *where,
                            const struct aiMaterial *am, vf_material *m) {
  int err;
  if ((err = load_texture(c, f, where, am, aiTextureType_DIFFUSE, &m->textures[VF_TEXTURE_COLOR])) < 0 ||
      (err = load_texture(c, f, where, am, aiTextureType_EMISSIVE, &m->textures[VF_TEXTURE_EMISSION])) < 0 ||
      (err = load_texture(c, f, where, am, aiTextureType_NORMALS, &m->textures[VF_TEXTURE_NORMAL])) < 0)
    return err;
  vf_texture_slot bump = {0}, alpha = {0};
  if ((err = load_texture(c, f, where, am, aiTextureType_HEIGHT, &bump)) < 0) return err;
  if (err > 0 && m->textures[VF_TEXTURE_NORMAL].texture == 0) {
    /* map_Bump is a height map by the format, a normal map by common practice. */
    if (looks_like_normal_map(&c->scene->textures[bump.texture - 1])) m->textures[VF_TEXTURE_NORMAL] = bump;
    else if ((err = vf_scene_note(c, "%s: bump maps that are height maps are not supported: ignored", f->file)) < 0)
      return err;
  }
  if ((err = load_texture(c, f, where, am, aiTextureType_OPACITY, &alpha)) < 0) return err;
  if (err > 0) { /* map_d: a cut-out, read from the image's alpha if it has one, else its grey */
    int channels = c->scene->textures[alpha.texture - 1].channels;
    m->textures[VF_TEXTURE_ALPHA] = alpha;
    m->alpha_channel = channels == 4 ? 3 : channels == 2 ? 1 : 0;
    m->alpha = 1.0f;
    m->alpha_cutoff = 0.5f;
  }
  m->normal_scale = 1.0f;
  static const enum aiTextureType unused[] = {aiTextureType_SPECULAR, aiTextureType_SHININESS, aiTextureType_AMBIENT,
                                             aiTextureType_DISPLACEMENT, aiTextureType_REFLECTION};
  static const char *const names[] = {"specular (map_Ks)", "shininess (map_Ns)", "ambient (map_Ka)",
                                      "displacement (disp)", "reflection (refl)"};
  return note_unused_textures(c, f, am, unused, names, 5);
}

static int classic_material(const parse_ctx *c, const vf_import_file *f, const char *where,
                            const struct aiMaterial *am, vf_material *m, vf_vec3 *emission) {
  struct aiColor4D kd = {0, 0, 0, 1}, ks = {0, 0, 0, 1}, ke = {0, 0, 0, 1}, tf = {0, 0, 0, 1};
  int illum = 2, err;
  unsigned one = 1;
  get_color(am, AI_MATKEY_COLOR_DIFFUSE, &kd);
  get_color(am, AI_MATKEY_COLOR_SPECULAR, &ks);
  get_color(am, AI_MATKEY_COLOR_EMISSIVE, &ke);
  get_color(am, AI_MATKEY_COLOR_TRANSPARENT, &tf);
  vf_assimp()->aiGetMaterialIntegerArray(am, AI_MATKEY_OBJ_ILLUM, &illum, &one);
  float ns = get_float(am, AI_MATKEY_SHININESS, 0.0f), ni = get_float(am, AI_MATKEY_REFRACTI, 1.0f);
  float d = get_float(am, AI_MATKEY_OPACITY, 1.0f);
  *emission = vf_vec3_make(fmaxf(ke.r, 0.0f), fmaxf(ke.g, 0.0f), fmaxf(ke.b, 0.0f));
  if ((err = classic_textures(c, f, where, am, m)) < 0) return err;
  int cut_out = m->textures[VF_TEXTURE_ALPHA].texture != 0;
  if (illum == 4 || illum == 6 || illum == 7 || (d < 1.0f && !cut_out)) {
    /* Glass: the transmission filter Tf tints it when given. Kd and Ks describe the
     * surface of a dielectric already (its Fresnel reflection): they are not added. */
    vf_vec3 tint = clamp01(rgb_of(&tf));
    m->dielectric = vf_is_zero(tint) ? vf_vec3_splat(1.0f) : tint;
    m->ior = ni > 1.0f ? ni : DEFAULT_IOR;
    memset(&m->textures[VF_TEXTURE_COLOR], 0, sizeof m->textures[0]);
    if (!(ni > 1.0f) && (err = vf_scene_note(c, "%s: glass without Ni (index of refraction) gets %g", f->file,
                                             (double)DEFAULT_IOR)) < 0)
      return err;
    return VF_OK;
  }
  m->diffuse = clamp01(rgb_of(&kd));
  m->glossy = clamp01(rgb_of(&ks));
  m->phong_exponent = fmaxf(ns, 1.0f);
  /* Kd + Ks may exceed 1 in a .mtl (nothing in the format forbids it); a surface reflecting
   * more than it receives would break the renderer's energy bound: scale both down. */
  float top = vf_max_component(vf_add(m->diffuse, m->glossy));
  if (top > 1.0f) {
    m->diffuse = vf_scale(m->diffuse, 1.0f / top);
    m->glossy = vf_scale(m->glossy, 1.0f / top);
    if (top > *f->kd_ks_largest) *f->kd_ks_largest = top;
  }
  return VF_OK;
}

int vf_scene_import_material(const parse_ctx *c, const vf_import_file *f, unsigned index, vf_material *m,
                             vf_vec3 *emission, int *interior) {
  const struct aiMaterial *am = f->ai->mMaterials[index];
  struct aiString name;
  char where[PATH_LEN];
  memset(m, 0, sizeof *m);
  if (vf_assimp()->aiGetMaterialString(am, AI_MATKEY_NAME, &name) != aiReturn_SUCCESS || name.length == 0)
    snprintf(name.data, sizeof name.data, "material %u", index);
  snprintf(m->name, sizeof m->name, "%.63s", name.data); /* longer names are cut: they only name */
  if (f->what) snprintf(where, sizeof where, "%.160s: material '%.63s'", f->what, name.data);
  else snprintf(where, sizeof where, "material '%.63s'", name.data);
  m->phong_exponent = m->ior = 1.0f; /* harmless values for unused parameters, as JSON materials */
  m->normal_scale = 1.0f;
  *interior = -1;
  return f->gltf_file ? gltf_material(c, f, index, where, am, m, emission, interior)
                      : classic_material(c, f, where, am, m, emission);
}
