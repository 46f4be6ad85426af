/* Fixed-radius range search over light vertices for vertex merging: a hashed uniform grid
 * (thesis 004, section 2.4.9), rebuilt every iteration.
 *
 * The grid sorts point indices by hashed cell; a query visits the cells that can hold
 * points within the radius. The sorted order is a pure function of the points (a stable
 * sort by cell, ties by point index), so queries visit points in the same order whatever
 * the number of threads that built the grid: renders stay reproducible bit for bit. */
#ifndef VF_HASHGRID_H
#define VF_HASHGRID_H

#include "../../common/pool.h"
#include "../../common/vec3.h"

#include <stddef.h>
#include <stdint.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

typedef struct vf_hashgrid vf_hashgrid;

/* A run of the sorted index array: indices[begin .. end). */
typedef struct {
  uint32_t begin, end;
} vf_index_range;

#define VF_HASHGRID_MAX_RANGES 27

/* A point as the grid stores it, in sorted order: its position and its index in the
 * caller's array. Candidate ranges index these, so a query's distance tests read
 * contiguous memory instead of the caller's large records. */
typedef struct {
  float x, y, z;
  uint32_t index;
} vf_grid_point;

int vf_hashgrid_create(vf_hashgrid **out);
void vf_hashgrid_destroy(vf_hashgrid *grid);
/* Frees the grid's buffers, leaving an empty grid that the next build allocates again. */
void vf_hashgrid_trim(vf_hashgrid *grid);

/* Builds over n points, positions read at base + i * stride (a vf_vec3 at offset 0 of each
 * record), for queries of the given radius. Reuses the grid's memory between builds.
 * Parallel over the pool's threads (pool NULL: serial). Non-finite points are left out.
 * On failure (VF_EINVAL for a bad radius, base or stride; VF_ENOMEM) the grid is empty. */
int vf_hashgrid_build(vf_hashgrid *grid, const void *base, size_t stride, uint32_t n, float radius,
                      vf_pool *pool);

/* Points kept in several arrays: segment k holds count points at base + i * stride, which
 * the grid names index_base + i (these names must fit in 32 bits). The grid is that of the
 * segments' points one after the other in a single array (the same sorted order, the same
 * runs), but with these indices: a caller can keep its points where they were made
 * instead of copying them together. */
typedef struct {
  const void *base;
  uint32_t count;
  uint32_t index_base;
} vf_grid_segment;

int vf_hashgrid_build_segments(vf_hashgrid *grid, const vf_grid_segment *segments, uint32_t num_segments,
                               size_t stride, float radius, vf_pool *pool);

/* The candidate ranges for a query at q: every point within the radius of q lies in one
 * of them (others may too: callers test the distance). Returns the number of ranges
 * written to out (<= VF_HASHGRID_MAX_RANGES), some of which may be empty. */
int vf_hashgrid_candidates(const vf_hashgrid *grid, vf_vec3 q, vf_index_range out[VF_HASHGRID_MAX_RANGES]);

/* The same in two steps, for callers that overlap the memory latency of many queries:
 * vf_grid_cells_of computes the buckets of q and prefetches their table entries;
 * vf_grid_ranges_of, called later, reads them. Both read the grid through its lookup
 * view (vf_hashgrid_lookup), and their common case is inline, below: merging calls them
 * for every camera vertex, where calls into hashgrid.c took a visible share of vcm's
 * time. */
typedef struct {
  uint32_t bucket[VF_HASHGRID_MAX_RANGES];
  int count;
  int span; /* buckets that each entry of bucket[] starts: 2 for a query's 2x2x2 block, else 1 */
} vf_grid_cells;

/* What a query reads of the grid. Owned by the grid, valid until its next build; callers
 * only read it. */
typedef struct {
  const uint32_t *cell_start; /* mask + 2 entries: bucket b's points are cell_start[b] .. [b + 1] */
  double search_radius;       /* the radius enlarged for choosing cells (hashgrid.c) */
  double inv_cell;            /* 1 / cell width */
  uint32_t mask;              /* table size - 1 */
  uint32_t count;             /* points indexed by the last build */
} vf_grid_lookup;

const vf_grid_lookup *vf_hashgrid_lookup(const vf_hashgrid *grid);

/* Cells and buckets, shared by the build and the queries so that both agree bit for bit.
 * The cell (cx, cy, cz) goes to bucket (row hash(cy, cz) + cx) mod table size: cells that
 * are neighbours along x are neighbours in the table. A cell coordinate is
 * floor(v * inv_cell), clamped to +-2^62; monotonic in v, which the queries' correctness
 * rests on. */
#define VF_GRID_CELL_LIMIT 0x1p62 /* exact in double */
static inline int64_t vf_grid_cell_coord(double v, double inv_cell) {
  double c = v * inv_cell;
  if (c < -VF_GRID_CELL_LIMIT) c = -VF_GRID_CELL_LIMIT;
  if (c > VF_GRID_CELL_LIMIT) c = VF_GRID_CELL_LIMIT;
  int64_t t = (int64_t)c; /* truncates toward zero; step down for negative non-integers */
  return t - ((double)t > c);
}

