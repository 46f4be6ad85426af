/* Vertex merging: the fast path the renderer runs (worker/render/merge_pipeline.c) against
 * the reference query (vf_vertex_merging_estimate, worker/render/vertex_merging.c), over
 * light-vertex sets and queries written straight into a renderer's iteration state.
 *
 * Equality is asserted bit for bit, not within a tolerance: the fast path's candidate
 * tests are the reference's float operations in the same order, and it sums the same
 * merges in the same (grid) order; the only terms it leaves out are those of light
 * vertices too long to merge, for which the reference adds +0.0f, and x + 0.0f is x for
 * every x but -0.0f, which a sum begun at +0.0f never is. Any difference is a bug, not
 * rounding.
 *
 * For each set and each candidate test this CPU has (SSE2 always; AVX-512 where the CPU
 * has it, else the test says it could not run it):
 *   - hits: the pipeline's candidate test (vf_merge_pipeline_find_hits) gives the same light
 *     vertices, in the same order, as testing every light vertex of the grid one by one,
 *     and keeps the first `max` of them when there are more;
 *   - sums: a tile's queued queries run by vf_vertex_merging_run_tile add to each pixel
 *     exactly what adding throughput x vf_vertex_merging_estimate query by query adds.
 * The sets cover: uniform points, clusters with many points per cell and hit counts on
 * both sides of the pipeline's slot (VF_MERGE_SLOT_HITS), points exactly on the radius
 * and one float inside or outside it, queries on and near cell boundaries (the grid's
 * general path, with one cell on an axis), empty cells and queries far from every point,
 * non-finite queries, points far from the origin, repeated points, path lengths on both
 * sides of the limit, and ppm's unweighted merging. */
#include "check.h"
#include "common/error.h"
#include "common/pool.h"
#include "common/rng.h"
#include "worker/render/accel.h"
#include "worker/render/merge_pipeline.h"
#include "worker/render/vcm_internal.h"
#include "worker/render/vertex_merging.h"
#include "worker/scene/load.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef VF_MERGE_PIPELINE
int main(void) {
  printf("skip: this target has no fast path for vertex merging; the renderer runs the reference\n");
  return 77;
}
#else

enum { WIDTH = 64, HEIGHT = 64 }; /* the renderer's image: 4 light chunks */

static vf_scene *scene;
static vf_accel *accel;
static vf_pool *pool;
static int materials[64], num_materials; /* the scene's materials that merge (not delta, not black) */

/* ---- random numbers ---- */

static float uniform(vf_rng *r, float lo, float hi) { return lo + (hi - lo) * vf_rng_float(r); }

static float log_uniform(vf_rng *r, float lo, float hi) { return lo * powf(hi / lo, vf_rng_float(r)); }

static float gaussian(vf_rng *r) {
  float u = 1.0f - vf_rng_float(r), v = vf_rng_float(r);
  return sqrtf(-2.0f * logf(u)) * cosf(6.2831853f * v);
}

static vf_vec3 unit_vector(vf_rng *r) {
  for (;;) {
    vf_vec3 d = vf_vec3_make(uniform(r, -1, 1), uniform(r, -1, 1), uniform(r, -1, 1));
    float l2 = vf_length_sq(d);
    if (l2 > 1e-4f && l2 <= 1.0f) return vf_scale(d, 1.0f / sqrtf(l2));
  }
}

static vf_vec3 jitter(vf_rng *r, vf_vec3 p, float size) {
  return vf_vec3_make(p.x + uniform(r, -size, size), p.y + uniform(r, -size, size), p.z + uniform(r, -size, size));
}

/* ---- a renderer with the test's light vertices and queries ---- */

/* A set of light-vertex positions and the queries to make around them. */
typedef struct {
  const char *name;
  float radius;
  int max_path_length;
  int ppm;
  vf_vec3 *points;
  uint32_t num_points;
  vf_vec3 *queries;
  uint32_t num_queries;
} merge_case;

