#include "blob_cache.h"

#include "../common/clock.h"
#include "../common/error.h"
#include "scene/job_scene.h"

#include <sodium.h>

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* Generous: a chunk of 16 MiB over a slow link. */
#define BLOB_TIMEOUT_MS 120000

int vf_blob_cache_default_dir(char *out, size_t n) {
  const char *xdg = getenv("XDG_CACHE_HOME"), *home = getenv("HOME");
  int w;
  if (xdg && xdg[0] == '/') w = snprintf(out, n, "%s/vcmfarm", xdg);
  else if (home && home[0]) w = snprintf(out, n, "%s/.cache/vcmfarm", home);
  else return vf_error_set(VF_EINVAL, "neither XDG_CACHE_HOME nor HOME is set: give --cache DIR");
  if (w < 0 || (size_t)w >= n) return vf_error_set(VF_EINVAL, "cache directory name too long: give --cache DIR");
  return VF_OK;
}

int vf_blob_cache_open(const char *cache_dir) {
  char path[4200];
  struct stat st;
  if (snprintf(path, sizeof path, "%s/" VF_STATE_MARKER, cache_dir) < (int)sizeof path && stat(path, &st) == 0)
    return vf_error_set(VF_EUSAGE, "--cache %s is a coordinator's state directory (it holds %s), not a cache", cache_dir,
                        VF_STATE_MARKER);
  if (snprintf(path, sizeof path, "%s/blobs", cache_dir) >= (int)sizeof path)
    return vf_error_set(VF_EIO, "cache directory name too long");
  /* mkdir -p: every prefix ending before a '/', then the whole path. */
  for (char *p = path + 1;; p++) {
    if (*p != '/' && *p != '\0') continue;
    char c = *p;
    *p = '\0';
    if (mkdir(path, 0700) != 0 && errno != EEXIST)
      return vf_error_set(VF_EIO, "cache %s: cannot create %s: %s", cache_dir, path, strerror(errno));
    *p = c;
    if (c == '\0') break;
  }
  if (access(path, W_OK | X_OK) != 0)
    return vf_error_set(VF_EIO, "cache %s: cannot write %s: %s", cache_dir, path, strerror(errno));
  char marker[4200];
  snprintf(marker, sizeof marker, "%s/" VF_BLOB_CACHE_MARKER, cache_dir);
  int fd = open(marker, O_WRONLY | O_CREAT | O_CLOEXEC, 0600);
  if (fd < 0) return vf_error_set(VF_EIO, "cache %s: cannot create %s: %s", cache_dir, marker, strerror(errno));
  close(fd);
  /* Transfers cut short: untouched for a day (other workers may share the cache). */
  vf_blob_store_clean_parts(cache_dir, 86400.0);
  return VF_OK;
}

/* Fetches a blob chunk by chunk into a part of the cache that becomes the blob once
 * complete and checked (vf_blob_store_append). */
static int fetch(vf_farm_client *client, uint64_t worker_id, const char *cache_dir, const vf_blob_ref *ref) {
  char hex[65];
  vf_blob_hex(ref->hash, hex);
  uint64_t transfer;
  randombytes_buf(&transfer, sizeof transfer);
  uint64_t offset = 0;
  int err = VF_OK, complete = 0;
  while (err == VF_OK && !complete) {
    Vcmfarm__BlobRequest m = VCMFARM__BLOB_REQUEST__INIT;
    m.worker_id = worker_id;
    m.hash.data = (uint8_t *)ref->hash;
    m.hash.len = 32;
    m.offset = offset;
    Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply = NULL;
    q.body_case = VCMFARM__ENVELOPE__BODY_BLOB_REQUEST;
    q.blob_request = &m;
    if ((err = vf_farm_request(client, &q, VCMFARM__ENVELOPE__BODY_BLOB, BLOB_TIMEOUT_MS, &reply)) != VF_OK)
      return vf_error_set(err, "file '%s': %s", ref->name, vf_error_detail(err));
    const Vcmfarm__Blob *b = reply->blob;
    if (b->hash.len != 32 || sodium_memcmp(b->hash.data, ref->hash, 32) != 0)
      err = vf_error_set(VF_EMISMATCH, "file '%s': asked for blob %.16s..., got another", ref->name, hex);
    else if (b->total_size != ref->size)
      err = vf_error_set(VF_EMISMATCH, "file '%s' (blob %.16s...): the coordinator's has %llu bytes, the job says %llu",
                         ref->name, hex, (unsigned long long)b->total_size, (unsigned long long)ref->size);
    else if (b->offset != offset || b->data.len > VF_BLOB_CHUNK_BYTES || (b->data.len == 0 && offset < ref->size))
      err = vf_error_set(VF_EPROTO, "file '%s' (blob %.16s...): asked for the chunk at %llu, got %zu bytes at %llu",
                         ref->name, hex, (unsigned long long)offset, b->data.len, (unsigned long long)b->offset);
    else if ((err = vf_blob_store_append(cache_dir, ref->hash, transfer, offset, ref->size, b->data.data, b->data.len,
                                         &complete)) != VF_OK)
      err = vf_error_set(err, "file '%s': %s", ref->name, vf_error_detail(err));
    else
      offset += b->data.len;
    vf_message_free(reply);
  }
  return err;
}

