/* Blobs (common/blob.c) and scenes loaded through their files (worker/scene/files.c,
 * worker/scene/job_scene.c): stores refuse bytes that do not match their hash and notice damage,
 * blobs arrive in chunks,
 * tables refuse bad entries, and a scene collected as blobs loads from a store with the
 * hash it has from its own directory, its glTF buffer included. */
#include "check.h"

#include "common/blob.h"
#include "common/error.h"
#include "common/file.h"
#include "worker/blob_cache.h"
#include "worker/scene/job_scene.h"
#include "worker/scene/load.h"

#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static char dir[64];

static void test_store_checks_hash(void) {
  const char data[] = "ply\nformat ascii 1.0\n";
  uint8_t hash[32], other[32];
  vf_blob_hash(data, sizeof data, hash);
  vf_blob_hash("x", 1, other);
  int err = vf_blob_store_put(dir, other, data, sizeof data);
  CHECK_INT_EQ(err, VF_EMISMATCH);
  CHECK_STR_CONTAINS(vf_error_detail(err), "not to its name");
  CHECK(!vf_blob_store_has(dir, other, NULL));
  CHECK_INT_EQ(vf_blob_store_put(dir, hash, data, sizeof data), VF_OK);
  CHECK_INT_EQ(vf_blob_store_put(dir, hash, data, sizeof data), VF_OK); /* once is enough, twice is harmless */
  uint64_t size = 0;
  CHECK(vf_blob_store_has(dir, hash, &size));
  CHECK_INT_EQ(size, sizeof data);
  uint8_t *back;
  size_t n;
  CHECK_INT_EQ(vf_blob_store_get(dir, hash, &back, &n), VF_OK);
  CHECK_INT_EQ(n, sizeof data);
  CHECK(memcmp(back, data, n) == 0);
  free(back);
  /* A damaged copy is noticed, not served. */
  char path[256];
  CHECK_INT_EQ(vf_blob_path(dir, hash, path, sizeof path), VF_OK);
  CHECK_INT_EQ(vf_file_write_atomic(path, "ply\nformat ascii 1.1\n", sizeof data, 0600), VF_OK);
  err = vf_blob_store_get(dir, hash, &back, &n);
  CHECK_INT_EQ(err, VF_EMISMATCH);
  CHECK_STR_CONTAINS(vf_error_detail(err), "damaged");
  CHECK_INT_EQ(vf_blob_store_get(dir, other, &back, &n), VF_ENOENT);
}

/* A blob of several chunks, as transfers deliver it: out of order and past the end
 * refused, complete only with the last chunk, checked whole, readable in pieces; the
 * check streams the file; parts left behind are cleaned up. */
