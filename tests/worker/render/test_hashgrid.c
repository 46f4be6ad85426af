/* Hash grid: every query agrees exactly with brute force, as a set and without repeats, on
 * many point distributions, strides and scales; builds are identical for any thread count.
 * `test_hashgrid --bench` times builds and queries over 500k points instead. */
#include "check.h"
#include "common/error.h"
#include "common/pool.h"
#include "common/rng.h"
#include "worker/render/hashgrid.h"

#include <float.h>
#include <stdint.h>
#include <stdlib.h>
#include <time.h>

static vf_pool *pool1, *pool2, *pool5;

/* ---- point sets ---- */

typedef struct {
  vf_vec3 *p;
  uint32_t n;
} point_set;

static point_set set_alloc(uint32_t n) {
  point_set s = {calloc(n ? n : 1, sizeof(vf_vec3)), n};
  return s;
}

static float uniform(vf_rng *r, float lo, float hi) { return lo + (hi - lo) * vf_rng_float(r); }

static float gaussian(vf_rng *r) {
  float u = 1.0f - vf_rng_float(r), v = vf_rng_float(r);
  return sqrtf(-2.0f * logf(u)) * cosf(6.2831853f * v);
}

static point_set make_uniform(uint32_t n, float scale, uint64_t seed) {
  point_set s = set_alloc(n);
  vf_rng r = vf_rng_for_path(seed, 0, 0, VF_STREAM_TEST);
  for (uint32_t i = 0; i < n; i++)
    s.p[i] = vf_vec3_make(uniform(&r, -scale, scale), uniform(&r, -scale, scale), uniform(&r, -scale, scale));
  return s;
}

/* Gaussian blobs of the given width around a few random centres in the unit cube. */
static point_set make_clustered(uint32_t n, int clusters, float sigma, uint64_t seed) {
  point_set s = set_alloc(n);
  vf_rng r = vf_rng_for_path(seed, 0, 0, VF_STREAM_TEST);
  vf_vec3 centre[64];
  for (int c = 0; c < clusters; c++) centre[c] = vf_vec3_make(vf_rng_float(&r), vf_rng_float(&r), vf_rng_float(&r));
  for (uint32_t i = 0; i < n; i++) {
    vf_vec3 c = centre[vf_rng_next(&r) % (uint32_t)clusters];
    s.p[i] = vf_vec3_make(c.x + sigma * gaussian(&r), c.y + sigma * gaussian(&r), c.z + sigma * gaussian(&r));
  }
  return s;
}

/* Half on the plane z = 0.25 (one cell layer), half on a tilted plane. */
static point_set make_planes(uint32_t n, uint64_t seed) {
  point_set s = set_alloc(n);
  vf_rng r = vf_rng_for_path(seed, 0, 0, VF_STREAM_TEST);
  for (uint32_t i = 0; i < n; i++) {
    float u = vf_rng_float(&r), v = vf_rng_float(&r);
    s.p[i] = i % 2 ? vf_vec3_make(u, v, 0.25f) : vf_vec3_make(u, v, 0.3f * u - 0.7f * v);
  }
  return s;
}

/* ---- reference and checks ---- */

typedef struct {
  uint32_t *items;
  size_t count, cap;
} index_list;

static void list_push(void *ctx, uint32_t i) {
  index_list *l = ctx;
  if (l->count == l->cap) {
    l->cap = l->cap ? 2 * l->cap : 64;
    l->items = realloc(l->items, l->cap * sizeof *l->items);
  }
  l->items[l->count++] = i;
}

static int cmp_u32(const void *a, const void *b) {
  uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
  return (x > y) - (x < y);
}

/* The query's definition: |p - q|^2 <= r^2 in double (exact differences and squares). */
static int within(vf_vec3 p, vf_vec3 q, float radius) {
  double dx = (double)p.x - q.x, dy = (double)p.y - q.y, dz = (double)p.z - q.z;
  return vf_is_finite(p) && dx * dx + dy * dy + dz * dz <= (double)radius * radius;
}

/* The same in float, as a renderer might test candidates. Beyond r = 1.8e19, r * r
 * overflows and a float test accepts everything: no grid can cover that, so skip it. */
static int within_float(vf_vec3 p, vf_vec3 q, float radius) {
  vf_vec3 d = vf_sub(p, q);
  return vf_is_finite(p) && isfinite(radius * radius) && vf_dot(d, d) <= radius * radius;
}

