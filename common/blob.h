/* Blobs: the files a JSON scene names (meshes, the files a mesh file pulls in such as glTF
 * buffers or OBJ material libraries, environment maps), kept and sent by content hash.
 *
 * A blob is named by BLAKE2b-256 of its bytes (libsodium, as the scene hash), so a store
 * needs no other index, a blob is stored once however many jobs use it, and any copy can
 * be checked against its name. A store is a directory holding DIR/blobs/HEX, one file per
 * blob (HEX: 64 lower-case hex digits); the coordinator's state directory, a worker's
 * cache and `submit`'s private staging directory are all stores. Nothing in a store is
 * ever named by a path that came from a peer: the file name is the hex of a hash.
 *
 * A blob table maps the names a scene's loader asks for (exactly as it asks: the scene's
 * "file" strings, and the paths mesh files derive from them) to blobs. Names are keys,
 * never opened as paths on a worker or the coordinator (worker/scene/files.h), so a name
 * such as "../meshes/bunny.ply" is as harmless as any other; names are still checked as
 * untrusted text (length, control characters, uniqueness). */
#ifndef VF_BLOB_H
#define VF_BLOB_H

#include "proto/vcmfarm.pb-c.h"
#include "wire.h"

#include <stddef.h>
#include <stdint.h>
#include <time.h>

/* A blob travels in chunks of at most VF_BLOB_CHUNK_BYTES, one per message, well under
 * the coordinator's request cap (VF_WIRE_MAX_REQUEST); a file can be up to 4 GiB. */
#define VF_BLOB_CHUNK_BYTES ((size_t)4 << 20) /* 16 MiB until protocol 7 */
#define VF_BLOB_MAX_BYTES ((uint64_t)4 << 30)
#define VF_BLOB_MAX_FILES 1024 /* per scene */
#define VF_BLOB_MAX_NAME 1023  /* bytes */
/* Blob stores of both roles have the same layout (DIR/blobs/), so each says what it is: a
 * worker's cache holds this file (worker/blob_cache.h), a coordinator's state directory
 * its lock file (coordinator/state.h), and neither role opens the other's directory,
 * whose files it would otherwise evict or collect. */
#define VF_BLOB_CACHE_MARKER "vcmfarm-worker-cache"
#define VF_STATE_MARKER "lock" /* coordinator/state.c: vf_state_lock, from its first start */

typedef struct {
  char *name; /* owned by the table */
  uint8_t hash[32];
  uint64_t size;
} vf_blob_ref;

typedef struct {
  vf_blob_ref *refs; /* owned; count entries, names unique */
  size_t count;
} vf_blob_table;

/* BLAKE2b-256 of n bytes, and its lower-case hex (65 bytes with the NUL). */
void vf_blob_hash(const void *data, size_t n, uint8_t hash[32]);
void vf_blob_hex(const uint8_t hash[32], char hex[65]);

/* DIR/blobs/HEX into out. VF_EINVAL when it does not fit. */
int vf_blob_path(const char *dir, const uint8_t hash[32], char *out, size_t n);

/* 1 when store `dir` holds a file for hash, with *size (may be NULL) its size; 0 when not.
 * Does not read or check the bytes. */
int vf_blob_store_has(const char *dir, const uint8_t hash[32], uint64_t *size);

/* Stores n bytes under hash after checking that they hash to it (VF_EMISMATCH, naming
 * both hashes, when they do not; VF_EINVAL above VF_BLOB_MAX_BYTES), all at once. Creates DIR/blobs if
 * needed; writes atomically (common/file.h), so concurrent writers of one blob, and a crash
 * at any moment, leave either no file or the whole one. A blob already held is not
 * written again (unless the copy held is damaged). VF_EIO on failure. */
int vf_blob_store_put(const char *dir, const uint8_t hash[32], const void *data, size_t n);

/* Reads the blob of hash and checks its bytes: *data (malloc'ed, the caller frees) and
 * *n on success only. VF_ENOENT when the store does not hold it, VF_EMISMATCH when its
 * bytes no longer hash to its name (a damaged store), VF_EIO. */
int vf_blob_store_get(const char *dir, const uint8_t hash[32], uint8_t **data, size_t *n);

