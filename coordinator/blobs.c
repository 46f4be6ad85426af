#include "blobs.h"

#include "../common/allocation.h"
#include "../common/error.h"
#include "log.h"

#include <sodium.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#define BAD_REQUEST VCMFARM__ERROR_CODE__ERROR_BAD_REQUEST

struct vf_blob_checked {
  uint8_t hash[32];
  off_t size;
  struct timespec mtime;
};

/* Records a blob as intact in the version `st` describes (taken before it was checked: a
 * change since makes it another version). Out of memory, it is simply not remembered. */
static void remember(vf_farm *farm, size_t i, const uint8_t hash[32], const struct stat *st) {
  if (i == farm->num_checked) {
    if (farm->num_checked == farm->checked_capacity) {
      size_t cap = farm->checked_capacity ? 2 * farm->checked_capacity : 64;
      struct vf_blob_checked *grown = realloc(farm->checked, cap * sizeof *grown);
      if (grown == NULL) return;
      farm->checked = grown;
      farm->checked_capacity = cap;
    }
    farm->num_checked++;
  }
  memcpy(farm->checked[i].hash, hash, 32);
  farm->checked[i].size = st->st_size;
  farm->checked[i].mtime = st->st_mtim;
}

static size_t find_checked(const vf_farm *farm, const uint8_t hash[32]) {
  size_t i = 0;
  while (i < farm->num_checked && memcmp(farm->checked[i].hash, hash, 32) != 0) i++;
  return i;
}

/* vf_blob_store_check, skipped for a blob found intact before and unchanged since. */
static int check_blob(vf_farm *farm, const uint8_t hash[32], uint64_t *size) {
  char path[4200];
  struct stat st;
  const char *dir = farm->config.state_dir;
  int err = vf_blob_path(dir, hash, path, sizeof path), known = stat(path, &st) == 0;
  if (err != VF_OK) return err;
  size_t i = find_checked(farm, hash);
  if (known && i < farm->num_checked && farm->checked[i].size == st.st_size &&
      farm->checked[i].mtime.tv_sec == st.st_mtim.tv_sec && farm->checked[i].mtime.tv_nsec == st.st_mtim.tv_nsec) {
    if (size) *size = (uint64_t)st.st_size;
    return VF_OK;
  }
  if ((err = vf_blob_store_check(dir, hash, size)) != VF_OK || !known) {
    if (i < farm->num_checked) farm->checked[i] = farm->checked[--farm->num_checked];
    return err;
  }
  remember(farm, i, hash, &st);
  return VF_OK;
}

int vf_blobs_named(const vf_farm *farm, const uint8_t hash[32], const vf_job *except) {
  for (size_t i = 0; i < farm->num_jobs; i++) {
    const vf_job *j = farm->jobs[i];
    if (j == except) continue;
    for (size_t k = 0; k < j->files.count; k++)
      if (memcmp(j->files.refs[k].hash, hash, 32) == 0) return 1;
    if (j->film->samples != NULL && memcmp(j->allocation_hash, hash, 32) == 0) return 1;
  }
  return 0;
}

unsigned vf_blobs_collect(const vf_farm *farm, double min_age) {
  vf_blob_entry *blobs;
  size_t count;
  if (vf_blob_store_list(farm->config.state_dir, &blobs, &count) != VF_OK) return 0;
  unsigned removed = 0;
  time_t now = time(NULL);
  for (size_t i = 0; i < count; i++) {
    double age = difftime(now, blobs[i].modified.tv_sec);
    if (age < min_age || vf_blobs_named(farm, blobs[i].hash, NULL) ||
        vf_blob_store_remove(farm->config.state_dir, blobs[i].hash) != VF_OK)
      continue;
    char hex[65];
    vf_blob_hex(blobs[i].hash, hex);
    vf_log("removed blob %s: no job names it (%llu bytes, unchanged for %.0f h)", hex,
           (unsigned long long)blobs[i].size, age / 3600.0);
    removed++;
  }
  free(blobs);
  return removed;
}

