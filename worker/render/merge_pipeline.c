/* Vertex merging's fast path: merge_pipeline.h.
 *
 * What it computes is the reference's (vf_vertex_merging_estimate, vertex_merging.c): for
 * each query, the light vertices within the radius in the candidate ranges of its cells,
 * merged by vf_vertex_merging_one and summed in the grid's order.
 *
 * Why it exists: a query does little arithmetic between three cache misses, each of which
 * needs the one before it (the cell table gives the ranges, the ranges give the merge
 * points, the passing merge points give the photons); the reference waits out each in
 * turn. Here a tile's queries run as a four-stage software pipeline, each stage AHEAD
 * queries behind the one before:
 *   A. the query's grid cells, prefetching their cell-table entries (vf_grid_cells_of);
 *   B. its candidate ranges, prefetching their merge points (vf_grid_ranges_of);
 *   C. the candidates within the radius and short enough to merge (find_hits, SIMD),
 *      prefetching the photons of those hits;
 *   D. the hits merged and added to the query's pixel.
 * Every miss of a query is then in flight while other queries compute. The candidate tests
 * of stage C take four candidates at a time with SSE2 and eight with AVX-512 where the CPU
 * has it, and branch on nothing but the rare long range, since the outcomes of the tests are
 * random. docs/BENCHMARKS.md ("Where vcm's time goes") has what each part costs.
 *
 * The same bits as the reference: stage C's tests are the reference's float operations in
 * the same order, so they pass the same light vertices, in the same order; stage D sums
 * them in that order. It leaves out only the light vertices whose joined path would be
 * too long, for which the reference adds vf_vertex_merging_one's +0.0f: x + 0.0f is x for
 * every x but -0.0f, which a sum begun at +0.0f never is. A query with more hits than its slot keeps is merged by the
 * reference itself. Pixels get their queries in queue order. tests/worker/render/test_vertex_merging.c
 * checks the hits and the sums of both against the reference, bit for bit. */
#include "merge_pipeline.h"
#include "vertex_merging.h"

#ifdef VF_MERGE_PIPELINE
#include <emmintrin.h>
#endif
#ifdef __x86_64__
#include <immintrin.h>
#endif
#include <stddef.h>

#ifdef VF_MERGE_PIPELINE
/* ---------------------------------------------------------------------------------------- */
/* Stage C: the candidate tests                                                              */

/* Which of the four merge points k .. k + 3 lie before `end`, within the radius of
 * (qx, qy, qz) and are at most `longest` segments long: bit i for point k + i. SSE2
 * (every x86-64 has it) turns the four points into one register per coordinate and tests
 * them together, with the same float operations in the same order as one at a time, so
 * the same points pass. Indices are compared as signed after flipping their top bit:
 * SSE2 has no unsigned comparison. */
static inline unsigned group_mask(const float *points, uint32_t k, __m128i end_flipped, __m128 qx, __m128 qy,
                                  __m128 qz, __m128 radius_sq, __m128i longest) {
  const float *p = points + 4 * (size_t)k;
  __m128 a = _mm_load_ps(p), b = _mm_load_ps(p + 4), c = _mm_load_ps(p + 8), d = _mm_load_ps(p + 12);
  __m128 ab_lo = _mm_unpacklo_ps(a, b), ab_hi = _mm_unpackhi_ps(a, b); /* ax bx ay by, az bz aw bw */
  __m128 cd_lo = _mm_unpacklo_ps(c, d), cd_hi = _mm_unpackhi_ps(c, d);
  __m128 dx = _mm_sub_ps(_mm_movelh_ps(ab_lo, cd_lo), qx);
  __m128 dy = _mm_sub_ps(_mm_movehl_ps(cd_lo, ab_lo), qy);
  __m128 dz = _mm_sub_ps(_mm_movelh_ps(ab_hi, cd_hi), qz);
  __m128i length = _mm_and_si128(_mm_castps_si128(_mm_movehl_ps(cd_hi, ab_hi)),
                                 _mm_set1_epi32((1 << VERTEX_LENGTH_BITS) - 1));
  __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz));
  __m128i index = _mm_add_epi32(_mm_set1_epi32((int)(k ^ 0x80000000u)), _mm_setr_epi32(0, 1, 2, 3));
  __m128i pass = _mm_and_si128(_mm_castps_si128(_mm_cmple_ps(d2, radius_sq)), _mm_cmplt_epi32(index, end_flipped));
  pass = _mm_andnot_si128(_mm_cmpgt_epi32(length, longest), pass);
  return (unsigned)_mm_movemask_ps(_mm_castsi128_ps(pass));
}

