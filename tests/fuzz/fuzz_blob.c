/* libFuzzer target: the blob store (common/blob.h) with what peers and files send it. One
 * input is read three ways:
 *
 *   - as a Scene message: its file table through vf_blob_table_from_wire, and a table that
 *     was accepted back to the wire and from it again, unchanged;
 *   - as a blob arriving in chunks: the input's first byte chooses chunk lengths, the
 *     rest is the blob, sent to vf_blob_store_append under its own hash (it must complete
 *     and read back whole), and again under another hash or out of order (refused, nothing
 *     stored);
 *   - as a table file for vf_blob_table_load.
 *
 * Stores live in one private directory made at the first input and emptied after each. */
#define _XOPEN_SOURCE 700 /* nftw */
#include "common/blob.h"
#include "common/error.h"

#include <ftw.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char store[4096];

static int remove_one(const char *path, const struct stat *st, int type, struct FTW *ftw) {
  (void)st;
  (void)type;
  return ftw->level > 0 && remove(path) != 0 ? -1 : 0;
}

/* Empties the store directory (it stays). */
static void remove_tree(const char *dir) {
  if (nftw(dir, remove_one, 16, FTW_DEPTH | FTW_PHYS) != 0) abort();
}

static void remove_store(void) {
  remove_tree(store);
  rmdir(store);
}

static void tables(const uint8_t *data, size_t size) {
  Vcmfarm__Scene *scene = vcmfarm__scene__unpack(NULL, size, data);
  if (scene == NULL) return;
  vf_blob_table table = {0};
  if (vf_blob_table_from_wire(scene->files, scene->n_files, &table) == VF_OK) {
    Vcmfarm__BlobRef *storage = NULL, **ptrs = NULL;
    if (vf_blob_table_to_wire(&table, &storage, &ptrs) == VF_OK) {
      vf_blob_table again = {0};
      /* What was accepted goes back and forth unchanged. */
      if (vf_blob_table_from_wire(ptrs, table.count, &again) != VF_OK || again.count != table.count) abort();
      for (size_t i = 0; i < table.count; i++)
        if (strcmp(again.refs[i].name, table.refs[i].name) != 0 || again.refs[i].size != table.refs[i].size ||
            memcmp(again.refs[i].hash, table.refs[i].hash, 32) != 0)
          abort();
      vf_blob_table_clear(&again);
    }
    free(storage);
    free(ptrs);
  }
  vf_blob_table_clear(&table);
  vcmfarm__scene__free_unpacked(scene, NULL);
}

static void chunks(const uint8_t *data, size_t size) {
  if (size < 1) return;
  size_t step = (size_t)(data[0] % 61) + 1;
  const uint8_t *blob = data + 1;
  size_t n = size - 1;
  uint8_t hash[32], other[32];
  vf_blob_hash(blob, n, hash);
  memcpy(other, hash, 32);
  other[0] ^= 1;
  /* In order, under its own name: completes with the last chunk, and reads back whole. */
  int complete = 0;
  for (size_t at = 0; at < n || (n == 0 && !complete); at += step) {
    size_t len = n - at < step ? n - at : step;
    if (vf_blob_store_append(store, hash, 7, at, n, blob + at, len, &complete) != VF_OK) abort();
    if (complete != (at + len == n)) abort();
    if (n == 0) break;
  }
  uint8_t *back = NULL;
  size_t back_n = 0;
  if (vf_blob_store_get(store, hash, &back, &back_n) != VF_OK || back_n != n || (n && memcmp(back, blob, n) != 0))
    abort();
  free(back);
  /* Under another name: refused once complete, and not stored. */
  int err = VF_OK;
  complete = 0;
  for (size_t at = 0; at < n && err == VF_OK; at += step) {
    size_t len = n - at < step ? n - at : step;
    err = vf_blob_store_append(store, other, 8, at, n, blob + at, len, &complete);
  }
  if (n > 0 && err != VF_EMISMATCH) abort();
  if (vf_blob_store_has(store, other, NULL)) abort();
  /* Out of order: a chunk that does not start where the part ends is refused. */
  if (n > step && vf_blob_store_append(store, other, 9, step, n, blob + step, 1, &complete) != VF_EINVAL) abort();
  remove_tree(store);
}

static void table_file(const uint8_t *data, size_t size) {
  char path[4200];
  snprintf(path, sizeof path, "%s/table.json", store);
  FILE *f = fopen(path, "wb");
  if (f == NULL || fwrite(data, 1, size, f) != size || fclose(f) != 0) abort();
  vf_blob_table table = {0};
  if (vf_blob_table_load(path, &table) == VF_OK)
    for (size_t i = 0; i < table.count; i++)
      if (vf_blob_check_name(table.refs[i].name) != VF_OK) abort();
  vf_blob_table_clear(&table);
  remove_tree(store);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  if (store[0] == '\0') {
    const char *tmp = getenv("TMPDIR");
    snprintf(store, sizeof store, "%s/vcmfarm-fuzz-blob-XXXXXX", tmp && *tmp ? tmp : "/tmp");
    if (mkdtemp(store) == NULL) abort();
    atexit(remove_store);
  }
  tables(data, size);
  chunks(data, size);
  table_file(data, size);
  return 0;
}
