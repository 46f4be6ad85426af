/* Where a sub-path's random numbers come from: the sampler.
 *
 * Two samplers, chosen by the settings (common/settings.h, "sampler="):
 *
 *   independent  every number is the next of the path's PCG32 stream (common/rng.h),
 *                itself a pure function of (job seed, global iteration, path index, kind).
 *   sobol        randomized quasi-Monte Carlo: the sample index is the global iteration
 *                index, so the iterations of a pixel (or of a light sub-path slot) are
 *                successive points of one low-discrepancy sequence, and any machine can
 *                still render any iteration.
 *
 * The sobol sampler is Owen-scrambled Sobol' in padded pairs. Every pair of dimensions
 * (a "pair" below, numbered by worker/render/sample_dims.h) is the first two dimensions of
 * Sobol' -- van der Corput and its companion, together a (0,2)-sequence in base 2 -- with
 *   - the index shuffled per pair by a nested uniform (Owen) permutation of its bits, so
 *     that pairs are decorrelated from one another while each aligned block of 2^m indices
 *     stays an aligned block of 2^m;
 *   - each of the two coordinates Owen-scrambled per pair.
 * Both are hash-based nested permutations (in the manner of Laine and Karras 2011, Burley
 * 2020): on the bit-reversed value, a chain of additions, odd multiplications and
 * x ^= x * even, each of which changes a bit only as a function of the bits below it, i.e.
 * a digit of the fraction only as a function of the digits before it. Any such
 * permutation maps elementary intervals onto elementary intervals, so every aligned block
 * of 2^m sample indices of any pair is a (0,m,2)-net: each of the 2^m elementary
 * intervals of every shape holds exactly one point. 1D numbers take the first coordinate
 * of a pair of their own (stratified in 1D).
 *
 * The seeds of the scrambling come from hashes of (job seed, replicate, path index, kind),
 * then of the pair number: a pixel's camera sub-paths and a light sub-path slot each have
 * scrambles of their own, independent of their neighbours'.
 *
 * Replicates keep the film's error estimate honest. Successive points of one scrambled
 * sequence are not independent, and the film's no-reference estimate (common/film.c)
 * needs independent parts. Iteration k therefore uses replicate k mod
 * VF_SOBOL_REPLICATES, an independent scrambling, at sample index k / VF_SOBOL_REPLICATES:
 * any long enough run of iterations holds the same number of points of each replicate,
 * each replicate's points are a well-stratified sequence, and the replicates' means are
 * independent estimates whose spread the film measures.
 *
 * Dimensions the sequence does not serve well (past VF_SOBOL_BOUNCES vertices, where
 * stratification no longer shows in the image) come from the path's PCG32 stream, the
 * independent sampler's; the caller asks for them with VF_SAMPLER_FALLBACK.
 *
 * Header only: the hot loops draw every number through these inline functions. */
#ifndef VF_SAMPLER_H
#define VF_SAMPLER_H

#include "rng.h"

#include <stdint.h>

typedef enum { VF_SAMPLER_INDEPENDENT, VF_SAMPLER_SOBOL, VF_SAMPLER_COUNT_ } vf_sampler_kind;

/* Independent scramblings interleaved across iterations (see above). */
#define VF_SOBOL_REPLICATES 2u
/* Vertices of a sub-path whose numbers the sequence serves; deeper ones fall back. */
#define VF_SOBOL_BOUNCES 8
/* A pair number that asks for the fallback stream. */
#define VF_SAMPLER_FALLBACK UINT32_MAX

typedef struct {
  vf_rng rng;        /* independent: the stream; sobol: the fallback stream; once rng_ready */
  uint32_t index;    /* sobol: the sample index, iteration / VF_SOBOL_REPLICATES (mod 2^32) */
  uint32_t index_reversed; /* its bits reversed, as the scrambling wants them */
  uint32_t scramble; /* sobol: the path's seed, from (job seed, replicate, path, kind) */
  int sobol;
  /* The stream is seeded when first drawn from (most sobol sub-paths never need their
   * fallback): from these, as vf_rng_for_path. */
  int rng_ready;
  uint32_t stream;
  uint64_t seed, iteration, path;
} vf_sampler;