static void test_chunked_transfers(void) {
  size_t n = 3 * 1000 + 7;
  uint8_t *data = malloc(n), hash[32], wrong[32];
  for (size_t i = 0; i < n; i++) data[i] = (uint8_t)(i * 7 + 3);
  vf_blob_hash(data, n, hash);
  vf_blob_hash(data, n - 1, wrong);
  int complete = -1, err;
  CHECK_INT_EQ(vf_blob_store_append(dir, hash, 1, 0, n, data, 1000, &complete), VF_OK);
  CHECK_INT_EQ(complete, 0);
  CHECK(!vf_blob_store_has(dir, hash, NULL)); /* nothing before the last chunk */
  err = vf_blob_store_append(dir, hash, 1, 2000, n, data + 2000, 1000, &complete);
  CHECK_INT_EQ(err, VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(err), "the transfer holds 1000 bytes");
  err = vf_blob_store_append(dir, hash, 1, 1000, n, data + 1000, n, &complete);
  CHECK_INT_EQ(err, VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(err), "pass its");
  /* Another transfer of the same blob meanwhile does not disturb this one. */
  CHECK_INT_EQ(vf_blob_store_append(dir, hash, 2, 0, n, data, 10, &complete), VF_OK);
  CHECK_INT_EQ(vf_blob_store_append(dir, hash, 1, 1000, n, data + 1000, 1000, &complete), VF_OK);
  CHECK_INT_EQ(vf_blob_store_append(dir, hash, 1, 2000, n, data + 2000, n - 2000, &complete), VF_OK);
  CHECK_INT_EQ(complete, 1);
  uint64_t size = 0;
  CHECK_INT_EQ(vf_blob_store_check(dir, hash, &size), VF_OK);
  CHECK_INT_EQ(size, n);
  uint8_t *piece;
  size_t len;
  uint64_t total;
  CHECK_INT_EQ(vf_blob_store_read(dir, hash, 2500, 1000, &piece, &len, &total), VF_OK);
  CHECK_INT_EQ(len, n - 2500);
  CHECK_INT_EQ(total, n);
  CHECK(memcmp(piece, data + 2500, len) == 0);
  free(piece);
  CHECK_INT_EQ(vf_blob_store_read(dir, hash, n + 1, 1000, &piece, &len, &total), VF_EINVAL);
  /* A whole that hashes to another name: refused with its last chunk, nothing kept. */
  CHECK_INT_EQ(vf_blob_store_append(dir, wrong, 3, 0, n, data, 2000, &complete), VF_OK);
  err = vf_blob_store_append(dir, wrong, 3, 2000, n, data + 2000, n - 2000, &complete);
  CHECK_INT_EQ(err, VF_EMISMATCH);
  CHECK_STR_CONTAINS(vf_error_detail(err), "not to its name");
  CHECK(!vf_blob_store_has(dir, wrong, NULL));
  CHECK_INT_EQ(vf_blob_store_append(dir, hash, 4, 0, (uint64_t)5 << 30, data, 10, &complete), VF_EINVAL);
  /* Damage is found by the streaming check too. */
  char path[256];
  CHECK_INT_EQ(vf_blob_path(dir, hash, path, sizeof path), VF_OK);
  FILE *f = fopen(path, "r+b");
  if (f) {
    fputc(data[0] ^ 1, f);
    fclose(f);
  }
  CHECK_INT_EQ(vf_blob_store_check(dir, hash, NULL), VF_EMISMATCH);
  /* Transfer 2 never finished: its part goes with a clean-up (none younger than a day). */
  char part[300];
  char hex[65];
  vf_blob_hex(hash, hex);
  snprintf(part, sizeof part, "%s/blobs/%s.%016llx.part", dir, hex, 2ull);
  CHECK(access(part, F_OK) == 0);
  vf_blob_store_clean_parts(dir, 86400.0);
  CHECK(access(part, F_OK) == 0);
  vf_blob_store_clean_parts(dir, 0.0);
  CHECK(access(part, F_OK) != 0);
  free(data);
}

/* A worker's cache kept under a size: least recently used blobs first, never the job's. */
static void test_cache_trim(void) {
  char cache[128];
  snprintf(cache, sizeof cache, "%s/cache", dir);
  CHECK_INT_EQ(vf_blob_cache_open(cache), VF_OK);
  uint8_t hash[4][32];
  char data[100];
  for (int i = 0; i < 4; i++) {
    memset(data, 'a' + i, sizeof data);
    vf_blob_hash(data, sizeof data, hash[i]);
    CHECK_INT_EQ(vf_blob_store_put(cache, hash[i], data, sizeof data), VF_OK);
    char path[256];
    vf_blob_path(cache, hash[i], path, sizeof path);
    struct timespec when[2] = {{1000 + i, 0}, {1000 + i, 0}}; /* blob 0 used longest ago */
    CHECK_INT_EQ(utimensat(AT_FDCWD, path, when, 0), 0);
  }
  vf_blob_table keep = {0};
  CHECK_INT_EQ(vf_blob_table_add(&keep, "old-but-needed.ply", hash[0], 100), VF_OK);
  CHECK_INT_EQ(vf_blob_cache_trim(cache, 0, &keep), 0); /* no limit */
  CHECK_INT_EQ(vf_blob_cache_trim(cache, 250, &keep), 2); /* 400 bytes: blobs 1 and 2 go */
  CHECK(vf_blob_store_has(cache, hash[0], NULL));
  CHECK(!vf_blob_store_has(cache, hash[1], NULL));
  CHECK(!vf_blob_store_has(cache, hash[2], NULL));
  CHECK(vf_blob_store_has(cache, hash[3], NULL));
  CHECK_INT_EQ(vf_blob_cache_trim(cache, 50, &keep), 1); /* the kept one alone stays over */
  CHECK(vf_blob_store_has(cache, hash[0], NULL));
  vf_blob_table_clear(&keep);
}

