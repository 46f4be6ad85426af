#include "blob.h"

#include "atomic_file.h"
#include "error.h"
#include "file.h"

#include <cjson/cJSON.h>
#include <sodium.h>

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

void vf_blob_hash(const void *data, size_t n, uint8_t hash[32]) {
  if (sodium_init() < 0) abort(); /* cannot happen once libsodium is linked; never hash garbage */
  crypto_generichash(hash, 32, data, n, NULL, 0);
}

void vf_blob_hex(const uint8_t hash[32], char hex[65]) { sodium_bin2hex(hex, 65, hash, 32); }

int vf_blob_path(const char *dir, const uint8_t hash[32], char *out, size_t n) {
  char hex[65];
  vf_blob_hex(hash, hex);
  int w = snprintf(out, n, "%s/blobs/%s", dir, hex);
  if (w < 0 || (size_t)w >= n) return vf_error_set(VF_EINVAL, "%s: blob store path too long", dir);
  return VF_OK;
}

int vf_blob_store_has(const char *dir, const uint8_t hash[32], uint64_t *size) {
  char path[4200];
  struct stat st;
  if (vf_blob_path(dir, hash, path, sizeof path) != VF_OK || stat(path, &st) != 0 || !S_ISREG(st.st_mode)) return 0;
  if (size) *size = (uint64_t)st.st_size;
  return 1;
}

static int make_dir(const char *path) {
  if (mkdir(path, 0700) == 0 || errno == EEXIST) return VF_OK;
  return vf_error_set(VF_EIO, "%s: cannot create: %s", path, strerror(errno));
}

int vf_blob_store_put(const char *dir, const uint8_t hash[32], const void *data, size_t n) {
  char path[4200], want[65], got[65];
  uint8_t actual[32];
  uint64_t size;
  if ((uint64_t)n > VF_BLOB_MAX_BYTES)
    return vf_error_set(VF_EINVAL, "blob of %zu bytes, at most %llu", n, (unsigned long long)VF_BLOB_MAX_BYTES);
  vf_blob_hash(data, n, actual);
  if (sodium_memcmp(actual, hash, 32) != 0) {
    vf_blob_hex(hash, want);
    vf_blob_hex(actual, got);
    return vf_error_set(VF_EMISMATCH, "blob %s: its %zu bytes hash to %s, not to its name", want, n, got);
  }
  int err;
  if (vf_blob_store_has(dir, hash, &size) && size == n) { /* held: keep it unless damaged */
    uint8_t *held;
    size_t held_len;
    if ((err = vf_blob_store_get(dir, hash, &held, &held_len)) == VF_OK) {
      free(held);
      return VF_OK;
    }
  }
  err = vf_blob_path(dir, hash, path, sizeof path);
  if (err != VF_OK) return err;
  char *slash = strrchr(path, '/');
  *slash = '\0';
  if ((err = make_dir(dir)) != VF_OK || (err = make_dir(path)) != VF_OK) return err;
  *slash = '/';
  return vf_file_write_atomic(path, data, n, 0600);
}

int vf_blob_store_get(const char *dir, const uint8_t hash[32], uint8_t **data, size_t *n) {
  char path[4200], want[65], got[65];
  uint8_t actual[32], *bytes;
  size_t len;
  int err = vf_blob_path(dir, hash, path, sizeof path);
  if (err != VF_OK) return err;
  vf_blob_hex(hash, want);
  if (!vf_blob_store_has(dir, hash, NULL)) return vf_error_set(VF_ENOENT, "no blob %s in %s", want, dir);
  if ((err = vf_file_read_all(path, VF_BLOB_MAX_BYTES, &bytes, &len)) != VF_OK) return err;
  vf_blob_hash(bytes, len, actual);
  if (sodium_memcmp(actual, hash, 32) != 0) {
    free(bytes);
    vf_blob_hex(actual, got);
    return vf_error_set(VF_EMISMATCH, "%s: damaged, its bytes hash to %s", path, got);
  }
  *data = bytes;
  *n = len;
  return VF_OK;
}

