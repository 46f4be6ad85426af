#include "file_lock.h"

#include "error.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

/* The path of the file that `path` names, symbolic links resolved: realpath of the file
 * when it exists, else of its directory joined with its name; `path` itself when neither
 * resolves (the open will fail and say why). Links to one film thus share one lock file. */
static char *resolved_path(const char *path) {
  char *real = realpath(path, NULL);
  if (real != NULL) return real;
  const char *slash = strrchr(path, '/');
  const char *name = slash ? slash + 1 : path;
  char *dir = slash ? strndup(path, (size_t)(slash - path + 1)) : strdup(".");
  char *real_dir = dir ? realpath(dir, NULL) : NULL;
  free(dir);
  if (real_dir == NULL) return strdup(path);
  size_t n = strlen(real_dir) + strlen(name) + 2;
  char *out = malloc(n);
  if (out) snprintf(out, n, "%s/%s", real_dir, name);
  free(real_dir);
  return out;
}

/* DIR/.NAME.vcmfarm-lock for DIR/NAME (NAME alone: in the working directory). */
static char *lock_path(const char *path) {
  const char *slash = strrchr(path, '/');
  int dir_len = slash ? (int)(slash - path + 1) : 0;
  const char *name = slash ? slash + 1 : path;
  size_t n = strlen(path) + sizeof "/..vcmfarm-lock";
  char *out = malloc(n);
  if (out) snprintf(out, n, "%.*s.%s.vcmfarm-lock", dir_len, path, name);
  return out;
}

/* The second half of the lock: an flock on the film itself, which every name of it (hard
 * links included) reaches. -1 in *fd when there is no film yet; VF_EBUSY when another
 * writer holds it under another name. */
static int lock_film(const char *path, int *fd) {
  *fd = open(path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (*fd < 0) return VF_OK; /* nothing there yet (or unreadable: its write will say so) */
  struct stat st;
  if (fstat(*fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    close(*fd);
    *fd = -1;
    return VF_OK;
  }
  if (flock(*fd, LOCK_EX | LOCK_NB) == 0) return VF_OK;
  int e = errno;
  close(*fd);
  *fd = -1;
  if (e == EWOULDBLOCK)
    return vf_error_set(VF_EBUSY, "%s is being written by another vcmfarm process under another name (a hard link "
                        "to the same file); try again when it ends", path);
  return vf_error_set(VF_EIO, "%s: cannot lock it: %s", path, strerror(e));
}

int vf_file_lock_acquire(const char *path, const char *holder, vf_file_lock *lock) {
  char *resolved = resolved_path(path);
  char *lp = resolved ? lock_path(resolved) : NULL;
  free(resolved);
  if (lp == NULL) return VF_ENOMEM;
  /* A holder that releases unlinks the file while others may have it open: whoever then
   * locks the unlinked inode sees that the path names another file now, and tries again. */
  for (int attempt = 0; attempt < 100; attempt++) {
    int fd = open(lp, O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) {
      int err = vf_error_set(VF_EIO, "%s: cannot create the lock file %s: %s", path, lp, strerror(errno));
      free(lp);
      return err;
    }
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
      int e = errno;
      char who[128] = "";
      ssize_t got = pread(fd, who, sizeof who - 1, 0);
      close(fd);
      int err;
      if (e == EWOULDBLOCK) {
        who[got > 0 ? got : 0] = '\0';
        who[strcspn(who, "\n")] = '\0';
        err = vf_error_set(VF_EBUSY, "%s is being written by another vcmfarm process (%s); try again when it ends",
                           path, who[0] ? who : "unknown");
      } else {
        err = vf_error_set(VF_EIO, "%s: cannot lock %s: %s", path, lp, strerror(e));
      }
      free(lp);
      return err;
    }
    struct stat held, named;
    if (fstat(fd, &held) == 0 && stat(lp, &named) == 0 && held.st_dev == named.st_dev && held.st_ino == named.st_ino) {
      char who[128];
      int len = snprintf(who, sizeof who, "pid %ld: %s\n", (long)getpid(), holder ? holder : "vcmfarm");
      if (ftruncate(fd, 0) != 0 || pwrite(fd, who, (size_t)len, 0) != len) {
        /* the record is informative only: the lock holds without it */
      }
      int film_fd = -1, err = lock_film(path, &film_fd);
      if (err != VF_OK) {
        unlink(lp); /* while still held, as vf_file_lock_release does */
        close(fd);
        free(lp);
        return err;
      }
      lock->fd = fd;
      lock->path = lp;
      lock->film_fd = film_fd;
      return VF_OK;
    }
    close(fd);
  }
  int err = vf_error_set(VF_EBUSY, "%s: its lock file %s keeps being replaced", path, lp);
  free(lp);
  return err;
}

void vf_file_lock_release(vf_file_lock *lock) {
  if (lock == NULL || lock->path == NULL) return;
  if (lock->film_fd >= 0) close(lock->film_fd);
  if (lock->fd >= 0) {
    unlink(lock->path); /* while still held: see vf_file_lock_acquire */
    close(lock->fd);
  }
  free(lock->path);
  lock->path = NULL;
  lock->fd = lock->film_fd = -1;
}