/* Checks the stored blob against its name, reading it in pieces (never whole in memory).
 * *size (may be NULL) its size on success; VF_ENOENT, VF_EMISMATCH (damaged), VF_EIO. */
int vf_blob_store_check(const char *dir, const uint8_t hash[32], uint64_t *size);

/* Reads up to max bytes of the stored blob from offset, unchecked (a receiver checks the
 * whole): *data (malloc'ed, the caller frees), *n and *total (the blob's size) on success
 * only. VF_ENOENT, VF_EINVAL (offset past the end), VF_EIO. */
int vf_blob_store_read(const char *dir, const uint8_t hash[32], uint64_t offset, size_t max, uint8_t **data,
                       size_t *n, uint64_t *total);

/* A blob arriving in chunks, in order, into DIR/blobs/HEX.TAG.part (TAG: the transfer's
 * id, so that concurrent transfers of one blob do not mix). A chunk at offset 0 starts the
 * part again; any other must start where the part ends. Once the part holds `total` bytes
 * they are checked against the name and the part becomes the blob (fsync, rename), and
 * *complete is set (else cleared). VF_EINVAL (out of order, past total, total above
 * VF_BLOB_MAX_BYTES), VF_EMISMATCH (complete but hashing to another name: the part is
 * removed), VF_EIO. Creates DIR/blobs if needed. */
int vf_blob_store_append(const char *dir, const uint8_t hash[32], uint64_t tag, uint64_t offset, uint64_t total,
                         const void *data, size_t n, int *complete);

/* A blob of a store as vf_blob_store_list sees it. */
typedef struct {
  uint8_t hash[32];
  uint64_t size;
  struct timespec modified; /* its last write, or its last use where the owner touches it */
} vf_blob_entry;

/* The blobs of store `dir` (not parts of transfers): *entries (malloc'ed, the caller
 * frees; NULL when none) and *n. An absent store is empty. VF_ENOMEM, VF_EIO. */
int vf_blob_store_list(const char *dir, vf_blob_entry **entries, size_t *n);

/* Removes the blob of hash from the store: VF_OK, or VF_EIO (absent included). */
int vf_blob_store_remove(const char *dir, const uint8_t hash[32]);

/* Removes parts of transfers that never completed, those untouched for min_age seconds
 * (another process may still be writing younger ones). */
void vf_blob_store_clean_parts(const char *dir, double min_age);

/* Checks a name as untrusted text: 1 to VF_BLOB_MAX_NAME bytes, no control characters.
 * VF_EINVAL with a detail. */
int vf_blob_check_name(const char *name);

/* Appends name -> (hash, size) to the table after checking the name, its uniqueness, the
 * size and the table's length. VF_EINVAL with a detail naming the file, or VF_ENOMEM. */
int vf_blob_table_add(vf_blob_table *table, const char *name, const uint8_t hash[32], uint64_t size);
/* The entry named `name`, or NULL. */
const vf_blob_ref *vf_blob_table_find(const vf_blob_table *table, const char *name);
/* Frees the entries; the table is then empty. NULL-safe. */
void vf_blob_table_clear(vf_blob_table *table);

/* A table from the wire (Scene.files), every field checked: hash of 32 bytes, size at most
 * VF_BLOB_MAX_BYTES, names as vf_blob_table_add. *out on success only; VF_EINVAL naming
 * the entry (files[i]) and the problem. */
int vf_blob_table_from_wire(Vcmfarm__BlobRef *const *refs, size_t n, vf_blob_table *out);

/* The table as wire entries: *storage and *ptrs are malloc'ed (the caller frees both; the
 * entries borrow the table's names and hashes). Nothing allocated when the table is empty. */
int vf_blob_table_to_wire(const vf_blob_table *table, Vcmfarm__BlobRef **storage, Vcmfarm__BlobRef ***ptrs);

/* The table as a JSON file ([{"name", "hash", "size"}...]), written atomically, and read
 * back with every entry checked as untrusted. VF_EIO / VF_ENOENT / VF_EINVAL. */
int vf_blob_table_save(const vf_blob_table *table, const char *path);
int vf_blob_table_load(const char *path, vf_blob_table *out);

#endif
