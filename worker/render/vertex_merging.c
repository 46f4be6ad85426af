/* Vertex merging, phases 2 and 3 of an iteration: vertex_merging.h. */
#include "vertex_merging.h"
#include "huge_pages.h"

#include "../../common/error.h"

#ifdef __SSE2__
#include <emmintrin.h>
#endif
#ifdef __x86_64__
#include <immintrin.h>
#endif
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#define GATHER_CHUNK 16384u
#define GATHER_AHEAD 16u

/* What vertex merging needs of the light vertices, in the grid's order, in two arrays: the
 * distance and path-length tests of a query's candidates read only merge_point (16 bytes,
 * four to a line), and only the candidates that pass read their photon (32 bytes, aligned:
 * one line). A query is bound by the lines it misses, not by its arithmetic. */
struct merge_point {
  float x, y, z;
  uint32_t path_length_shape; /* as in light_vertex */
};
_Static_assert(sizeof(merge_point) == 16, "find_hits reads a merge point as four floats");
/* The merge points are the grid's sorted points, their index fields overwritten. */
_Static_assert(sizeof(merge_point) == sizeof(vf_grid_point) && offsetof(merge_point, x) == offsetof(vf_grid_point, x) &&
                   offsetof(merge_point, path_length_shape) == offsetof(vf_grid_point, index),
               "a merge point is a grid point whose index became the path length");
#define MERGE_POINT_PAD 7u /* find_hits reads up to this many points past the last */
_Static_assert(MERGE_POINT_PAD <= VF_HASHGRID_POINT_PAD, "the grid pads its points for find_hits");

struct photon {
  vf_vec3 throughput;
  vf_vec3 direction; /* world, towards the previous light vertex */
  float d_vcm, d_vm;
};
_Static_assert(sizeof(photon) == 32, "two photons to a cache line");

/* Photons and merge points on huge pages (worker/render/huge_pages.h). Measured on cornell 512x512,
 * vcm, alternating 4 rounds: camera pass 174.5-176.8 -> 171.6-173.3 ms, 2% more iterations
 * per second (with the light vertices, then one joined array). The grid's other arrays
 * gained nothing, nor did the chunks' vertex lists once aligned to the cache line
 * (docs/BENCHMARKS.md). */

/* ---------------------------------------------------------------------------------------- */
/* Phase 2: the grid                                                                         */

/* The light vertex the grid names `index` (vf_vcm.chunk_shift). */
static const light_vertex *grid_vertex(const vf_vcm *v, uint32_t index) {
  return &v->chunks[index >> v->chunk_shift].vertices[index & ((1u << v->chunk_shift) - 1u)];
}

/* Copies what vertex merging needs of the light vertices into the grid's order, so that the
 * vertices a query accepts lie next to each other in memory: the photons, and in the grid's
 * own sorted points (whose positions are there already) each vertex's path length in place
 * of its index, read just before. */
static void gather_task(void *ctx, size_t task, int thread) {
  vf_vcm *v = ctx;
  merge_point *points = v->merge_points;
  uint32_t n = vf_hashgrid_count(v->grid);
  uint32_t begin = (uint32_t)task * GATHER_CHUNK, end = begin + GATHER_CHUNK < n ? begin + GATHER_CHUNK : n;
  for (uint32_t k = begin; k < end; k++) {
    /* The vertices are read in grid order, that is at random: fetch ahead of use. */
    if (k + GATHER_AHEAD < end) __builtin_prefetch(grid_vertex(v, points[k + GATHER_AHEAD].path_length_shape));
    const light_vertex *lv = grid_vertex(v, points[k].path_length_shape); /* still the index */
    points[k].path_length_shape = lv->path_length_shape;
    v->photons[k] = (photon){lv->throughput, lv->fix, lv->mis.d_vcm, lv->mis.d_vm};
  }
}