int vf_blobs_attach(const vf_farm *farm, vf_job *job, const Vcmfarm__Scene *scene) {
  if (scene->n_files == 0) return VF_OK;
  if (scene->source_case == VCMFARM__SCENE__SOURCE_BUILTIN)
    return vf_error_set(VF_EINVAL, "scene: a built-in scene has no files; the job names %zu", scene->n_files);
  vf_blob_table files;
  int err = vf_blob_table_from_wire(scene->files, scene->n_files, &files);
  if (err != VF_OK) return vf_error_set(err, "scene.%s", vf_error_detail(err));
  for (size_t i = 0; i < files.count; i++) {
    const vf_blob_ref *ref = &files.refs[i];
    char hex[65];
    uint64_t size;
    vf_blob_hex(ref->hash, hex);
    if (!vf_blob_store_has(farm->config.state_dir, ref->hash, &size))
      err = vf_error_set(VF_EINVAL, "scene.files[%zu]: file '%s': the coordinator has no blob %s (send it first)", i,
                         ref->name, hex);
    else if (size != ref->size)
      err = vf_error_set(VF_EINVAL, "scene.files[%zu]: file '%s': %llu bytes, the blob %.16s... has %llu", i,
                         ref->name, (unsigned long long)ref->size, hex, (unsigned long long)size);
    if (err != VF_OK) {
      vf_blob_table_clear(&files);
      return err;
    }
  }
  vf_blob_table_clear(&job->files);
  job->files = files;
  return VF_OK;
}

/* A blob a request names by reference (`what` in errors): a hash of 32 bytes, held
 * undamaged, of the size the reference says. */
static int check_ref(vf_farm *farm, const Vcmfarm__BlobRef *ref, const char *what) {
  if (ref->hash.len != 32) return vf_error_set(VF_EINVAL, "%s: hash of %zu bytes, expected 32", what, ref->hash.len);
  char hex[65];
  vf_blob_hex(ref->hash.data, hex);
  uint64_t size;
  int err = check_blob(farm, ref->hash.data, &size);
  if (err == VF_ENOENT) return vf_error_set(VF_EINVAL, "%s: the coordinator has no blob %s (send it first)", what, hex);
  if (err != VF_OK) return err == VF_EMISMATCH ? vf_error_set(VF_EIO, "%s: %s", what, vf_error_detail(err)) : err;
  if (size != ref->size)
    return vf_error_set(VF_EINVAL, "%s: %llu bytes, the blob %.16s... has %llu", what, (unsigned long long)ref->size,
                        hex, (unsigned long long)size);
  return VF_OK;
}

int vf_blobs_reference(vf_farm *farm, const Vcmfarm__BlobRef *ref) { return check_ref(farm, ref, "reference"); }

int vf_blobs_scene_text(vf_farm *farm, const Vcmfarm__BlobRef *ref, char **text, size_t *len) {
  if (ref->hash.len != 32) return vf_error_set(VF_EINVAL, "scene text: hash of %zu bytes, expected 32", ref->hash.len);
  if (ref->size == 0 || ref->size > VF_JOB_MAX_SCENE)
    return vf_error_set(VF_EINVAL, "scene text: %llu bytes, must be 1 to %zu", (unsigned long long)ref->size,
                        VF_JOB_MAX_SCENE);
  int err = check_ref(farm, ref, "scene text");
  if (err != VF_OK) return err;
  uint8_t *bytes;
  size_t n;
  uint64_t total;
  if ((err = vf_blob_store_read(farm->config.state_dir, ref->hash.data, 0, (size_t)ref->size, &bytes, &n, &total)) !=
      VF_OK)
    return err;
  char *t = realloc(bytes, n + 1);
  if (t == NULL) {
    free(bytes);
    return vf_error_set(VF_ENOMEM, "out of memory for a scene text of %zu bytes", n);
  }
  t[n] = '\0';
  if (strlen(t) != n) {
    free(t);
    char hex[65];
    vf_blob_hex(ref->hash.data, hex);
    return vf_error_set(VF_EINVAL, "scene text: blob %.16s... holds a NUL byte", hex);
  }
  *text = t;
  *len = n;
  return VF_OK;
}

