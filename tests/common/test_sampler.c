/* common/sampler.h: the sequence's own properties. The sobol sampler's points over
 * consecutive iterations of one replicate are nets (every elementary interval of a pair
 * holds exactly one point), its scrambles are independent across pixels, replicates,
 * kinds of sub-path and pairs, and the independent sampler is the PCG32 stream itself. */
#include "check.h"
#include "common/sampler.h"

#include <stdint.h>
#include <stdlib.h>

enum { MAX_M = 12 };

/* The point of pair `pair` at sample index `index` of replicate `replicate` of a path, as
 * the renderer draws it: through an iteration index. */
static void point_at(uint64_t seed, uint64_t path, uint32_t stream, uint32_t replicate, uint32_t index,
                     uint32_t pair, float out[2]) {
  vf_sampler s;
  vf_sampler_start(&s, VF_SAMPLER_SOBOL, seed, (uint64_t)index * VF_SOBOL_REPLICATES + replicate, path, stream);
  vf_sampler_2d(&s, pair, out);
}

/* Whether the 2^m points are a (0,m,2)-net: for every split m = k + (m - k), each of the
 * 2^k x 2^(m-k) elementary boxes holds exactly one point. Prints the first failure. */
static int is_net(const float (*p)[2], int m) {
  static unsigned char seen[1 << MAX_M];
  uint32_t n = 1u << m;
  for (int k = 0; k <= m; k++) {
    for (uint32_t i = 0; i < n; i++) seen[i] = 0;
    for (uint32_t i = 0; i < n; i++) {
      uint32_t bx = (uint32_t)(p[i][0] * (float)(1u << k)), by = (uint32_t)(p[i][1] * (float)(1u << (m - k)));
      uint32_t box = (bx << (m - k)) | by;
      if (seen[box]++) {
        printf("  m %d, boxes %u x %u: box (%u, %u) holds two points\n", m, 1u << k, 1u << (m - k), bx, by);
        return 0;
      }
    }
  }
  return 1;
}

static void test_consecutive_iterations_of_a_replicate_are_nets(void) {
  static float p[1 << MAX_M][2];
  static const uint32_t pairs[] = {0, 1, 2, 3, 7, 22, 41};
  int nets = 0;
  for (uint64_t path = 0; path < 3; path++)
    for (uint32_t replicate = 0; replicate < VF_SOBOL_REPLICATES; replicate++)
      for (size_t q = 0; q < sizeof pairs / sizeof *pairs; q++)
        for (int m = 1; m <= MAX_M; m++)
          for (uint32_t block = 0; block < 3; block++) { /* the first, second and fourth block of 2^m */
            uint32_t first = (block == 2 ? 3u : block) << m;
            for (uint32_t i = 0; i < (1u << m); i++)
              point_at(17, 1000 * path + 5, VF_STREAM_CAMERA, replicate, first + i, pairs[q], p[i]);
            int ok = is_net((const float(*)[2])p, m);
            if (!ok) printf("  path %llu replicate %u pair %u indices [%u, %u)\n", (unsigned long long)path,
                            replicate, pairs[q], first, first + (1u << m));
            CHECK(ok);
            nets += ok;
            if (!ok) return;
          }
  printf("  %d blocks of 2^1 .. 2^%d iterations: all nets\n", nets, MAX_M);
}

/* A 1D number is stratified alone: 2^m consecutive indices put one point in each 1/2^m. */
static void test_one_dimension_is_stratified(void) {
  static unsigned char seen[1 << MAX_M];
  for (uint32_t pair = 0; pair < 30; pair += 3)
    for (int m = 1; m <= MAX_M; m += 3) {
      uint32_t n = 1u << m;
      for (uint32_t i = 0; i < n; i++) seen[i] = 0;
      int ok = 1;
      for (uint32_t i = 0; i < n; i++) {
        vf_sampler s;
        vf_sampler_start(&s, VF_SAMPLER_SOBOL, 3, (uint64_t)(n + i) * VF_SOBOL_REPLICATES, 77, VF_STREAM_LIGHT);
        float u = vf_sampler_1d(&s, pair);
        if (seen[(uint32_t)(u * (float)n)]++) ok = 0;
      }
      if (!ok) printf("  pair %u, 2^%d points: an interval holds two\n", pair, m);
      CHECK(ok);
    }
}

