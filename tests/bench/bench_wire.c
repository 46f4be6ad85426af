/* The cost of sealing and opening frames, protocol 7 against protocol 8, in one run
 * (docs/BENCHMARKS.md, "The wire"): a LeaseResult of 4 MiB (the largest a worker sends,
 * VF_WIRE_MAX_RESULT) and a Heartbeat. Protocol 7 framed the packed Envelope in clear with
 * an HMAC-SHA-512/256 tag (libsodium crypto_auth); protocol 8 encrypts it with
 * XChaCha20-Poly1305 under a subkey of the farm key (common/wire.c). Both sides include
 * protobuf packing and unpacking, as vf_message_pack and vf_message_unpack do. Median of
 * RUNS runs of a batch each.
 *
 *   bench_wire [RUNS] */
#include "common/message.h"

#include <sodium.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int by_value(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

/* Protocol 7's vf_message_pack, as it was. */
static uint8_t *pack_v7(const vf_wire_key *key, Vcmfarm__Envelope *env, size_t *len) {
  env->protocol_version = 7;
  size_t size = vcmfarm__envelope__get_packed_size(env);
  uint8_t *payload = malloc(size), *f = malloc(12 + size + 32);
  vcmfarm__envelope__pack(env, payload);
  memcpy(f, "VCMF", 4);
  uint32_t be[2] = {__builtin_bswap32(7), __builtin_bswap32((uint32_t)size)};
  memcpy(f + 4, be, 8);
  memcpy(f + 12, payload, size);
  crypto_auth(f + 12 + size, f, 12 + size, key->bytes);
  free(payload);
  *len = 12 + size + 32;
  return f;
}

/* Protocol 7's vf_message_unpack: tag, then protobuf from the frame in place. */
static Vcmfarm__Envelope *unpack_v7(const vf_wire_key *key, const uint8_t *f, size_t len) {
  if (crypto_auth_verify(f + len - 32, f, len - 32, key->bytes) != 0) return NULL;
  return vcmfarm__envelope__unpack(NULL, len - 44, f + 12);
}

typedef struct {
  double seal, open; /* seconds per message */
} cost;

/* One batch: seal `batch` frames, then open them; seconds per message. */
static cost batch_cost(const vf_wire_key *key, Vcmfarm__Envelope *env, int version, int batch) {
  uint8_t **frames = malloc((size_t)batch * sizeof *frames);
  size_t *lens = malloc((size_t)batch * sizeof *lens);
  double t0 = now();
  for (int i = 0; i < batch; i++) {
    if (version == 7) frames[i] = pack_v7(key, env, &lens[i]);
    else if (vf_message_pack(key, NULL, env, &frames[i], &lens[i], NULL) != 0) exit(1);
  }
  double t1 = now();
  for (int i = 0; i < batch; i++) {
    Vcmfarm__Envelope *out = NULL;
    if (version == 7) out = unpack_v7(key, frames[i], lens[i]);
    else if (vf_message_unpack(key, NULL, frames[i], lens[i], &out, NULL) != 0) out = NULL;
    if (out == NULL) exit(1);
    vf_message_free(out);
  }
  double t2 = now();
  for (int i = 0; i < batch; i++) free(frames[i]);
  free(frames);
  free(lens);
  return (cost){(t1 - t0) / batch, (t2 - t1) / batch};
}

static double median(double *v, int n) {
  qsort(v, (size_t)n, sizeof *v, by_value);
  return v[n / 2];
}

/* Batches of protocol 7 and protocol 8 alternate, so that both see the same machine. */
static void measure(const vf_wire_key *key, Vcmfarm__Envelope *env, int batch, int runs, cost *v7, cost *v8) {
  double *x = malloc(4 * (size_t)runs * sizeof *x);
  for (int r = 0; r < runs; r++) {
    cost a = batch_cost(key, env, 7, batch), b = batch_cost(key, env, 8, batch);
    x[r] = a.seal, x[runs + r] = a.open, x[2 * runs + r] = b.seal, x[3 * runs + r] = b.open;
  }
  *v7 = (cost){median(x, runs), median(x + runs, runs)};
  *v8 = (cost){median(x + 2 * runs, runs), median(x + 3 * runs, runs)};
  free(x);
}

