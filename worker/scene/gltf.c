/* What a glTF 2.0 file says that Assimp 5.2.5 does not pass on: the extensions it uses
 * (each one vcmfarm does not implement becomes a load note), the materials'
 * KHR_materials_emissive_strength, and the facts worth a note (light ranges, occlusion
 * textures, several scenes). Read from the file's own JSON with cJSON: the .gltf text, or
 * a .glb's first chunk. */
#include "gltf.h"

#include "../../common/error.h"

#include <cjson/cJSON.h>

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* A glb's JSON chunk is the glTF text; anything above this is not a scene description. */
#define MAX_GLTF_JSON_BYTES ((uint32_t)256 << 20)

/* Extensions vcmfarm renders as the specification says; every other one gets a note.
 * KHR_draco_mesh_compression is Assimp's to decode: a mesh it did not decode is noted
 * where it is met (import.c), the extension itself is not. */
static const char *const supported[] = {"KHR_lights_punctual", "KHR_materials_emissive_strength",
                                        "KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_specular",
                                        "KHR_materials_volume", "KHR_materials_clearcoat", "KHR_materials_sheen",
                                        "KHR_texture_transform", "KHR_draco_mesh_compression", NULL};

int vf_gltf_is_gltf(const char *file) {
  size_t n = strlen(file);
  return (n >= 5 && strcasecmp(file + n - 5, ".gltf") == 0) || (n >= 4 && strcasecmp(file + n - 4, ".glb") == 0);
}

static uint32_t le32(const uint8_t *b) { return b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24; }

/* The JSON text of the file at `full`: all of a .gltf, or the JSON chunk of a .glb (12-byte
 * header "glTF", version, length; then chunk length, type "JSON", data). NUL-terminated. */
static int read_json(const parse_ctx *c, const char *file, const char *full, const char *what, char **out,
                     vf_gltf_info *info) {
  FILE *f = fopen(full, "rb");
  if (f == NULL) return vf_scene_fail(c, VF_ENOENT, what, "cannot open '%s': %s", file, strerror(errno));
  uint8_t head[20];
  size_t got = fread(head, 1, sizeof head, f);
  uint32_t offset = 0, length;
  if (got >= 4 && memcmp(head, "glTF", 4) == 0) {
    if (got < 20 || le32(head + 16) != 0x4E4F534Au) { /* "JSON" */
      fclose(f);
      return vf_scene_fail(c, VF_EMESH, what, "'%s' is a glTF binary without a JSON chunk", file);
    }
    offset = 20;
    length = le32(head + 12);
  } else {
    fseek(f, 0, SEEK_END);
    long size = ftell(f);
    length = size < 0 || size > (long)MAX_GLTF_JSON_BYTES ? UINT32_MAX : (uint32_t)size;
  }
  if (length > MAX_GLTF_JSON_BYTES) {
    fclose(f);
    return vf_scene_fail(c, VF_EMESH, what, "the JSON of '%s' is larger than %u MiB", file, MAX_GLTF_JSON_BYTES >> 20);
  }
  char *text = malloc((size_t)length + 1);
  if (text == NULL || fseek(f, offset, SEEK_SET) != 0 || fread(text, 1, length, f) != length) {
    free(text);
    fclose(f);
    return text == NULL ? vf_error_set(VF_ENOMEM, "out of memory")
                        : vf_scene_fail(c, VF_EMESH, what, "'%s' ends inside its JSON", file);
  }
  if (offset > 0) { /* a BIN chunk after the JSON's: length, "BIN\0", data */
    uint8_t chunk[8];
    if (fread(chunk, 1, 8, f) == 8 && le32(chunk + 4) == 0x004E4942u) {
      info->bin_offset = offset + length + 8;
      info->bin_length = le32(chunk);
    }
  }
  fclose(f);
  text[length] = '\0';
  *out = text;
  return VF_OK;
}

static int note_extensions(const parse_ctx *c, const char *file, const cJSON *root) {
  const cJSON *e;
  cJSON_ArrayForEach(e, cJSON_GetObjectItemCaseSensitive(root, "extensionsUsed")) {
    if (!cJSON_IsString(e)) continue;
    int known = 0;
    for (int i = 0; supported[i] != NULL; i++) known |= strcmp(supported[i], e->valuestring) == 0;
    int err = VF_OK;
    if (!known)
      err = vf_scene_note(c, "%s: extension %s is not supported: ignored", file, e->valuestring);
    if (err < 0) return err;
  }
  return VF_OK;
}