/* Queries at points, next to points (within ~2r), and anywhere in the points' box. */
static point_set make_queries(point_set pts, uint32_t nq, float radius, uint64_t seed) {
  point_set q = set_alloc(nq);
  vf_rng r = vf_rng_for_path(seed, 1, 0, VF_STREAM_TEST);
  vf_vec3 lo = vf_vec3_splat(0.0f), hi = vf_vec3_splat(0.0f);
  int any = 0;
  for (uint32_t i = 0; i < pts.n; i++) {
    if (!vf_is_finite(pts.p[i])) continue;
    lo = any ? vf_vec3_make(fminf(lo.x, pts.p[i].x), fminf(lo.y, pts.p[i].y), fminf(lo.z, pts.p[i].z)) : pts.p[i];
    hi = any ? vf_vec3_make(fmaxf(hi.x, pts.p[i].x), fmaxf(hi.y, pts.p[i].y), fmaxf(hi.z, pts.p[i].z)) : pts.p[i];
    any = 1;
  }
  for (uint32_t k = 0; k < nq; k++) {
    vf_vec3 base = pts.n ? pts.p[vf_rng_next(&r) % pts.n] : vf_vec3_splat(0.0f);
    if (!vf_is_finite(base)) base = lo;
    float j = 2.0f * radius;
    switch (k % 4) {
    case 0: q.p[k] = base; break;
    case 1:
    case 2: q.p[k] = vf_add(base, vf_vec3_make(uniform(&r, -j, j), uniform(&r, -j, j), uniform(&r, -j, j))); break;
    default:
      q.p[k] = vf_vec3_make(uniform(&r, lo.x, hi.x), uniform(&r, lo.y, hi.y), uniform(&r, lo.z, hi.z));
    }
  }
  return q;
}

/* Checks the grid (already built over pts, r) against brute force at every query: the same
 * set, no index twice, disjoint candidate ranges that also cover a float-precision test.
 * Returns the total number of neighbours found. */
static size_t check_queries(const vf_hashgrid *grid, point_set pts, float radius, point_set queries) {
  index_list got = {0}, want = {0};
  unsigned char *seen = calloc(pts.n ? pts.n : 1, 1);
  const vf_grid_point *points = vf_hashgrid_points(grid);
  size_t total = 0;
  int reported = 0;
  for (uint32_t k = 0; k < queries.n && !reported; k++) {
    vf_vec3 q = queries.p[k];
    got.count = want.count = 0;
    vf_hashgrid_query(grid, q, list_push, &got);
    for (uint32_t i = 0; i < pts.n; i++)
      if (within(pts.p[i], q, radius)) list_push(&want, i);
    total += want.count;
    if (got.count) qsort(got.items, got.count, sizeof *got.items, cmp_u32);
    int dup = 0;
    for (size_t a = 1; a < got.count; a++) dup |= got.items[a] == got.items[a - 1];
    int same = got.count == want.count && (got.count == 0 || !memcmp(got.items, want.items, got.count * 4));

    /* Candidates: each index at most once over all ranges, and a superset of the float test. */
    vf_index_range ranges[VF_HASHGRID_MAX_RANGES];
    int nr = vf_hashgrid_candidates(grid, q, ranges);
    int cand_dup = 0, cand_missing = 0;
    for (int a = 0; a < nr; a++)
      for (uint32_t j = ranges[a].begin; j < ranges[a].end; j++) {
        cand_dup |= seen[points[j].index];
        seen[points[j].index] = 1;
      }
    for (uint32_t i = 0; i < pts.n; i++) cand_missing += within_float(pts.p[i], q, radius) && !seen[i];
    for (int a = 0; a < nr; a++)
      for (uint32_t j = ranges[a].begin; j < ranges[a].end; j++) seen[points[j].index] = 0;

    if (dup || !same || cand_dup || cand_missing) {
      CHECK_FAIL_("query %u at (%.9g, %.9g, %.9g), r %.9g: %zu found, %zu by brute force%s%s%s, "
                  "%d float neighbours outside the candidates",
                  k, q.x, q.y, q.z, radius, got.count, want.count, dup ? ", duplicates" : "",
                  same ? "" : ", sets differ", cand_dup ? ", a candidate index twice" : "", cand_missing);
      reported = 1;
    }
  }
  free(got.items);
  free(want.items);
  free(seen);
  return total;
}

/* Builds over pts with each radius on pool2 and checks nq queries per radius. */
static size_t check_set(point_set pts, const float *radii, int nradii, uint32_t nq) {
  vf_hashgrid *grid = NULL;
  CHECK_INT_EQ(vf_hashgrid_create(&grid), VF_OK);
  size_t total = 0;
  for (int k = 0; k < nradii; k++) {
    CHECK_INT_EQ(vf_hashgrid_build(grid, pts.p, sizeof(vf_vec3), pts.n, radii[k], pool2), VF_OK);
    point_set queries = make_queries(pts, nq, radii[k], 1000 + (uint64_t)k);
    total += check_queries(grid, pts, radii[k], queries);
    free(queries.p);
  }
  vf_hashgrid_destroy(grid);
  return total;
}

