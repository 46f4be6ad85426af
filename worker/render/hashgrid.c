/* Hashed uniform grid for vertex merging (thesis 004, section 2.4.9), rebuilt every iteration.
 *
 * Layout. Cells are cubes a little wider than 2r (the diameter of a query), so along each
 * axis a query ball touches at most two cells: the one holding q and its neighbour on the
 * side of the half q lies in. A query therefore visits the 2x2x2 block of cells nearest q.
 * The cell (cx, cy, cz) goes to bucket (vf_grid_row_hash(cy, cz) + cx) mod T, with T a power of two
 * >= 2n: cells that are neighbours along x are neighbours in the table, so the two x-cells
 * of a query are one contiguous run of the sorted indices. This is the thesis's
 * "triplet" trick, at cell size 2r where a query needs pairs. Point indices are sorted by
 * bucket, ties by index; cell_start[b] .. cell_start[b + 1] is bucket b's run.
 *
 * Candidates. The eight buckets of a query are sorted and merged: equal buckets (two cells
 * that collide) are visited once and adjacent buckets become one range. The ranges handed
 * out are thus disjoint, and no point is ever returned twice. A collision only adds
 * candidates that fail the distance test.
 *
 * Build: a stable two-level counting sort, parallel over vf_pool, result independent of the
 * thread count.
 *   1. keys:    per fixed-size chunk of CHUNK points (chunk count depends on n only):
 *               copy positions into a compact array, compute buckets, and a histogram of
 *               the bucket's top bits (the "group").
 *   2. offsets: serial exclusive prefix sum over (group, chunk), so each chunk knows where
 *               its points of each group go.
 *   3. scatter: per chunk, in index order: stable.
 *   4. groups:  per group, a counting sort on the low bits of the bucket, in place in the
 *               group's own slice of the cell table, which it leaves holding the starts of
 *               its buckets. Positions are copied in sorted order next to the indices, so
 *               queries read contiguous memory, not the caller's large records.
 * Every task writes only its own outputs; nothing depends on which thread ran it.
 * The input may be several arrays (segments, vf_hashgrid_build_segments): the phases see
 * their points one after the other, and phase 3 gives each the caller's name for it, its
 * segment's index_base plus its place in the segment.
 *
 * Degenerate cases.
 *   - n = 0: the grid is empty; candidates returns 0 and query visits nothing.
 *   - All points in one cell: one bucket holds them all; still correct, and every query
 *     near it scans them all (inherent to a grid). The build's last phase then runs on one
 *     thread for that group.
 *   - Huge coordinates: cell coordinates are computed in double and held in int64, clamped
 *     to +-2^62 (beyond int32 for, e.g., |p| = 1e30 with r = 1e-3). Clamping is monotonic,
 *     so the search stays exact; far points then share clamp cells and are merely slow.
 *     When floats near q are farther apart than the radius (|q| / r beyond ~2^51), the cells
 *     of q - r and q + r can lie 3 or more apart with nothing representable in between; a
 *     query then visits only the cells of the floats within reach (q itself, in practice).
 *   - Non-finite positions are skipped at build time (the index array holds only the finite
 *     points, in order) and never returned. A non-finite query point has no candidates.
 *   - Exactness: the query test is |p - q|^2 <= r^2 evaluated in double, where float
 *     differences and squares are exact. Candidates are collected for a radius enlarged by
 *     2^-12 relative (and at least 2^-74 absolute), so callers testing in float, with its
 *     rounding and underflow, never miss a point either. */
#include "hashgrid.h"
#include "huge_pages.h"

#include "../../common/error.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

enum {
  CHUNK = 8192,          /* points per build task in phases 1 and 3: fixed, not per thread */
  GROUP_BITS_MAX = 8,    /* 256 groups: few enough write streams for phase 3 to scatter fast */
  TABLE_BITS_MIN = 4,
  TABLE_BITS_MAX = 28,   /* 1 GiB of cell table; more points just share buckets */
  AXIS_CELLS_MAX = 3,
};