/* BLAKE2b-256 of an open file's first `size` bytes, read in pieces. */
static int hash_fd(int fd, uint64_t size, const char *path, uint8_t hash[32]) {
  if (sodium_init() < 0) abort();
  crypto_generichash_state state;
  crypto_generichash_init(&state, NULL, 0, 32);
  size_t cap = (size_t)1 << 20;
  uint8_t *buf = malloc(cap);
  if (buf == NULL) return vf_error_set(VF_ENOMEM, "out of memory hashing %s", path);
  int err = VF_OK;
  for (uint64_t at = 0; at < size && err == VF_OK;) {
    size_t want = size - at < cap ? (size_t)(size - at) : cap;
    ssize_t got = pread(fd, buf, want, (off_t)at);
    if (got <= 0) err = vf_error_set(VF_EIO, "%s: read: %s", path, got < 0 ? strerror(errno) : "file shrank");
    else {
      crypto_generichash_update(&state, buf, (size_t)got);
      at += (uint64_t)got;
    }
  }
  free(buf);
  if (err == VF_OK) crypto_generichash_final(&state, hash, 32);
  return err;
}

int vf_blob_store_check(const char *dir, const uint8_t hash[32], uint64_t *size) {
  char path[4200], want[65], got[65];
  int err = vf_blob_path(dir, hash, path, sizeof path);
  if (err != VF_OK) return err;
  vf_blob_hex(hash, want);
  int fd = open(path, O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    if (errno == ENOENT) return vf_error_set(VF_ENOENT, "no blob %s in %s", want, dir);
    return vf_error_set(VF_EIO, "%s: %s", path, strerror(errno));
  }
  struct stat st;
  uint8_t actual[32];
  if (fstat(fd, &st) != 0) err = vf_error_set(VF_EIO, "%s: %s", path, strerror(errno));
  else err = hash_fd(fd, (uint64_t)st.st_size, path, actual);
  close(fd);
  if (err != VF_OK) return err;
  if (sodium_memcmp(actual, hash, 32) != 0) {
    vf_blob_hex(actual, got);
    return vf_error_set(VF_EMISMATCH, "%s: damaged, its bytes hash to %s", path, got);
  }
  if (size) *size = (uint64_t)st.st_size;
  return VF_OK;
}

int vf_blob_store_read(const char *dir, const uint8_t hash[32], uint64_t offset, size_t max, uint8_t **data,
                       size_t *n, uint64_t *total) {
  char path[4200], hex[65];
  int err = vf_blob_path(dir, hash, path, sizeof path);
  if (err != VF_OK) return err;
  int fd = open(path, O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    vf_blob_hex(hash, hex);
    if (errno == ENOENT) return vf_error_set(VF_ENOENT, "no blob %s in %s", hex, dir);
    return vf_error_set(VF_EIO, "%s: %s", path, strerror(errno));
  }
  struct stat st;
  uint8_t *buf = NULL;
  size_t len = 0;
  if (fstat(fd, &st) != 0) {
    err = vf_error_set(VF_EIO, "%s: %s", path, strerror(errno));
  } else if (offset > (uint64_t)st.st_size) {
    err = vf_error_set(VF_EINVAL, "%s: offset %llu past its %lld bytes", path, (unsigned long long)offset,
                       (long long)st.st_size);
  } else {
    uint64_t left = (uint64_t)st.st_size - offset;
    len = left < max ? (size_t)left : max;
    if ((buf = malloc(len ? len : 1)) == NULL) err = vf_error_set(VF_ENOMEM, "out of memory reading %s", path);
    for (size_t at = 0; err == VF_OK && at < len;) {
      ssize_t got = pread(fd, buf + at, len - at, (off_t)(offset + at));
      if (got <= 0) err = vf_error_set(VF_EIO, "%s: read: %s", path, got < 0 ? strerror(errno) : "file shrank");
      else at += (size_t)got;
    }
  }
  close(fd);
  if (err != VF_OK) {
    free(buf);
    return err;
  }
  *data = buf;
  *n = len;
  *total = (uint64_t)st.st_size;
  return VF_OK;
}

static int part_path(const char *dir, const uint8_t hash[32], uint64_t tag, char *out, size_t n) {
  char hex[65];
  vf_blob_hex(hash, hex);
  int w = snprintf(out, n, "%s/blobs/%s.%016llx.part", dir, hex, (unsigned long long)tag);
  if (w < 0 || (size_t)w >= n) return vf_error_set(VF_EINVAL, "%s: blob store path too long", dir);
  return VF_OK;
}