static void case_alloc(merge_case *c, uint32_t points, uint32_t queries) {
  c->points = calloc(points ? points : 1, sizeof *c->points);
  c->queries = calloc(queries ? queries : 1, sizeof *c->queries);
  c->num_points = c->num_queries = 0;
}

static void case_free(merge_case *c) {
  free(c->points);
  free(c->queries);
}

static vf_vcm *renderer_create(int ppm) {
  vf_settings s = scene->settings;
  s.algorithm = ppm ? VF_ALGO_PPM : VF_ALGO_VCM;
  s.width = WIDTH;
  s.height = HEIGHT;
  vf_vcm *v = NULL;
  CHECK_INT_EQ(vf_vcm_create(scene, accel, &s, pool, &v), VF_OK);
  return v;
}

/* The case's light vertices as a light pass would leave them, spread over the chunks in
 * order, with random throughput, direction, MIS quantities, shape and path length; then
 * the iteration's radius and MIS set-up, and phase 2 (the grid and the gather). */
static int install_light_vertices(vf_vcm *v, const merge_case *c, vf_rng *r) {
  v->settings.max_path_length = c->max_path_length;
  uint32_t per_chunk = (c->num_points + v->num_chunks - 1) / v->num_chunks, largest = 0;
  for (uint32_t k = 0; k < v->num_chunks; k++) {
    light_chunk *ch = &v->chunks[k];
    uint32_t first = k * per_chunk < c->num_points ? k * per_chunk : c->num_points;
    uint32_t count = c->num_points - first < per_chunk ? c->num_points - first : per_chunk;
    free(ch->vertices);
    ch->vertices = aligned_alloc(64, (count ? count : 1) * sizeof(light_vertex));
    if (ch->vertices == NULL) return 0;
    ch->num_vertices = ch->vertex_capacity = count;
    for (uint32_t i = 0; i < count; i++) {
      light_vertex *lv = &ch->vertices[i];
      memset(lv, 0, sizeof *lv);
      lv->position = c->points[first + i];
      lv->throughput = vf_vec3_make(log_uniform(r, 1e-3f, 10.0f), log_uniform(r, 1e-3f, 10.0f),
                                    log_uniform(r, 1e-3f, 10.0f));
      lv->fix = unit_vector(r);
      lv->at.normal = unit_vector(r);
      lv->mis = (vf_mis){log_uniform(r, 1e-3f, 1e3f), log_uniform(r, 1e-3f, 1e3f), log_uniform(r, 1e-3f, 1e3f)};
      uint32_t length = 1 + vf_rng_next(r) % (uint32_t)c->max_path_length;
      uint32_t shape = vf_rng_next(r) % (uint32_t)scene->num_shapes;
      lv->path_length_shape = length | shape << VERTEX_LENGTH_BITS;
    }
    if (count > largest) largest = count;
  }
  v->num_vertices = c->num_points;
  v->chunk_shift = 0;
  while ((1u << v->chunk_shift) < largest) v->chunk_shift++;
  /* as setup_iteration (worker/render/vcm.c) sets them for a radius */
  double radius = c->radius, eta = M_PI * radius * radius * (double)v->num_pixels;
  v->merge.radius = c->radius;
  v->merge.radius_sq = (float)(radius * radius);
  v->merge.vm_normalization = (float)(1.0 / eta);
  v->merge.mis.vm_weight = c->ppm ? 0.0f : (float)eta;
  v->merge.mis.vc_weight = c->ppm ? 0.0f : (float)(1.0 / eta);
  v->merge.mis.light_paths = (float)v->num_pixels;
  v->merge.mis.pt = 0;
  v->radius_exact = radius;
  v->grid_radius = v->merge.radius;
  int err = vf_vertex_merging_build_grid(v, v->chunks, v->chunk_shift);
  CHECK_INT_EQ(err, VF_OK);
  return err == VF_OK;
}

/* A camera vertex at p as the camera pass queues it: a merging material's BSDF for a random
 * normal and direction, random throughput and MIS quantities, a path short enough to
 * merge at all. */