#define SKIPPED UINT32_MAX         /* key of a non-finite point */
#define SEARCH_SLACK (1.0 + 0x1p-12)
#define SEARCH_FLOOR 0x1p-74       /* float squares of |d| < 2^-75 underflow to 0 */
#define CELL_SLACK (1.0 + 0x1p-10) /* cell > search diameter: at most 2 cells per axis */

/* vf_grid_point during the build: `index` holds the bucket (or SKIPPED) in phases 1-3 and
 * the point index from phase 4 on. */
typedef vf_grid_point grid_point;

struct vf_hashgrid {
  /* The last build. */
  vf_grid_lookup lk;    /* what queries read (hashgrid.h); its cell_start is cell_start below */
  double radius_sq;     /* exact square of the float radius */
  unsigned low_bits;    /* bucket bits below the group */
  uint32_t points;      /* n of the build, finite or not */
  int points_overwritten; /* the caller's since the build (writable or released): no index to trust */
  uint32_t chunks, groups;
  const vf_grid_segment *segments; /* the input: borrowed for the build */
  uint32_t num_segments;
  size_t stride;

  /* Owned, grow-only buffers; *_cap counts elements. */
  grid_point *keyed;      /* phases 1-3 by input index; then sorted (sorted_points) */
  grid_point *scattered;  /* phase 3 output, grouped */
  uint32_t *scattered_index;
  uint32_t *segment_start; /* num_segments + 1: where each segment's points begin in input order */
  uint32_t *segment_rename; /* num_segments: index_base - start, so that point i is named i + this */
  size_t segment_cap;
  size_t points_cap;
  uint32_t *cell_start;   /* mask + 2 entries */
  size_t table_cap;
  uint32_t *chunk_offset; /* chunks x groups histogram, then offsets */
  size_t chunk_offset_cap;
  uint32_t *group_start;  /* groups + 1 */
  size_t group_cap;
};

/* ---- cells and buckets: shared by build and query (hashgrid.h), so both agree bit for bit ---- */

static inline uint32_t point_bucket(const vf_hashgrid *g, vf_vec3 p) {
  int64_t cx = vf_grid_cell_coord(p.x, g->lk.inv_cell);
  int64_t cy = vf_grid_cell_coord(p.y, g->lk.inv_cell);
  int64_t cz = vf_grid_cell_coord(p.z, g->lk.inv_cell);
  return vf_grid_bucket(cx, vf_grid_row_hash(cy, cz), g->lk.mask);
}

/* The cells along one axis that can hold a coordinate within the search radius of v.
 * Every float p with |p - v| <= search_radius has lo <= cell(p) <= hi, since rounding and
 * vf_grid_cell_coord are monotonic. The cell is wider than the search diameter, so hi - lo <= 1
 * unless |v| is so large that double rounding moves a cell (|v| / cell > ~2^51): then
 * floats near v are far more than the radius apart and only those within reach count. */
static int axis_cells(double v, double search_radius, double inv_cell, int64_t out[AXIS_CELLS_MAX]) {
  int64_t lo = vf_grid_cell_coord(v - search_radius, inv_cell);
  int64_t hi = vf_grid_cell_coord(v + search_radius, inv_cell);
  if (hi - lo < AXIS_CELLS_MAX) {
    int k = 0;
    for (int64_t c = lo; c <= hi; c++) out[k++] = c;
    return k;
  }
  float f = (float)v; /* v came from a float: exact */
  float below = nextafterf(f, -INFINITY), above = nextafterf(f, INFINITY);
  int k = 0;
  out[k++] = vf_grid_cell_coord(f, inv_cell);
  if (v - (double)below <= search_radius) out[k++] = vf_grid_cell_coord(below, inv_cell);
  if ((double)above - v <= search_radius) out[k++] = vf_grid_cell_coord(above, inv_cell);
  return k;
}