int vf_blob_store_append(const char *dir, const uint8_t hash[32], uint64_t tag, uint64_t offset, uint64_t total,
                         const void *data, size_t n, int *complete) {
  char part[4300], path[4200], hex[65], got[65];
  vf_blob_hex(hash, hex);
  *complete = 0;
  if (total > VF_BLOB_MAX_BYTES)
    return vf_error_set(VF_EINVAL, "blob %s of %llu bytes, at most %llu", hex, (unsigned long long)total,
                        (unsigned long long)VF_BLOB_MAX_BYTES);
  if (offset > total || n > total - offset)
    return vf_error_set(VF_EINVAL, "blob %s: %zu bytes at offset %llu pass its %llu", hex, n,
                        (unsigned long long)offset, (unsigned long long)total);
  int err;
  if ((err = part_path(dir, hash, tag, part, sizeof part)) != VF_OK ||
      (err = vf_blob_path(dir, hash, path, sizeof path)) != VF_OK)
    return err;
  char *slash = strrchr(path, '/');
  *slash = '\0';
  if ((err = make_dir(dir)) != VF_OK || (err = make_dir(path)) != VF_OK) return err;
  *slash = '/';
  vf_atomic_file file;
  uint64_t held = 0;
  if ((err = vf_atomic_resume(&file, path, part, 0600, offset == 0, &held)) != VF_OK) return err;
  if (held != offset) {
    err = vf_error_set(VF_EINVAL, "blob %s: a chunk at offset %llu, but the transfer holds %llu bytes", hex,
                       (unsigned long long)offset, (unsigned long long)held);
    vf_atomic_suspend(&file); /* the part stays as it was: the right chunk may still come */
    return err;
  }
  if ((err = vf_atomic_pwrite(&file, data, n, offset)) != VF_OK) {
    vf_atomic_abort(&file);
    return err;
  }
  if (offset + n < total) {
    vf_atomic_suspend(&file);
    return VF_OK;
  }
  uint8_t actual[32];
  if ((err = hash_fd(file.fd, total, part, actual)) == VF_OK && sodium_memcmp(actual, hash, 32) != 0) {
    vf_blob_hex(actual, got);
    err = vf_error_set(VF_EMISMATCH, "blob %s: its %llu bytes hash to %s, not to its name", hex,
                       (unsigned long long)total, got);
  }
  if (err != VF_OK) {
    vf_atomic_abort(&file);
    return err;
  }
  if ((err = vf_atomic_commit(&file)) == VF_OK) *complete = 1;
  return err;
}

int vf_blob_store_list(const char *dir, vf_blob_entry **entries, size_t *n) {
  char blobs[4200], path[4300];
  *entries = NULL;
  *n = 0;
  if (snprintf(blobs, sizeof blobs, "%s/blobs", dir) >= (int)sizeof blobs)
    return vf_error_set(VF_EINVAL, "%s: blob store path too long", dir);
  DIR *d = opendir(blobs);
  if (d == NULL) return errno == ENOENT ? VF_OK : vf_error_set(VF_EIO, "%s: %s", blobs, strerror(errno));
  vf_blob_entry *list = NULL;
  size_t count = 0, cap = 0;
  int err = VF_OK;
  struct dirent *e;
  while ((e = readdir(d)) != NULL) {
    uint8_t hash[32];
    size_t len = 0;
    struct stat st;
    if (strlen(e->d_name) != 64 || strspn(e->d_name, "0123456789abcdef") != 64 ||
        sodium_hex2bin(hash, sizeof hash, e->d_name, 64, NULL, &len, NULL) != 0 || len != 32)
      continue; /* not a blob: a transfer's part */
    if (snprintf(path, sizeof path, "%s/%s", blobs, e->d_name) >= (int)sizeof path || stat(path, &st) != 0 ||
        !S_ISREG(st.st_mode))
      continue;
    if (count == cap) {
      vf_blob_entry *grown = realloc(list, (cap = cap ? 2 * cap : 64) * sizeof *grown);
      if (grown == NULL) {
        err = vf_error_set(VF_ENOMEM, "out of memory listing %s", blobs);
        break;
      }
      list = grown;
    }
    memcpy(list[count].hash, hash, 32);
    list[count].size = (uint64_t)st.st_size;
    list[count].modified = st.st_mtim;
    count++;
  }
  closedir(d);
  if (err != VF_OK) {
    free(list);
    return err;
  }
  *entries = list;
  *n = count;
  return VF_OK;
}