static vertex_merging_query make_query(const vf_vcm *v, vf_rng *r, vf_vec3 p, uint32_t tile_pixel) {
  vertex_merging_query q;
  memset(&q, 0, sizeof q);
  int m;
  do {
    m = materials[vf_rng_next(r) % (uint32_t)num_materials];
  } while (!vf_bsdf_setup(&q.bsdf, &scene->materials[m], &v->lobes[m], unit_vector(r), unit_vector(r)));
  q.bsdf.radiance = 1;
  q.position = p;
  q.throughput = vf_vec3_make(log_uniform(r, 1e-3f, 10.0f), log_uniform(r, 1e-3f, 10.0f), log_uniform(r, 1e-3f, 10.0f));
  q.mis = (vf_mis){log_uniform(r, 1e-3f, 1e3f), log_uniform(r, 1e-3f, 1e3f), log_uniform(r, 1e-3f, 1e3f)};
  q.path_length = 1 + (int)(vf_rng_next(r) % (uint32_t)(v->settings.max_path_length - 1));
  q.tile_pixel = tile_pixel;
  q.merge = v->merge; /* the iteration's global radius */
  return q;
}

static int float_bits_equal(float a, float b) { return memcmp(&a, &b, sizeof a) == 0; }

/* The hits of query q, testing every light vertex of the grid one by one in the grid's
 * order, with the reference's float operations and path-length rule. */
static int hits_one_by_one(const vf_vcm *v, const vertex_merging_query *q, uint32_t *hits, uint32_t *on_radius) {
  uint32_t n = vf_hashgrid_count(v->grid);
  int longest = v->settings.max_path_length - q->path_length, found = 0;
  for (uint32_t k = 0; k < n; k++) {
    const merge_point *p = &v->merge_points[k];
    float dx = p->x - q->position.x, dy = p->y - q->position.y, dz = p->z - q->position.z;
    float d2 = dx * dx + dy * dy + dz * dz;
    if (d2 <= v->merge.radius_sq && (int)(p->path_length_shape & ((1u << VERTEX_LENGTH_BITS) - 1u)) <= longest) {
      hits[found++] = k;
      *on_radius += d2 == v->merge.radius_sq;
    }
  }
  return found;
}

typedef struct {
  uint64_t queries, hits, over_slot, without_hits, empty_ranges, general_path, on_radius;
  int most_hits;
} coverage;

/* The pipeline's candidate test against hits_one_by_one, over every query of the case;
 * with a full buffer and with one of 3, where it must keep the first 3 and count the rest. */
static void check_hits(const vf_vcm *v, const vertex_merging_query *qs, uint32_t nq, int avx512, coverage *cov) {
  uint32_t n = vf_hashgrid_count(v->grid);
  uint32_t *expected = malloc((n + 1) * sizeof *expected);
  uint32_t *got = malloc((n + VF_MERGE_HITS_SLACK + 1) * sizeof *got);
  int reported = 0;
  for (uint32_t i = 0; i < nq && expected && got; i++) {
    const vertex_merging_query *q = &qs[i];
    vf_index_range ranges[VF_HASHGRID_MAX_RANGES];
    int num_ranges = vf_hashgrid_candidates(v->grid, q->position, ranges);
    vf_grid_cells cells;
    vf_grid_cells_of(vf_hashgrid_lookup(v->grid), q->position, &cells);
    uint32_t on_radius = 0;
    int want = hits_one_by_one(v, q, expected, &on_radius);
    int have = vf_merge_pipeline_find_hits(v, q, ranges, num_ranges, got, (int)n + 1, avx512);
    int same = want == have && memcmp(expected, got, (size_t)want * sizeof *got) == 0;
    int few = vf_merge_pipeline_find_hits(v, q, ranges, num_ranges, got, 3, avx512);
    same = same && few == want && memcmp(expected, got, (size_t)(want < 3 ? want : 3) * sizeof *got) == 0;
    if (!same && reported++ < 5) {
      int k = 0;
      while (k < want && k < have && expected[k] == got[k]) k++;
      CHECK_FAIL_("query %u at (%a, %a, %a): %d hits one by one, %d from the %s test (%d with room for 3); "
                  "first difference at hit %d",
                  i, q->position.x, q->position.y, q->position.z, want, have, avx512 ? "AVX-512" : "SSE2", few, k);
    }
    if (avx512) continue; /* coverage once per case */
    cov->queries++;
    cov->hits += (uint64_t)want;
    cov->over_slot += want > VF_MERGE_SLOT_HITS;
    for (int k = 0; k < num_ranges; k++) cov->empty_ranges += ranges[k].begin == ranges[k].end;
    cov->without_hits += want == 0;
    cov->general_path += cells.span != 2;
    cov->on_radius += on_radius;
    if (want > cov->most_hits) cov->most_hits = want;
  }
  if (!expected || !got) CHECK(!"out of memory");
  free(expected);
  free(got);
}