static float number_or(const cJSON *obj, const char *key, float fallback) {
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
  return cJSON_IsNumber(v) && isfinite(v->valuedouble) ? (float)v->valuedouble : fallback;
}

static int index_or(const cJSON *obj, const char *key, int fallback) {
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
  return cJSON_IsNumber(v) && v->valuedouble >= 0 && v->valuedouble < 1e9 ? (int)v->valuedouble : fallback;
}

/* A textureInfo (`info`, may be NULL) into *ref: texture -> image and sampler, texCoord, and
 * KHR_texture_transform, whose matrix is T(offset) R(rotation) S(scale) with
 * R = [cos sin; -sin cos] [KHR_texture_transform, "Implementation"]. */
static void read_texture_ref(const cJSON *root, const cJSON *info, vf_gltf_texture_ref *ref) {
  memset(ref, 0, sizeof *ref);
  ref->image = ref->sampler = -1;
  if (!cJSON_IsObject(info)) return;
  const cJSON *texture = cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(root, "textures"), index_or(info, "index", -1));
  if (!cJSON_IsObject(texture)) return;
  ref->image = index_or(texture, "source", -1);
  ref->sampler = index_or(texture, "sampler", -1);
  ref->uv_set = index_or(info, "texCoord", 0);
  const cJSON *tt = cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(info, "extensions"),
                                                     "KHR_texture_transform");
  if (!cJSON_IsObject(tt)) return;
  const cJSON *offset = cJSON_GetObjectItemCaseSensitive(tt, "offset"), *scale = cJSON_GetObjectItemCaseSensitive(tt, "scale");
  float ox = 0.0f, oy = 0.0f, sx = 1.0f, sy = 1.0f;
  if (cJSON_IsArray(offset) && cJSON_GetArraySize(offset) == 2) {
    ox = (float)cJSON_GetArrayItem(offset, 0)->valuedouble;
    oy = (float)cJSON_GetArrayItem(offset, 1)->valuedouble;
  }
  if (cJSON_IsArray(scale) && cJSON_GetArraySize(scale) == 2) {
    sx = (float)cJSON_GetArrayItem(scale, 0)->valuedouble;
    sy = (float)cJSON_GetArrayItem(scale, 1)->valuedouble;
  }
  double r = number_or(tt, "rotation", 0.0f), cr = cos(r), sr = sin(r);
  ref->has_transform = 1;
  ref->transform[0] = (float)(cr * sx), ref->transform[1] = (float)(sr * sy), ref->transform[2] = ox;
  ref->transform[3] = (float)(-sr * sx), ref->transform[4] = (float)(cr * sy), ref->transform[5] = oy;
  ref->uv_set = index_or(tt, "texCoord", ref->uv_set);
  for (int k = 0; k < 6; k++)
    if (!isfinite(ref->transform[k])) ref->has_transform = 0, ref->image = -1; /* refused in import_material.c */
}

/* KHR_materials_clearcoat and KHR_materials_sheen of a material's `extensions` (read here
 * rather than from Assimp, as KHR_materials_specular is, with their textures' uv sets and
 * transforms). */
