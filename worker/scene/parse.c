/* The parse context's helpers: errors naming the field path, field paths, notes, and the
 * files a scene names resolved, media by name (parse.h). */
#include "parse.h"

#include "../../common/error.h"
#include "files.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Formats into a local buffer first, so arguments may point into the thread's error detail
 * (vf_error_detail) that vf_error_set is about to overwrite. */
int vf_scene_fail(const parse_ctx *c, int err, const char *path, const char *fmt, ...) {
  char msg[768];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(msg, sizeof msg, fmt, ap);
  va_end(ap);
  if (path != NULL && path[0] != '\0') return vf_error_set(err, "%s: %s: %s", c->label, path, msg);
  return vf_error_set(err, "%s: %s", c->label, msg);
}

/* Field paths longer than PATH_LEN only come from absurd keys: they end in "..." instead. */
const char *vf_scene_join(char *dst, const char *path, const char *key) {
  int w = path[0] == '\0' ? snprintf(dst, PATH_LEN, "%s", key) : snprintf(dst, PATH_LEN, "%s.%s", path, key);
  if (w >= PATH_LEN) memcpy(dst + PATH_LEN - 4, "...", 4);
  return dst;
}

const char *vf_scene_join_index(char *dst, const char *path, long index) {
  if (snprintf(dst, PATH_LEN, "%s[%ld]", path, index) >= PATH_LEN) memcpy(dst + PATH_LEN - 4, "...", 4);
  return dst;
}

int vf_scene_note(const parse_ctx *c, const char *fmt, ...) {
  char line[512];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(line, sizeof line - 1, fmt, ap);
  va_end(ap);
  strcat(line, "\n");
  vf_scene *s = c->scene;
  size_t have = s->notes ? strlen(s->notes) : 0, len = strlen(line);
  for (const char *p = s->notes; p != NULL && *p != '\0'; p = strchr(p, '\n') + 1)
    if (strncmp(p, line, len) == 0) return VF_OK;
  char *grown = realloc(s->notes, have + len + 1);
  if (grown == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  memcpy(grown + have, line, len + 1);
  s->notes = grown;
  return VF_OK;
}

int vf_scene_medium_index(const parse_ctx *c, const char *name) {
  for (int i = 0; i < c->scene->num_media; i++)
    if (strcmp(c->scene->media[i].name, name) == 0) return i;
  return -1;
}

int vf_scene_add_medium(const parse_ctx *c, vf_medium *m, int *index) {
  vf_scene *s = c->scene;
  vf_medium *grown = realloc(s->media, (size_t)(s->num_media + 1) * sizeof *grown);
  if (grown == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  s->media = grown;
  s->media[s->num_media] = *m;
  m->grid = NULL; /* the scene's now */
  *index = s->num_media++;
  return VF_OK;
}

int vf_scene_resolve(const parse_ctx *c, const char *file, const char *path, char *out, size_t n) {
  if (c->files != NULL) { /* a farm job's scene: its files by name (files.h) */
    int err = vf_scene_files_resolve(c->files, file, out, n);
    return err < 0 ? vf_scene_fail(c, err, path, "%s", vf_error_detail(err)) : VF_OK;
  }
  int w = file[0] == '/' ? snprintf(out, n, "%s", file) : snprintf(out, n, "%s/%s", c->base_dir, file);
  if (w < 0 || (size_t)w >= n) return vf_scene_fail(c, VF_ESCENE, path, "path too long");
  return VF_OK;
}