/* The tile's queries run by the renderer's path (vf_vertex_merging_run_tile) against the
 * reference added query by query in queue order; queries share pixels, three to a pixel. */
static void check_sums(vf_vcm *v, const vertex_merging_query *qs, uint32_t nq, uint32_t pixels) {
  thread_scratch *ts = &v->scratch[0];
  if (ts->query_capacity < nq) {
    free(ts->queries);
    ts->queries = malloc(nq * sizeof *ts->queries);
    ts->query_capacity = ts->queries ? nq : 0;
  }
  float *got = calloc(3 * (size_t)pixels, sizeof *got), *want = calloc(3 * (size_t)pixels, sizeof *want);
  if (!ts->queries || !got || !want) {
    CHECK(!"out of memory");
    free(got);
    free(want);
    return;
  }
  memcpy(ts->queries, qs, nq * sizeof *qs);
  ts->num_queries = nq;
  vf_vertex_merging_run_tile(v, 0, got);
  CHECK_INT_EQ(ts->num_queries, 0);
  for (uint32_t i = 0; i < nq; i++) {
    vf_vec3 contrib = vf_mul(qs[i].throughput, vf_vertex_merging_estimate(v, &qs[i]));
    float *rgb = &want[3 * (size_t)qs[i].tile_pixel];
    rgb[0] += contrib.x;
    rgb[1] += contrib.y;
    rgb[2] += contrib.z;
  }
  int reported = 0;
  uint32_t nonzero = 0;
  for (uint32_t p = 0; p < pixels; p++) {
    const float *a = &got[3 * (size_t)p], *b = &want[3 * (size_t)p];
    nonzero += a[0] != 0.0f || a[1] != 0.0f || a[2] != 0.0f;
    if (float_bits_equal(a[0], b[0]) && float_bits_equal(a[1], b[1]) && float_bits_equal(a[2], b[2])) continue;
    if (reported++ < 5)
      CHECK_FAIL_("pixel %u: the tile's run gives (%a, %a, %a), the reference (%a, %a, %a)", p, a[0], a[1], a[2],
                  b[0], b[1], b[2]);
  }
  /* the comparison means something only where the estimates are not all zero */
  CHECK(nq < 64 || nonzero > 0);
  free(got);
  free(want);
}

/* Builds the case's light vertices into a renderer, makes its queries, and checks hits and
 * sums with every candidate test this CPU has; returns what the queries met. */
