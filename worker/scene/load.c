/* Loading a scene by name or path: a built-in name, a JSON scene file, or a model file
 * (glTF, OBJ) read as the JSON scene that imports it, or a Mitsuba 3 scene read as the
 * JSON scene that says the same (load.h). */
#include "load.h"

#include "../../common/error.h"
#include "builtin.h"
#include "gltf.h"
#include "json.h"
#include "mitsuba.h"

#include <cjson/cJSON.h>

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* Inline meshes make big scene files plausible; anything larger is a mistake or an attack. */
#define MAX_SCENE_FILE_BYTES ((size_t)512 << 20)

/* Reads a whole file into a NUL-terminated buffer the caller frees. */
static int read_text(const char *path, char **text, size_t *length) {
  FILE *f = fopen(path, "rb");
  if (f == NULL) return vf_error_set(VF_ENOENT, "%s: cannot open: %s", path, strerror(errno));
  char *buf = NULL;
  size_t n = 0, cap = 0;
  int err = VF_OK;
  for (;;) {
    if (cap - n < 65536) {
      cap = cap ? 2 * cap : 65536;
      char *grown = cap > MAX_SCENE_FILE_BYTES + 65536 ? NULL : realloc(buf, cap + 1);
      if (grown == NULL) {
        err = vf_error_set(VF_ESCENE, "%s: larger than %zu MiB or out of memory", path, MAX_SCENE_FILE_BYTES >> 20);
        goto done;
      }
      buf = grown;
    }
    size_t got = fread(buf + n, 1, cap - n, f);
    n += got;
    if (got == 0) break;
  }
  if (ferror(f) || n > MAX_SCENE_FILE_BYTES) {
    err = ferror(f) ? vf_error_set(VF_ENOENT, "%s: read error", path)
                    : vf_error_set(VF_ESCENE, "%s: larger than %zu MiB", path, MAX_SCENE_FILE_BYTES >> 20);
    goto done;
  }
  buf[n] = '\0';
  *text = buf;
  *length = n;
  buf = NULL;
done:
  free(buf);
  fclose(f);
  return err;
}

int vf_scene_not_found(const char *name, int err) {
  size_t n = strlen(name);
  if (err != VF_ENOENT || strchr(name, '/') != NULL || (n >= 5 && strcmp(name + n - 5, ".json") == 0)) return err;
  char names[512] = "";
  size_t used = 0;
  for (const char *const *b = vf_scene_builtin_names(); *b != NULL && used < sizeof names; b++) {
    int w = snprintf(names + used, sizeof names - used, "%s%s", used ? ", " : "", *b);
    if (w < 0) break;
    used += (size_t)w;
  }
  char detail[256];
  snprintf(detail, sizeof detail, "%s", vf_error_detail(err));
  return vf_error_set(err, "%s; '%s' is not a built-in scene either (built-in: %s)", detail, name, names);
}

int vf_scene_load_camera(const char *name_or_path, const char *camera, vf_scene **out) {
  int model = vf_scene_is_model_file(name_or_path);
  for (const char *const *n = vf_scene_builtin_names(); *n != NULL && !model; n++)
    if (strcmp(*n, name_or_path) == 0) {
      if (camera != NULL) return vf_error_set(VF_EUSAGE, "--camera chooses a camera of a glTF or OBJ file, not of a built-in scene");
      return vf_scene_builtin_load(name_or_path, out);
    }
  if (camera != NULL && !model)
    return vf_error_set(VF_EUSAGE, "--camera chooses a camera of a glTF or OBJ file; a JSON scene chooses it in "
                        "import[i].camera (docs/SCENES.md)");
  char *text = NULL, dir[4096];
  size_t length = 0;
  const char *slash = strrchr(name_or_path, '/');
  if (slash == NULL) snprintf(dir, sizeof dir, ".");
  else if (slash == name_or_path) snprintf(dir, sizeof dir, "/");
  else snprintf(dir, sizeof dir, "%.*s", (int)(slash - name_or_path), name_or_path);
  /* A model file is read as the JSON scene that imports it, so local renders and farm jobs
   * (which carry that text) load it by one path. */
  int err = model ? vf_scene_model_text(name_or_path, camera, &text, &length) : read_text(name_or_path, &text, &length);
  if (err < 0) return model ? err : vf_scene_not_found(name_or_path, err);
  err = vf_scene_parse(text, length, name_or_path, dir, NULL, 0, out);
  free(text);
  return err;
}

int vf_scene_load(const char *name_or_path, vf_scene **out) { return vf_scene_load_camera(name_or_path, NULL, out); }

int vf_scene_is_model_file(const char *path) {
  size_t n = strlen(path);
  return vf_gltf_is_gltf(path) || (n >= 4 && strcasecmp(path + n - 4, ".obj") == 0) || vf_mitsuba_is_xml(path);
}

int vf_scene_model_text(const char *path, const char *camera, char **text, size_t *len) {
  /* A Mitsuba scene becomes the JSON scene that says the same (mitsuba.h). */
  if (vf_mitsuba_is_xml(path)) return vf_mitsuba_scene_text(path, camera, text, len);
  const char *slash = strrchr(path, '/');
  cJSON *root = cJSON_CreateObject(), *list = root ? cJSON_AddArrayToObject(root, "import") : NULL;
  cJSON *entry = list ? cJSON_CreateObject() : NULL;
  if (entry != NULL && !cJSON_AddItemToArray(list, entry)) {
    cJSON_Delete(entry);
    entry = NULL;
  }
  /* The file by its name alone: it is read from the directory the scene's label names. */
  int ok = entry && cJSON_AddStringToObject(entry, "file", slash ? slash + 1 : path) &&
           (camera == NULL || cJSON_AddStringToObject(entry, "camera", camera));
  char *out = ok ? cJSON_PrintUnformatted(root) : NULL;
  cJSON_Delete(root);
  if (out == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  *text = out;
  *len = strlen(out);
  return VF_OK;
}