/* ---- allocation ---- */

/* The capacity to grow to for need elements: by half at least, so slowly rising counts
 * from one iteration to the next do not reallocate every time. */
static size_t grown(size_t cap, size_t need) { return need <= cap ? cap : (need > cap + cap / 2 ? need : cap + cap / 2); }

/* Gives the whole pages inside [p, p + bytes) back to the kernel (they read as zeros when
 * touched again; the caller rewrites them before reading). Advice: ignored when refused. */
static void release_pages(void *p, size_t bytes) {
  const uintptr_t page = 4096;
  uintptr_t begin = ((uintptr_t)p + page - 1) & ~(page - 1), end = ((uintptr_t)p + bytes) & ~(page - 1);
  if (bytes >= ((size_t)1 << 20) && end > begin) madvise((void *)begin, end - begin, MADV_DONTNEED);
}

/* The sorted points: VF_HASHGRID_POINT_PAD more than cap, on huge pages
 * (worker/render/huge_pages.h), as vertex merging reads them at random in place (hashgrid.h). Old
 * contents are not kept: every build writes them before reading. On failure the grid
 * forgets every capacity, so that the next build allocates again. */
static int grow_points(vf_hashgrid *g, size_t cap) {
  if (cap <= g->points_cap && g->keyed != NULL) return VF_OK;
  size_t bytes = (cap + VF_HASHGRID_POINT_PAD) * sizeof *g->keyed;
  free(g->keyed);
  if ((g->keyed = vf_huge_alloc(bytes)) == NULL) {
    g->points_cap = 0;
    return vf_error_set(VF_ENOMEM, "hash grid: cannot allocate %zu bytes", bytes);
  }
  return VF_OK;
}

/* Resizes *buf to cap elements of size elem when cap exceeds old_cap; never shrinks. */
static int grow(void **buf, size_t old_cap, size_t cap, size_t elem) {
  if (cap <= old_cap) return VF_OK;
  void *p = realloc(*buf, cap * elem);
  if (p == NULL) return vf_error_set(VF_ENOMEM, "hash grid: cannot allocate %zu bytes", cap * elem);
  *buf = p;
  return VF_OK;
}

int vf_hashgrid_create(vf_hashgrid **out) {
  vf_hashgrid *g = calloc(1, sizeof *g);
  if (g == NULL) return VF_ENOMEM;
  *out = g;
  return VF_OK;
}

void vf_hashgrid_trim(vf_hashgrid *g) {
  if (g == NULL) return;
  void **buffers[] = {(void **)&g->keyed, (void **)&g->scattered, (void **)&g->scattered_index,
                      (void **)&g->segment_start, (void **)&g->segment_rename, (void **)&g->cell_start,
                      (void **)&g->chunk_offset, (void **)&g->group_start};
  for (size_t i = 0; i < sizeof buffers / sizeof *buffers; i++) {
    free(*buffers[i]);
    *buffers[i] = NULL;
  }
  g->points_cap = g->segment_cap = g->table_cap = g->chunk_offset_cap = g->group_cap = 0;
  g->lk.cell_start = NULL;
  g->lk.count = 0;
  g->points = 0;
}

void vf_hashgrid_destroy(vf_hashgrid *g) {
  if (g == NULL) return;
  free(g->keyed);
  free(g->scattered);
  free(g->scattered_index);
  free(g->segment_start);
  free(g->segment_rename);
  free(g->cell_start);
  free(g->chunk_offset);
  free(g->group_start);
  free(g);
}

/* ---- build ---- */

static void run_tasks(vf_pool *pool, size_t tasks, vf_pool_task fn, void *ctx) {
  if (pool != NULL) {
    vf_pool_run(pool, tasks, fn, ctx);
    return;
  }
  for (size_t t = 0; t < tasks; t++) fn(ctx, t, 0);
}