static coverage run_case(merge_case *c, uint64_t seed) {
  coverage cov = {0};
  vf_vcm *v = renderer_create(c->ppm);
  if (v == NULL) return cov;
  vf_rng r = vf_rng_for_path(seed, 0, 0, VF_STREAM_TEST);
  if (!install_light_vertices(v, c, &r)) {
    vf_vcm_destroy(v);
    return cov;
  }
  uint32_t nq = c->num_queries, pixels = (nq + 2) / 3;
  vertex_merging_query *qs = malloc((nq ? nq : 1) * sizeof *qs);
  if (qs == NULL) {
    CHECK(!"out of memory");
    vf_vcm_destroy(v);
    return cov;
  }
  for (uint32_t i = 0; i < nq; i++) qs[i] = make_query(v, &r, c->queries[i], i % pixels);
  int has_avx512 = vf_merge_pipeline_detect_avx512();
  for (int avx512 = 0; avx512 <= has_avx512; avx512++) {
    check_hits(v, qs, nq, avx512, &cov);
    v->vertex_merging_avx512 = avx512;
    check_sums(v, qs, nq, pixels);
  }
  printf("  %s: %u light vertices, %llu queries (%llu without hits, %llu over the slot of %d, %llu through the "
         "grid's general path), %llu hits (at most %d a query, %llu on the radius), %llu empty candidate ranges\n",
         c->name, c->num_points, (unsigned long long)cov.queries, (unsigned long long)cov.without_hits,
         (unsigned long long)cov.over_slot, VF_MERGE_SLOT_HITS, (unsigned long long)cov.general_path,
         (unsigned long long)cov.hits, cov.most_hits, (unsigned long long)cov.on_radius,
         (unsigned long long)cov.empty_ranges);
  free(qs);
  vf_vcm_destroy(v);
  return cov;
}

/* ---- the cases ---- */

/* Queries: half at light vertices moved by up to twice the radius, half anywhere in the box. */
static void queries_near_points(merge_case *c, vf_rng *r, uint32_t n, float lo, float hi) {
  for (uint32_t i = 0; i < n; i++)
    c->queries[c->num_queries++] =
        i % 2 == 0 && c->num_points > 0
            ? jitter(r, c->points[vf_rng_next(r) % c->num_points], 2.0f * c->radius)
            : vf_vec3_make(uniform(r, lo, hi), uniform(r, lo, hi), uniform(r, lo, hi));
}

static void test_uniform_points(void) {
  for (int ppm = 0; ppm <= 1; ppm++) {
    merge_case c = {.name = ppm ? "uniform, ppm" : "uniform", .radius = 0.04f, .max_path_length = 10, .ppm = ppm};
    case_alloc(&c, 20000, 4000);
    vf_rng r = vf_rng_for_path(1, (uint64_t)ppm, 0, VF_STREAM_TEST);
    for (uint32_t i = 0; i < 20000; i++)
      c.points[c.num_points++] = vf_vec3_make(vf_rng_float(&r), vf_rng_float(&r), vf_rng_float(&r));
    queries_near_points(&c, &r, 4000, -0.1f, 1.1f);
    coverage cov = run_case(&c, 11 + (uint64_t)ppm);
    CHECK(cov.hits > cov.queries); /* a few hits per query near the points */
    case_free(&c);
  }
}

/* Gaussian clusters of a third of the radius: tens to hundreds of hits per query, most
 * past the pipeline's slot; and clusters of exactly k points within a quarter of the
 * radius for k = 1 .. 2 x VF_MERGE_SLOT_HITS, queried at their centres: every hit count
 * on both sides of the slot's size. Path lengths short enough that most hits merge. */
