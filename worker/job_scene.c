#include "job_scene.h"

#include "../common/error.h"
#include "../common/file.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

int vf_job_scene_is_builtin(const char *name) {
  for (const char *const *n = vf_scene_builtin_names(); *n; n++)
    if (strcmp(*n, name) == 0) return 1;
  return 0;
}

int vf_job_scene_load(int builtin, const char *text, size_t len, const char *label, vf_scene **out) {
  if (builtin) {
    if (!vf_job_scene_is_builtin(text)) return vf_error_set(VF_ESCENE, "%s: no built-in scene '%s'", label, text);
    return vf_scene_load(text, out);
  }
  const char *tmp = getenv("TMPDIR");
  char dir[4096], path[4200];
  if (snprintf(dir, sizeof dir, "%s/vcmfarm-scene-XXXXXX", tmp && tmp[0] ? tmp : "/tmp") >= (int)sizeof dir)
    return vf_error_set(VF_EINVAL, "TMPDIR too long");
  if (mkdtemp(dir) == NULL) return vf_error_set(VF_EIO, "%s: %s", dir, strerror(errno));
  snprintf(path, sizeof path, "%s/scene.json", dir);
  vf_scene *scene = NULL;
  int err = vf_file_write_atomic(path, text, len, 0600);
  if (err == VF_OK) err = vf_scene_load(path, &scene);
  unlink(path);
  rmdir(dir);
  if (err != VF_OK) {
    const char *detail = vf_error_detail(err), *at = strstr(detail, path);
    char rest[1024];
    snprintf(rest, sizeof rest, "%s", at ? at + strlen(path) : detail);
    if (err == VF_ENOENT)
      return vf_error_set(err, "%s%s%s (scenes that name mesh or map files cannot be sent to a farm yet)", label,
                          at ? "" : ": ", rest);
    return vf_error_set(err, "%s%s%s", label, at ? "" : ": ", rest);
  }
  *out = scene;
  return VF_OK;
}