int vf_blob_store_remove(const char *dir, const uint8_t hash[32]) {
  char path[4200];
  int err = vf_blob_path(dir, hash, path, sizeof path);
  if (err != VF_OK) return err;
  if (unlink(path) != 0) return vf_error_set(VF_EIO, "%s: %s", path, strerror(errno));
  return VF_OK;
}

void vf_blob_store_clean_parts(const char *dir, double min_age) {
  char blobs[4200], path[4500];
  if (snprintf(blobs, sizeof blobs, "%s/blobs", dir) >= (int)sizeof blobs) return;
  DIR *d = opendir(blobs);
  if (d == NULL) return;
  struct dirent *e;
  time_t now = time(NULL);
  while ((e = readdir(d)) != NULL) {
    size_t len = strlen(e->d_name);
    struct stat st;
    if (len < 5 || strcmp(e->d_name + len - 5, ".part") != 0) continue;
    if (snprintf(path, sizeof path, "%s/%s", blobs, e->d_name) >= (int)sizeof path) continue;
    if (stat(path, &st) == 0 && difftime(now, st.st_mtime) >= min_age) unlink(path);
  }
  closedir(d);
}

int vf_blob_check_name(const char *name) {
  size_t n = strlen(name);
  if (n == 0 || n > VF_BLOB_MAX_NAME)
    return vf_error_set(VF_EINVAL, "file name of %zu bytes, must be 1 to %d", n, VF_BLOB_MAX_NAME);
  for (size_t i = 0; i < n; i++)
    if ((unsigned char)name[i] < 0x20 || name[i] == 0x7f)
      return vf_error_set(VF_EINVAL, "file name with a control character at byte %zu", i);
  return VF_OK;
}

const vf_blob_ref *vf_blob_table_find(const vf_blob_table *t, const char *name) {
  for (size_t i = 0; i < t->count; i++)
    if (strcmp(t->refs[i].name, name) == 0) return &t->refs[i];
  return NULL;
}

