/* Files that check themselves (exr_util.h, VF_EXR_CHECKSUM_ATTR): finding the attribute,
 * hashing the file in parallel segments, writing and verifying the value. */
#define _GNU_SOURCE /* memmem */
#include "error.h"
#include "exr_chunk.h"
#include "exr_util.h"
#include "pool.h"

#include <sodium.h>

#include <errno.h>
#include <fcntl.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* How the attribute is stored in an EXR header: name, type, value size (little-endian
 * 64), then the value. Found by this prefix, which a header holds once. */
static const char checksum_prefix[] = VF_EXR_CHECKSUM_ATTR "\0string\0\x40\0\0";
#define CHECKSUM_PREFIX_LEN (sizeof checksum_prefix) /* the array's own NUL is the size's last byte */
#define CHECKSUM_HEX 64
/* The header comes first, and its attributes (a convergence log included) are far
 * smaller than this: the prefix is looked for within it, block by block. */
#define CHECKSUM_SEARCH (64u << 20)
#define CHECKSUM_SEARCH_BLOCK (64u << 10)
/* The file is hashed in segments of this size in parallel, and the segments' digests
 * together: a tree of two levels, the same whatever the number of threads. */
#define CHECKSUM_SEGMENT (8u << 20)

typedef struct { /* a file on disk (fd) or in memory */
  int fd;
  const uint8_t *memory;
  uint64_t size;
} checksum_source;

static int source_read(const checksum_source *src, uint8_t *buf, size_t n, uint64_t at) {
  if (src->memory) {
    memcpy(buf, src->memory + at, n);
    return VF_OK;
  }
  for (size_t done = 0; done < n;) {
    ssize_t r = pread(src->fd, buf + done, n - done, (off_t)(at + done));
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) return vf_error_set(VF_EIO, "%s", r < 0 ? strerror(errno) : "unexpected end of file");
    done += (size_t)r;
  }
  return VF_OK;
}

/* Where the checksum's value begins: *at; VF_EEXR when there is no such attribute. Blocks
 * overlap by the prefix's length, so a prefix across two blocks is found. */
static int find_checksum(const checksum_source *src, const char *path, uint64_t *at) {
  uint8_t buf[CHECKSUM_SEARCH_BLOCK];
  uint64_t limit = src->size < CHECKSUM_SEARCH ? src->size : CHECKSUM_SEARCH;
  for (uint64_t pos = 0; pos < limit; pos += CHECKSUM_SEARCH_BLOCK - CHECKSUM_PREFIX_LEN) {
    size_t n = limit - pos < CHECKSUM_SEARCH_BLOCK ? (size_t)(limit - pos) : CHECKSUM_SEARCH_BLOCK;
    int err = source_read(src, buf, n, pos);
    if (err != VF_OK) return err;
    const uint8_t *hit = memmem(buf, n, checksum_prefix, CHECKSUM_PREFIX_LEN);
    if (hit != NULL) {
      *at = pos + (uint64_t)(hit - buf) + CHECKSUM_PREFIX_LEN;
      if (*at + CHECKSUM_HEX > src->size) break;
      return VF_OK;
    }
    if (n < CHECKSUM_SEARCH_BLOCK) break;
  }
  return vf_error_set(VF_EEXR, "%s: damaged: no " VF_EXR_CHECKSUM_ATTR " attribute of 64 digits", path);
}

typedef struct {
  const checksum_source *src;
  uint64_t at;          /* the value's 64 bytes, read as '0's */
  uint8_t (*digests)[32];
  _Atomic int error;
} hash_job;

/* Hashes bytes[0, n) of the file at offset pos into state, the value's bytes as '0's. */
static void hash_bytes(crypto_generichash_state *state, const uint8_t *bytes, size_t n, uint64_t pos, uint64_t at) {
  static const uint8_t zeros[CHECKSUM_HEX] = "0000000000000000000000000000000000000000000000000000000000000000";
  uint64_t a = at > pos ? at : pos, b = at + CHECKSUM_HEX < pos + n ? at + CHECKSUM_HEX : pos + n;
  if (a >= b) {
    crypto_generichash_update(state, bytes, n);
    return;
  }
  crypto_generichash_update(state, bytes, (size_t)(a - pos));
  crypto_generichash_update(state, zeros, (size_t)(b - a));
  crypto_generichash_update(state, bytes + (b - pos), (size_t)(pos + n - b));
}

static void hash_segment(void *ctx, size_t segment, int thread) {
  (void)thread;
  enum { STEP = 256 << 10 }; /* read through one small buffer: no page faults per segment */
  hash_job *job = ctx;
  const checksum_source *src = job->src;
  uint64_t first = (uint64_t)segment * CHECKSUM_SEGMENT;
  uint64_t end = src->size - first < CHECKSUM_SEGMENT ? src->size : first + CHECKSUM_SEGMENT;
  crypto_generichash_state state;
  crypto_generichash_init(&state, NULL, 0, 32);
  if (src->memory) {
    hash_bytes(&state, src->memory + first, (size_t)(end - first), first, job->at);
  } else {
    uint8_t *buf = malloc(STEP);
    for (uint64_t pos = first; buf != NULL && pos < end; pos += STEP) {
      size_t n = end - pos < STEP ? (size_t)(end - pos) : STEP;
      if (source_read(src, buf, n, pos) != VF_OK) {
        free(buf);
        buf = NULL;
        break;
      }
      hash_bytes(&state, buf, n, pos, job->at);
    }
    if (buf == NULL) atomic_store(&job->error, 1);
    free(buf);
  }
  crypto_generichash_final(&state, job->digests[segment], 32);
}