static inline uint32_t vf_reverse_bits32(uint32_t x) {
  x = __builtin_bswap32(x);
  x = ((x & 0x0f0f0f0fu) << 4) | ((x & 0xf0f0f0f0u) >> 4);
  x = ((x & 0x33333333u) << 2) | ((x & 0xccccccccu) >> 2);
  x = ((x & 0x55555555u) << 1) | ((x & 0xaaaaaaaau) >> 1);
  return x;
}

/* A permutation of 32-bit words in which bit b of the result depends only on bits 0..b of
 * x (and on the seed). Applied to a binary fraction with its digits reversed (digit j of
 * the fraction at bit j) it is a nested uniform scramble: digit j changes only as a
 * function of the digits before it. The even constants are the first fractional bits of
 * the square roots of 2, 3, 5 and 7 with the low bit cleared; the seed enters through
 * additions and an odd multiplier. */
static inline uint32_t vf_nested_permute(uint32_t x, uint32_t seed) {
  x += seed;
  x ^= x * 0x6a09e666u;
  x *= (seed >> 15) | 1u;
  x ^= x * 0xbb67ae84u;
  x += seed >> 7;
  x ^= x * 0x3c6ef372u;
  x ^= x * 0xa54ff53au;
  return x;
}

/* Owen scrambling of the binary fraction x (bit 31 first). */
static inline uint32_t vf_owen_scramble(uint32_t x, uint32_t seed) {
  return vf_reverse_bits32(vf_nested_permute(vf_reverse_bits32(x), seed));
}

/* The second dimension of Sobol' with its digits reversed (digit j of the fraction at bit
 * j) for index i: its generator is the Pascal matrix mod 2, digit j = xor of the bits i_k
 * with C(k, j) odd, that is (Lucas) with k a superset of j's bits. Five steps of the
 * superset-sum transform compute all 32 digits. */
static inline uint32_t vf_sobol_second_reversed(uint32_t i) {
  i ^= (i >> 1) & 0x55555555u;
  i ^= (i >> 2) & 0x33333333u;
  i ^= (i >> 4) & 0x0f0f0f0fu;
  i ^= (i >> 8) & 0x00ff00ffu;
  i ^= (i >> 16) & 0x0000ffffu;
  return i;
}

/* The same as a fraction, bit 31 first. */
static inline uint32_t vf_sobol_second(uint32_t i) { return vf_reverse_bits32(vf_sobol_second_reversed(i)); }

/* The seeds of pair `pair`: [0] shuffles the index, [1] and [2] scramble the coordinates. */
static inline void vf_sobol_pair_seeds(uint32_t scramble, uint32_t pair, uint32_t seeds[3]) {
  uint64_t h = vf_splitmix64(((uint64_t)scramble << 32) | pair);
  seeds[0] = (uint32_t)h;
  seeds[1] = (uint32_t)(h >> 32);
  seeds[2] = (uint32_t)((h * 0xd1342543de82ef95ULL) >> 32);
}

/* The shuffled index of pair seeds `seeds` for an index whose bits are reversed
 * (index_reversed): Owen scrambling of the index's digits, which keeps each aligned block
 * of 2^m indices an aligned block of 2^m. Returned as an integer (bit 0 its lowest). */
static inline uint32_t vf_sobol_shuffle(uint32_t index_reversed, uint32_t seed) {
  return vf_reverse_bits32(vf_nested_permute(index_reversed, seed));
}

/* Point `index` of pair `pair` as two 32-bit fractions (bit 31 first), scrambled with
 * `scramble`. The first coordinate is van der Corput, whose reversed digits are the index
 * itself. */
static inline void vf_sobol_pair_bits(uint32_t index, uint32_t scramble, uint32_t pair, uint32_t out[2]) {
  uint32_t seeds[3];
  vf_sobol_pair_seeds(scramble, pair, seeds);
  uint32_t i = vf_sobol_shuffle(vf_reverse_bits32(index), seeds[0]);
  out[0] = vf_reverse_bits32(vf_nested_permute(i, seeds[1]));
  out[1] = vf_reverse_bits32(vf_nested_permute(vf_sobol_second_reversed(i), seeds[2]));
}

static inline float vf_sampler_bits_float(uint32_t x) { return (float)(x >> 8) * 0x1p-24f; }

/* Keeps what seeds the path's PCG32 stream, which vf_sampler_rng seeds when first drawn
 * from. */