/* ---- cases ---- */

static void test_empty_grid_has_no_candidates(void) {
  vf_hashgrid *grid = NULL;
  CHECK_INT_EQ(vf_hashgrid_create(&grid), VF_OK);
  vf_index_range ranges[VF_HASHGRID_MAX_RANGES];
  CHECK_INT_EQ(vf_hashgrid_candidates(grid, vf_vec3_splat(0.0f), ranges), 0); /* never built */
  CHECK_INT_EQ(vf_hashgrid_build(grid, NULL, sizeof(vf_vec3), 0, 0.1f, pool2), VF_OK);
  CHECK_INT_EQ(vf_hashgrid_candidates(grid, vf_vec3_splat(0.0f), ranges), 0);
  index_list got = {0};
  vf_hashgrid_query(grid, vf_vec3_splat(0.0f), list_push, &got);
  CHECK_INT_EQ(got.count, 0);
  vf_hashgrid_destroy(grid);
  vf_hashgrid_destroy(NULL);
}

static void test_single_point(void) {
  point_set pts = set_alloc(1);
  pts.p[0] = vf_vec3_make(0.5f, -0.25f, 3.0f);
  const float radii[] = {0.0f, 0.01f, 1.0f};
  check_set(pts, radii, 3, 200);
  free(pts.p);
}

static void test_uniform_matches_brute_force(void) {
  point_set pts = make_uniform(20000, 1.0f, 1);
  const float radii[] = {0.003f, 0.03f, 0.1f};
  CHECK(check_set(pts, radii, 3, 600) > 1000); /* the queries did find neighbours */
  free(pts.p);
}

static void test_clustered_matches_brute_force(void) {
  point_set pts = make_clustered(20000, 8, 0.01f, 2);
  const float radii[] = {0.0005f, 0.003f, 0.02f};
  CHECK(check_set(pts, radii, 3, 600) > 1000);
  free(pts.p);
}

static void test_planes_match_brute_force(void) {
  point_set pts = make_planes(20000, 3);
  const float radii[] = {0.003f, 0.02f};
  CHECK(check_set(pts, radii, 2, 600) > 1000);
  free(pts.p);
}

static void test_identical_points_are_each_found_once(void) {
  point_set pts = set_alloc(3000);
  for (uint32_t i = 0; i < pts.n; i++) pts.p[i] = vf_vec3_make(0.3f, 0.3f, -0.3f);
  const float radii[] = {0.0f, 0.01f};
  check_set(pts, radii, 2, 50);
  vf_hashgrid *grid = NULL;
  vf_hashgrid_create(&grid);
  vf_hashgrid_build(grid, pts.p, sizeof(vf_vec3), pts.n, 0.01f, pool2);
  const vf_grid_point *points = vf_hashgrid_points(grid); /* one cell: ties go by point index */
  uint32_t out_of_order = 0;
  for (uint32_t i = 0; i < pts.n; i++) out_of_order += points[i].index != i;
  CHECK_INT_EQ(out_of_order, 0);
  index_list got = {0};
  vf_hashgrid_query(grid, vf_vec3_make(0.3f, 0.3f, -0.3f), list_push, &got);
  CHECK_INT_EQ(got.count, pts.n);
  got.count = 0;
  vf_hashgrid_query(grid, vf_vec3_make(0.3f, 0.3f, -0.3f + 0.0101f), list_push, &got);
  CHECK_INT_EQ(got.count, 0);
  free(got.items);
  vf_hashgrid_destroy(grid);
  free(pts.p);
}

static void test_radius_is_inclusive(void) {
  point_set pts = set_alloc(4);
  pts.p[0] = vf_vec3_make(0.5f, 0.0f, 0.0f);    /* exactly r away */
  pts.p[1] = vf_vec3_make(0.0f, -0.5f, 0.0f);   /* exactly r away */
  pts.p[2] = vf_vec3_make(0.0f, 0.0f, nextafterf(0.5f, 1.0f)); /* one ulp beyond */
  pts.p[3] = vf_vec3_make(0.3f, 0.4f, 0.0f);    /* 0.5 up to rounding: brute force decides */
  vf_hashgrid *grid = NULL;
  vf_hashgrid_create(&grid);
  CHECK_INT_EQ(vf_hashgrid_build(grid, pts.p, sizeof(vf_vec3), pts.n, 0.5f, pool1), VF_OK);
  index_list got = {0};
  vf_hashgrid_query(grid, vf_vec3_splat(0.0f), list_push, &got);
  qsort(got.items, got.count, sizeof *got.items, cmp_u32);
  CHECK(got.count >= 2 && got.items[0] == 0 && got.items[1] == 1);
  for (size_t k = 0; k < got.count; k++) CHECK(got.items[k] != 2);
  point_set q = set_alloc(1);
  check_queries(grid, pts, 0.5f, q);
  free(q.p);
  free(got.items);
  vf_hashgrid_destroy(grid);
  free(pts.p);
}

