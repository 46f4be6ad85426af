/* Reproducible random streams.
 *
 * Every sub-path draws from its own stream, and a stream is a pure function of
 * (job seed, global iteration index, path index, stream kind): any machine can replay any
 * path of any iteration, and the result does not depend on thread count or scheduling.
 * The stream is PCG32 (O'Neill 2014) whose 64-bit state and increment are derived from the
 * four keys with the SplitMix64 finaliser. */
#ifndef VF_RNG_H
#define VF_RNG_H

#include <stdint.h>

typedef struct {
  uint64_t state, inc;
} vf_rng;

/* Stream kinds. upg's gatherings take VF_STREAM_GATHER with the camera vertex's index in
 * the bits above the eighth (worker/render/gathering_pass.c). */
enum { VF_STREAM_LIGHT = 1, VF_STREAM_CAMERA = 2, VF_STREAM_TEST = 3, VF_STREAM_GATHER = 4 };

static inline uint64_t vf_splitmix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

static inline uint32_t vf_rng_next(vf_rng *r) {
  uint64_t old = r->state;
  r->state = old * 6364136223846793005ULL + r->inc;
  uint32_t xorshifted = (uint32_t)(((old >> 18u) ^ old) >> 27u);
  uint32_t rot = (uint32_t)(old >> 59u);
  return (xorshifted >> rot) | (xorshifted << ((-rot) & 31));
}

static inline vf_rng vf_rng_for_path(uint64_t seed, uint64_t iteration, uint64_t path_index,
                                     uint32_t stream) {
  uint64_t k = vf_splitmix64(seed ^ vf_splitmix64(iteration ^ vf_splitmix64(path_index)));
  vf_rng r;
  r.inc = (vf_splitmix64(k ^ stream) << 1) | 1u;
  r.state = 0;
  vf_rng_next(&r);
  r.state += vf_splitmix64(k + 0x632be59bd9b4e019ULL);
  vf_rng_next(&r);
  return r;
}

/* Uniform float in [0, 1): 24 random mantissa bits, never 1.0f. */
static inline float vf_rng_float(vf_rng *r) { return (float)(vf_rng_next(r) >> 8) * 0x1p-24f; }

#endif