static void test_table_refuses_bad_entries(void) {
  vf_blob_table t = {0};
  uint8_t hash[32] = {1};
  CHECK_INT_EQ(vf_blob_table_add(&t, "meshes/a.ply", hash, 10), VF_OK);
  int err = vf_blob_table_add(&t, "meshes/a.ply", hash, 10);
  CHECK_INT_EQ(err, VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(err), "named twice");
  err = vf_blob_table_add(&t, "bad\nname.ply", hash, 10);
  CHECK_INT_EQ(err, VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(err), "control character");
  CHECK_INT_EQ(vf_blob_table_add(&t, "", hash, 10), VF_EINVAL);
  err = vf_blob_table_add(&t, "huge.ply", hash, (uint64_t)VF_BLOB_MAX_BYTES + 1);
  CHECK_INT_EQ(err, VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(err), "at most");
  /* From the wire: hash length checked and the entry named. */
  Vcmfarm__BlobRef ref = VCMFARM__BLOB_REF__INIT, *refs[1] = {&ref};
  ref.name = "a.obj";
  ref.hash.data = hash;
  ref.hash.len = 31;
  vf_blob_table w;
  err = vf_blob_table_from_wire(refs, 1, &w);
  CHECK_INT_EQ(err, VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(err), "files[0]: hash of 31 bytes");
  /* Saved and read back. */
  char path[128];
  snprintf(path, sizeof path, "%s/table.json", dir);
  CHECK_INT_EQ(vf_blob_table_save(&t, path), VF_OK);
  vf_blob_table back = {0};
  CHECK_INT_EQ(vf_blob_table_load(path, &back), VF_OK);
  CHECK_INT_EQ(back.count, 1);
  CHECK(back.count == 1 && strcmp(back.refs[0].name, "meshes/a.ply") == 0 && back.refs[0].size == 10 &&
        memcmp(back.refs[0].hash, hash, 32) == 0);
  vf_blob_table_clear(&back);
  /* Sizes that are no number of bytes are refused by name, before any conversion (5e30
   * reached an undefined conversion to uint64_t, found by fuzz_blob). */
  const char *bad_sizes[] = {"5e30", "-1", "0.5", "4294967297", "1e400"};
  for (size_t k = 0; k < sizeof bad_sizes / sizeof *bad_sizes; k++) {
    FILE *f = fopen(path, "w");
    fprintf(f, "[{\"name\": \"a.obj\", \"hash\": \"%064d\", \"size\": %s}]", 0, bad_sizes[k]);
    fclose(f);
    vf_blob_table none = {0};
    err = vf_blob_table_load(path, &none);
    CHECK_INT_EQ(err, VF_EINVAL);
    CHECK_STR_CONTAINS(vf_error_detail(err), "entry 0");
    CHECK_INT_EQ(none.count, 0);
  }
  vf_blob_table_clear(&t);
}

/* tests/scenes/good/meshes.json (OBJ and PLY) and gltf.json, plus a copy of the glTF with
 * its buffer in a file of its own, collected, then loaded from the stage. */
static void collect_and_compare(const char *scene_path) {
  uint8_t *text;
  size_t len;
  CHECK_INT_EQ(vf_file_read_all(scene_path, 1 << 20, &text, &len), VF_OK);
  vf_scene *direct = NULL, *collected = NULL, *again = NULL;
  CHECK_INT_EQ(vf_scene_load(scene_path, &direct), VF_OK);
  char stage[128];
  snprintf(stage, sizeof stage, "%s/stage", dir);
  mkdir(stage, 0700);
  vf_blob_table files = {0};
  int err = vf_job_scene_collect(scene_path, (const char *)text, len, stage, &files, &collected);
  if (err != VF_OK) fprintf(stderr, "  %s\n", vf_error_detail(err));
  CHECK_INT_EQ(err, VF_OK);
  CHECK(files.count > 0);
  if (direct && collected) CHECK(memcmp(direct->hash, collected->hash, 32) == 0);
  /* As a worker: the same table, the same store, the same hash. */
  CHECK_INT_EQ(vf_job_scene_load(0, (const char *)text, len, &files, stage, "job", &again), VF_OK);
  if (direct && again) CHECK(memcmp(direct->hash, again->hash, 32) == 0);
  /* Without its files the text names nothing that exists. */
  vf_scene *none = NULL;
  err = vf_job_scene_load(0, (const char *)text, len, NULL, stage, "job 9 scene", &none);
  CHECK_INT_EQ(err, VF_ENOENT);
  CHECK_STR_CONTAINS(vf_error_detail(err), "not among the job's files");
  vf_scene_destroy(none);
  vf_scene_destroy(again);
  vf_scene_destroy(collected);
  vf_scene_destroy(direct);
  vf_blob_table_clear(&files);
  free(text);
}