int vf_vertex_merging_build_grid(vf_vcm *v) {
  for (uint32_t c = 0; c < v->num_chunks; c++)
    v->segments[c] = (vf_grid_segment){v->chunks[c].vertices, v->chunks[c].num_vertices, c << v->chunk_shift};
  int err = vf_hashgrid_build_segments(v->grid, v->segments, v->num_chunks, sizeof(light_vertex), v->radius,
                                       v->pool);
  if (err != VF_OK) return err;
  uint32_t n = vf_hashgrid_count(v->grid);
  if (n > v->photon_capacity) {
    /* Photons aligned to the line, so that each lies in one; old contents are not kept.
     * Slack as for the vertices. */
    size_t capacity = n + n / 8 < UINT32_MAX ? (size_t)(n + n / 8) : UINT32_MAX;
    free(v->photons);
    v->photons = vf_huge_alloc(capacity * sizeof(photon));
    v->photon_capacity = v->photons ? (uint32_t)capacity : 0;
    if (v->photon_capacity == 0) return VF_ENOMEM;
  }
  /* Borrowed from the grid until its next build; its pad past n reads as zeros, ignored. */
  v->merge_points = (merge_point *)vf_hashgrid_points_writable(v->grid);
  vf_pool_run(v->pool, (n + GATHER_CHUNK - 1) / GATHER_CHUNK, gather_task, v);
  return VF_OK;
}

/* Below this the copies keep their pages: re-faulting them would cost about 1% of a small
 * image's iteration, and the memory matters only for large ones (docs/BENCHMARKS.md,
 * "Memory"). Zeroing the pages again costs about 0.2% of an iteration's time at 1920x1080. */
#define RELEASE_MIN_BYTES ((size_t)64 << 20)

void vf_vertex_merging_release(vf_vcm *v) {
  size_t n = vf_hashgrid_count(v->grid);
  if (n * (sizeof(photon) + sizeof(merge_point)) < RELEASE_MIN_BYTES) return;
  vf_huge_release(v->photons, n * sizeof(photon));
  vf_hashgrid_release_points(v->grid); /* the merge points */
  v->merge_points = NULL;
}

/* ---------------------------------------------------------------------------------------- */
/* Phase 3: the queries of a camera tile                                                     */

/* Merges camera vertex q with light vertex k (an index into the grid's order), which lies
 * within the radius: the vertex merging estimate with its MIS weight (eq. 38-39). */
static vf_vec3 merge_one(const vf_vcm *v, const vertex_merging_query *q, uint32_t k) {
  uint32_t length_shape = v->merge_points[k].path_length_shape;
  if ((int)(length_shape & ((1u << VERTEX_LENGTH_BITS) - 1u)) + q->path_length > v->settings.max_path_length)
    return vf_vec3_splat(0.0f);
  const photon *ph = &v->photons[k];
  float cos_camera, camera_pdf, camera_rev_pdf;
  vf_vec3 f = vf_bsdf_evaluate(&q->bsdf, ph->direction, &cos_camera, &camera_pdf, &camera_rev_pdf);
  if (vf_is_zero(f)) return f;
  float w = 1.0f;
  if (!v->t.ppm) {
    /* The reverse step is taken at the light vertex: its Russian roulette applies. */
    camera_rev_pdf *= v->shape_continuation[length_shape >> VERTEX_LENGTH_BITS] / q->bsdf.continuation;
    vf_mis light = {ph->d_vcm, 0.0f, ph->d_vm};
    w = vf_mis_weight_merge(&light, &q->mis, &v->mis, camera_pdf, camera_rev_pdf);
  }
  return vf_scale(vf_mul(f, ph->throughput), w);
}

#ifdef __SSE2__
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

/* The light vertices of the candidate ranges within the radius of query q and short
 * enough to merge with it (merge_one would give the others nothing), in grid order: up to
 * max of them into hits[0 .. max), which has room for max + 4 (the slots past max take
 * writes past it). Returns their number, which may exceed max. Nearly every range holds
 * at most eight points; each is tested as two groups of four, whatever its length, so
 * that nothing here branches on the data but the rare longer range: the lengths of ranges
 * and the outcomes of the tests are random, and each mispredicted branch would cost as
 * much as testing a group. Groups may read up to seven points past a range, or past the
 * last point (the array has room), and ignore them. */