static void test_many_points_per_cell(void) {
  merge_case c = {.name = "clusters", .radius = 0.01f, .max_path_length = 12};
  enum { CLUSTERS = 40, PER_CLUSTER = 400, COUNTED = 2 * VF_MERGE_SLOT_HITS };
  case_alloc(&c, CLUSTERS * PER_CLUSTER + COUNTED * (COUNTED + 1) / 2, 3000 + COUNTED);
  vf_rng r = vf_rng_for_path(2, 0, 0, VF_STREAM_TEST);
  vf_vec3 centre[CLUSTERS];
  for (int k = 0; k < CLUSTERS; k++) centre[k] = vf_vec3_make(vf_rng_float(&r), vf_rng_float(&r), vf_rng_float(&r));
  for (int k = 0; k < CLUSTERS; k++)
    for (int i = 0; i < PER_CLUSTER; i++) {
      float s = c.radius / 3.0f;
      c.points[c.num_points++] = vf_vec3_make(centre[k].x + s * gaussian(&r), centre[k].y + s * gaussian(&r),
                                              centre[k].z + s * gaussian(&r));
    }
  for (uint32_t i = 0; i < 3000; i++) c.queries[c.num_queries++] = jitter(&r, centre[i % CLUSTERS], c.radius);
  for (int k = 1; k <= COUNTED; k++) { /* on a line away from the clusters, 10 radii apart */
    vf_vec3 at = vf_vec3_make(2.0f + 10.0f * c.radius * (float)k, 2.0f, 2.0f);
    for (int i = 0; i < k; i++) c.points[c.num_points++] = jitter(&r, at, c.radius / 4.0f);
    c.queries[c.num_queries++] = at;
  }
  coverage cov = run_case(&c, 21);
  CHECK(cov.over_slot > 0 && cov.most_hits > 4 * VF_MERGE_SLOT_HITS);
  case_free(&c);
}

/* Light vertices exactly on the radius of a query, and one float inside and outside it.
 * With r = 15/64 and the query on a grid of 1/64, every difference, square and sum of
 * |p - q|^2 is exact for the offsets (a, b, c) / 64 with a^2 + b^2 + c^2 = 15^2: it equals
 * r^2 = 225/4096 exactly, which the test d^2 <= r^2 accepts. */
