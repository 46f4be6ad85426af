/* Writes the seed corpora of the fuzz targets into DIR/<target>/ (tests/fuzz/corpus is
 * what it wrote, committed): valid inputs of each kind, from which libFuzzer's mutations
 * start.   fuzz_seeds DIR */
#include "common/film.h"
#include "common/film_wire.h"
#include "common/message.h"

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

/* A frame and its payload alone, for the two ways fuzz_message tries an input. */
static int put_message(const char *dir, const char *name, Vcmfarm__Envelope *env) {
  vf_wire_key key;
  memset(key.bytes, 0x5a, sizeof key.bytes);
  uint8_t *frame = NULL;
  size_t len = 0;
  if (vf_message_pack(&key, env, &frame, &len) != 0) return 1;
  char payload[64];
  snprintf(payload, sizeof payload, "%s.payload", name);
  int err = put(dir, "fuzz_message", name, frame, len) ||
            put(dir, "fuzz_message", payload, frame + VF_WIRE_HEADER_SIZE, len - VF_WIRE_HEADER_SIZE - VF_WIRE_TAG_SIZE);
  free(frame);
  return err;
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
  return err;
}
