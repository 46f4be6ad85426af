/* Atomic files: the one way vcmfarm replaces a file, so that a crash, a full disk or a
 * killed process never leaves a half-written film, image, blob or state file.
 *
 * The rule (docs/FILM.md, "Atomic writes"):
 *   1. the bytes go to a temporary file in the same directory as PATH ("PATH.tmp.<pid>", or
 *      a name the caller keeps across calls for a file arriving in pieces, vf_atomic_resume);
 *   2. every write retries EINTR and short writes;
 *   3. the temporary file is fsync'ed, closed and renamed over PATH (or, for a file that
 *      must never replace one, such as a new key, linked to PATH and unlinked: refused
 *      with VF_EINVAL when PATH exists);
 *   4. the directory is fsync'ed (without it the rename may not survive a crash), and its
 *      failure is reported like any other;
 *   5. on every failure before the rename the temporary file is removed and an existing
 *      PATH is left exactly as it was.
 * Errors are VF_EIO (VF_EINVAL for an empty path, VF_ENOMEM) with a detail naming the path.
 * A VF_EIO from step 4 means PATH already holds the new bytes, not yet durably.
 * Two threads of one process must not write the same path at once (they would share the
 * temporary name). */
#ifndef VF_ATOMIC_FILE_H
#define VF_ATOMIC_FILE_H

#include <stddef.h>
#include <stdint.h>

typedef struct {
  char *path;     /* owned copy of the final path */
  char *tmp_path; /* owned: the temporary file, removed by vf_atomic_abort */
  int fd;         /* open on tmp_path, or -1 */
} vf_atomic_file;

/* Creates PATH.tmp.<pid> (emptied if present), permissions 0666 or `mode`, less the umask.
 * On failure file is released (vf_atomic_abort is a no-op on it) and nothing is created. */
int vf_atomic_open(vf_atomic_file *file, const char *path);
int vf_atomic_open_mode(vf_atomic_file *file, const char *path, unsigned mode);

/* Opens tmp_path (NULL: PATH.tmp.<pid>), a temporary file for path that outlives one call
 * (a blob arriving in chunks over several messages, common/blob.c), read-write, created
 * with permissions `mode` when absent and emptied when `restart` is set. *size (written on
 * success only): the bytes it holds. */
int vf_atomic_resume(vf_atomic_file *file, const char *path, const char *tmp_path, unsigned mode, int restart,
                     uint64_t *size);

/* Writes all of buf at offset, retrying EINTR and short writes. The file stays open either
 * way: the caller aborts (or commits) it. */
int vf_atomic_pwrite(vf_atomic_file *file, const void *buf, uint64_t size, uint64_t offset);

/* Steps 3 to 5 of the rule. Releases the file either way. */
int vf_atomic_commit(vf_atomic_file *file);
/* The same without ever replacing an existing PATH: VF_EINVAL "PATH: exists already" then,
 * PATH untouched. Needs a file system with hard links. */
int vf_atomic_commit_new(vf_atomic_file *file);

/* Closes and removes the temporary file; releases the file. No-op on a released file. */
void vf_atomic_abort(vf_atomic_file *file);

/* Closes the temporary file and keeps it for a later vf_atomic_resume; releases the file. */
void vf_atomic_suspend(vf_atomic_file *file);

#endif