/* Pearson correlation of x and y over n values. */
static double correlation(const double *x, const double *y, int n) {
  double mx = 0, my = 0, sxy = 0, sxx = 0, syy = 0;
  for (int i = 0; i < n; i++) mx += x[i], my += y[i];
  mx /= n, my /= n;
  for (int i = 0; i < n; i++) {
    sxy += (x[i] - mx) * (y[i] - my);
    sxx += (x[i] - mx) * (x[i] - mx);
    syy += (y[i] - my) * (y[i] - my);
  }
  return sxy / sqrt(sxx * syy);
}

/* Scrambles of neighbouring pixels, of the two replicates, of camera and light sub-paths
 * and of different pairs are independent: the correlation of the numbers they give at the
 * same index, over many indices, is within 4.5 standard errors (1/sqrt(n)) of 0; so is
 * that of two pixels' numbers across the pixels of an image at one index. */
enum { NCORR = 8192 };
static void check_uncorrelated(const char *what, const double *x, const double *y) {
  double r = correlation(x, y, NCORR), limit = 4.5 / sqrt((double)NCORR);
  if (!(fabs(r) < limit)) printf("  %s: correlation %.4f (limit %.4f)\n", what, r, limit);
  CHECK(fabs(r) < limit);
}

static void test_scrambles_are_independent(void) {
  static double a[NCORR], b[NCORR];
  float p[2], q[2];
  for (uint32_t pair = 0; pair < 12; pair += 5) {
    /* along the iterations: pixel 100 against pixel 101, and against the other replicate */
    for (int i = 0; i < NCORR; i++) {
      point_at(1, 100, VF_STREAM_CAMERA, 0, (uint32_t)i, pair, p);
      point_at(1, 101, VF_STREAM_CAMERA, 0, (uint32_t)i, pair, q);
      a[i] = p[0], b[i] = q[0];
    }
    check_uncorrelated("neighbouring pixels, x", a, b);
    for (int i = 0; i < NCORR; i++) {
      point_at(1, 100, VF_STREAM_CAMERA, 0, (uint32_t)i, pair, p);
      point_at(1, 100, VF_STREAM_CAMERA, 1, (uint32_t)i, pair, q);
      a[i] = p[1], b[i] = q[1];
    }
    check_uncorrelated("replicates, y", a, b);
    for (int i = 0; i < NCORR; i++) {
      point_at(1, 100, VF_STREAM_CAMERA, 0, (uint32_t)i, pair, p);
      point_at(1, 100, VF_STREAM_LIGHT, 0, (uint32_t)i, pair, q);
      a[i] = p[0], b[i] = q[0];
    }
    check_uncorrelated("camera and light, x", a, b);
    for (int i = 0; i < NCORR; i++) {
      point_at(1, 100, VF_STREAM_CAMERA, 0, (uint32_t)i, pair, p);
      point_at(1, 100, VF_STREAM_CAMERA, 0, (uint32_t)i, pair + 1, q);
      a[i] = p[0], b[i] = q[0];
    }
    check_uncorrelated("next pair, x", a, b);
    /* across an image at one index: each pixel against its right-hand neighbour */
    for (uint32_t index = 0; index < 3; index++) {
      for (int i = 0; i < NCORR; i++) {
        point_at(9, 2 * (uint64_t)i, VF_STREAM_CAMERA, 0, index, pair, p);
        point_at(9, 2 * (uint64_t)i + 1, VF_STREAM_CAMERA, 0, index, pair, q);
        a[i] = p[0], b[i] = q[1];
      }
      check_uncorrelated("across pixels at one index", a, b);
    }
  }
}

/* At a fixed index the pixels' points are uniform over the square (the scramble is random
 * per pixel): chi-square over 8 x 8 cells of 8192 pixels, 63 degrees of freedom, below the
 * 1e-5 tail (about 120); and not suspiciously uniform either (above the 1e-5 low tail, 25). */
static void test_pixels_at_one_index_are_uniform(void) {
  for (uint32_t index = 0; index < 4; index += 3) {
    int cells[64] = {0};
    for (uint64_t pixel = 0; pixel < NCORR; pixel++) {
      float p[2];
      point_at(5, pixel, VF_STREAM_CAMERA, 1, index, index + 2, p);
      cells[(int)(p[0] * 8) * 8 + (int)(p[1] * 8)]++;
    }
    double expected = NCORR / 64.0, chi2 = 0;
    for (int c = 0; c < 64; c++) chi2 += (cells[c] - expected) * (cells[c] - expected) / expected;
    printf("  index %u: chi-square %.1f over 63 degrees of freedom\n", index, chi2);
    CHECK(chi2 < 120.0 && chi2 > 25.0);
  }
}