static void read_layers(const cJSON *root, const cJSON *ext, vf_gltf_material *g) {
  const cJSON *coat = cJSON_GetObjectItemCaseSensitive(ext, "KHR_materials_clearcoat");
  const cJSON *sheen = cJSON_GetObjectItemCaseSensitive(ext, "KHR_materials_sheen");
  const cJSON *normal = cJSON_GetObjectItemCaseSensitive(coat, "clearcoatNormalTexture");
  g->clearcoat = number_or(coat, "clearcoatFactor", 0.0f);
  g->clearcoat_roughness = number_or(coat, "clearcoatRoughnessFactor", 0.0f);
  g->clearcoat_normal_scale = number_or(normal, "scale", 1.0f);
  read_texture_ref(root, cJSON_GetObjectItemCaseSensitive(coat, "clearcoatTexture"),
                   &g->textures[VF_TEXTURE_CLEARCOAT]);
  read_texture_ref(root, cJSON_GetObjectItemCaseSensitive(coat, "clearcoatRoughnessTexture"),
                   &g->textures[VF_TEXTURE_CLEARCOAT_ROUGHNESS]);
  read_texture_ref(root, normal, &g->textures[VF_TEXTURE_CLEARCOAT_NORMAL]);
  const cJSON *color = cJSON_GetObjectItemCaseSensitive(sheen, "sheenColorFactor");
  for (int k = 0; k < 3; k++) {
    const cJSON *v = cJSON_IsArray(color) && cJSON_GetArraySize(color) == 3 ? cJSON_GetArrayItem(color, k) : NULL;
    g->sheen_color[k] = cJSON_IsNumber(v) && isfinite(v->valuedouble) ? (float)v->valuedouble : 0.0f;
  }
  g->sheen_roughness = number_or(sheen, "sheenRoughnessFactor", 0.0f);
  read_texture_ref(root, cJSON_GetObjectItemCaseSensitive(sheen, "sheenColorTexture"),
                   &g->textures[VF_TEXTURE_SHEEN_COLOR]);
  read_texture_ref(root, cJSON_GetObjectItemCaseSensitive(sheen, "sheenRoughnessTexture"),
                   &g->textures[VF_TEXTURE_SHEEN_ROUGHNESS]);
}

/* What Assimp does not read of each material, in the file's order (Assimp's material
 * order too). */
static int read_materials(const cJSON *root, vf_gltf_info *info) {
  const cJSON *materials = cJSON_GetObjectItemCaseSensitive(root, "materials");
  int n = cJSON_IsArray(materials) ? cJSON_GetArraySize(materials) : 0;
  if (n == 0) return VF_OK;
  if ((info->materials = calloc((size_t)n, sizeof *info->materials)) == NULL)
    return vf_error_set(VF_ENOMEM, "out of memory");
  info->num_materials = n;
  int i = 0;
  const cJSON *m;
  cJSON_ArrayForEach(m, materials) {
    vf_gltf_material *g = &info->materials[i++];
    const cJSON *ext = cJSON_GetObjectItemCaseSensitive(m, "extensions");
    const cJSON *pbr = cJSON_GetObjectItemCaseSensitive(m, "pbrMetallicRoughness");
    const cJSON *spec = cJSON_GetObjectItemCaseSensitive(ext, "KHR_materials_specular");
    g->emissive_strength = number_or(cJSON_GetObjectItemCaseSensitive(ext, "KHR_materials_emissive_strength"),
                                     "emissiveStrength", 1.0f);
    g->ior = number_or(cJSON_GetObjectItemCaseSensitive(ext, "KHR_materials_ior"), "ior", 1.5f);
    const cJSON *volume = cJSON_GetObjectItemCaseSensitive(ext, "KHR_materials_volume");
    g->has_volume = cJSON_IsObject(volume);
    g->thickness = number_or(volume, "thicknessFactor", 0.0f);
    g->attenuation_distance = number_or(volume, "attenuationDistance", INFINITY);
    const cJSON *attenuation = cJSON_GetObjectItemCaseSensitive(volume, "attenuationColor");
    for (int k = 0; k < 3; k++) {
      const cJSON *v = cJSON_IsArray(attenuation) && cJSON_GetArraySize(attenuation) == 3 ? cJSON_GetArrayItem(attenuation, k) : NULL;
      g->attenuation_color[k] = cJSON_IsNumber(v) && isfinite(v->valuedouble) ? (float)v->valuedouble : 1.0f;
    }
    g->has_thickness_texture = cJSON_GetObjectItemCaseSensitive(volume, "thicknessTexture") != NULL;
    g->has_specular = cJSON_IsObject(spec);
    g->specular = number_or(spec, "specularFactor", 1.0f);
    const cJSON *color = cJSON_GetObjectItemCaseSensitive(spec, "specularColorFactor");
    for (int k = 0; k < 3; k++) {
      const cJSON *v = cJSON_IsArray(color) && cJSON_GetArraySize(color) == 3 ? cJSON_GetArrayItem(color, k) : NULL;
      g->specular_color[k] = cJSON_IsNumber(v) && isfinite(v->valuedouble) ? (float)v->valuedouble : 1.0f;
    }
    for (int k = 0; k < VF_TEXTURE_SLOTS; k++) read_texture_ref(root, NULL, &g->textures[k]);
    read_texture_ref(root, cJSON_GetObjectItemCaseSensitive(pbr, "baseColorTexture"), &g->textures[VF_TEXTURE_COLOR]);
    read_texture_ref(root, cJSON_GetObjectItemCaseSensitive(pbr, "metallicRoughnessTexture"),
                     &g->textures[VF_TEXTURE_ROUGHNESS_METALLIC]);
    read_texture_ref(root, cJSON_GetObjectItemCaseSensitive(m, "normalTexture"), &g->textures[VF_TEXTURE_NORMAL]);
    read_texture_ref(root, cJSON_GetObjectItemCaseSensitive(m, "emissiveTexture"), &g->textures[VF_TEXTURE_EMISSION]);
    read_texture_ref(root, cJSON_GetObjectItemCaseSensitive(spec, "specularTexture"), &g->textures[VF_TEXTURE_SPECULAR]);
    read_texture_ref(root, cJSON_GetObjectItemCaseSensitive(spec, "specularColorTexture"),
                     &g->textures[VF_TEXTURE_SPECULAR_COLOR]);
    read_layers(root, ext, g);
    if (cJSON_GetObjectItemCaseSensitive(m, "occlusionTexture") != NULL) info->has_occlusion = 1;
  }
  const cJSON *mesh, *prim;
  cJSON_ArrayForEach(mesh, cJSON_GetObjectItemCaseSensitive(root, "meshes")) {
    cJSON_ArrayForEach(prim, cJSON_GetObjectItemCaseSensitive(mesh, "primitives")) {
      if (cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(prim, "extensions"),
                                           "KHR_draco_mesh_compression") != NULL)
        info->uses_draco = 1;
    }
  }
  return VF_OK;
}