/* The checksum of the whole source, the value at `at` read as '0's, into hex: BLAKE2b-256
 * of the segments' BLAKE2b-256 digests in order, and of the file's size. */
static int hash_source(const checksum_source *src, uint64_t at, char hex[CHECKSUM_HEX + 1]) {
  size_t segments = (size_t)((src->size + CHECKSUM_SEGMENT - 1) / CHECKSUM_SEGMENT);
  hash_job job = {src, at, calloc(segments ? segments : 1, 32), 0};
  if (job.digests == NULL) return VF_ENOMEM;
  vf_pool *pool = NULL;
  int threads = vf_exr_chunk_threads(segments);
  if (threads > 1 && vf_pool_create(threads, &pool) == VF_OK) {
    vf_pool_run(pool, segments, hash_segment, &job);
    vf_pool_destroy(pool);
  } else {
    for (size_t i = 0; i < segments; i++) hash_segment(&job, i, 0);
  }
  uint8_t size_le[8], digest[32];
  for (int i = 0; i < 8; i++) size_le[i] = (uint8_t)(src->size >> (8 * i));
  crypto_generichash_state state;
  crypto_generichash_init(&state, NULL, 0, sizeof digest);
  crypto_generichash_update(&state, (const uint8_t *)job.digests, segments * 32);
  crypto_generichash_update(&state, size_le, sizeof size_le);
  crypto_generichash_final(&state, digest, sizeof digest);
  free(job.digests);
  if (atomic_load(&job.error)) return vf_error_set(VF_EIO, "cannot read the file to check its checksum");
  sodium_bin2hex(hex, CHECKSUM_HEX + 1, digest, sizeof digest);
  return VF_OK;
}

int vf_exr_add_checksum(vf_exr_out *out) {
  char pending[CHECKSUM_HEX + 1];
  memset(pending, '0', CHECKSUM_HEX);
  pending[CHECKSUM_HEX] = '\0';
  exr_result_t rv = exr_attr_set_string(out->ctx, 0, VF_EXR_CHECKSUM_ATTR, pending);
  if (rv != EXR_ERR_SUCCESS) return vf_exr_error(out->file.path, rv, "cannot add the checksum attribute");
  out->checksum = 1;
  return VF_OK;
}

int vf_exr_write_checksum(vf_exr_out *out) {
  checksum_source src = {open(out->file.tmp_path, O_RDONLY | O_CLOEXEC), NULL, 0};
  if (src.fd < 0) return vf_error_set(VF_EIO, "%s: %s", out->file.tmp_path, strerror(errno));
  struct stat st;
  int err = fstat(src.fd, &st) == 0 ? VF_OK : vf_error_set(VF_EIO, "%s: %s", out->file.tmp_path, strerror(errno));
  uint64_t at = 0;
  char hex[CHECKSUM_HEX + 1];
  src.size = (uint64_t)st.st_size;
  if (err == VF_OK) err = find_checksum(&src, out->file.path, &at);
  if (err == VF_OK) err = hash_source(&src, at, hex);
  close(src.fd);
  if (err == VF_OK) err = vf_atomic_pwrite(&out->file, hex, CHECKSUM_HEX, at);
  return err;
}

int vf_exr_verify_checksum(const vf_exr_in *in) {
  checksum_source src = {-1, in->memory, in->memory_size};
  if (in->memory == NULL) {
    if ((src.fd = open(in->path, O_RDONLY | O_CLOEXEC)) < 0)
      return vf_error_set(VF_EIO, "%s: %s", in->path, strerror(errno));
    struct stat st;
    if (fstat(src.fd, &st) != 0) {
      close(src.fd);
      return vf_error_set(VF_EIO, "%s: %s", in->path, strerror(errno));
    }
    src.size = (uint64_t)st.st_size;
  }
  uint64_t at = 0;
  char stored[CHECKSUM_HEX + 1], computed[CHECKSUM_HEX + 1];
  int err = find_checksum(&src, in->path, &at);
  if (err == VF_OK) err = source_read(&src, (uint8_t *)stored, CHECKSUM_HEX, at);
  stored[CHECKSUM_HEX] = '\0';
  if (err == VF_OK) err = hash_source(&src, at, computed);
  if (src.fd >= 0) close(src.fd);
  if (err == VF_OK && strcmp(stored, computed) != 0)
    err = vf_error_set(VF_EEXR, "%s: damaged: its checksum does not match its contents", in->path);
  return err;
}