/* 16 points make a 32-bucket table, so the 8 cells of a query often share buckets (about
 * half of the queries); each shared bucket must be visited once. */
static void test_colliding_buckets_never_repeat_a_point(void) {
  for (uint64_t seed = 0; seed < 20; seed++) {
    point_set pts = make_uniform(16, 0.2f, 100 + seed);
    const float radii[] = {0.02f, 0.1f, 0.3f};
    check_set(pts, radii, 3, 400);
    free(pts.p);
  }
  /* A row of 32 cells along x covers every bucket: all queries nearby collide. */
  point_set row = set_alloc(16);
  for (uint32_t i = 0; i < row.n; i++) row.p[i] = vf_vec3_make(0.1f * (float)(2 * i), 0.0f, 0.0f);
  const float radius[] = {0.049f};
  check_set(row, radius, 1, 400);
  free(row.p);
}

static void test_huge_and_tiny_scales_match_brute_force(void) {
  const float scales[] = {1e6f, 1e-6f, 1e20f, 1e-20f};
  for (int k = 0; k < 4; k++) {
    point_set pts = make_uniform(5000, scales[k], 10 + (uint64_t)k);
    const float radii[] = {0.003f * scales[k], 0.05f * scales[k]};
    CHECK(check_set(pts, radii, 2, 300) > 100);
    free(pts.p);
  }
  /* A unit cloud far from the origin: floats near 1e6 are 1/16 apart, coarser than r. */
  point_set far = make_uniform(5000, 1.0f, 20);
  for (uint32_t i = 0; i < far.n; i++) far.p[i] = vf_add(far.p[i], vf_vec3_splat(1e6f));
  const float far_radii[] = {0.01f, 0.04f, 0.07f, 0.2f};
  CHECK(check_set(far, far_radii, 4, 300) > 100);
  free(far.p);
}

/* Cell coordinates beyond int32 and int64 (clamped), float lattices coarser than the cell,
 * the largest floats, subnormal coordinates and radii. */
static void test_extreme_coordinates_match_brute_force(void) {
  const float anchors[] = {1e9f, -3e12f, 1e30f, -1e30f, FLT_MAX, -FLT_MAX, 1e-40f, 0.0f};
  point_set pts = set_alloc(8 * 9);
  uint32_t n = 0;
  for (int a = 0; a < 8; a++) {
    float v = anchors[a], lo = nextafterf(v, -INFINITY), hi = nextafterf(v, INFINITY);
    float xs[3] = {lo, v, isfinite(hi) ? hi : v};
    for (int k = 0; k < 9; k++) pts.p[n++] = vf_vec3_make(xs[k % 3], xs[k / 3], v);
  }
  const float radii[] = {0.0f, 1e-44f, 1e-3f, 1e4f, 1e25f, 1e36f};
  for (int k = 0; k < 6; k++) {
    vf_hashgrid *grid = NULL;
    vf_hashgrid_create(&grid);
    CHECK_INT_EQ(vf_hashgrid_build(grid, pts.p, sizeof(vf_vec3), n, radii[k], pool2), VF_OK);
    check_queries(grid, pts, radii[k], pts); /* at every point */
    vf_hashgrid_destroy(grid);
  }
  free(pts.p);
}

static void test_nonfinite_points_are_skipped(void) {
  point_set pts = make_uniform(30000, 1.0f, 4);
  uint32_t finite = 0;
  for (uint32_t i = 0; i < pts.n; i++) {
    if (i % 7 == 3) pts.p[i].x = NAN;
    if (i % 11 == 5) pts.p[i].y = INFINITY;
    if (i % 13 == 6) pts.p[i].z = -INFINITY;
    finite += vf_is_finite(pts.p[i]);
  }
  vf_hashgrid *grid = NULL;
  vf_hashgrid_create(&grid);
  CHECK_INT_EQ(vf_hashgrid_build(grid, pts.p, sizeof(vf_vec3), pts.n, 0.05f, pool5), VF_OK);
  /* The index array holds the finite points, each once: a permutation of them. */
  const vf_grid_point *points = vf_hashgrid_points(grid);
  unsigned char *seen = calloc(pts.n, 1);
  int bad = 0;
  for (uint32_t j = 0; j < finite; j++) {
    bad += points[j].index >= pts.n || !vf_is_finite(pts.p[points[j].index]) || seen[points[j].index];
    if (points[j].index < pts.n) seen[points[j].index] = 1;
  }
  CHECK_INT_EQ(bad, 0);
  point_set q = make_queries(pts, 500, 0.05f, 5);
  check_queries(grid, pts, 0.05f, q);
  vf_index_range ranges[VF_HASHGRID_MAX_RANGES];
  CHECK_INT_EQ(vf_hashgrid_candidates(grid, vf_vec3_make(NAN, 0.5f, 0.5f), ranges), 0);
  CHECK_INT_EQ(vf_hashgrid_candidates(grid, vf_vec3_make(0.5f, INFINITY, 0.5f), ranges), 0);
  free(seen);
  free(q.p);
  vf_hashgrid_destroy(grid);
  free(pts.p);
}

