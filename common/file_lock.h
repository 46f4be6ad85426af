/* Advisory locks on the file a command extends or replaces, so that two vcmfarm processes
 * never write one film at the same time (two `continue`s, or `continue` beside `merge -o`,
 * would each write the film without the other's iterations: work lost without an error).
 *
 * The lock is an flock(2) on a lock file beside the path, DIR/.NAME.vcmfarm-lock, not on
 * the file itself: films are replaced by rename (common/atomic_file.h), which gives the
 * path a new inode, and a lock on the old one would guard nothing. The lock file holds the
 * holder's pid and command, for the error the second writer gets. The kernel drops the
 * lock when its process dies, so a killed render never leaves a film locked; the file it
 * leaves is taken over by the next writer. Only vcmfarm processes take these locks.
 *
 * Links must not let a second writer in: the lock file is beside the path with its
 * symbolic links resolved (a symlink to a film takes the film's lock), and the film itself,
 * when it exists, is flock'ed too, so that a hard link (another name of the same inode) is
 * refused as well while the holder keeps that inode open. */
#ifndef VF_FILE_LOCK_H
#define VF_FILE_LOCK_H

typedef struct {
  int fd;      /* -1: not held */
  char *path;  /* owned: the lock file's path; NULL: not held (the other fields unused) */
  int film_fd; /* the film as it was when locked, flock'ed; -1 when there was none */
} vf_file_lock;

/* Takes the lock for `path` without waiting; `holder` (e.g. "continue") is recorded.
 * VF_EBUSY naming the path and the process that holds it; VF_EIO when the lock file
 * cannot be made; VF_ENOMEM. *lock is written only on success. */
int vf_file_lock_acquire(const char *path, const char *holder, vf_file_lock *lock);

/* Releases a lock taken by vf_file_lock_acquire and removes its file; a lock that is not
 * held (fd -1, or zeroed) is a no-op. */
void vf_file_lock_release(vf_file_lock *lock);

#endif
