#include "atomic_file.h"

#include "error.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static void release(vf_atomic_file *file) {
  free(file->tmp_path);
  free(file->path);
  memset(file, 0, sizeof *file);
  file->fd = -1;
}

/* Copies the two names into file, which owns nothing yet. */
static int take_names(vf_atomic_file *file, const char *path, const char *tmp_path) {
  memset(file, 0, sizeof *file);
  file->fd = -1;
  if (path == NULL || path[0] == '\0') return vf_error_set(VF_EINVAL, "empty output path");
  size_t n = strlen(path) + 32;
  file->path = strdup(path);
  file->tmp_path = tmp_path ? strdup(tmp_path) : malloc(n);
  if (file->path == NULL || file->tmp_path == NULL) {
    release(file);
    return vf_error_set(VF_ENOMEM, "%s: out of memory", path);
  }
  if (tmp_path == NULL) snprintf(file->tmp_path, n, "%s.tmp.%ld", path, (long)getpid());
  return VF_OK;
}

/* Opens the temporary file with flags; nothing is left to remove when this fails. */
static int open_tmp(vf_atomic_file *file, int flags, unsigned mode) {
  file->fd = open(file->tmp_path, flags | O_CREAT | O_CLOEXEC, (mode_t)mode);
  if (file->fd >= 0) return VF_OK;
  int err =
      vf_error_set(VF_EIO, "%s: cannot create temporary file %s: %s", file->path, file->tmp_path, strerror(errno));
  release(file); /* nothing was created: do not unlink someone else's file */
  return err;
}

int vf_atomic_open_mode(vf_atomic_file *file, const char *path, unsigned mode) {
  int err = take_names(file, path, NULL);
  return err != VF_OK ? err : open_tmp(file, O_WRONLY | O_TRUNC, mode);
}

int vf_atomic_open(vf_atomic_file *file, const char *path) { return vf_atomic_open_mode(file, path, 0666); }

int vf_atomic_resume(vf_atomic_file *file, const char *path, const char *tmp_path, unsigned mode, int restart,
                     uint64_t *size) {
  int err = take_names(file, path, tmp_path);
  if (err != VF_OK || (err = open_tmp(file, O_RDWR | (restart ? O_TRUNC : 0), mode)) != VF_OK) return err;
  struct stat st;
  if (fstat(file->fd, &st) != 0) {
    err = vf_error_set(VF_EIO, "%s: %s", file->tmp_path, strerror(errno));
    vf_atomic_abort(file);
    return err;
  }
  *size = (uint64_t)st.st_size;
  return VF_OK;
}

int vf_atomic_pwrite(vf_atomic_file *file, const void *buf, uint64_t size, uint64_t offset) {
  const char *p = buf;
  while (size > 0) {
    ssize_t w = pwrite(file->fd, p, size, (off_t)offset);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0)
      return vf_error_set(VF_EIO, "%s: write failed: %s", file->path, w < 0 ? strerror(errno) : "no progress");
    p += w;
    size -= (uint64_t)w;
    offset += (uint64_t)w;
  }
  return VF_OK;
}

void vf_atomic_abort(vf_atomic_file *file) {
  if (file->fd >= 0) close(file->fd);
  if (file->tmp_path) unlink(file->tmp_path);
  release(file);
}

void vf_atomic_suspend(vf_atomic_file *file) {
  if (file->fd >= 0) close(file->fd);
  release(file);
}

/* The rename is durable only once the directory entry is. */
static int sync_parent_dir(const char *path) {
  const char *slash = strrchr(path, '/');
  char *dir = slash ? strndup(path, (size_t)(slash - path) + (slash == path)) : strdup(".");
  if (dir == NULL) return vf_error_set(VF_ENOMEM, "%s: out of memory", path);
  int err = VF_OK, fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0 || fsync(fd) != 0)
    err = vf_error_set(VF_EIO, "%s: cannot sync the directory %s: %s", path, dir, strerror(errno));
  if (fd >= 0) close(fd);
  free(dir);
  return err;
}

/* Steps 3 to 5, the temporary file put in place by rename (over PATH) or, when PATH must
 * not be replaced, by link (refused when PATH exists) and unlink. */
static int put_in_place(vf_atomic_file *file, int replace) {
  int err = VF_OK;
  if (fsync(file->fd) != 0) {
    err = vf_error_set(VF_EIO, "%s: fsync failed: %s", file->path, strerror(errno));
    goto fail;
  }
  int fd = file->fd;
  file->fd = -1;
  if (close(fd) != 0) {
    err = vf_error_set(VF_EIO, "%s: close failed: %s", file->path, strerror(errno));
    goto fail;
  }
  if (!replace && link(file->tmp_path, file->path) != 0) {
    err = errno == EEXIST ? vf_error_set(VF_EINVAL, "%s: exists already; not replacing it", file->path)
                          : vf_error_set(VF_EIO, "%s: cannot link %s into place: %s", file->path, file->tmp_path,
                                         strerror(errno));
    goto fail;
  }
  if (replace && rename(file->tmp_path, file->path) != 0) {
    err = vf_error_set(VF_EIO, "%s: cannot rename %s into place: %s", file->path, file->tmp_path, strerror(errno));
    goto fail;
  }
  if (!replace) unlink(file->tmp_path); /* PATH holds the bytes now */
  err = sync_parent_dir(file->path);
  release(file); /* in place: nothing to remove */
  return err;
fail:
  vf_atomic_abort(file);
  return err;
}

int vf_atomic_commit(vf_atomic_file *file) { return put_in_place(file, 1); }

int vf_atomic_commit_new(vf_atomic_file *file) { return put_in_place(file, 0); }