#define VF_GRID_ROW_Y 0x9e3779b97f4a7c15ULL
#define VF_GRID_ROW_Z 0xc2b2ae3d27d4eb4fULL
static inline uint64_t vf_grid_row_mix(uint64_t h) {
  h ^= h >> 31;
  h *= 0xbf58476d1ce4e5b9ULL;
  return h ^ (h >> 29);
}

static inline uint64_t vf_grid_row_hash(int64_t cy, int64_t cz) {
  return vf_grid_row_mix((uint64_t)cy * VF_GRID_ROW_Y ^ (uint64_t)cz * VF_GRID_ROW_Z);
}

static inline uint32_t vf_grid_bucket(int64_t cx, uint64_t row, uint32_t mask) {
  return (uint32_t)((row + (uint64_t)cx) & mask);
}

/* The paths for what the inline functions below leave: queries whose cells are not a
 * 2x2x2 block of four separate runs (a few in a thousand), an empty grid, a non-finite q. */
void vf_grid_cells_general(const vf_grid_lookup *lk, vf_vec3 q, vf_grid_cells *cells);
int vf_grid_ranges_general(const vf_grid_lookup *lk, const vf_grid_cells *cells,
                           vf_index_range out[VF_HASHGRID_MAX_RANGES]);

/* The query's 2x2x2 block of cells, the case of all but a few queries in a thousand (two
 * cells per axis unless q's interval falls inside one cell). Its four rows of two cells
 * are four pairs of consecutive buckets, row + x0 and row + x0 + 1: the block is four
 * runs of the table, in increasing order of their first bucket (sorted by a network of
 * five comparators in registers: the buckets are random, so an insertion sort's
 * comparisons would mispredict about half the time). The runs are those the general path
 * would give, in its order, unless two rows share or touch a bucket or a pair wraps
 * around the table's end: then the general path takes the query and merges them. So does
 * it when an axis has one cell or three. */
#ifdef __SSE2__
/* vf_grid_cell_coord of both doubles of c, as int32 in the two low lanes, for |c| < 2^30
 * (no clamping then): truncation, then one step down where it went up, which is the floor
 * exactly, as there. */
static inline __m128i vf_grid_floor2(__m128d c) {
  __m128i t = _mm_cvttpd_epi32(c);
  __m128d up = _mm_cmpgt_pd(_mm_cvtepi32_pd(t), c);
  return _mm_add_epi32(t, _mm_shuffle_epi32(_mm_castpd_si128(up), _MM_SHUFFLE(3, 3, 2, 0)));
}
#endif

static inline void vf_grid_cells_of(const vf_grid_lookup *lk, vf_vec3 q, vf_grid_cells *cells) {
  if (lk->count == 0 || !vf_is_finite(q)) { /* no candidates: before any conversion of q */
    vf_grid_cells_general(lk, q, cells);
    return;
  }
  double r = lk->search_radius, ic = lk->inv_cell;
#ifdef __SSE2__
  /* The six cell coordinates two at a time, with the same double operations as
   * vf_grid_cell_coord (q.z + -r is q.z - r exactly); cells beyond 2^30 go the general way. */
  __m128d radius = _mm_set1_pd(r), inv = _mm_set1_pd(ic), qxy = _mm_setr_pd(q.x, q.y);
  __m128d lo = _mm_mul_pd(_mm_sub_pd(qxy, radius), inv), hi = _mm_mul_pd(_mm_add_pd(qxy, radius), inv);
  __m128d zs = _mm_mul_pd(_mm_add_pd(_mm_set1_pd(q.z), _mm_setr_pd(-r, r)), inv);
  __m128d magnitude = _mm_castsi128_pd(_mm_set1_epi64x(INT64_MAX)), limit = _mm_set1_pd(0x1p30);
  __m128d small = _mm_and_pd(_mm_cmplt_pd(_mm_and_pd(lo, magnitude), limit),
                             _mm_cmplt_pd(_mm_and_pd(hi, magnitude), limit));
  small = _mm_and_pd(small, _mm_cmplt_pd(_mm_and_pd(zs, magnitude), limit));
  if (_mm_movemask_pd(small) != 3) {
    vf_grid_cells_general(lk, q, cells);
    return;
  }
  __m128i first = vf_grid_floor2(lo), last = vf_grid_floor2(hi), z = vf_grid_floor2(zs); /* x0 y0, x1 y1, z0 z1 */
  __m128i span = _mm_sub_epi32(_mm_unpacklo_epi64(last, _mm_shuffle_epi32(z, 1)), _mm_unpacklo_epi64(first, z));
  if ((_mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(span, _mm_set1_epi32(1)))) & 7) != 7) {
    vf_grid_cells_general(lk, q, cells);
    return;
  }
  int64_t x0 = _mm_cvtsi128_si32(first), y0 = _mm_cvtsi128_si32(_mm_shuffle_epi32(first, 1));
  int64_t z0 = _mm_cvtsi128_si32(z);