/* Records, as the renderer's light vertices are: the position at offset 0 of 80 bytes, and
 * an odd stride that leaves positions unaligned. */
static void test_strides_other_than_vec3(void) {
  point_set pts = make_clustered(20000, 5, 0.02f, 6);
  const size_t strides[] = {80, 13};
  for (int s = 0; s < 2; s++) {
    unsigned char *records = malloc(pts.n * strides[s]);
    memset(records, 0xab, pts.n * strides[s]);
    for (uint32_t i = 0; i < pts.n; i++) memcpy(records + i * strides[s], &pts.p[i], sizeof(vf_vec3));
    vf_hashgrid *grid = NULL;
    vf_hashgrid_create(&grid);
    CHECK_INT_EQ(vf_hashgrid_build(grid, records, strides[s], pts.n, 0.005f, pool2), VF_OK);
    point_set q = make_queries(pts, 500, 0.005f, 7);
    CHECK(check_queries(grid, pts, 0.005f, q) > 100);
    free(q.p);
    vf_hashgrid_destroy(grid);
    free(records);
  }
  free(pts.p);
}

typedef struct {
  uint32_t count;
  uint32_t *indices;
  vf_index_range *ranges; /* VF_HASHGRID_MAX_RANGES per query */
  int *range_count;
  index_list visits;      /* in visiting order */
} build_result;

static build_result build_with(vf_pool *pool, point_set pts, float radius, uint32_t finite, point_set queries) {
  build_result r = {finite, malloc(finite * 4 + 4), calloc(queries.n * VF_HASHGRID_MAX_RANGES, sizeof(vf_index_range)),
                    calloc(queries.n, sizeof(int)), {0}};
  vf_hashgrid *grid = NULL;
  vf_hashgrid_create(&grid);
  CHECK_INT_EQ(vf_hashgrid_build(grid, pts.p, sizeof(vf_vec3), pts.n, radius, pool), VF_OK);
  for (uint32_t j = 0; j < finite; j++) r.indices[j] = vf_hashgrid_points(grid)[j].index;
  for (uint32_t k = 0; k < queries.n; k++) {
    r.range_count[k] = vf_hashgrid_candidates(grid, queries.p[k], r.ranges + k * VF_HASHGRID_MAX_RANGES);
    vf_hashgrid_query(grid, queries.p[k], list_push, &r.visits);
  }
  vf_hashgrid_destroy(grid);
  return r;
}

static void test_result_independent_of_thread_count(void) {
  /* 100k points: 13 build chunks; clustered so groups are uneven; some non-finite. */
  point_set pts = make_clustered(100000, 6, 0.03f, 8);
  uint32_t finite = 0;
  for (uint32_t i = 0; i < pts.n; i++) {
    if (i % 1001 == 0) pts.p[i].y = NAN;
    finite += vf_is_finite(pts.p[i]);
  }
  point_set q = make_queries(pts, 3000, 0.004f, 9);
  build_result ref = build_with(NULL, pts, 0.004f, finite, q);
  vf_pool *pools[] = {pool1, pool2, pool5};
  for (int k = 0; k < 3; k++) {
    build_result r = build_with(pools[k], pts, 0.004f, finite, q);
    CHECK(!memcmp(ref.indices, r.indices, finite * 4));
    CHECK(!memcmp(ref.range_count, r.range_count, q.n * sizeof(int)));
    CHECK(!memcmp(ref.ranges, r.ranges, q.n * VF_HASHGRID_MAX_RANGES * sizeof(vf_index_range)));
    CHECK_INT_EQ(r.visits.count, ref.visits.count);
    CHECK(r.visits.count == ref.visits.count && !memcmp(ref.visits.items, r.visits.items, r.visits.count * 4));
    free(r.indices);
    free(r.ranges);
    free(r.range_count);
    free(r.visits.items);
  }
  CHECK(ref.visits.count > 1000);
  free(ref.indices);
  free(ref.ranges);
  free(ref.range_count);
  free(ref.visits.items);
  free(q.p);
  free(pts.p);
}

