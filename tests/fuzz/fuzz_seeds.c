/* Writes the seed corpora of the fuzz targets into DIR/<target>/ (tests/fuzz/corpus is
 * what it wrote, committed): valid inputs of each kind, from which libFuzzer's mutations
 * start.   fuzz_seeds DIR */
#include "common/blob.h"
#include "common/film.h"
#include "common/film_wire.h"
#include "common/message.h"

#include <sodium.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static int put(const char *dir, const char *target, const char *name, const void *data, size_t len) {
  char path[4096];
  snprintf(path, sizeof path, "%s/%s", dir, target);
  mkdir(path, 0777);
  snprintf(path, sizeof path, "%s/%s/%s", dir, target, name);
  FILE *f = fopen(path, "wb");
  if (f == NULL || fwrite(data, 1, len, f) != len) return 1;
  return fclose(f) != 0;
}

/* For the ways fuzz_message tries an input: the message as a request, as the reply to
 * fuzz_message's fixed request, and its payload alone (the packed Envelope). */
static int put_message(const char *dir, const char *name, Vcmfarm__Envelope *env) {
  vf_wire_key key;
  memset(key.bytes, 0x5a, sizeof key.bytes);
  vf_wire_stamp request = {VF_PROTOCOL_VERSION, 0, {0}};
  memset(request.nonce, 0xa5, sizeof request.nonce);
  uint8_t *frame = NULL, *reply = NULL;
  size_t len = 0, reply_len = 0;
  if (vf_message_pack(&key, NULL, env, &frame, &len, NULL) != 0) return 1;
  if (vf_message_pack(&key, &request, env, &reply, &reply_len, NULL) != 0) return 1;
  size_t payload_len = vcmfarm__envelope__get_packed_size(env);
  uint8_t *payload = malloc(payload_len ? payload_len : 1);
  if (payload == NULL) return 1;
  vcmfarm__envelope__pack(env, payload);
  char payload_name[64], reply_name[64];
  snprintf(payload_name, sizeof payload_name, "%s.payload", name);
  snprintf(reply_name, sizeof reply_name, "%s.reply", name);
  int err = put(dir, "fuzz_message", name, frame, len) || put(dir, "fuzz_message", reply_name, reply, reply_len) ||
            put(dir, "fuzz_message", payload_name, payload, payload_len);
  free(frame);
  free(reply);
  free(payload);
  return err;
}

/* fuzz_blob: a scene's file table as a Scene message, the same table as a table file, and
 * a blob of some bytes (its first byte chooses the chunk length). */
static int blob_seeds(const char *dir) {
  static const char mesh[] = "ply\nformat ascii 1.0\nelement vertex 0\nend_header\n";
  uint8_t hash[32];
  vf_blob_hash(mesh, sizeof mesh - 1, hash);
  vf_blob_table table = {0};
  int err = vf_blob_table_add(&table, "meshes/empty.ply", hash, sizeof mesh - 1) != 0 ||
            vf_blob_table_add(&table, "../textures/wood.png", hash, sizeof mesh - 1) != 0;
  Vcmfarm__BlobRef *storage = NULL, **ptrs = NULL;
  err = err || vf_blob_table_to_wire(&table, &storage, &ptrs) != 0;
  if (!err) {
    Vcmfarm__Scene scene = VCMFARM__SCENE__INIT;
    scene.n_files = table.count;
    scene.files = ptrs;
    size_t len = vcmfarm__scene__get_packed_size(&scene);
    uint8_t *bytes = malloc(len ? len : 1);
    err = bytes == NULL;
    if (!err) vcmfarm__scene__pack(&scene, bytes);
    err = err || put(dir, "fuzz_blob", "scene_files", bytes, len);
    free(bytes);
  }
  free(storage);
  free(ptrs);
  char path[4096];
  snprintf(path, sizeof path, "%s/fuzz_blob/table.json", dir);
  err = err || vf_blob_table_save(&table, path) != 0;
  vf_blob_table_clear(&table);
  char blob[sizeof mesh + 1] = {7};
  memcpy(blob + 1, mesh, sizeof mesh - 1);
  return err || put(dir, "fuzz_blob", "chunks", blob, sizeof mesh);
}

int main(int argc, char **argv) {
  if (argc != 2) {
    fprintf(stderr, "usage: fuzz_seeds DIR\n");
    return 2;
  }
  const char *dir = argv[1];
  mkdir(dir, 0777);
  /* a small film of two iterations */
  vf_film *film = NULL;
  if (vf_film_create(24, 16, &film) != 0) return 1;
  float *camera = calloc(3 * 24 * 16, sizeof(float)), *light = calloc(3 * 24 * 16, sizeof(float));
  for (int i = 0; i < 3 * 24 * 16; i++) camera[i] = (float)(i % 97) / 97.0f;
  for (uint64_t k = 0; k < 2; k++)
    if (vf_film_add_iteration(film, k, camera, light, 0) != 0) return 1;
  uint8_t *bytes = NULL;
  size_t len = 0;
  int err = vf_film_to_bytes(film, (size_t)1 << 30, &bytes, &len) || put(dir, "fuzz_film", "film.exr", bytes, len) ||
            put(dir, "fuzz_texture", "film.exr", bytes, len);
  free(bytes);

  Vcmfarm__Envelope env = VCMFARM__ENVELOPE__INIT;
  Vcmfarm__Register reg = VCMFARM__REGISTER__INIT;
  reg.name = "seed";
  reg.threads = 2;
  env.body_case = VCMFARM__ENVELOPE__BODY_REGISTER;
  env.register_ = &reg;
  err = err || put_message(dir, "register", &env);
  {
    /* a frame of protocol version 7 (payload in clear, HMAC tag): refused as another version */
    vf_wire_key key;
    memset(key.bytes, 0x5a, sizeof key.bytes);
    uint8_t legacy[12 + 4 + 32] = {'V', 'C', 'M', 'F', 0, 0, 0, 7, 0, 0, 0, 4, 0x08, 0x07, 0x52, 0x00};
    crypto_auth(legacy + 16, legacy, 16, key.bytes);
    err = err || put(dir, "fuzz_message", "version7", legacy, sizeof legacy);
  }
  Vcmfarm__Tile tile = VCMFARM__TILE__INIT, *tiles[1] = {&tile};
  uint8_t *storage = NULL;
  err = err || vf_film_tile_encode(film, 0, 0, &tile, &storage) != 0;
  Vcmfarm__LeaseResult result = VCMFARM__LEASE_RESULT__INIT;
  result.begin = 0;
  result.end = 2;
  result.n_tiles = 1;
  result.tiles = tiles;
  env.body_case = VCMFARM__ENVELOPE__BODY_RESULT;
  env.result = &result;
  err = err || put_message(dir, "lease_result", &env);
  free(storage);
  vf_film_destroy(film);
  free(camera);
  free(light);
  return err || blob_seeds(dir);
}