static void test_points_on_the_radius(void) {
  static const int triples[][3] = {{15, 0, 0}, {9, 12, 0}, {5, 10, 10}, {2, 5, 14}, {2, 10, 11}, {0, 9, 12}};
  merge_case c = {.name = "on the radius", .radius = 15.0f / 64.0f, .max_path_length = 10};
  enum { CENTRES = 64 };
  case_alloc(&c, CENTRES * 6 * 48 * 3, CENTRES);
  vf_rng r = vf_rng_for_path(3, 0, 0, VF_STREAM_TEST);
  for (int k = 0; k < CENTRES; k++) {
    vf_vec3 q = vf_vec3_make((float)(k % 4) * 1.5f, (float)(k / 4 % 4) * 1.5f, (float)(k / 16) * 1.5f);
    c.queries[c.num_queries++] = q;
    for (int t = 0; t < 6; t++)
      for (int perm = 0; perm < 6; perm++)
        for (int signs = 0; signs < 8; signs++) {
          static const int order[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
          float d[3];
          for (int a = 0; a < 3; a++)
            d[a] = (float)triples[t][order[perm][a]] / 64.0f * ((signs >> a & 1) ? -1.0f : 1.0f);
          if (vf_rng_next(&r) % 3 != 0) continue; /* a third of the 288 combinations, repeats included */
          vf_vec3 p = vf_vec3_make(q.x + d[0], q.y + d[1], q.z + d[2]);
          c.points[c.num_points++] = p;
          /* one float further out and one further in along x, where x moves at all */
          if (d[0] != 0.0f) {
            float out = nextafterf(p.x, d[0] > 0.0f ? INFINITY : -INFINITY);
            float in = nextafterf(p.x, q.x);
            c.points[c.num_points++] = vf_vec3_make(out, p.y, p.z);
            c.points[c.num_points++] = vf_vec3_make(in, p.y, p.z);
          }
        }
  }
  coverage cov = run_case(&c, 31);
  CHECK(cov.on_radius > 100);
  case_free(&c);
}

/* Queries on cell boundaries, a float either side of them, and where q - r or q + r falls
 * on one (one cell on that axis: the grid's general path), over a lattice of light vertices
 * spaced half a cell apart. The cell width is the grid's own (vf_grid_lookup.inv_cell),
 * read from a first build over the same points. */
static void test_cell_boundaries(void) {
  merge_case c = {.name = "cell boundaries", .radius = 0.05f, .max_path_length = 10};
  enum { SIDE = 24, QUERIES = 6000 };
  case_alloc(&c, SIDE * SIDE * SIDE, QUERIES);
  vf_rng r = vf_rng_for_path(4, 0, 0, VF_STREAM_TEST);
  vf_hashgrid *grid = NULL;
  vf_vec3 origin = vf_vec3_make(0.0f, 0.0f, 0.0f);
  CHECK_INT_EQ(vf_hashgrid_create(&grid), VF_OK);
  if (grid == NULL) return;
  CHECK_INT_EQ(vf_hashgrid_build(grid, &origin, sizeof origin, 1, c.radius, NULL), VF_OK);
  double cell = 1.0 / vf_hashgrid_lookup(grid)->inv_cell, reach = vf_hashgrid_lookup(grid)->search_radius;
  vf_hashgrid_destroy(grid);
  for (int z = 0; z < SIDE; z++)
    for (int y = 0; y < SIDE; y++)
      for (int x = 0; x < SIDE; x++)
        c.points[c.num_points++] = vf_vec3_make((float)(x * cell / 2), (float)(y * cell / 2), (float)(z * cell / 2));
  for (uint32_t i = 0; i < QUERIES; i++) {
    float xyz[3];
    for (int a = 0; a < 3; a++) {
      double boundary = (double)(1 + vf_rng_next(&r) % (SIDE / 2 - 2)) * cell;
      double at;
      switch (vf_rng_next(&r) % 6) {
      case 0: at = boundary; break;
      case 1: at = boundary + reach; break; /* q - r on the boundary: one cell on this axis */
      case 2: at = boundary - reach; break; /* q + r on it */
      case 3: at = boundary + cell / 2; break;
      default: at = boundary + uniform(&r, -1.0f, 1.0f) * cell; break;
      }
      xyz[a] = (float)at;
      int step = (int)(vf_rng_next(&r) % 3) - 1; /* the float itself, or one either side */
      if (step) xyz[a] = nextafterf(xyz[a], step > 0 ? INFINITY : -INFINITY);
    }
    c.queries[c.num_queries++] = vf_vec3_make(xyz[0], xyz[1], xyz[2]);
  }
  coverage cov = run_case(&c, 41);
  CHECK(cov.general_path > 100);
  case_free(&c);
}

/* Few light vertices: a grid of 7 (whose table of 16 buckets sends most queries the
 * general way) and 300 spread over a box of side 4 (most candidate ranges empty); queries
 * mostly far from any light vertex, some very far, and non-finite ones (no candidates at
 * all). */
static void test_empty_cells(void) {
  static const uint32_t sizes[] = {7, 300};
  coverage all = {0};
  for (int s = 0; s < 2; s++) {
    merge_case c = {.name = s == 0 ? "empty cells, 7 light vertices" : "empty cells, 300 light vertices",
                    .radius = 0.02f, .max_path_length = 10};
    case_alloc(&c, sizes[s], 2000);
    vf_rng r = vf_rng_for_path(5, (uint64_t)s, 0, VF_STREAM_TEST);
    float side = s == 0 ? 1.0f : 4.0f;
    for (uint32_t i = 0; i < sizes[s]; i++)
      c.points[c.num_points++] =
          vf_vec3_make(side * vf_rng_float(&r), side * vf_rng_float(&r), side * vf_rng_float(&r));
    queries_near_points(&c, &r, 1990, -1.0f, side + 1.0f);
    for (int i = 0; i < 6; i++) c.queries[c.num_queries++] = vf_vec3_make(100.0f + (float)i, -100.0f, 1e6f);
    c.queries[c.num_queries++] = vf_vec3_make(NAN, 0.5f, 0.5f);
    c.queries[c.num_queries++] = vf_vec3_make(0.5f, INFINITY, 0.5f);
    c.queries[c.num_queries++] = vf_vec3_make(-INFINITY, NAN, 0.5f);
    c.queries[c.num_queries++] = c.points[0];
    coverage cov = run_case(&c, 51 + (uint64_t)s);
    all.empty_ranges += cov.empty_ranges;
    all.without_hits += cov.without_hits;
    all.hits += cov.hits;
    all.general_path += cov.general_path;
    case_free(&c);
  }
  CHECK(all.empty_ranges > 1000 && all.without_hits > 1000 && all.hits > 0 && all.general_path > 1000);
}

/* Light vertices around (1000, -1000, 1000), where a float's step is 2^-14 and the
 * differences of the distance test round; a short maximum path length, so that the
 * length test refuses many candidates within the radius. */
static void test_far_from_the_origin(void) {
  merge_case c = {.name = "far from the origin, short", .radius = 0.01f, .max_path_length = 3};
  case_alloc(&c, 20000, 3000);
  vf_rng r = vf_rng_for_path(6, 0, 0, VF_STREAM_TEST);
  for (uint32_t i = 0; i < 20000; i++)
    c.points[c.num_points++] = vf_vec3_make(1000.0f + 0.5f * vf_rng_float(&r), -1000.0f + 0.5f * vf_rng_float(&r),
                                            1000.0f + 0.5f * vf_rng_float(&r));
  for (uint32_t i = 0; i < 3000; i++)
    c.queries[c.num_queries++] = jitter(&r, c.points[vf_rng_next(&r) % c.num_points], 1.5f * c.radius);
  run_case(&c, 61);
  case_free(&c);
}

/* Many light vertices at the very same positions: every copy is a hit of its own, in the
 * grid's order. */
static void test_repeated_points(void) {
  merge_case c = {.name = "repeated points", .radius = 0.03f, .max_path_length = 10};
  enum { DISTINCT = 30, COPIES = 60 };
  case_alloc(&c, DISTINCT * COPIES, 1500);
  vf_rng r = vf_rng_for_path(7, 0, 0, VF_STREAM_TEST);
  vf_vec3 at[DISTINCT];
  for (int k = 0; k < DISTINCT; k++) at[k] = vf_vec3_make(vf_rng_float(&r), vf_rng_float(&r), vf_rng_float(&r));
  for (int i = 0; i < COPIES; i++)
    for (int k = 0; k < DISTINCT; k++) c.points[c.num_points++] = at[k];
  for (uint32_t i = 0; i < 1500; i++)
    c.queries[c.num_queries++] = i % 3 == 0 ? at[i % DISTINCT] : jitter(&r, at[i % DISTINCT], 1.5f * c.radius);
  run_case(&c, 71);
  case_free(&c);
}

int main(void) {
  setvbuf(stdout, NULL, _IOLBF, 0);
  int err;
  if ((err = vf_scene_load("cornell-glossy", &scene)) != VF_OK || (err = vf_accel_create(scene, &accel)) != VF_OK ||
      (err = vf_pool_create(2, &pool)) != VF_OK) {
    fprintf(stderr, "set-up failed: %s\n", vf_error_detail(err));
    return 1;
  }
  for (int m = 0; m < scene->num_materials && num_materials < 64; m++) {
    vf_bsdf_lobes lobes;
    vf_bsdf_lobes_of(&scene->materials[m], &lobes);
    if (!lobes.is_delta && !lobes.black) materials[num_materials++] = m;
  }
  if (vf_merge_pipeline_detect_avx512())
    printf("candidate tests: AVX-512 and SSE2, each against the reference\n");
  else
    printf("candidate tests: SSE2 against the reference; this CPU has no AVX-512, so its test is not run\n");
  RUN(test_uniform_points);
  RUN(test_many_points_per_cell);
  RUN(test_points_on_the_radius);
  RUN(test_cell_boundaries);
  RUN(test_empty_cells);
  RUN(test_far_from_the_origin);
  RUN(test_repeated_points);
  vf_pool_destroy(pool);
  vf_accel_destroy(accel);
  vf_scene_destroy(scene);
  return check_finish();
}
#endif