/* The offsets of the set bits of a 4-bit mask, in order (the rest 0), and their number: a
 * group's passing points are appended with one vector store and no branch per point, whose
 * outcome is random. */
static const uint32_t set_bits[16][4] __attribute__((aligned(16))) = {
    {0, 0, 0, 0}, {0, 0, 0, 0}, {1, 0, 0, 0}, {0, 1, 0, 0}, {2, 0, 0, 0}, {0, 2, 0, 0}, {1, 2, 0, 0}, {0, 1, 2, 0},
    {3, 0, 0, 0}, {0, 3, 0, 0}, {1, 3, 0, 0}, {0, 1, 3, 0}, {2, 3, 0, 0}, {0, 2, 3, 0}, {1, 2, 3, 0}, {0, 1, 2, 3}};
static const uint8_t bit_count[16] = {0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4};

/* vf_merge_pipeline_find_hits with SSE2: hits[] needs room for max + 4. Nearly every range
 * holds at most eight points; each is tested as two groups of four, whatever its length,
 * so that nothing here branches on the data but the rare longer range: the lengths of
 * ranges and the outcomes of the tests are random, and each mispredicted branch would cost
 * as much as testing a group. Groups may read up to seven points past a range, or past the
 * last point (the array has room: MERGE_POINT_PAD), and ignore them. */
static inline int find_hits_sse2(const vf_vcm *v, const vertex_merging_query *q, const vf_index_range *ranges, int n,
                                 uint32_t *hits, int max) {
  const float *points = (const float *)v->merge_points;
  __m128 qx = _mm_set1_ps(q->position.x), qy = _mm_set1_ps(q->position.y), qz = _mm_set1_ps(q->position.z);
  __m128 radius_sq = _mm_set1_ps(q->merge.radius_sq);
  __m128i longest = _mm_set1_epi32(v->settings.max_path_length - q->path_length); /* >= 1 */
  int found = 0;
  for (int r = 0; r < n; r++) {
    uint32_t k = ranges[r].begin, end = ranges[r].end;
    __m128i end_flipped = _mm_set1_epi32((int)(end ^ 0x80000000u));
    do {
      for (int g = 0; g < 2; g++, k += 4) {
        unsigned mask = group_mask(points, k, end_flipped, qx, qy, qz, radius_sq, longest);
        __m128i at = _mm_add_epi32(_mm_set1_epi32((int)k), _mm_load_si128((const __m128i *)set_bits[mask]));
        _mm_storeu_si128((__m128i *)(hits + (found < max ? found : max)), at);
        found += bit_count[mask];
      }
    } while (k < end);
  }
  return found;
}

#ifdef __x86_64__
#define MERGE_AVX512 1
/* vf_merge_pipeline_find_hits on CPUs with AVX-512 (F and VL;
 * vf_merge_pipeline_detect_avx512 looks): a range's eight points in one step instead of
 * two groups of four. Two 64-byte loads hold the eight points; one permutation per field
 * gathers them into a register per coordinate; the tests are the same float operations, in
 * the same order, as group_mask's, and the passing indices are packed in order into one
 * register (VPCOMPRESSD) and stored whole: compressing straight into memory is microcoded
 * on AMD Zen 4, where it made vertex merging slower than SSE2 (docs/BENCHMARKS.md,
 * "Renderer throughput"). So the same hits, in the same order. This target allows FMA: the
 * build's -ffp-contract=off (CMakeLists.txt) keeps every product and sum rounded on its
 * own, here and in the code inlined into run_avx512. hits[] needs room for max + 8. */