/* Assimp's material order (gltf.h): a depth-first walk of the default scene, each node's
 * children before its own mesh, each mesh and node once. */
typedef struct {
  const cJSON *nodes, *meshes;
  uint8_t *node_seen, *mesh_seen, *material_seen;
  int num_nodes, num_meshes, num_materials;
  vf_gltf_info *info;
} order_walk;

static void walk_node(order_walk *w, int n, int depth) {
  if (n < 0 || n >= w->num_nodes || w->node_seen[n] || depth > 256) return;
  w->node_seen[n] = 1;
  const cJSON *node = cJSON_GetArrayItem(w->nodes, n), *child;
  cJSON_ArrayForEach(child, cJSON_GetObjectItemCaseSensitive(node, "children"))
    if (cJSON_IsNumber(child)) walk_node(w, child->valueint, depth + 1);
  int mesh = index_or(node, "mesh", -1);
  if (mesh < 0 || mesh >= w->num_meshes || w->mesh_seen[mesh]) return;
  w->mesh_seen[mesh] = 1;
  const cJSON *prim;
  cJSON_ArrayForEach(prim, cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(w->meshes, mesh), "primitives")) {
    int m = index_or(prim, "material", -1);
    if (m < 0 || m >= w->num_materials || w->material_seen[m]) continue;
    w->material_seen[m] = 1;
    w->info->assimp_order[w->info->num_assimp_order++] = m;
  }
}

static int read_material_order(const cJSON *root, vf_gltf_info *info) {
  order_walk w = {.nodes = cJSON_GetObjectItemCaseSensitive(root, "nodes"),
                  .meshes = cJSON_GetObjectItemCaseSensitive(root, "meshes")};
  w.num_nodes = cJSON_GetArraySize(w.nodes);
  w.num_meshes = cJSON_GetArraySize(w.meshes);
  w.num_materials = info->num_materials;
  w.info = info;
  w.node_seen = calloc((size_t)w.num_nodes + 1, 1);
  w.mesh_seen = calloc((size_t)w.num_meshes + 1, 1);
  w.material_seen = calloc((size_t)w.num_materials + 1, 1);
  info->assimp_order = malloc(((size_t)w.num_materials + 1) * sizeof *info->assimp_order);
  int err = VF_OK;
  if (w.node_seen && w.mesh_seen && w.material_seen && info->assimp_order) {
    const cJSON *scene = cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(root, "scenes"), index_or(root, "scene", 0)), *n;
    cJSON_ArrayForEach(n, cJSON_GetObjectItemCaseSensitive(scene, "nodes")) if (cJSON_IsNumber(n)) walk_node(&w, n->valueint, 0);
  } else {
    err = vf_error_set(VF_ENOMEM, "out of memory");
  }
  free(w.node_seen);
  free(w.mesh_seen);
  free(w.material_seen);
  return err;
}