/* Points in several arrays (as the renderer keeps its light vertices, one list per chunk of
 * sub-paths, some lists empty) give the grid of the same points in one array: the same
 * runs, the points in the same order, each named by its segment's index_base plus its
 * place in the segment. Segments cross the build's 8192-point tasks and one holds a
 * non-finite point. */
static void test_segments_build_the_grid_of_their_concatenation(void) {
  point_set pts = make_clustered(30000, 5, 0.02f, 12);
  pts.p[12345].x = NAN;
  const uint32_t counts[] = {0, 7000, 1, 0, 9000, 8191, 5808};
  enum { SEGMENTS = sizeof counts / sizeof *counts };
  vf_grid_segment segments[SEGMENTS];
  uint32_t start[SEGMENTS + 1] = {0};
  for (int k = 0; k < SEGMENTS; k++) {
    start[k + 1] = start[k] + counts[k];
    segments[k] = (vf_grid_segment){pts.p + start[k], counts[k], (uint32_t)k << 20};
  }
  CHECK_INT_EQ(start[SEGMENTS], pts.n);
  vf_hashgrid *whole = NULL, *split = NULL;
  vf_hashgrid_create(&whole);
  vf_hashgrid_create(&split);
  CHECK_INT_EQ(vf_hashgrid_build(whole, pts.p, sizeof(vf_vec3), pts.n, 0.004f, pool2), VF_OK);
  CHECK_INT_EQ(vf_hashgrid_build_segments(split, segments, SEGMENTS, sizeof(vf_vec3), 0.004f, pool2), VF_OK);
  uint32_t n = vf_hashgrid_count(whole);
  CHECK_INT_EQ(n, pts.n - 1);
  CHECK_INT_EQ(vf_hashgrid_count(split), n);
  const vf_grid_lookup *a = vf_hashgrid_lookup(whole), *b = vf_hashgrid_lookup(split);
  CHECK_INT_EQ(a->mask, b->mask);
  CHECK(a->mask == b->mask && !memcmp(a->cell_start, b->cell_start, ((size_t)a->mask + 2) * sizeof(uint32_t)));
  const vf_grid_point *pa = vf_hashgrid_points(whole), *pb = vf_hashgrid_points(split);
  uint32_t mismatches = 0;
  for (uint32_t k = 0; k < n; k++) {
    uint32_t i = pa[k].index, seg = 0;
    while (start[seg + 1] <= i) seg++;
    uint32_t renamed = ((uint32_t)seg << 20) + (i - start[seg]);
    mismatches += pb[k].index != renamed || pa[k].x != pb[k].x || pa[k].y != pb[k].y ||
                  pa[k].z != pb[k].z;
  }
  CHECK_INT_EQ(mismatches, 0);
  /* Indices past 2^32 are refused. */
  vf_grid_segment too_far = {pts.p, 2, UINT32_MAX};
  CHECK_INT_EQ(vf_hashgrid_build_segments(split, &too_far, 1, sizeof(vf_vec3), 0.004f, pool2), VF_EINVAL);
  CHECK_INT_EQ(vf_hashgrid_count(split), 0);
  vf_hashgrid_destroy(whole);
  vf_hashgrid_destroy(split);
  free(pts.p);
}

/* Buffers only grow: a small build after a large one must not see stale entries. */
static void test_rebuilds_reuse_memory(void) {
  vf_hashgrid *grid = NULL;
  vf_hashgrid_create(&grid);
  const uint32_t sizes[] = {60000, 100, 0, 20000, 1, 60001};
  const float radii[] = {0.01f, 0.2f, 0.1f, 0.02f, 0.5f, 0.003f};
  for (int k = 0; k < 6; k++) {
    point_set pts = k % 2 ? make_uniform(sizes[k], 1.0f, 30 + (uint64_t)k) : make_clustered(sizes[k], 4, 0.02f, 30 + (uint64_t)k);
    CHECK_INT_EQ(vf_hashgrid_build(grid, pts.p, sizeof(vf_vec3), pts.n, radii[k], pool2), VF_OK);
    point_set q = make_queries(pts, 300, radii[k], 40 + (uint64_t)k);
    check_queries(grid, pts, radii[k], q);
    free(q.p);
    free(pts.p);
  }
  vf_hashgrid_destroy(grid);
}

/* Vertex merging copies the sorted points and releases them for the camera pass: the
 * candidates stay those of the build, and the next build (whose pages read as zeros until
 * written) finds every neighbour again. 200,000 points: 3.2 MB, whole pages to give back. */