/* The second dimension of Sobol' as its definition gives it, column by column. */
static uint32_t sobol_second_by_columns(uint32_t i) {
  uint32_t r = 0, v = 0x80000000u;
  for (; i; i >>= 1, v ^= v >> 1)
    if (i & 1u) r ^= v;
  return r;
}

static void test_sobol_second_dimension_matches_its_definition(void) {
  uint64_t x = 12345;
  for (int k = 0; k < 100000; k++) {
    uint32_t i = k < 1024 ? (uint32_t)k : (uint32_t)(x = vf_splitmix64(x));
    if (vf_sobol_second(i) != sobol_second_by_columns(i)) {
      CHECK_INT_EQ(vf_sobol_second(i), sobol_second_by_columns(i));
      return;
    }
  }
}

/* The nested permutation changes bit b only as a function of bits 0..b: flipping a higher
 * bit of the input leaves bits 0..b of the output as they were; and it is a bijection on
 * the low m bits (a permutation of each aligned block). */
static void test_nested_permutation_is_nested(void) {
  uint64_t x = 99;
  for (int k = 0; k < 20000; k++) {
    x = vf_splitmix64(x);
    uint32_t v = (uint32_t)x, seed = (uint32_t)(x >> 32);
    int b = k % 31, c = b + 1 + (int)((x >> 27) % (uint64_t)(31 - b));
    uint32_t low = (1u << (b + 1)) - 1u;
    uint32_t a = vf_nested_permute(v, seed), a2 = vf_nested_permute(v ^ (1u << c), seed);
    if ((a & low) != (a2 & low)) {
      CHECK_INT_EQ(a & low, a2 & low);
      return;
    }
  }
  static unsigned char hit[1 << 10];
  for (uint32_t seed = 1; seed < 50; seed += 7) {
    for (uint32_t i = 0; i < 1024; i++) hit[i] = 0;
    for (uint32_t i = 0; i < 1024; i++) hit[vf_nested_permute(i, seed * 2654435761u) & 1023u]++;
    for (uint32_t i = 0; i < 1024; i++) CHECK_INT_EQ(hit[i], 1);
  }
}

/* The independent sampler is the path's PCG32 stream, in the order numbers are asked for,
 * whatever pair they name; so is the sobol sampler's fallback. */
static void test_independent_sampler_is_the_stream(void) {
  for (int kind = 0; kind < VF_SAMPLER_COUNT_; kind++) {
    vf_sampler s;
    vf_sampler_start(&s, (vf_sampler_kind)kind, 4, 1234, 56, VF_STREAM_CAMERA);
    vf_rng r = vf_rng_for_path(4, 1234, 56, VF_STREAM_CAMERA);
    uint32_t pair = kind == VF_SAMPLER_SOBOL ? VF_SAMPLER_FALLBACK : 3;
    for (int i = 0; i < 100; i++) {
      float u[2];
      vf_sampler_2d(&s, pair, u);
      float one = vf_sampler_1d(&s, pair);
      float e0 = vf_rng_float(&r), e1 = vf_rng_float(&r), e2 = vf_rng_float(&r);
      CHECK(u[0] == e0 && u[1] == e1 && one == e2);
    }
  }
}

/* The same (seed, iteration, path) gives the same numbers, and the 1D number of a pair is
 * the first coordinate of its 2D point. */
static void test_numbers_are_a_function_of_the_keys(void) {
  for (uint32_t pair = 0; pair < 40; pair++) {
    vf_sampler a, b;
    vf_sampler_start(&a, VF_SAMPLER_SOBOL, 8, 77, 1234, VF_STREAM_LIGHT);
    vf_sampler_start(&b, VF_SAMPLER_SOBOL, 8, 77, 1234, VF_STREAM_LIGHT);
    float p[2], q[2];
    vf_sampler_2d(&a, pair, p);
    vf_sampler_2d(&b, pair, q);
    CHECK(p[0] == q[0] && p[1] == q[1]);
    CHECK(vf_sampler_1d(&a, pair) == p[0]);
    CHECK(p[0] >= 0.0f && p[0] < 1.0f && p[1] >= 0.0f && p[1] < 1.0f);
  }
}

int main(void) {
  RUN(test_sobol_second_dimension_matches_its_definition);
  RUN(test_nested_permutation_is_nested);
  RUN(test_consecutive_iterations_of_a_replicate_are_nets);
  RUN(test_one_dimension_is_stratified);
  RUN(test_scrambles_are_independent);
  RUN(test_pixels_at_one_index_are_uniform);
  RUN(test_independent_sampler_is_the_stream);
  RUN(test_numbers_are_a_function_of_the_keys);
  return check_finish();
}
