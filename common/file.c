#define _XOPEN_SOURCE 700 /* nftw */
#include "file.h"

#include "error.h"

#include <errno.h>
#include <fcntl.h>
#include <ftw.h>
#include <libgen.h>
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

static int fsync_parent(const char *path) {
  char *copy = strdup(path);
  if (copy == NULL) return vf_error_set(VF_ENOMEM, "%s: out of memory", path);
  int dfd = open(dirname(copy), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  int err = VF_OK;
  if (dfd < 0 || fsync(dfd) != 0) err = vf_error_set(VF_EIO, "%s: syncing the directory: %s", path, strerror(errno));
  if (dfd >= 0) close(dfd);
  free(copy);
  return err;
}

int vf_file_write_atomic(const char *path, const void *data, size_t len, unsigned mode) {
  char tmp[4096];
  if (snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, (long)getpid()) >= (int)sizeof tmp)
    return vf_error_set(VF_EINVAL, "%s: path too long", path);
  int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, (mode_t)mode);
  if (fd < 0) return vf_error_set(VF_EIO, "%s: %s", tmp, strerror(errno));
  int err = VF_OK;
  const uint8_t *p = data;
  size_t done = 0;
  while (done < len) {
    ssize_t n = write(fd, p + done, len - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      err = vf_error_set(VF_EIO, "%s: %s", tmp, strerror(errno));
      goto remove_tmp;
    }
    done += (size_t)n;
  }
  if (fsync(fd) != 0) {
    err = vf_error_set(VF_EIO, "%s: fsync: %s", tmp, strerror(errno));
    goto remove_tmp;
  }
  if (close(fd) != 0) {
    fd = -1;
    err = vf_error_set(VF_EIO, "%s: close: %s", tmp, strerror(errno));
    goto remove_tmp;
  }
  fd = -1;
  if (rename(tmp, path) != 0) {
    err = vf_error_set(VF_EIO, "%s: rename: %s", path, strerror(errno));
    goto remove_tmp;
  }
  return fsync_parent(path);
remove_tmp:
  if (fd >= 0) close(fd);
  unlink(tmp);
  return err;
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
