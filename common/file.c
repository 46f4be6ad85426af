#define _XOPEN_SOURCE 700 /* nftw */
#include "file.h"

#include "atomic_file.h"
#include "error.h"

#include <errno.h>
#include <fcntl.h>
#include <ftw.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

int vf_file_read_all(const char *path, size_t max, uint8_t **data, size_t *len) {
  int fd = open(path, O_RDONLY | O_CLOEXEC);
  if (fd < 0)
    return vf_error_set(errno == ENOENT ? VF_ENOENT : VF_EIO, "%s: %s", path, strerror(errno));
  int err = VF_OK;
  uint8_t *buf = NULL;
  struct stat st;
  if (fstat(fd, &st) != 0) {
    err = vf_error_set(VF_EIO, "%s: %s", path, strerror(errno));
    goto close_fd;
  }
  if (!S_ISREG(st.st_mode)) {
    err = vf_error_set(VF_EINVAL, "%s: not a regular file", path);
    goto close_fd;
  }
  if ((uint64_t)st.st_size > max) {
    err = vf_error_set(VF_EINVAL, "%s: %lld bytes, more than the limit of %zu", path, (long long)st.st_size, max);
    goto close_fd;
  }
  size_t size = (size_t)st.st_size, got = 0;
  if ((buf = malloc(size + 1)) == NULL) {
    err = vf_error_set(VF_ENOMEM, "%s: cannot hold %zu bytes", path, size);
    goto close_fd;
  }
  while (got < size) {
    ssize_t n = read(fd, buf + got, size - got);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      err = vf_error_set(VF_EIO, "%s: %s", path, n < 0 ? strerror(errno) : "file shrank while reading");
      goto free_buf;
    }
    got += (size_t)n;
  }
  buf[size] = '\0';
  *data = buf;
  *len = size;
  close(fd);
  return VF_OK;
free_buf:
  free(buf);
close_fd:
  close(fd);
  return err;
}

int vf_file_write_atomic(const char *path, const void *data, size_t len, unsigned mode) {
  vf_atomic_file file;
  int err = vf_atomic_open_mode(&file, path, mode);
  if (err == VF_OK && (err = vf_atomic_pwrite(&file, data, len, 0)) != VF_OK) vf_atomic_abort(&file);
  return err == VF_OK ? vf_atomic_commit(&file) : err;
}

int vf_file_temp_dir(const char *name, char *out, size_t n) {
  const char *tmp = getenv("TMPDIR");
  if (snprintf(out, n, "%s/%s-XXXXXX", tmp && tmp[0] ? tmp : "/tmp", name) >= (int)n)
    return vf_error_set(VF_EINVAL, "TMPDIR too long");
  if (mkdtemp(out) == NULL) return vf_error_set(VF_EIO, "%s: %s", out, strerror(errno));
  return VF_OK;
}

static int remove_entry(const char *path, const struct stat *sb, int flag, struct FTW *ftw) {
  (void)sb, (void)flag, (void)ftw;
  remove(path);
  return 0;
}

void vf_file_remove_tree(const char *dir) { nftw(dir, remove_entry, 16, FTW_DEPTH | FTW_PHYS); }