#else
  int64_t x0 = vf_grid_cell_coord(q.x - r, ic), x1 = vf_grid_cell_coord(q.x + r, ic);
  int64_t y0 = vf_grid_cell_coord(q.y - r, ic), y1 = vf_grid_cell_coord(q.y + r, ic);
  int64_t z0 = vf_grid_cell_coord(q.z - r, ic), z1 = vf_grid_cell_coord(q.z + r, ic);
  if (x1 - x0 != 1 || y1 - y0 != 1 || z1 - z0 != 1) {
    vf_grid_cells_general(lk, q, cells);
    return;
  }
#endif
  /* The rows' hashes: y1 = y0 + 1 and z1 = z0 + 1, so their products are one addition away
   * from y0's and z0's (modulo 2^64, as vf_grid_row_hash computes them). */
  uint64_t y0p = (uint64_t)y0 * VF_GRID_ROW_Y, y1p = y0p + VF_GRID_ROW_Y;
  uint64_t z0p = (uint64_t)z0 * VF_GRID_ROW_Z, z1p = z0p + VF_GRID_ROW_Z;
  uint32_t m = lk->mask;
  uint32_t b0 = vf_grid_bucket(x0, vf_grid_row_mix(y0p ^ z0p), m);
  uint32_t b1 = vf_grid_bucket(x0, vf_grid_row_mix(y1p ^ z0p), m);
  uint32_t b2 = vf_grid_bucket(x0, vf_grid_row_mix(y0p ^ z1p), m);
  uint32_t b3 = vf_grid_bucket(x0, vf_grid_row_mix(y1p ^ z1p), m);
  /* Queries are bound by these misses; a run's end is on its start's line but for one
   * start in eight. */
  __builtin_prefetch(&lk->cell_start[b0]);
  __builtin_prefetch(&lk->cell_start[b1]);
  __builtin_prefetch(&lk->cell_start[b2]);
  __builtin_prefetch(&lk->cell_start[b3]);
  uint32_t t;
#define VF_GRID_ORDER(a, b) (t = a < b ? a : b, b = a < b ? b : a, a = t)
  VF_GRID_ORDER(b0, b1), VF_GRID_ORDER(b2, b3);
  VF_GRID_ORDER(b0, b2), VF_GRID_ORDER(b1, b3);
  VF_GRID_ORDER(b1, b2);
#undef VF_GRID_ORDER
  if (b3 == m || b1 - b0 < 2 || b2 - b1 < 2 || b3 - b2 < 2) {
    vf_grid_cells_general(lk, q, cells);
    return;
  }
  cells->bucket[0] = b0;
  cells->bucket[1] = b1;
  cells->bucket[2] = b2;
  cells->bucket[3] = b3;
  cells->count = 4;
  cells->span = 2;
}

/* The candidate ranges of cells (vf_grid_cells_of). A block's four runs are returned all
 * four, empty or not: a branch on emptiness would mispredict, an empty range costs a
 * caller nothing. */
static inline int vf_grid_ranges_of(const vf_grid_lookup *lk, const vf_grid_cells *cells,
                                    vf_index_range out[VF_HASHGRID_MAX_RANGES]) {
  if (cells->span != 2) return vf_grid_ranges_general(lk, cells, out);
  for (int k = 0; k < 4; k++) {
    uint32_t b = cells->bucket[k];
    out[k] = (vf_index_range){lk->cell_start[b], lk->cell_start[(size_t)b + 2]};
  }
  return 4;
}

/* The sorted points that candidate ranges refer to (vf_hashgrid_count of them), their
 * indices in the caller's array; NULL after vf_hashgrid_release_points. */
const vf_grid_point *vf_hashgrid_points(const vf_hashgrid *grid);

/* Number of points indexed by the last build (the finite ones). */
uint32_t vf_hashgrid_count(const vf_hashgrid *grid);

/* The sorted points for a caller that reads them in place and replaces their index fields
 * by data of its own, once it has read them (vertex merging keeps each light vertex's
 * path length there: a second array of positions in the same order would cost 16 bytes
 * per point at the peak of an iteration's memory). VF_HASHGRID_POINT_PAD zeroed points
 * follow the last, so that a reader may run past the end of a range; the array is on
 * 2 MiB pages where the kernel has them. Until the next build the grid reads the points no
 * more: candidate ranges stay valid (they read only the cell table), while
 * vf_hashgrid_points is NULL and vf_hashgrid_query visits nothing. */
#define VF_HASHGRID_POINT_PAD 8u
vf_grid_point *vf_hashgrid_points_writable(vf_hashgrid *grid);

/* Gives the sorted points' pages back to the kernel until the next build, for a caller
 * that is done with them (their contents read as zeros), with the same consequences. */
void vf_hashgrid_release_points(vf_hashgrid *grid);

/* Calls visit(ctx, i) for every point i with |p_i - q|^2 <= radius^2. */
void vf_hashgrid_query(const vf_hashgrid *grid, vf_vec3 q, void (*visit)(void *ctx, uint32_t i), void *ctx);

#endif