__attribute__((target("avx512f,avx512vl,popcnt"))) static inline int find_hits_avx512(
    const vf_vcm *v, const vertex_merging_query *q, const vf_index_range *ranges, int n, uint32_t *hits, int max) {
  const float *points = (const float *)v->merge_points;
  __m256 qx = _mm256_set1_ps(q->position.x), qy = _mm256_set1_ps(q->position.y), qz = _mm256_set1_ps(q->position.z);
  __m256 radius_sq = _mm256_set1_ps(q->merge.radius_sq);
  __m256i longest = _mm256_set1_epi32(v->settings.max_path_length - q->path_length); /* >= 1 */
  __m256i length_mask = _mm256_set1_epi32((1 << VERTEX_LENGTH_BITS) - 1);
  __m256i iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  /* Field f of point i (of the sixteen floats of a, then b) is float 4 i + f. */
  __m512i field_x = _mm512_setr_epi32(0, 4, 8, 12, 16, 20, 24, 28, 0, 0, 0, 0, 0, 0, 0, 0);
  __m512i field_y = _mm512_add_epi32(field_x, _mm512_set1_epi32(1));
  __m512i field_z = _mm512_add_epi32(field_x, _mm512_set1_epi32(2));
  __m512i field_w = _mm512_add_epi32(field_x, _mm512_set1_epi32(3));
  int found = 0;
  for (int r = 0; r < n; r++) {
    uint32_t k = ranges[r].begin, end = ranges[r].end;
    __m256i end_v = _mm256_set1_epi32((int)end);
    do {
      const float *p = points + 4 * (size_t)k;
      __m512 a = _mm512_loadu_ps(p), b = _mm512_loadu_ps(p + 16);
      __m256 dx = _mm256_sub_ps(_mm512_castps512_ps256(_mm512_permutex2var_ps(a, field_x, b)), qx);
      __m256 dy = _mm256_sub_ps(_mm512_castps512_ps256(_mm512_permutex2var_ps(a, field_y, b)), qy);
      __m256 dz = _mm256_sub_ps(_mm512_castps512_ps256(_mm512_permutex2var_ps(a, field_z, b)), qz);
      __m256i length = _mm256_and_si256(
          _mm256_castps_si256(_mm512_castps512_ps256(_mm512_permutex2var_ps(a, field_w, b))), length_mask);
      __m256 d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
      __mmask8 pass = _mm256_cmp_ps_mask(d2, radius_sq, _CMP_LE_OS);
      __m256i index = _mm256_add_epi32(_mm256_set1_epi32((int)k), iota);
      pass &= _mm256_cmplt_epu32_mask(index, end_v) & _mm256_cmple_epi32_mask(length, longest);
      _mm256_storeu_si256((__m256i *)(hits + (found < max ? found : max)), _mm256_maskz_compress_epi32(pass, index));
      found += __builtin_popcount(pass);
      k += 8;
    } while (k < end);
  }
  return found;
}
#endif

int vf_merge_pipeline_find_hits(const vf_vcm *v, const vertex_merging_query *q, const vf_index_range *ranges, int n,
                                uint32_t *hits, int max, int avx512) {
#ifdef MERGE_AVX512
  if (avx512) return find_hits_avx512(v, q, ranges, n, hits, max);
#else
  (void)avx512;
#endif
  return find_hits_sse2(v, q, ranges, n, hits, max);
}

/* ---------------------------------------------------------------------------------------- */
/* The pipeline                                                                              */

#define AHEAD 4            /* queries between one stage and the next */
#define RING (4 * AHEAD)   /* slots: a query holds its own from stage A to stage D */
_Static_assert(VF_MERGE_HITS_SLACK >= 8, "find_hits_avx512 writes up to 8 past a slot's VF_MERGE_SLOT_HITS");

/* A query in flight: what each stage leaves for the next. */
typedef struct {
  vf_grid_cells cells;                           /* A */
  vf_index_range ranges[VF_HASHGRID_MAX_RANGES]; /* B */
  int num_ranges;
  uint32_t hits[VF_MERGE_SLOT_HITS + VF_MERGE_HITS_SLACK]; /* C */
  int num_hits;
} query_slot;

/* B: prefetches the lines of merge points that find_hits reads first (two groups of four
 * points, or eight at once: up to three lines), then any further ones of a longer range. */