static const char *material_name(const vf_gltf_info *info, int m) {
  const cJSON *name = cJSON_GetObjectItemCaseSensitive(
      cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(info->root, "materials"), m), "name");
  return cJSON_IsString(name) ? name->valuestring : "";
}

const vf_gltf_material *vf_gltf_material_of(const vf_gltf_info *info, unsigned index, const char *name) {
  if (index < (unsigned)info->num_assimp_order && strcmp(material_name(info, info->assimp_order[index]), name) == 0)
    return &info->materials[info->assimp_order[index]];
  int found = -1;
  for (int m = 0; m < info->num_materials && name[0]; m++)
    if (strcmp(material_name(info, m), name) == 0) {
      if (found >= 0) return NULL;
      found = m;
    }
  return found >= 0 ? &info->materials[found] : NULL;
}

static int note_facts(const parse_ctx *c, const char *file, const cJSON *root, const vf_gltf_info *info) {
  int err = VF_OK;
  const cJSON *ext = cJSON_GetObjectItemCaseSensitive(root, "extensions");
  const cJSON *lights = cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(ext, "KHR_lights_punctual"),
                                                         "lights");
  const cJSON *l;
  cJSON_ArrayForEach(l, lights) if (cJSON_GetObjectItemCaseSensitive(l, "range") != NULL && err == VF_OK) err =
      vf_scene_note(c, "%s: light ranges are ignored: punctual lights fall off with the inverse square everywhere", file);
  if (info->has_occlusion && err == VF_OK)
    err = vf_scene_note(c, "%s: occlusion textures are ignored (the light transport computes occlusion)", file);
  const cJSON *scenes = cJSON_GetObjectItemCaseSensitive(root, "scenes");
  if (cJSON_IsArray(scenes) && cJSON_GetArraySize(scenes) > 1 && err == VF_OK)
    err = vf_scene_note(c, "%s: the file has %d scenes: only its default scene is rendered", file,
                        cJSON_GetArraySize(scenes));
  return err;
}

int vf_gltf_read_info(const parse_ctx *c, const char *file, const char *what, vf_gltf_info *out) {
  char full[4096], *text = NULL;
  vf_gltf_info info = {0};
  int err = vf_scene_resolve(c, file, what, full, sizeof full);
  if (err < 0 || (err = read_json(c, file, full, what, &text, &info)) < 0) return err;
  cJSON *root = cJSON_Parse(text);
  free(text);
  if (root == NULL) return vf_scene_fail(c, VF_EMESH, what, "'%s': JSON syntax error", file);
  info.root = root;
  snprintf(info.full, sizeof info.full, "%s", full);
  if ((err = note_extensions(c, file, root)) == VF_OK && (err = read_materials(root, &info)) == VF_OK &&
      (err = read_material_order(root, &info)) == VF_OK)
    err = note_facts(c, file, root, &info);
  if (err < 0) {
    vf_gltf_info_release(&info);
    return err;
  }
  *out = info;
  return VF_OK;
}

void vf_gltf_info_release(vf_gltf_info *info) {
  free(info->materials);
  free(info->assimp_order);
  cJSON_Delete(info->root);
  memset(info, 0, sizeof *info);
}

/* ---- images Assimp does not load ------------------------------------------------------------ */

static int base64_value(char ch) {
  return ch >= 'A' && ch <= 'Z' ? ch - 'A' : ch >= 'a' && ch <= 'z' ? ch - 'a' + 26 : ch >= '0' && ch <= '9' ? ch - '0' + 52
         : ch == '+' ? 62 : ch == '/' ? 63 : -1;
}