static void chunk_range(const vf_hashgrid *g, size_t chunk, uint32_t *begin, uint32_t *end) {
  *begin = (uint32_t)(chunk * CHUNK);
  *end = g->points - *begin < CHUNK ? g->points : *begin + CHUNK;
}

/* The segment holding input point i: the last whose start is <= i (segments may be empty). */
static uint32_t segment_of(const vf_hashgrid *g, uint32_t i) {
  uint32_t lo = 0, hi = g->num_segments - 1;
  while (lo < hi) {
    uint32_t mid = lo + (hi - lo + 1) / 2;
    if (g->segment_start[mid] <= i) lo = mid;
    else hi = mid - 1;
  }
  return lo;
}

/* The end of the run of input points from i (< end) that lie in one segment, *s: the
 * phases walk a chunk's points segment by segment, *s from segment_of(begin) on. */
static uint32_t segment_run(const vf_hashgrid *g, uint32_t *s, uint32_t i, uint32_t end) {
  while (g->segment_start[*s + 1] <= i) (*s)++; /* past the segment's end (or an empty one) */
  return g->segment_start[*s + 1] < end ? g->segment_start[*s + 1] : end;
}

/* Phase 1: compact positions, buckets, and this chunk's histogram of groups. */
static void key_chunk(void *ctx, size_t chunk, int thread) {
  vf_hashgrid *g = ctx;
  uint32_t *hist = g->chunk_offset + chunk * g->groups;
  memset(hist, 0, g->groups * sizeof *hist);
  uint32_t begin, end;
  chunk_range(g, chunk, &begin, &end);
  uint32_t s = segment_of(g, begin);
  for (uint32_t i = begin; i < end;) {
    uint32_t stop = segment_run(g, &s, i, end), first = g->segment_start[s];
    const unsigned char *base = g->segments[s].base;
    for (; i < stop; i++) {
      vf_vec3 p;
      memcpy(&p, base + (size_t)(i - first) * g->stride, sizeof p); /* records need not be aligned */
      uint32_t key = SKIPPED;
      if (vf_is_finite(p)) {
        key = point_bucket(g, p);
        hist[key >> g->low_bits]++;
      }
      g->keyed[i] = (grid_point){p.x, p.y, p.z, key};
    }
  }
}

/* Phase 3: stable scatter of the chunk's points to their groups. */
static void scatter_chunk(void *ctx, size_t chunk, int thread) {
  vf_hashgrid *g = ctx;
  uint32_t *offset = g->chunk_offset + chunk * g->groups;
  uint32_t begin, end;
  chunk_range(g, chunk, &begin, &end);
  uint32_t s = segment_of(g, begin);
  for (uint32_t i = begin; i < end;) {
    uint32_t stop = segment_run(g, &s, i, end);
    uint32_t rename = g->segment_rename[s]; /* the caller's name of point i, modulo 2^32 */
    for (; i < stop; i++) {
      grid_point p = g->keyed[i];
      if (p.index == SKIPPED) continue;
      uint32_t at = offset[p.index >> g->low_bits]++;
      g->scattered[at] = p;
      g->scattered_index[at] = i + rename;
    }
  }
}

/* Phase 4: stable counting sort of one group by the low bucket bits, counting in the
 * group's slice of the cell table. */
static void sort_group(void *ctx, size_t group, int thread) {
  vf_hashgrid *g = ctx;
  uint32_t begin = g->group_start[group], end = g->group_start[group + 1];
  size_t buckets = (size_t)1 << g->low_bits;
  uint32_t low_mask = (uint32_t)buckets - 1;
  uint32_t *start = g->cell_start + (group << g->low_bits);
  grid_point *sorted = g->keyed;
  memset(start, 0, buckets * sizeof *start);
  for (uint32_t k = begin; k < end; k++) start[g->scattered[k].index & low_mask]++;
  uint32_t sum = begin;
  for (size_t b = 0; b < buckets; b++) {
    uint32_t c = start[b];
    start[b] = sum;
    sum += c;
  }
  for (uint32_t k = begin; k < end; k++) {
    grid_point p = g->scattered[k];
    uint32_t at = start[p.index & low_mask]++;
    p.index = g->scattered_index[k];
    sorted[at] = p;
  }
  /* Each counter now holds its bucket's end, the next bucket's start: shift by one. */
  memmove(start + 1, start, (buckets - 1) * sizeof *start);
  start[0] = begin;
}

