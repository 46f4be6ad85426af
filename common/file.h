/* Whole-file reads and atomic whole-file writes, for the small files the farm keeps
 * (keys, coordinator state, scene texts) and for passing films through memory; and the
 * private temporary directories of `submit` and `render`.
 *
 * Atomic writes follow the rule of common/atomic_file.h (docs/FILM.md): "PATH.tmp.<pid>"
 * in the same directory, fsync, rename over PATH, fsync of the directory; on any failure
 * before the rename the temporary file is removed and an existing PATH is left as it was. */
#ifndef VF_FILE_H
#define VF_FILE_H

#include <stddef.h>
#include <stdint.h>

/* Reads all of path into a malloc'ed buffer (NUL-terminated for convenience, the NUL not
 * counted in *len) that the caller frees. VF_ENOENT, VF_EIO, or VF_EINVAL when the file is
 * larger than max bytes; *data and *len are written only on success. */
int vf_file_read_all(const char *path, size_t max, uint8_t **data, size_t *len);

/* Atomically replaces path with len bytes of data, created with permissions `mode`
 * (subject to the umask): a thin wrapper of vf_atomic_open_mode, vf_atomic_pwrite and
 * vf_atomic_commit. VF_EIO (VF_EINVAL for an empty path) with a detail naming the path. */
int vf_file_write_atomic(const char *path, const void *data, size_t len, unsigned mode);

/* A new private directory $TMPDIR/NAME-XXXXXX (/tmp without TMPDIR) into out. VF_EINVAL
 * when the path does not fit, VF_EIO with a detail. */
int vf_file_temp_dir(const char *name, char *out, size_t n);

/* Removes dir and everything below it (not following symbolic links); best effort. */
void vf_file_remove_tree(const char *dir);

#endif
