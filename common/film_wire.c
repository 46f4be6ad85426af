#include "film_wire.h"

#include "error.h"
#include "file.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static int temp_path(char *path, size_t n) {
  const char *dir = getenv("TMPDIR");
  if (dir == NULL || dir[0] == '\0') dir = "/tmp";
  if (snprintf(path, n, "%s/vcmfarm-film-XXXXXX.exr", dir) >= (int)n)
    return vf_error_set(VF_EINVAL, "TMPDIR too long");
  int fd = mkstemps(path, 4);
  if (fd < 0) return vf_error_set(VF_EIO, "%s: %s", path, strerror(errno));
  close(fd);
  return VF_OK;
}

int vf_film_to_bytes(const vf_film *film, size_t max_len, uint8_t **data, size_t *len) {
  char path[4096];
  int err = temp_path(path, sizeof path);
  if (err != VF_OK) return err;
  if ((err = vf_film_write(film, path)) == VF_OK) err = vf_file_read_all(path, max_len, data, len);
  unlink(path);
  return err;
}

/* A private scratch file read back at once: no fsync, no rename (an atomic write's fsync
 * cost the coordinator ~5 ms of waiting per result, twice its CPU time). */
static int write_scratch(const char *path, const uint8_t *data, size_t len) {
  FILE *f = fopen(path, "wb");
  if (f == NULL) return vf_error_set(VF_EIO, "%s: %s", path, strerror(errno));
  int ok = fwrite(data, 1, len, f) == len;
  if (fclose(f) != 0) ok = 0;
  return ok ? VF_OK : vf_error_set(VF_EIO, "%s: %s", path, strerror(errno));
}

int vf_film_from_bytes(const uint8_t *data, size_t len, const char *name, vf_film **out) {
  char path[4096];
  int err = temp_path(path, sizeof path);
  if (err != VF_OK) return err;
  vf_film *film = NULL;
  if ((err = write_scratch(path, data, len)) == VF_OK) err = vf_film_read(path, &film);
  unlink(path);
  if (err != VF_OK) {
    /* Name the source, not our temporary file, in the detail. */
    const char *detail = vf_error_detail(err), *at = strstr(detail, path);
    if (at != NULL) {
      char rest[1024];
      snprintf(rest, sizeof rest, "%s", at + strlen(path));
      return vf_error_set(err, "%s%s", name, rest);
    }
    return err;
  }
  *out = film;
  return VF_OK;
}
