/* Fixed-radius range search over light vertices for vertex merging: a hashed uniform grid
 * (thesis 004, section 2.4.9), rebuilt every iteration.
 *
 * The grid sorts point indices by hashed cell; a query visits the cells that can hold
 * points within the radius. The sorted order is a pure function of the points (a stable
 * sort by cell, ties by point index), so queries visit points in the same order whatever
 * the number of threads that built the grid: renders stay reproducible bit for bit. */
#ifndef VF_HASHGRID_H
#define VF_HASHGRID_H

#include "../common/pool.h"
#include "../common/vec3.h"

#include <stddef.h>
#include <stdint.h>

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

/* Builds over n points, positions read at base + i * stride (a vf_vec3 at offset 0 of each
 * record), for queries of the given radius. Reuses the grid's memory between builds.
 * Parallel over the pool's threads (pool NULL: serial). Non-finite points are left out.
 * On failure (VF_EINVAL for a bad radius, base or stride; VF_ENOMEM) the grid is empty. */
int vf_hashgrid_build(vf_hashgrid *grid, const void *base, size_t stride, uint32_t n, float radius,
                      vf_pool *pool);

/* The candidate ranges for a query at q: every point within the radius of q lies in one
 * of them (others may too: callers test the distance). Returns the number of ranges
 * written to out (<= VF_HASHGRID_MAX_RANGES), some of which may be empty. */
int vf_hashgrid_candidates(const vf_hashgrid *grid, vf_vec3 q, vf_index_range out[VF_HASHGRID_MAX_RANGES]);

/* The same in two steps, for callers that overlap the memory latency of many queries:
 * vf_hashgrid_cells computes the buckets of q and prefetches their table entries;
 * vf_hashgrid_ranges, called later, reads them. */
typedef struct {
  uint32_t bucket[VF_HASHGRID_MAX_RANGES];
  int count;
  int span; /* buckets that each entry of bucket[] starts: 2 for a query's 2x2x2 block, else 1 */
} vf_grid_cells;
void vf_hashgrid_cells(const vf_hashgrid *grid, vf_vec3 q, vf_grid_cells *cells);
int vf_hashgrid_ranges(const vf_hashgrid *grid, const vf_grid_cells *cells, vf_index_range out[VF_HASHGRID_MAX_RANGES]);

/* The sorted point indices that candidate ranges refer to. */
const uint32_t *vf_hashgrid_indices(const vf_hashgrid *grid);

/* The sorted points that candidate ranges refer to (vf_hashgrid_count of them). */
const vf_grid_point *vf_hashgrid_points(const vf_hashgrid *grid);

/* Number of points indexed by the last build (the finite ones). */
uint32_t vf_hashgrid_count(const vf_hashgrid *grid);

/* Calls visit(ctx, i) for every point i with |p_i - q|^2 <= radius^2. */
void vf_hashgrid_query(const vf_hashgrid *grid, vf_vec3 q, void (*visit)(void *ctx, uint32_t i), void *ctx);

#endif
