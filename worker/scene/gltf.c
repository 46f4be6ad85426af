/* What a glTF 2.0 file says that Assimp 5.2.5 does not pass on: the extensions it uses
 * (each one vcmfarm does not implement becomes a load note), the materials'
 * KHR_materials_emissive_strength, and the facts worth a note (light ranges, occlusion
 * textures, several scenes). Read from the file's own JSON with cJSON: the .gltf text, or
 * a .glb's first chunk. */
#include "gltf.h"

#include "../../common/error.h"

#include <cjson/cJSON.h>

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* A glb's JSON chunk is the glTF text; anything above this is not a scene description. */
#define MAX_GLTF_JSON_BYTES ((uint32_t)256 << 20)

/* Extensions vcmfarm renders as the specification says; every other one gets a note. */
static const char *const supported[] = {"KHR_lights_punctual", "KHR_materials_emissive_strength",
                                        "KHR_materials_transmission", "KHR_materials_ior", NULL};

int vf_gltf_is_gltf(const char *file) {
  size_t n = strlen(file);
  return (n >= 5 && strcasecmp(file + n - 5, ".gltf") == 0) || (n >= 4 && strcasecmp(file + n - 4, ".glb") == 0);
}

static uint32_t le32(const uint8_t *b) { return b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24; }

/* The JSON text of the file at `full`: all of a .gltf, or the JSON chunk of a .glb (12-byte
 * header "glTF", version, length; then chunk length, type "JSON", data). NUL-terminated. */
static int read_json(const parse_ctx *c, const char *file, const char *full, const char *what, char **out) {
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
    if (strcmp(e->valuestring, "KHR_texture_transform") == 0)
      err = vf_scene_note(c, "%s: texture transforms (KHR_texture_transform) are ignored: textures are read at the "
                          "mesh's own coordinates", file);
    else if (!known)
      err = vf_scene_note(c, "%s: extension %s is not supported: ignored", file, e->valuestring);
    if (err < 0) return err;
  }
  return VF_OK;
}

/* Emissive strengths of the materials, in the file's order (Assimp's material order too). */
static int read_strengths(const cJSON *root, vf_gltf_info *info) {
  const cJSON *materials = cJSON_GetObjectItemCaseSensitive(root, "materials");
  int n = cJSON_IsArray(materials) ? cJSON_GetArraySize(materials) : 0;
  if (n == 0) return VF_OK;
  if ((info->emissive_strength = malloc((size_t)n * sizeof(float))) == NULL)
    return vf_error_set(VF_ENOMEM, "out of memory");
  info->num_materials = n;
  int i = 0;
  const cJSON *m;
  cJSON_ArrayForEach(m, materials) {
    const cJSON *ext = cJSON_GetObjectItemCaseSensitive(m, "extensions");
    const cJSON *es = cJSON_GetObjectItemCaseSensitive(ext, "KHR_materials_emissive_strength");
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(es, "emissiveStrength");
    info->emissive_strength[i] = cJSON_IsNumber(v) ? (float)v->valuedouble : 1.0f;
    if (cJSON_GetObjectItemCaseSensitive(m, "occlusionTexture") != NULL) info->has_occlusion = 1;
    i++;
  }
  return VF_OK;
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
  if (err < 0 || (err = read_json(c, file, full, what, &text)) < 0) return err;
  cJSON *root = cJSON_Parse(text);
  free(text);
  if (root == NULL) return vf_scene_fail(c, VF_EMESH, what, "'%s': JSON syntax error", file);
  if ((err = note_extensions(c, file, root)) == VF_OK && (err = read_strengths(root, &info)) == VF_OK)
    err = note_facts(c, file, root, &info);
  cJSON_Delete(root);
  if (err < 0) {
    vf_gltf_info_release(&info);
    return err;
  }
  *out = info;
  return VF_OK;
}

void vf_gltf_info_release(vf_gltf_info *info) {
  free(info->emissive_strength);
  memset(info, 0, sizeof *info);
}