static unsigned ceil_log2(uint32_t n) {
  unsigned b = 0;
  while (b < 32 && ((uint64_t)1 << b) < n) b++;
  return b;
}

int vf_hashgrid_build(vf_hashgrid *g, const void *base, size_t stride, uint32_t n, float radius,
                      vf_pool *pool) {
  vf_grid_segment all = {base, n, 0};
  return vf_hashgrid_build_segments(g, &all, 1, stride, radius, pool);
}

int vf_hashgrid_build_segments(vf_hashgrid *g, const vf_grid_segment *segments, uint32_t num_segments,
                               size_t stride, float radius, vf_pool *pool) {
  if (g == NULL) return vf_error_set(VF_EINVAL, "hash grid: NULL grid");
  g->lk.count = 0; /* an empty grid on failure */
  g->points_overwritten = 0;
  g->points = 0;
  if (!(radius >= 0.0f) || !isfinite(radius))
    return vf_error_set(VF_EINVAL, "hash grid: radius %g is not a finite number >= 0", radius);
  if (num_segments > 0 && segments == NULL) return vf_error_set(VF_EINVAL, "hash grid: NULL segments");
  uint64_t total = 0;
  for (uint32_t k = 0; k < num_segments; k++) {
    const vf_grid_segment *seg = &segments[k];
    if (seg->count > 0 && seg->base == NULL)
      return vf_error_set(VF_EINVAL, "hash grid: NULL points for n = %u (segment %u)", seg->count, k);
    if ((uint64_t)seg->index_base + seg->count - (seg->count > 0) > UINT32_MAX)
      return vf_error_set(VF_EINVAL, "hash grid: segment %u's indices pass 2^32", k);
    total += seg->count;
  }
  if (total > UINT32_MAX) return vf_error_set(VF_EINVAL, "hash grid: %llu points, more than 2^32 - 1",
                                              (unsigned long long)total);
  uint32_t n = (uint32_t)total;
  if (n > 0 && stride < sizeof(vf_vec3))
    return vf_error_set(VF_EINVAL, "hash grid: stride %zu is less than a vf_vec3", stride);

  double r = radius;
  g->radius_sq = r * r;
  g->lk.search_radius = r * SEARCH_SLACK > SEARCH_FLOOR ? r * SEARCH_SLACK : SEARCH_FLOOR;
  g->lk.inv_cell = 1.0 / (2.0 * g->lk.search_radius * CELL_SLACK);
  unsigned table_bits = ceil_log2(n) + 1; /* >= 2n buckets: ~0.5 colliding points per bucket */
  if (table_bits < TABLE_BITS_MIN) table_bits = TABLE_BITS_MIN;
  if (table_bits > TABLE_BITS_MAX) table_bits = TABLE_BITS_MAX;
  unsigned group_bits = table_bits < GROUP_BITS_MAX ? table_bits : GROUP_BITS_MAX;
  g->low_bits = table_bits - group_bits;
  g->lk.mask = (uint32_t)(((uint64_t)1 << table_bits) - 1);
  g->groups = (uint32_t)1 << group_bits;
  g->chunks = (uint32_t)(((uint64_t)n + CHUNK - 1) / CHUNK);
  g->segments = segments;
  g->num_segments = num_segments;
  g->stride = stride;
  if (n == 0) return VF_OK;

  /* A failure leaves some buffers larger than their recorded capacity: harmless. */
  size_t points_cap = grown(g->points_cap, n);
  size_t table_cap = grown(g->table_cap, (size_t)g->lk.mask + 2);
  size_t chunk_offset_cap = grown(g->chunk_offset_cap, (size_t)g->chunks * g->groups);
  size_t group_cap = grown(g->group_cap, (size_t)g->groups + 1);
  int err;
  if ((err = grow_points(g, points_cap)) < 0 ||
      (err = grow((void **)&g->scattered, g->points_cap, points_cap, sizeof *g->scattered)) < 0 ||
      (err = grow((void **)&g->scattered_index, g->points_cap, points_cap, sizeof *g->scattered_index)) < 0 ||
      (err = grow((void **)&g->segment_start, g->segment_cap, grown(g->segment_cap, (size_t)num_segments + 1),
                  sizeof *g->segment_start)) < 0 ||
      (err = grow((void **)&g->segment_rename, g->segment_cap, grown(g->segment_cap, (size_t)num_segments + 1),
                  sizeof *g->segment_rename)) < 0 ||
      (err = grow((void **)&g->cell_start, g->table_cap, table_cap, sizeof *g->cell_start)) < 0 ||
      (err = grow((void **)&g->chunk_offset, g->chunk_offset_cap, chunk_offset_cap, sizeof *g->chunk_offset)) < 0 ||
      (err = grow((void **)&g->group_start, g->group_cap, group_cap, sizeof *g->group_start)) < 0)
    return err;
  g->points_cap = points_cap;
  g->segment_cap = grown(g->segment_cap, (size_t)num_segments + 1);
  g->table_cap = table_cap;
  g->chunk_offset_cap = chunk_offset_cap;
  g->group_cap = group_cap;

  g->lk.cell_start = g->cell_start;

  g->segment_start[0] = 0;
  for (uint32_t k = 0; k < num_segments; k++) {
    g->segment_start[k + 1] = g->segment_start[k] + segments[k].count;
    g->segment_rename[k] = segments[k].index_base - g->segment_start[k];
  }
  g->points = n;
  run_tasks(pool, g->chunks, key_chunk, g);
  g->segments = NULL; /* borrowed for the build only */

  /* Phase 2, serial: ~n / 8 additions. */
  uint32_t sum = 0;
  for (uint32_t group = 0; group < g->groups; group++) {
    g->group_start[group] = sum;
    for (uint32_t chunk = 0; chunk < g->chunks; chunk++) {
      uint32_t *c = &g->chunk_offset[(size_t)chunk * g->groups + group];
      uint32_t h = *c;
      *c = sum;
      sum += h;
    }
  }
  g->group_start[g->groups] = sum;

  run_tasks(pool, g->chunks, scatter_chunk, g);
  run_tasks(pool, g->groups, sort_group, g);
  g->cell_start[(size_t)g->lk.mask + 1] = sum;
  g->lk.count = sum;
  memset(&g->keyed[sum], 0, VF_HASHGRID_POINT_PAD * sizeof *g->keyed);
  /* Phase 3's output is read by no query: its pages go back to the kernel until the next
   * build (20 bytes per point, while the camera pass, the peak of an iteration's memory,
   * runs; docs/BENCHMARKS.md, "Memory"). */
  release_pages(g->scattered, (size_t)n * sizeof *g->scattered);
  release_pages(g->scattered_index, (size_t)n * sizeof *g->scattered_index);
  return VF_OK;
}