int vf_blob_table_add(vf_blob_table *t, const char *name, const uint8_t hash[32], uint64_t size) {
  int err = vf_blob_check_name(name);
  if (err != VF_OK) return err;
  if (vf_blob_table_find(t, name)) return vf_error_set(VF_EINVAL, "file '%s' named twice", name);
  if (size > VF_BLOB_MAX_BYTES)
    return vf_error_set(VF_EINVAL, "file '%s' is %llu bytes; a file can be at most %llu", name,
                        (unsigned long long)size, (unsigned long long)VF_BLOB_MAX_BYTES);
  if (t->count >= VF_BLOB_MAX_FILES) return vf_error_set(VF_EINVAL, "more than %d files", VF_BLOB_MAX_FILES);
  vf_blob_ref *grown = realloc(t->refs, (t->count + 1) * sizeof *grown);
  if (grown == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  t->refs = grown;
  vf_blob_ref *r = &t->refs[t->count];
  if ((r->name = strdup(name)) == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  memcpy(r->hash, hash, 32);
  r->size = size;
  t->count++;
  return VF_OK;
}

void vf_blob_table_clear(vf_blob_table *t) {
  if (t == NULL) return;
  for (size_t i = 0; i < t->count; i++) free(t->refs[i].name);
  free(t->refs);
  t->refs = NULL;
  t->count = 0;
}

int vf_blob_table_from_wire(Vcmfarm__BlobRef *const *refs, size_t n, vf_blob_table *out) {
  vf_blob_table t = {0};
  int err = VF_OK;
  if (n > VF_BLOB_MAX_FILES) return vf_error_set(VF_EINVAL, "files: %zu entries, at most %d", n, VF_BLOB_MAX_FILES);
  for (size_t i = 0; i < n; i++) {
    if (refs[i]->hash.len != 32) {
      err = vf_error_set(VF_EINVAL, "files[%zu]: hash of %zu bytes, expected 32", i, refs[i]->hash.len);
      break;
    }
    if ((err = vf_blob_table_add(&t, refs[i]->name, refs[i]->hash.data, refs[i]->size)) != VF_OK) {
      err = vf_error_set(err, "files[%zu]: %s", i, vf_error_detail(err));
      break;
    }
  }
  if (err != VF_OK) {
    vf_blob_table_clear(&t);
    return err;
  }
  *out = t;
  return VF_OK;
}

int vf_blob_table_to_wire(const vf_blob_table *t, Vcmfarm__BlobRef **storage, Vcmfarm__BlobRef ***ptrs) {
  *storage = NULL;
  *ptrs = NULL;
  if (t->count == 0) return VF_OK;
  Vcmfarm__BlobRef *s = calloc(t->count, sizeof *s), **p = calloc(t->count, sizeof *p);
  if (s == NULL || p == NULL) {
    free(s);
    free(p);
    return vf_error_set(VF_ENOMEM, "out of memory");
  }
  for (size_t i = 0; i < t->count; i++) {
    vcmfarm__blob_ref__init(&s[i]);
    s[i].name = t->refs[i].name;
    s[i].hash.data = t->refs[i].hash;
    s[i].hash.len = 32;
    s[i].size = t->refs[i].size;
    p[i] = &s[i];
  }
  *storage = s;
  *ptrs = p;
  return VF_OK;
}

int vf_blob_table_save(const vf_blob_table *t, const char *path) {
  cJSON *a = cJSON_CreateArray();
  char hex[65];
  if (a == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  for (size_t i = 0; i < t->count; i++) {
    cJSON *o = cJSON_CreateObject();
    vf_blob_hex(t->refs[i].hash, hex);
    if (o == NULL || !cJSON_AddItemToArray(a, o) || !cJSON_AddStringToObject(o, "name", t->refs[i].name) ||
        !cJSON_AddStringToObject(o, "hash", hex) || !cJSON_AddNumberToObject(o, "size", (double)t->refs[i].size)) {
      cJSON_Delete(a);
      return vf_error_set(VF_ENOMEM, "out of memory");
    }
  }
  char *text = cJSON_Print(a);
  cJSON_Delete(a);
  if (text == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  int err = vf_file_write_atomic(path, text, strlen(text), 0600);
  free(text);
  return err;
}

int vf_blob_table_load(const char *path, vf_blob_table *out) {
  uint8_t *text;
  size_t len;
  int err = vf_file_read_all(path, (size_t)4 << 20, &text, &len);
  if (err != VF_OK) return err;
  cJSON *a = cJSON_ParseWithLength((const char *)text, len);
  free(text);
  vf_blob_table t = {0};
  if (!cJSON_IsArray(a)) {
    cJSON_Delete(a);
    return vf_error_set(VF_EINVAL, "%s: not a JSON array", path);
  }
  const cJSON *o;
  size_t i = 0;
  cJSON_ArrayForEach(o, a) {
    const cJSON *name = cJSON_GetObjectItemCaseSensitive(o, "name"), *hex = cJSON_GetObjectItemCaseSensitive(o, "hash"),
                *size = cJSON_GetObjectItemCaseSensitive(o, "size");
    uint8_t hash[32];
    size_t hash_len = 0;
    if (!cJSON_IsString(name) || !cJSON_IsString(hex) || !cJSON_IsNumber(size) ||
        sodium_hex2bin(hash, 32, hex->valuestring, strlen(hex->valuestring), NULL, &hash_len, NULL) != 0 ||
        hash_len != 32) {
      err = vf_error_set(VF_EINVAL, "%s: entry %zu is not {\"name\", \"hash\" (64 hex digits), \"size\"}", path, i);
      break;
    }
    /* Checked as a double before it becomes an integer (a conversion out of range is
     * undefined): a whole number of bytes, at most a blob's limit. */
    double bytes = size->valuedouble;
    if (!(bytes >= 0.0 && bytes <= (double)VF_BLOB_MAX_BYTES) || bytes != (double)(uint64_t)bytes) {
      err = vf_error_set(VF_EINVAL, "%s: entry %zu: size %g is not a whole number of bytes from 0 to %llu", path, i,
                         bytes, (unsigned long long)VF_BLOB_MAX_BYTES);
      break;
    }
    if ((err = vf_blob_table_add(&t, name->valuestring, hash, (uint64_t)bytes)) != VF_OK) {
      err = vf_error_set(err, "%s: entry %zu: %s", path, i, vf_error_detail(err));
      break;
    }
    i++;
  }
  cJSON_Delete(a);
  if (err != VF_OK) {
    vf_blob_table_clear(&t);
    return err;
  }
  *out = t;
  return VF_OK;
}