static int find_hits(const vf_vcm *v, const vertex_merging_query *q, const vf_index_range *ranges, int n,
                     uint32_t *hits, int max) {
  const float *points = (const float *)v->merge_points;
  __m128 qx = _mm_set1_ps(q->position.x), qy = _mm_set1_ps(q->position.y), qz = _mm_set1_ps(q->position.z);
  __m128 radius_sq = _mm_set1_ps(v->radius_sq);
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
/* find_hits on CPUs with AVX-512 (F and VL; vf_vertex_merging_detect_avx512 looks): a
 * range's eight points in one step instead of two groups of four. Two 64-byte loads hold
 * the eight points; one permutation per field gathers them into a register per
 * coordinate; the tests are the same float operations, in the same order, as
 * group_mask's, and the passing indices are packed in order into one register
 * (VPCOMPRESSD) and stored whole: compressing straight into memory is microcoded on AMD
 * Zen 4, and made vertex merging slower than SSE2 there. So the same hits, in the same
 * order (test_vcm compares the frames). This target allows FMA:
 * the build's -ffp-contract=off (CMakeLists.txt) keeps every product and sum rounded on
 * its own, here and in the code inlined into run_merges_avx512. The caller's hits[] needs
 * room for max + 8. */
__attribute__((target("avx512f,avx512vl,popcnt"))) static inline int find_hits_avx512(
    const vf_vcm *v, const vertex_merging_query *q, const vf_index_range *ranges, int n, uint32_t *hits, int max) {
  const float *points = (const float *)v->merge_points;
  __m256 qx = _mm256_set1_ps(q->position.x), qy = _mm256_set1_ps(q->position.y), qz = _mm256_set1_ps(q->position.z);
  __m256 radius_sq = _mm256_set1_ps(v->radius_sq);
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

#else
/* find_hits one candidate at a time, for targets without SSE2: the same tests in the same
 * order, so the same hits (the vector version's comment above says why it branches less). */
static int find_hits(const vf_vcm *v, const vertex_merging_query *q, const vf_index_range *ranges, int n,
                     uint32_t *hits, int max) {
  uint32_t longest = (uint32_t)(v->settings.max_path_length - q->path_length); /* >= 1 */
  int found = 0;
  for (int r = 0; r < n; r++)
    for (uint32_t k = ranges[r].begin; k < ranges[r].end; k++) {
      const merge_point *mp = &v->merge_points[k];
      float dx = mp->x - q->position.x, dy = mp->y - q->position.y, dz = mp->z - q->position.z;
      hits[found < max ? found : max] = k;
      found += (dx * dx + dy * dy + dz * dz <= v->radius_sq) &
               ((mp->path_length_shape & ((1u << VERTEX_LENGTH_BITS) - 1u)) <= longest);
    }
  return found;
}
#endif

static vf_vec3 merge_all(const vf_vcm *v, const vertex_merging_query *q, const vf_index_range *ranges, int n) {
  vf_vec3 sum = vf_vec3_splat(0.0f);
  const merge_point *points = v->merge_points;
  for (int r = 0; r < n; r++)
    for (uint32_t k = ranges[r].begin; k < ranges[r].end; k++) {
      const merge_point *gp = &points[k];
      float dx = gp->x - q->position.x, dy = gp->y - q->position.y, dz = gp->z - q->position.z;
      if (dx * dx + dy * dy + dz * dz <= v->radius_sq) sum = vf_add(sum, merge_one(v, q, k));
    }
  return vf_scale(sum, v->vm_normalization);
}

/* Merges a camera vertex at once: the path when a query cannot be queued. */
vf_vec3 vf_vertex_merging_now(const vf_vcm *v, const vertex_merging_query *q) {
  vf_index_range ranges[VF_HASHGRID_MAX_RANGES];
  int n = vf_hashgrid_candidates(v->grid, q->position, ranges);
  return merge_all(v, q, ranges, n);
}

/* Runs the tile's queued queries as a four-stage software pipeline, each stage AHEAD
 * queries behind the previous one:
 *   A. compute the query's grid cells, prefetching their cell-table entries;
 *   B. read its candidate ranges, prefetching their sorted positions;
 *   C. test distances, prefetching the photon records of the hits;
 *   D. evaluate the hits (BSDF and MIS weight) and add them to the pixel.
 * Every miss of a query is then in flight while other queries compute, instead of each
 * query waiting for its own misses in turn. Results are added in queue order, so they do
 * not depend on the thread. */
#define AHEAD 4
#define RING (4 * AHEAD)
#define MAX_HITS 24
static inline __attribute__((always_inline)) void merge_pipeline(vf_vcm *v, int thread, float *tile_rgb,
                                                                 int avx512) {
  thread_stats *ts = &v->stats[thread];
  int n = (int)ts->num_queries;
  if (n == 0) return; /* nothing queued: no vertex merging, or no grid this iteration */
  const vertex_merging_query *q = ts->queries;
  const merge_point *points = v->merge_points;
  const vf_grid_lookup *lookup = vf_hashgrid_lookup(v->grid);
  vf_grid_cells cells[RING];
  vf_index_range ranges[RING][VF_HASHGRID_MAX_RANGES];
  int num_ranges[RING], num_hits[RING];
  uint32_t hits[RING][MAX_HITS + 8]; /* room for find_hits' writes past MAX_HITS */
  for (int i = 0; i < n + 3 * AHEAD; i++) {
    int a = i, b = i - AHEAD, c = i - 2 * AHEAD, d = i - 3 * AHEAD;
    if (a < n) vf_grid_cells_of(lookup, q[a].position, &cells[a % RING]);
    if (b >= 0 && b < n) {
      int m = num_ranges[b % RING] = vf_grid_ranges_of(lookup, &cells[b % RING], ranges[b % RING]);
      for (int r = 0; r < m; r++) {
        /* The lines that find_hits reads first, then any of a longer range. */
        const char *p0 = (const char *)&points[ranges[b % RING][r].begin];
        const char *p1 = (const char *)&points[ranges[b % RING][r].end];
        __builtin_prefetch(p0);
        __builtin_prefetch(p0 + 64);
        __builtin_prefetch(p0 + 127);
        for (p0 += 191; p0 < p1; p0 += 64) __builtin_prefetch(p0);
      }
    }
    if (c >= 0 && c < n) {
      int h = num_hits[c % RING] =
#ifdef MERGE_AVX512
          avx512 ? find_hits_avx512(v, &q[c], ranges[c % RING], num_ranges[c % RING], hits[c % RING], MAX_HITS) :
#endif
                 find_hits(v, &q[c], ranges[c % RING], num_ranges[c % RING], hits[c % RING], MAX_HITS);
      for (int k = 0; k < h && k < MAX_HITS; k++) __builtin_prefetch(&v->photons[hits[c % RING][k]]);
    }
    if (d >= 0 && d < n) {
      vf_vec3 sum;
      if (num_hits[d % RING] > MAX_HITS) {
        sum = merge_all(v, &q[d], ranges[d % RING], num_ranges[d % RING]);
      } else {
        sum = vf_vec3_splat(0.0f);
        for (int k = 0; k < num_hits[d % RING]; k++) sum = vf_add(sum, merge_one(v, &q[d], hits[d % RING][k]));
        sum = vf_scale(sum, v->vm_normalization);
      }
      vf_vec3 contrib = vf_mul(q[d].throughput, sum);
      float *rgb = &tile_rgb[3 * (size_t)q[d].tile_pixel];
      rgb[0] += contrib.x;
      rgb[1] += contrib.y;
      rgb[2] += contrib.z;
    }
  }
  ts->num_queries = 0;
}

/* The pipeline compiled twice, with find_hits and with find_hits_avx512, where the CPU
 * has AVX-512 (vf_vcm.vertex_merging_avx512): the choice is made once per tile, and each
 * version inlines its own test. */
static void run_merges_sse2(vf_vcm *v, int thread, float *tile_rgb) { merge_pipeline(v, thread, tile_rgb, 0); }

#ifdef MERGE_AVX512
__attribute__((target("avx512f,avx512vl,popcnt"))) static void run_merges_avx512(vf_vcm *v, int thread,
                                                                                 float *tile_rgb) {
  merge_pipeline(v, thread, tile_rgb, 1);
}
#endif

void vf_vertex_merging_run_tile(vf_vcm *v, int thread, float *tile_rgb) {
#ifdef MERGE_AVX512
  if (v->vertex_merging_avx512) {
    run_merges_avx512(v, thread, tile_rgb);
    return;
  }
#endif
  run_merges_sse2(v, thread, tile_rgb);
}

int vf_vertex_merging_detect_avx512(void) {
#ifdef MERGE_AVX512
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl");
#else
  return 0;
#endif
}