/* The bytes of a "data:...;base64,..." URI. */
static int decode_data_uri(const parse_ctx *c, const char *uri, const char *where, void **bytes, size_t *size) {
  const char *comma = strchr(uri, ',');
  if (comma == NULL || comma - uri < 7 || strncmp(comma - 7, ";base64", 7) != 0)
    return vf_scene_fail(c, VF_ETEXTURE, where, "an image's data URI is not base64");
  size_t n = strlen(comma + 1);
  uint8_t *out = malloc(n / 4 * 3 + 3);
  if (out == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  size_t len = 0;
  uint32_t acc = 0;
  int bits = 0;
  for (const char *p = comma + 1; *p && *p != '='; p++) {
    int v = base64_value(*p);
    if (v < 0) {
      free(out);
      return vf_scene_fail(c, VF_ETEXTURE, where, "an image's data URI has a byte that is not base64");
    }
    acc = acc << 6 | (uint32_t)v;
    if ((bits += 6) >= 8) out[len++] = (uint8_t)(acc >> (bits -= 8));
  }
  *bytes = out;
  *size = len;
  return VF_OK;
}

/* `length` bytes at `offset` of the file at `full`. */
static int read_range(const parse_ctx *c, const char *full, uint64_t offset, uint64_t length, const char *where,
                      void **bytes) {
  FILE *f = fopen(full, "rb");
  if (f == NULL) return vf_scene_fail(c, VF_ENOENT, where, "cannot open '%s': %s", full, strerror(errno));
  uint8_t *out = length <= (1u << 30) ? malloc(length ? length : 1) : NULL;
  int no_memory = out == NULL && length <= (1u << 30);
  int ok = out != NULL && fseek(f, (long)offset, SEEK_SET) == 0 && fread(out, 1, length, f) == length;
  fclose(f);
  if (!ok) {
    free(out);
    return no_memory ? vf_error_set(VF_ENOMEM, "out of memory")
                     : vf_scene_fail(c, VF_EMESH, where, "an image's buffer view lies outside its buffer");
  }
  *bytes = out;
  return VF_OK;
}

int vf_gltf_image(const parse_ctx *c, const vf_gltf_info *info, const char *dir, int image, const char *where,
                  const char **uri, void **bytes, size_t *size) {
  const cJSON *img = cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(info->root, "images"), image);
  if (!cJSON_IsObject(img)) return vf_scene_fail(c, VF_EMESH, where, "names image %d, which the file lacks", image);
  const cJSON *u = cJSON_GetObjectItemCaseSensitive(img, "uri");
  *uri = NULL;
  *bytes = NULL;
  if (cJSON_IsString(u)) {
    if (strncmp(u->valuestring, "data:", 5) == 0) return decode_data_uri(c, u->valuestring, where, bytes, size);
    *uri = u->valuestring;
    return VF_OK;
  }
  const cJSON *view = cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(info->root, "bufferViews"),
                                         index_or(img, "bufferView", -1));
  if (!cJSON_IsObject(view)) return vf_scene_fail(c, VF_EMESH, where, "image %d has neither a URI nor a buffer view", image);
  int buffer_index = index_or(view, "buffer", -1);
  const cJSON *buffer = cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(info->root, "buffers"), buffer_index);
  const cJSON *buri = cJSON_GetObjectItemCaseSensitive(buffer, "uri");
  double offset = number_or(view, "byteOffset", 0.0f), length = number_or(view, "byteLength", -1.0f);
  if (!(offset >= 0 && length >= 0)) return vf_scene_fail(c, VF_EMESH, where, "image %d has a bad buffer view", image);
  *size = (size_t)length;
  if (cJSON_IsString(buri)) {
    if (strncmp(buri->valuestring, "data:", 5) == 0) {
      void *all;
      size_t n;
      int err = decode_data_uri(c, buri->valuestring, where, &all, &n);
      if (err < 0) return err;
      if (offset + length > (double)n) {
        free(all);
        return vf_scene_fail(c, VF_EMESH, where, "image %d's buffer view lies outside its buffer", image);
      }
      memmove(all, (uint8_t *)all + (size_t)offset, *size);
      *bytes = all;
      return VF_OK;
    }
    char file[2 * PATH_LEN], full[4096];
    snprintf(file, sizeof file, "%s%s%s", dir, dir[0] ? "/" : "", buri->valuestring);
    int err = vf_scene_resolve(c, file, where, full, sizeof full);
    return err < 0 ? err : read_range(c, full, (uint64_t)offset, *size, where, bytes);
  }
  if (buffer_index != 0 || info->bin_length == 0 || offset + length > info->bin_length)
    return vf_scene_fail(c, VF_EMESH, where, "image %d's buffer view lies outside the file's binary chunk", image);
  return read_range(c, info->full, info->bin_offset + (uint64_t)offset, *size, where, bytes);
}