/* Marks a blob used now (its modification time), for vf_blob_cache_trim. */
static void touch(const char *cache_dir, const uint8_t hash[32]) {
  char path[4200];
  if (vf_blob_path(cache_dir, hash, path, sizeof path) == VF_OK) utimensat(AT_FDCWD, path, NULL, 0);
}

static int older_first(const void *a, const void *b) {
  const vf_blob_entry *x = a, *y = b;
  if (x->modified.tv_sec != y->modified.tv_sec) return x->modified.tv_sec < y->modified.tv_sec ? -1 : 1;
  if (x->modified.tv_nsec != y->modified.tv_nsec) return x->modified.tv_nsec < y->modified.tv_nsec ? -1 : 1;
  return memcmp(x->hash, y->hash, 32);
}

unsigned vf_blob_cache_trim(const char *cache_dir, uint64_t max_bytes, const vf_blob_table *keep) {
  vf_blob_entry *blobs;
  size_t count;
  if (max_bytes == 0 || vf_blob_store_list(cache_dir, &blobs, &count) != VF_OK) return 0;
  uint64_t total = 0;
  for (size_t i = 0; i < count; i++) total += blobs[i].size;
  if (count > 0) qsort(blobs, count, sizeof *blobs, older_first);
  unsigned removed = 0;
  for (size_t i = 0; i < count && total > max_bytes; i++) {
    int kept = 0;
    for (size_t k = 0; keep && k < keep->count && !kept; k++) kept = memcmp(keep->refs[k].hash, blobs[i].hash, 32) == 0;
    if (kept || vf_blob_store_remove(cache_dir, blobs[i].hash) != VF_OK) continue;
    total -= blobs[i].size;
    removed++;
  }
  free(blobs);
  return removed;
}

int vf_blob_cache_fill(vf_farm_client *client, uint64_t worker_id, const char *cache_dir, const vf_blob_table *files,
                       int quiet, unsigned *fetched) {
  unsigned count = 0;
  for (size_t i = 0; i < files->count; i++) {
    const vf_blob_ref *ref = &files->refs[i];
    char hex[65];
    uint64_t len;
    vf_blob_hex(ref->hash, hex);
    int err = vf_blob_store_check(cache_dir, ref->hash, &len);
    if (err == VF_OK) {
      if (len == ref->size) {
        touch(cache_dir, ref->hash);
        continue;
      }
      err = vf_error_set(VF_EMISMATCH, "size differs from the job's");
    }
    if (err == VF_EMISMATCH) { /* damaged copy in the cache: replace it */
      fprintf(stderr, "vcmfarm worker %d: cached blob %s: %s; fetching it again\n", (int)getpid(), hex,
              vf_error_detail(err));
      char path[4200];
      if (vf_blob_path(cache_dir, ref->hash, path, sizeof path) == VF_OK) unlink(path);
    } else if (err != VF_ENOENT) {
      return vf_error_set(err, "file '%s': %s", ref->name, vf_error_detail(err));
    }
    double start = vf_seconds_now();
    if ((err = fetch(client, worker_id, cache_dir, ref)) != VF_OK) return err;
    count++;
    if (!quiet)
      fprintf(stderr, "vcmfarm worker %d: fetched blob %s (file '%s', %llu bytes) in %.3f s into the cache %s\n",
            (int)getpid(), hex, ref->name, (unsigned long long)ref->size, vf_seconds_now() - start, cache_dir);
  }
  if (fetched) *fetched = count;
  return VF_OK;
}

int vf_blob_cache_load_scene(vf_farm_client *client, uint64_t worker_id, const char *cache_dir,
                             uint64_t max_bytes, const Vcmfarm__Scene *scene, const char *label, int quiet,
                             vf_scene **out) {
  int builtin = scene->source_case == VCMFARM__SCENE__SOURCE_BUILTIN;
  const char *text = builtin ? scene->builtin : scene->json;
  vf_blob_table files = {0};
  int err = vf_blob_table_from_wire(scene->files, scene->n_files, &files);
  if (err != VF_OK) return vf_error_set(VF_ESCENE, "%s: %s", label, vf_error_detail(err));
  if (files.count > 0 && (err = vf_blob_cache_fill(client, worker_id, cache_dir, &files, quiet, NULL)) != VF_OK)
    err = vf_error_set(err, "%s: %s", label, vf_error_detail(err));
  else if (files.count > 0 && max_bytes > 0) {
    unsigned removed = vf_blob_cache_trim(cache_dir, max_bytes, &files);
    if (removed && !quiet)
      fprintf(stderr, "vcmfarm worker %d: removed %u least recently used blob%s from the cache %s\n", (int)getpid(),
              removed, removed == 1 ? "" : "s", cache_dir);
  }
  if (err == VF_OK)
    err = vf_job_scene_load(builtin, text, strlen(text), &files, cache_dir, label, out);
  vf_blob_table_clear(&files);
  return err;
}