int vf_blobs_lease(const vf_job *job, vf_farm_reply *r) {
  int err = vf_blob_table_to_wire(&job->files, &r->file_refs, &r->file_ref_ptrs);
  if (err != VF_OK) return err;
  r->scene.n_files = job->files.count;
  r->scene.files = r->file_ref_ptrs;
  return VF_OK;
}

int vf_blobs_allocation(vf_farm *farm, const Vcmfarm__BlobRef *ref, size_t pixels, uint8_t **samples) {
  if (ref->size != (uint64_t)pixels)
    return vf_error_set(VF_EINVAL, "allocation: %llu counts, the job's film has %zu pixels (one count a pixel)",
                        (unsigned long long)ref->size, pixels);
  int err = check_ref(farm, ref, "allocation");
  if (err != VF_OK) return err;
  uint8_t *bytes;
  size_t n;
  uint64_t total;
  if ((err = vf_blob_store_read(farm->config.state_dir, ref->hash.data, 0, pixels, &bytes, &n, &total)) != VF_OK)
    return err;
  /* The counts are opaque here: their validity is allocation.h's to say. */
  if (n != pixels || total != (uint64_t)pixels)
    err = vf_error_set(VF_EIO, "allocation: read %zu of %zu counts from the blob store", n, pixels);
  else
    err = vf_allocation_validate(bytes, pixels, "allocation");
  if (err != VF_OK) {
    free(bytes);
    return err;
  }
  *samples = bytes;
  return VF_OK;
}

int vf_blobs_put_allocation(vf_farm *farm, const vf_job *job) {
  if (job->film->samples == NULL) return VF_OK;
  if (check_blob(farm, job->allocation_hash, NULL) == VF_OK) return VF_OK;
  size_t pixels = (size_t)job->film->width * (size_t)job->film->height;
  int err = vf_blob_store_put(farm->config.state_dir, job->allocation_hash, job->film->samples, pixels);
  if (err != VF_OK)
    return vf_error_set(err, "job %llu: storing its allocation of camera sub-paths: %s", (unsigned long long)job->id,
                        vf_error_detail(err));
  return VF_OK;
}

void vf_blobs_query(vf_farm *farm, const Vcmfarm__BlobQuery *m, vf_farm_reply *r) {
  if (m->n_hashes > VF_BLOB_MAX_FILES)
    return vf_farm_reply_errorf(r, BAD_REQUEST, "blob query of %zu hashes, at most %d", m->n_hashes, VF_BLOB_MAX_FILES);
  for (size_t i = 0; i < m->n_hashes; i++)
    if (m->hashes[i].len != 32)
      return vf_farm_reply_errorf(r, BAD_REQUEST, "blob query: hashes[%zu] is %zu bytes, expected 32", i, m->hashes[i].len);
  vcmfarm__blob_have__init(&r->blob_have);
  if (m->n_hashes > 0 && (r->missing = calloc(m->n_hashes, sizeof *r->missing)) == NULL)
    return vf_farm_reply_fail(r, vf_error_set(VF_ENOMEM, "out of memory"));
  /* Each held blob is read and checked: a query comes once per submission, and a damaged
   * copy found here is dropped and reported missing, so the client sends it again. */
  for (size_t i = 0; i < m->n_hashes; i++) {
    int err = check_blob(farm, m->hashes[i].data, NULL);
    if (err == VF_EMISMATCH) {
      char path[4200];
      vf_log("%s; removed, the client will send it again", vf_error_detail(err));
      if (vf_blob_path(farm->config.state_dir, m->hashes[i].data, path, sizeof path) == VF_OK) unlink(path);
    }
    if (err != VF_OK) r->missing[r->blob_have.n_missing++] = m->hashes[i]; /* borrowed from the request */
  }
  r->blob_have.missing = r->missing;
  r->env.body_case = VCMFARM__ENVELOPE__BODY_BLOB_HAVE;
  r->env.blob_have = &r->blob_have;
}

