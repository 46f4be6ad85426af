#include "job_scene.h"

#include "../../common/error.h"
#include "../../common/file.h"
#include "builtin.h"
#include "files.h"
#include "json.h"
#include "load.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

int vf_job_scene_is_builtin(const char *name) {
  for (const char *const *n = vf_scene_builtin_names(); *n; n++)
    if (strcmp(*n, name) == 0) return 1;
  return 0;
}

int vf_job_scene_load(int builtin, const char *text, size_t len, const vf_blob_table *files, const char *store_dir,
                      const char *label, vf_scene **out) {
  static const vf_blob_table none = {0};
  if (builtin) {
    if (!vf_job_scene_is_builtin(text)) return vf_error_set(VF_ESCENE, "%s: no built-in scene '%s'", label, text);
    if (files != NULL && files->count > 0)
      return vf_error_set(VF_ESCENE, "%s: built-in scene '%s' with %zu files", label, text, files->count);
    return vf_scene_load(text, out);
  }
  vf_scene_files *fs;
  int err = vf_scene_files_mapping(files ? files : &none, store_dir ? store_dir : "", &fs);
  if (err != VF_OK) return err;
  err = vf_scene_parse_files(text, len, label, fs, out);
  vf_scene_files_destroy(fs);
  return err;
}

/* Reads one recorded file into the stage and the table. */
static int stage_file(const char *stage_dir, const char *name, const char *path, vf_blob_table *files) {
  struct stat st;
  uint8_t *bytes, hash[32];
  size_t len;
  if (stat(path, &st) != 0) return vf_error_set(VF_ENOENT, "%s: vanished while submitting", path);
  if ((uint64_t)st.st_size > VF_BLOB_MAX_BYTES)
    return vf_error_set(VF_EINVAL,
                        "file '%s' is %.1f MiB; a file sent to a farm can be at most %llu MiB "
                        "(`vcmfarm render` renders it on one machine)", name,
                        (double)st.st_size / 1048576.0, (unsigned long long)(VF_BLOB_MAX_BYTES >> 20));
  int err = vf_file_read_all(path, VF_BLOB_MAX_BYTES, &bytes, &len);
  if (err != VF_OK) return err;
  vf_blob_hash(bytes, len, hash);
  if ((err = vf_blob_store_put(stage_dir, hash, bytes, len)) == VF_OK) err = vf_blob_table_add(files, name, hash, len);
  free(bytes);
  return err;
}

int vf_job_scene_collect(const char *path, const char *text, size_t len, const char *stage_dir,
                         vf_blob_table *files, vf_scene **out) {
  char dir[4096];
  const char *slash = strrchr(path, '/');
  if (slash == NULL) snprintf(dir, sizeof dir, ".");
  else if (slash == path) snprintf(dir, sizeof dir, "/");
  else snprintf(dir, sizeof dir, "%.*s", (int)(slash - path), path);
  vf_scene_files *recorder = NULL;
  vf_scene *from_dir = NULL, *from_stage = NULL;
  int err = vf_scene_files_recording(dir, &recorder);
  if (err != VF_OK) return err;
  uint8_t dir_hash[32];
  if ((err = vf_scene_parse_files(text, len, path, recorder, &from_dir)) != VF_OK) goto done;
  /* Only its hash is needed from here on: the second load need not share memory with it. */
  memcpy(dir_hash, from_dir->hash, sizeof dir_hash);
  vf_scene_destroy(from_dir);
  from_dir = NULL;
  for (size_t i = 0; i < vf_scene_files_count(recorder); i++)
    if ((err = stage_file(stage_dir, vf_scene_files_name(recorder, i), vf_scene_files_path(recorder, i), files)) !=
        VF_OK)
      goto done;
  if ((err = vf_job_scene_load(0, text, len, files, stage_dir, path, &from_stage)) != VF_OK) goto done;
  /* Differs only if a file changed between the two loads, or the loader read something it
   * did not ask for by name: either way the workers would not render what was asked. */
  if (memcmp(dir_hash, from_stage->hash, 32) != 0) {
    err = vf_error_set(VF_EMISMATCH, "%s: loads differently from its %zu files as sent (did a file change while "
                       "submitting?)", path, files->count);
    goto done;
  }
  *out = from_stage;
  from_stage = NULL;
done:
  vf_scene_destroy(from_stage);
  vf_scene_destroy(from_dir);
  vf_scene_files_destroy(recorder);
  return err;
}