static inline void vf_sampler_defer_rng(vf_sampler *s, uint64_t seed, uint64_t iteration, uint64_t path,
                                        uint32_t stream) {
  s->seed = seed;
  s->iteration = iteration;
  s->path = path;
  s->stream = stream;
  s->rng_ready = 0;
}

/* The sampler of sub-path `path` (a pixel for camera sub-paths, a light sub-path index) of
 * `kind` (VF_STREAM_*) in global iteration `iteration`. */
static inline void vf_sampler_start(vf_sampler *s, vf_sampler_kind kind, uint64_t seed, uint64_t iteration,
                                    uint64_t path, uint32_t stream) {
  s->sobol = kind == VF_SAMPLER_SOBOL;
  vf_sampler_defer_rng(s, seed, iteration, path, stream);
  s->index = (uint32_t)(iteration / VF_SOBOL_REPLICATES);
  s->index_reversed = vf_reverse_bits32(s->index);
  uint64_t replicate = iteration % VF_SOBOL_REPLICATES;
  s->scramble = (uint32_t)vf_splitmix64(vf_splitmix64(seed ^ 0x5851f42d4c957f2dULL) ^
                                        vf_splitmix64(path ^ (replicate << 40) ^ ((uint64_t)stream << 56)));
}

/* A sobol sampler over another index: point `index` of the sequence scrambled by `key`
 * (in place of the iteration's replicate and the path), for sub-paths stratified across
 * one another rather than across iterations. The fallback stream is the path's as above. */
static inline void vf_sampler_start_across(vf_sampler *s, uint64_t seed, uint64_t iteration, uint64_t path,
                                           uint32_t stream, uint64_t key, uint32_t index) {
  s->sobol = 1;
  vf_sampler_defer_rng(s, seed, iteration, path, stream);
  s->index = index;
  s->index_reversed = vf_reverse_bits32(index);
  s->scramble = (uint32_t)vf_splitmix64(vf_splitmix64(seed ^ 0x2545f4914f6cdd1dULL) ^
                                        vf_splitmix64(key ^ ((uint64_t)stream << 56)));
}

/* The path's PCG32 stream, seeded on first use. */
static inline vf_rng *vf_sampler_rng(vf_sampler *s) {
  if (__builtin_expect(!s->rng_ready, 0)) {
    s->rng = vf_rng_for_path(s->seed, s->iteration, s->path, s->stream);
    s->rng_ready = 1;
  }
  return &s->rng;
}

/* Whether pair `pair`'s numbers come from the path's stream, one after another, so that
 * whether they are drawn moves every later number; else they are a function of the pair
 * alone, and a caller that needs none of them may leave them undrawn. */
static inline int vf_sampler_in_order(const vf_sampler *s, uint32_t pair) {
  return !s->sobol || pair == VF_SAMPLER_FALLBACK;
}

/* Two numbers in [0, 1) of pair `pair`; the independent sampler's next two instead. */
static inline void vf_sampler_2d(vf_sampler *s, uint32_t pair, float out[2]) {
  if (vf_sampler_in_order(s, pair)) {
    vf_rng *r = vf_sampler_rng(s);
    out[0] = vf_rng_float(r);
    out[1] = vf_rng_float(r);
    return;
  }
  uint32_t seeds[3];
  vf_sobol_pair_seeds(s->scramble, pair, seeds);
  uint32_t i = vf_sobol_shuffle(s->index_reversed, seeds[0]);
  uint32_t b[2] = {vf_reverse_bits32(vf_nested_permute(i, seeds[1])),
                   vf_reverse_bits32(vf_nested_permute(vf_sobol_second_reversed(i), seeds[2]))};
  out[0] = vf_sampler_bits_float(b[0]);
  out[1] = vf_sampler_bits_float(b[1]);
}

/* One number in [0, 1): the first coordinate of pair `pair`, alone (its van der Corput
 * component, Owen-scrambled, with the index shuffled); the independent sampler's next. */
static inline float vf_sampler_1d(vf_sampler *s, uint32_t pair) {
  if (vf_sampler_in_order(s, pair)) return vf_rng_float(vf_sampler_rng(s));
  uint32_t seeds[3];
  vf_sobol_pair_seeds(s->scramble, pair, seeds);
  uint32_t i = vf_sobol_shuffle(s->index_reversed, seeds[0]);
  return vf_sampler_bits_float(vf_reverse_bits32(vf_nested_permute(i, seeds[1])));
}

#endif
