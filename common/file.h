/* Whole-file reads and atomic whole-file writes, for the small files the farm keeps
 * (keys, coordinator state, scene texts) and for passing films through memory; and the
 * private temporary directories of `submit` and `render`.
 *
 * Atomic writes follow the rule of docs/FILM.md: the bytes go to "PATH.tmp.<pid>" in the
 * same directory, are fsync'ed, renamed over PATH, and the directory is fsync'ed; on any
 * failure the temporary file is removed and an existing PATH is left as it was. */
#ifndef VF_FILE_H
#define VF_FILE_H

#include <stddef.h>
#include <stdint.h>

/* Reads all of path into a malloc'ed buffer (NUL-terminated for convenience, the NUL not
 * counted in *len) that the caller frees. VF_ENOENT, VF_EIO, or VF_EINVAL when the file is
 * larger than max bytes; *data and *len are written only on success. */
int vf_file_read_all(const char *path, size_t max, uint8_t **data, size_t *len);

/* Atomically replaces path with len bytes of data, created with permissions `mode`
 * (subject to the umask). VF_EIO with a detail naming the path on failure. */
int vf_file_write_atomic(const char *path, const void *data, size_t len, unsigned mode);

/* A new private directory $TMPDIR/NAME-XXXXXX (/tmp without TMPDIR) into out. VF_EINVAL
 * when the path does not fit, VF_EIO with a detail. */
int vf_file_temp_dir(const char *name, char *out, size_t n);

/* Removes dir and everything below it (not following symbolic links); best effort. */
void vf_file_remove_tree(const char *dir);

#endif