static void test_collect_obj_ply(void) { collect_and_compare(VF_SOURCE_DIR "/tests/scenes/good/meshes.json"); }

static void test_collect_gltf_with_buffer_file(void) {
  /* The glTF's buffer moved from a data: URI into gltf/tri.bin. */
  uint8_t *gltf;
  size_t len;
  CHECK_INT_EQ(vf_file_read_all(VF_SOURCE_DIR "/tests/scenes/good/meshes/tri.gltf", 1 << 20, &gltf, &len), VF_OK);
  static const uint8_t buffer[44] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0x80, 0x3f, 0, 0, 0, 0, 0, 0,
                                     0, 0, 0, 0, 0, 0, 0, 0, 0x80, 0x3f, 0, 0, 0, 0, 0, 0, 1, 0, 2, 0, 0, 0};
  char *uri = strstr((char *)gltf, "data:application/octet-stream;base64,");
  CHECK(uri != NULL);
  if (uri == NULL) return;
  char *end = strchr(uri, '"'), out[4096];
  snprintf(out, sizeof out, "%.*stri.bin%s", (int)(uri - (char *)gltf), (char *)gltf, end);
  char path[256];
  snprintf(path, sizeof path, "%s/gltf", dir);
  mkdir(path, 0700);
  snprintf(path, sizeof path, "%s/gltf/tri.gltf", dir);
  CHECK_INT_EQ(vf_file_write_atomic(path, out, strlen(out), 0600), VF_OK);
  snprintf(path, sizeof path, "%s/gltf/tri.bin", dir);
  CHECK_INT_EQ(vf_file_write_atomic(path, buffer, sizeof buffer, 0600), VF_OK);
  const char *scene = "{\"camera\": {\"position\": [0, 0, 10], \"target\": [0, 0, 0], \"fov\": 30},"
                      " \"materials\": {\"white\": {\"diffuse\": [0.5, 0.5, 0.5]}},"
                      " \"shapes\": [{\"type\": \"mesh\", \"file\": \"gltf/tri.gltf\", \"material\": \"white\","
                      " \"emission\": [1, 1, 1]}]}";
  snprintf(path, sizeof path, "%s/gltf.json", dir);
  CHECK_INT_EQ(vf_file_write_atomic(path, scene, strlen(scene), 0600), VF_OK);
  collect_and_compare(path);
  /* The buffer was collected under the name Assimp asked for. */
  vf_blob_table files = {0};
  vf_scene *s = NULL;
  char stage[128];
  snprintf(stage, sizeof stage, "%s/stage", dir);
  CHECK_INT_EQ(vf_job_scene_collect(path, scene, strlen(scene), stage, &files, &s), VF_OK);
  CHECK_INT_EQ(files.count, 2);
  CHECK(vf_blob_table_find(&files, "gltf/tri.bin") != NULL);
  vf_scene_destroy(s);
  vf_blob_table_clear(&files);
  free(gltf);
}

int main(void) {
  snprintf(dir, sizeof dir, "/tmp/vf-test-blob-XXXXXX");
  if (mkdtemp(dir) == NULL) return 1;
  RUN(test_store_checks_hash);
  RUN(test_chunked_transfers);
  RUN(test_cache_trim);
  RUN(test_table_refuses_bad_entries);
  RUN(test_collect_obj_ply);
  RUN(test_collect_gltf_with_buffer_file);
  char cmd[128];
  snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
  if (system(cmd) != 0) fprintf(stderr, "could not remove %s\n", dir);
  return check_finish();
}