/* ---- queries ---- */

void vf_grid_cells_general(const vf_grid_lookup *lk, vf_vec3 q, vf_grid_cells *cells) {
  cells->count = 0;
  cells->span = 1;
  if (lk->count == 0 || !vf_is_finite(q)) return;
  int64_t xs[AXIS_CELLS_MAX], ys[AXIS_CELLS_MAX], zs[AXIS_CELLS_MAX];
  int nx = axis_cells(q.x, lk->search_radius, lk->inv_cell, xs);
  int ny = axis_cells(q.y, lk->search_radius, lk->inv_cell, ys);
  int nz = axis_cells(q.z, lk->search_radius, lk->inv_cell, zs);

  /* What the block path leaves: 1 to 27 buckets, insertion-sorted as they come. */
  uint32_t *buckets = cells->bucket;
  int nb = 0;
  for (int z = 0; z < nz; z++)
    for (int y = 0; y < ny; y++) {
      uint64_t row = vf_grid_row_hash(ys[y], zs[z]);
      for (int x = 0; x < nx; x++) {
        uint32_t b = vf_grid_bucket(xs[x], row, lk->mask);
        __builtin_prefetch(&lk->cell_start[b]); /* queries are bound by these misses */
        int k = nb++;
        for (; k > 0 && buckets[k - 1] > b; k--) buckets[k] = buckets[k - 1];
        buckets[k] = b;
      }
    }
  cells->count = nb;
}