static void test_released_points_keep_candidates_and_come_back(void) {
  point_set pts = make_clustered(200000, 8, 0.05f, 61);
  point_set q = make_queries(pts, 400, 0.01f, 62);
  vf_hashgrid *grid = NULL;
  vf_hashgrid_create(&grid);
  for (int round = 0; round < 2; round++) {
    CHECK_INT_EQ(vf_hashgrid_build(grid, pts.p, sizeof(vf_vec3), pts.n, 0.01f, pool2), VF_OK);
    CHECK(check_queries(grid, pts, 0.01f, q) > 0);
    vf_index_range after[VF_HASHGRID_MAX_RANGES];
    int changed = 0, counts[400];
    static vf_index_range saved[400][VF_HASHGRID_MAX_RANGES];
    for (uint32_t k = 0; k < q.n; k++) counts[k] = vf_hashgrid_candidates(grid, q.p[k], saved[k]);
    vf_hashgrid_release_points(grid);
    CHECK(vf_hashgrid_points(grid) == NULL);
    CHECK_INT_EQ(vf_hashgrid_count(grid), 200000);
    for (uint32_t k = 0; k < q.n; k++) {
      int na = vf_hashgrid_candidates(grid, q.p[k], after);
      changed += na != counts[k] || memcmp(after, saved[k], (size_t)na * sizeof *after) != 0;
    }
    CHECK_INT_EQ(changed, 0);
  }
  vf_hashgrid_destroy(grid);
  free(q.p);
  free(pts.p);
}

static void test_invalid_arguments_leave_an_empty_grid(void) {
  point_set pts = make_uniform(100, 1.0f, 50);
  vf_hashgrid *grid = NULL;
  vf_hashgrid_create(&grid);
  CHECK_INT_EQ(vf_hashgrid_build(grid, pts.p, sizeof(vf_vec3), pts.n, 0.5f, pool1), VF_OK);
  vf_index_range ranges[VF_HASHGRID_MAX_RANGES];
  CHECK(vf_hashgrid_candidates(grid, pts.p[0], ranges) > 0);
  CHECK_INT_EQ(vf_hashgrid_build(grid, pts.p, sizeof(vf_vec3), pts.n, -1.0f, pool1), VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EINVAL), "radius");
  CHECK_INT_EQ(vf_hashgrid_candidates(grid, pts.p[0], ranges), 0);
  CHECK_INT_EQ(vf_hashgrid_build(grid, pts.p, sizeof(vf_vec3), pts.n, NAN, pool1), VF_EINVAL);
  CHECK_INT_EQ(vf_hashgrid_build(grid, pts.p, sizeof(vf_vec3), pts.n, INFINITY, pool1), VF_EINVAL);
  CHECK_INT_EQ(vf_hashgrid_build(grid, NULL, sizeof(vf_vec3), 5, 0.5f, pool1), VF_EINVAL);
  CHECK_INT_EQ(vf_hashgrid_build(grid, pts.p, 8, pts.n, 0.5f, pool1), VF_EINVAL);
  vf_hashgrid_destroy(grid);
  free(pts.p);
}

/* ---- benchmark ---- */

static double now_ms(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec * 1e3 + (double)t.tv_nsec * 1e-6;
}

static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