static inline void prefetch_ranges(const vf_vcm *v, const query_slot *s) {
  for (int r = 0; r < s->num_ranges; r++) {
    const char *p0 = (const char *)&v->merge_points[s->ranges[r].begin];
    const char *p1 = (const char *)&v->merge_points[s->ranges[r].end];
    __builtin_prefetch(p0);
    __builtin_prefetch(p0 + 64);
    __builtin_prefetch(p0 + 127);
    for (p0 += 191; p0 < p1; p0 += 64) __builtin_prefetch(p0);
  }
}

/* D: the query's hits merged, in order, and added to its pixel as the reference's sum. */
static inline void merge_hits(const vf_vcm *v, const vertex_merging_query *q, const query_slot *s, float *tile_rgb) {
  vf_vec3 sum;
  if (s->num_hits > VF_MERGE_SLOT_HITS) {
    sum = vf_vertex_merging_estimate(v, q);
  } else {
    sum = vf_vec3_splat(0.0f);
    for (int k = 0; k < s->num_hits; k++) sum = vf_add(sum, vf_vertex_merging_one(v, q, s->hits[k]));
    sum = vf_scale(sum, q->merge.vm_normalization);
  }
  vf_vec3 contrib = vf_mul(q->throughput, sum);
  float *rgb = &tile_rgb[3 * (size_t)q->tile_pixel];
  rgb[0] += contrib.x;
  rgb[1] += contrib.y;
  rgb[2] += contrib.z;
}

/* Step i of the loop runs stage A of query i, B of query i - AHEAD, C of query
 * i - 2 AHEAD and D of query i - 3 AHEAD; query j lives in slot j % RING. */
static inline __attribute__((always_inline)) void run_pipeline(vf_vcm *v, int thread, float *tile_rgb, int avx512) {
  thread_scratch *ts = &v->scratch[thread];
  int n = (int)ts->num_queries;
  if (n == 0) return; /* nothing queued: no vertex merging, or no grid this iteration */
  const vertex_merging_query *q = ts->queries;
  const vf_grid_lookup *lookup = vf_hashgrid_lookup(v->grid);
  query_slot slot[RING];
  for (int i = 0; i < n + 3 * AHEAD; i++) {
    int a = i, b = i - AHEAD, c = i - 2 * AHEAD, d = i - 3 * AHEAD;
    if (a < n) vf_grid_cells_of(lookup, q[a].position, &slot[a % RING].cells);
    if (b >= 0 && b < n) {
      query_slot *s = &slot[b % RING];
      s->num_ranges = vf_grid_ranges_of(lookup, &s->cells, s->ranges);
      prefetch_ranges(v, s);
    }
    if (c >= 0 && c < n) {
      query_slot *s = &slot[c % RING];
      s->num_hits =
#ifdef MERGE_AVX512
          avx512 ? find_hits_avx512(v, &q[c], s->ranges, s->num_ranges, s->hits, VF_MERGE_SLOT_HITS) :
#endif
                 find_hits_sse2(v, &q[c], s->ranges, s->num_ranges, s->hits, VF_MERGE_SLOT_HITS);
      for (int k = 0; k < s->num_hits && k < VF_MERGE_SLOT_HITS; k++) __builtin_prefetch(&v->photons[s->hits[k]]);
    }
    if (d >= 0 && d < n) merge_hits(v, &q[d], &slot[d % RING], tile_rgb);
  }
  ts->num_queries = 0;
}

/* The pipeline compiled twice, with each candidate test inlined: the choice between them
 * is made once per tile. */
static void run_sse2(vf_vcm *v, int thread, float *tile_rgb) { run_pipeline(v, thread, tile_rgb, 0); }

#ifdef MERGE_AVX512
__attribute__((target("avx512f,avx512vl,popcnt"))) static void run_avx512(vf_vcm *v, int thread, float *tile_rgb) {
  run_pipeline(v, thread, tile_rgb, 1);
}
#endif

void vf_merge_pipeline_run(vf_vcm *v, int thread, float *tile_rgb) {
#ifdef MERGE_AVX512
  if (v->vertex_merging_avx512) {
    run_avx512(v, thread, tile_rgb);
    return;
  }
#endif
  run_sse2(v, thread, tile_rgb);
}
#endif /* VF_MERGE_PIPELINE */

int vf_merge_pipeline_detect_avx512(void) {
#ifdef MERGE_AVX512
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl");
#else
  return 0;
#endif
}