int vf_grid_ranges_general(const vf_grid_lookup *lk, const vf_grid_cells *cells,
                           vf_index_range out[VF_HASHGRID_MAX_RANGES]) {
  /* Runs of equal or consecutive buckets become one range: disjoint, no point twice. */
  const uint32_t *buckets = cells->bucket;
  int nb = cells->count, nr = 0;
  for (int k = 0; k < nb;) {
    uint32_t first = buckets[k], last = first;
    for (k++; k < nb && buckets[k] <= last + 1; k++) last = buckets[k];
    uint32_t begin = lk->cell_start[first], end = lk->cell_start[(size_t)last + 1];
    if (begin < end) out[nr++] = (vf_index_range){begin, end};
  }
  return nr;
}

const vf_grid_lookup *vf_hashgrid_lookup(const vf_hashgrid *g) { return &g->lk; }

int vf_hashgrid_candidates(const vf_hashgrid *g, vf_vec3 q, vf_index_range out[VF_HASHGRID_MAX_RANGES]) {
  vf_grid_cells cells;
  vf_grid_cells_of(&g->lk, q, &cells);
  return vf_grid_ranges_of(&g->lk, &cells, out);
}

const vf_grid_point *vf_hashgrid_points(const vf_hashgrid *g) { return g->points_overwritten ? NULL : g->keyed; }

uint32_t vf_hashgrid_count(const vf_hashgrid *g) { return g->lk.count; }

vf_grid_point *vf_hashgrid_points_writable(vf_hashgrid *g) {
  g->points_overwritten = 1;
  return g->keyed;
}

void vf_hashgrid_release_points(vf_hashgrid *g) {
  if (g->lk.count == 0 || g->keyed == NULL) return;
  release_pages(g->keyed, ((size_t)g->lk.count + VF_HASHGRID_POINT_PAD) * sizeof *g->keyed);
  g->points_overwritten = 1;
}

void vf_hashgrid_query(const vf_hashgrid *g, vf_vec3 q, void (*visit)(void *ctx, uint32_t i), void *ctx) {
  vf_index_range ranges[VF_HASHGRID_MAX_RANGES];
  int nr = vf_hashgrid_candidates(g, q, ranges);
  if (g->points_overwritten) return; /* a misuse (hashgrid.h): visit nothing rather than what is there now */
  const grid_point *sorted = g->keyed;
  double qx = q.x, qy = q.y, qz = q.z, r2 = g->radius_sq;
  for (int k = 0; k < nr; k++) __builtin_prefetch(&sorted[ranges[k].begin]);
  for (int k = 0; k < nr; k++)
    for (uint32_t j = ranges[k].begin; j < ranges[k].end; j++) {
      const grid_point *p = &sorted[j];
      double dx = p->x - qx, dy = p->y - qy, dz = p->z - qz;
      if (dx * dx + dy * dy + dz * dz <= r2) visit(ctx, p->index);
    }
}