static double median(double *v, int n) {
  qsort(v, (size_t)n, sizeof *v, cmp_double);
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

enum { BENCH_QUERY_TASK = 4096 };

typedef struct {
  const vf_hashgrid *grid;
  const vf_vec3 *queries;
  uint32_t nq;
  uint64_t *found; /* per task */
} bench_queries;

static void count_visit(void *ctx, uint32_t i) { (*(uint64_t *)ctx)++; }

static void query_task(void *ctx, size_t task, int thread) {
  bench_queries *b = ctx;
  uint64_t found = 0;
  uint32_t end = (uint32_t)((task + 1) * BENCH_QUERY_TASK < b->nq ? (task + 1) * BENCH_QUERY_TASK : b->nq);
  for (uint32_t k = (uint32_t)(task * BENCH_QUERY_TASK); k < end; k++)
    vf_hashgrid_query(b->grid, b->queries[k], count_visit, &found);
  b->found[task] = found;
}

/* Records as large as the renderer's light vertices. */
typedef struct {
  vf_vec3 position;
  float payload[17];
} bench_record;

static void bench_one(const char *name, point_set pts, point_set queries, float radius, size_t stride, vf_pool *pool) {
  enum { REPS = 20 };
  void *base = pts.p;
  bench_record *records = NULL;
  if (stride == sizeof(bench_record)) {
    records = calloc(pts.n, sizeof *records);
    for (uint32_t i = 0; i < pts.n; i++) records[i].position = pts.p[i];
    base = records;
  }
  vf_hashgrid *grid = NULL;
  vf_hashgrid_create(&grid);
  size_t tasks = (queries.n + BENCH_QUERY_TASK - 1) / BENCH_QUERY_TASK;
  bench_queries bq = {grid, queries.p, queries.n, calloc(tasks, sizeof(uint64_t))};
  double build[REPS], query1[REPS], queryp[REPS];
  uint64_t found = 0, candidates = 0;
  for (int rep = 0; rep < REPS; rep++) {
    double t0 = now_ms();
    vf_hashgrid_build(grid, base, stride, pts.n, radius, pool);
    double t1 = now_ms();
    for (size_t t = 0; t < tasks; t++) query_task(&bq, t, 0);
    double t2 = now_ms();
    vf_pool_run(pool, tasks, query_task, &bq);
    double t3 = now_ms();
    build[rep] = t1 - t0;
    query1[rep] = t2 - t1;
    queryp[rep] = t3 - t2;
  }
  for (size_t t = 0; t < tasks; t++) found += bq.found[t];
  for (uint32_t k = 0; k < queries.n; k++) {
    vf_index_range ranges[VF_HASHGRID_MAX_RANGES];
    int nr = vf_hashgrid_candidates(grid, queries.p[k], ranges);
    for (int a = 0; a < nr; a++) candidates += ranges[a].end - ranges[a].begin;
  }
  printf("%-28s stride %3zu  %d threads  build %7.2f ms  1M queries: %7.1f ms on 1 thread, %7.1f ms on %d"
         "  (%.2f candidates, %.2f found per query)\n",
         name, stride, vf_pool_threads(pool), median(build, REPS), median(query1, REPS), median(queryp, REPS),
         vf_pool_threads(pool), (double)candidates / queries.n, (double)found / queries.n);
  fflush(stdout);
  free(bq.found);
  vf_hashgrid_destroy(grid);
  free(records);
}

static int bench(void) {
  const uint32_t n = 500000, nq = 1000000;
  const float radius = 0.003f;
  /* Unit cube; 40 blobs of sigma 0.01: ~10 neighbours per query, like surfaces in VCM. */
  point_set uni = make_uniform(n, 0.5f, 60), uniq = make_uniform(nq, 0.5f, 61);
  point_set clu = make_clustered(n, 40, 0.01f, 62), cluq = set_alloc(nq);
  vf_rng r = vf_rng_for_path(63, 0, 0, VF_STREAM_TEST);
  for (uint32_t k = 0; k < nq; k++) { /* near the points: jittered copies of random ones */
    vf_vec3 p = clu.p[vf_rng_next(&r) % n];
    cluq.p[k] = vf_add(p, vf_vec3_make(0.01f * gaussian(&r), 0.01f * gaussian(&r), 0.01f * gaussian(&r)));
  }
  printf("hash grid benchmark: %u points, r = %g, medians of 20 builds / 20 x %u queries\n", n, radius, nq);
  vf_pool *pools[] = {pool1, pool2};
  for (int p = 0; p < 2; p++) {
    bench_one("uniform unit cube", uni, uniq, radius, sizeof(vf_vec3), pools[p]);
    bench_one("uniform unit cube", uni, uniq, radius, sizeof(bench_record), pools[p]);
    bench_one("clustered (40 x sigma 0.01)", clu, cluq, radius, sizeof(vf_vec3), pools[p]);
    bench_one("clustered (40 x sigma 0.01)", clu, cluq, radius, sizeof(bench_record), pools[p]);
  }
  free(uni.p);
  free(uniq.p);
  free(clu.p);
  free(cluq.p);
  return 0;
}

int main(int argc, char **argv) {
  if (vf_pool_create(1, &pool1) || vf_pool_create(2, &pool2) || vf_pool_create(5, &pool5)) {
    fprintf(stderr, "cannot create thread pools\n");
    return 1;
  }
  int status;
  if (argc > 1 && !strcmp(argv[1], "--bench")) {
    status = bench();
  } else {
    RUN(test_empty_grid_has_no_candidates);
    RUN(test_single_point);
    RUN(test_uniform_matches_brute_force);
    RUN(test_clustered_matches_brute_force);
    RUN(test_planes_match_brute_force);
    RUN(test_identical_points_are_each_found_once);
    RUN(test_radius_is_inclusive);
    RUN(test_colliding_buckets_never_repeat_a_point);
    RUN(test_huge_and_tiny_scales_match_brute_force);
    RUN(test_extreme_coordinates_match_brute_force);
    RUN(test_nonfinite_points_are_skipped);
    RUN(test_strides_other_than_vec3);
    RUN(test_result_independent_of_thread_count);
    RUN(test_segments_build_the_grid_of_their_concatenation);
    RUN(test_rebuilds_reuse_memory);
    RUN(test_released_points_keep_candidates_and_come_back);
    RUN(test_invalid_arguments_leave_an_empty_grid);
    status = check_finish();
  }
  vf_pool_destroy(pool5);
  vf_pool_destroy(pool2);
  vf_pool_destroy(pool1);
  return status;
}