void vf_blobs_put(vf_farm *farm, const Vcmfarm__BlobPut *m, vf_farm_reply *r) {
  if (m->hash.len != 32) return vf_farm_reply_errorf(r, BAD_REQUEST, "blob put: hash of %zu bytes, expected 32", m->hash.len);
  if (m->data.len > VF_BLOB_CHUNK_BYTES)
    return vf_farm_reply_errorf(r, BAD_REQUEST, "blob put: a chunk of %zu bytes, at most %zu", m->data.len,
                                VF_BLOB_CHUNK_BYTES);
  char hex[65];
  vf_blob_hex(m->hash.data, hex);
  int complete;
  int err = vf_blob_store_append(farm->config.state_dir, m->hash.data, m->transfer_id, m->offset, m->total_size,
                                 m->data.data, m->data.len, &complete);
  if (err != VF_OK) {
    vf_log("refused a blob chunk: %s", vf_error_detail(err));
    return vf_farm_reply_fail(r, err);
  }
  if (complete) {
    char path[4200];
    struct stat st; /* checked whole as it arrived */
    if (vf_blob_path(farm->config.state_dir, m->hash.data, path, sizeof path) == VF_OK && stat(path, &st) == 0)
      remember(farm, find_checked(farm, m->hash.data), m->hash.data, &st);
    vf_log("stored blob %s (%llu bytes)", hex, (unsigned long long)m->total_size);
    snprintf(r->text, sizeof r->text, "blob %s stored", hex);
  } else {
    snprintf(r->text, sizeof r->text, "blob %s: %llu of %llu bytes", hex,
             (unsigned long long)(m->offset + m->data.len), (unsigned long long)m->total_size);
  }
  vf_farm_reply_ack(r, 1, r->text);
}

void vf_blobs_request(vf_farm *farm, const vf_farm_worker *w, const Vcmfarm__BlobRequest *m, vf_farm_reply *r) {
  if (m->hash.len != 32) return vf_farm_reply_errorf(r, BAD_REQUEST, "blob request: hash of %zu bytes, expected 32", m->hash.len);
  char hex[65];
  vf_blob_hex(m->hash.data, hex);
  uint8_t *bytes = NULL;
  size_t len = 0;
  uint64_t total = 0;
  const char *dir = farm->config.state_dir;
  int err = m->offset == 0 ? check_blob(farm, m->hash.data, NULL) : VF_OK;
  if (err == VF_OK) err = vf_blob_store_read(dir, m->hash.data, m->offset, VF_BLOB_CHUNK_BYTES, &bytes, &len, &total);
  if (err != VF_OK) {
    vf_log("worker %s asked for blob %s at %llu: %s", w->name, hex, (unsigned long long)m->offset,
           vf_error_detail(err));
    /* Short details: the worker's failure message carries them into the job's status. A
     * damaged blob in the store is the coordinator's failure, not the request's. */
    if (err == VF_ENOENT) err = vf_error_set(VF_ENOENT, "the coordinator has no blob %s", hex);
    else if (err == VF_EMISMATCH) err = vf_error_set(VF_EIO, "blob %.16s... is damaged in the coordinator's store", hex);
    return vf_farm_reply_fail(r, err);
  }
  if (m->offset + len == total)
    vf_log("served blob %s (%llu bytes) to worker %s", hex, (unsigned long long)total, w->name);
  vcmfarm__blob__init(&r->blob);
  r->blob_bytes = bytes;
  r->blob.hash = m->hash;
  r->blob.data.data = bytes;
  r->blob.data.len = len;
  r->blob.offset = m->offset;
  r->blob.total_size = total;
  r->env.body_case = VCMFARM__ENVELOPE__BODY_BLOB;
  r->env.blob = &r->blob;
}