static void report(const char *what, size_t bytes, cost v7, cost v8) {
  double mb = (double)bytes / 1e6;
  printf("%-28s %10zu B  seal %9.1f us %8.0f MB/s | %9.1f us %8.0f MB/s   open %9.1f us %8.0f MB/s | %9.1f us "
         "%8.0f MB/s\n",
         what, bytes, 1e6 * v7.seal, mb / v7.seal, 1e6 * v8.seal, mb / v8.seal, 1e6 * v7.open, mb / v7.open,
         1e6 * v8.open, mb / v8.open);
}

int main(int argc, char **argv) {
  int runs = argc > 1 ? atoi(argv[1]) : 9;
  if (sodium_init() < 0 || runs < 1) return 1;
  vf_wire_key key;
  randombytes_buf(key.bytes, sizeof key.bytes);

  /* a result message as large as a worker sends: tiles whose chunks fill 4 MiB */
  enum { TILES = 12 };
  size_t chunk = (VF_WIRE_MAX_RESULT - 4096) / TILES;
  Vcmfarm__Tile tiles[TILES], *tile_ptrs[TILES];
  uint8_t *data = malloc(chunk * TILES);
  randombytes_buf(data, chunk * TILES);
  for (int i = 0; i < TILES; i++) {
    vcmfarm__tile__init(&tiles[i]);
    tiles[i].x = (uint32_t)i;
    tiles[i].chunk = (ProtobufCBinaryData){chunk, data + (size_t)i * chunk};
    tile_ptrs[i] = &tiles[i];
  }
  Vcmfarm__LeaseResult result = VCMFARM__LEASE_RESULT__INIT;
  uint8_t hash[32] = {1};
  result.worker_id = 0x1234567890abcdefull;
  result.lease_id = 0xfedcba0987654321ull;
  result.job_id = 3;
  result.end = 40;
  result.width = result.height = 1024;
  result.scene_hash = (ProtobufCBinaryData){32, hash};
  result.settings = "algorithm=vcm max_path_length=10 radius_factor=0.003 alpha=0.75 seed=7 resolution=1024x1024";
  result.tiles_total = 256;
  result.n_tiles = TILES;
  result.tiles = tile_ptrs;
  Vcmfarm__Envelope big = VCMFARM__ENVELOPE__INIT;
  big.body_case = VCMFARM__ENVELOPE__BODY_RESULT;
  big.result = &result;

  Vcmfarm__Heartbeat hb = VCMFARM__HEARTBEAT__INIT;
  hb.worker_id = 0x1234567890abcdefull;
  hb.lease_id = 0xfedcba0987654321ull;
  hb.iterations_done = 17;
  hb.seconds = 3.25;
  Vcmfarm__Envelope small = VCMFARM__ENVELOPE__INIT;
  small.body_case = VCMFARM__ENVELOPE__BODY_HEARTBEAT;
  small.heartbeat = &hb;

  printf("%d runs, median; each cell: protocol 7 (HMAC, clear) | protocol 8 (XChaCha20-Poly1305)\n", runs);
  size_t big_bytes = vcmfarm__envelope__get_packed_size(&big), small_bytes = vcmfarm__envelope__get_packed_size(&small);
  cost b7, b8, s7, s8;
  measure(&key, &big, 8, runs, &b7, &b8);
  measure(&key, &small, 20000, runs, &s7, &s8);
  report("LeaseResult (4 MiB)", big_bytes, b7, b8);
  report("Heartbeat", small_bytes, s7, s8);
  free(data);
  return 0;
}
