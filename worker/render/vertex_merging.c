/* Vertex merging (vertex_merging.h): phase 2, the grid and the light vertices copied into
 * its order; then the reference query, as SmallVCM writes its range query, and the choice
 * of the implementation a tile's queries run with.
 *
 * The reference is the definition of a query's result: it reads as the estimator does,
 * one candidate at a time, and waits out each cache miss in turn. The renderer runs the
 * fast path of merge_pipeline.c instead, which computes the same bits; the reference
 * merges what the fast path does not keep (a query that could not be queued, or with more
 * hits than the pipeline holds), and is what tests/worker/render/test_vertex_merging.c holds the fast
 * path to. */
#include "vertex_merging.h"
#include "huge_pages.h"
#include "gathering_pass.h"
#include "merge_pipeline.h"

#include "../../common/error.h"

#include <stdlib.h>

/* ---------------------------------------------------------------------------------------- */
/* Phase 2: the grid                                                                         */

#define GATHER_CHUNK 16384u
#define GATHER_AHEAD 16u

/* Photons and merge points are on huge pages (huge_pages.h): queries read them at random,
 * and on small pages nearly every one of those reads would miss the TLB as well as the
 * cache. The grid's other arrays gained nothing from them, nor did the chunks' vertex
 * lists once aligned to the cache line (docs/BENCHMARKS.md, "Renderer throughput"). */

/* The light vertex the grid names `index` (vf_vcm.grid_shift). */
static const light_vertex *grid_vertex(const vf_vcm *v, uint32_t index) {
  return &v->grid_chunks[index >> v->grid_shift].vertices[index & ((1u << v->grid_shift) - 1u)];
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
    if (v->photon_source) v->photon_source[k] = points[k].path_length_shape;
    points[k].path_length_shape = lv->path_length_shape;
    if (__builtin_expect(vertex_in_medium(lv), 0)) {
      /* A light vertex in a medium does not merge with surface points: nothing merges
       * in media (the MIS quantities count no merging there). Its merge point takes the
       * longest path length, which every query refuses before reading further, and its
       * photon carries nothing. */
      points[k].path_length_shape = (1u << VERTEX_LENGTH_BITS) - 1u;
      v->photons[k] = (photon){vf_vec3_splat(0.0f), lv->fix, 0.0f, 0.0f};
      if (v->photon_c_vc) v->photon_c_vc[k] = 0.0f;
    } else if (v->photon_c_vc) {
      v->photons[k] = (photon){lv->throughput, lv->fix, lv->mis.d_vcm, lv->mis.c_vm};
      v->photon_c_vc[k] = lv->mis.c_vc;
    } else {
      v->photons[k] = (photon){lv->throughput, lv->fix, lv->mis.d_vcm, vf_mis_d_vm(&lv->mis, &v->merge.mis)};
    }
  }
}

int vf_vertex_merging_build_grid(vf_vcm *v, const light_chunk *chunks, unsigned shift) {
  v->grid_chunks = chunks;
  v->grid_shift = shift;
  for (uint32_t c = 0; c < v->num_chunks; c++)
    v->segments[c] = (vf_grid_segment){v->grid_chunks[c].vertices, v->grid_chunks[c].num_vertices, c << v->grid_shift};
  int err = vf_hashgrid_build_segments(v->grid, v->segments, v->num_chunks, sizeof(light_vertex), v->grid_radius,
                                       v->pool);
  if (err != VF_OK) return err;
  uint32_t n = vf_hashgrid_count(v->grid);
  int radius_free = vf_vcm_radii_vary(v); /* from the iteration a pilot's allocation arrives */
  if (n > v->photon_capacity || (radius_free && v->photon_c_vc == NULL && n > 0)) {
    /* Photons aligned to the line, so that each lies in one; old contents are not kept.
     * Slack as for the vertices. */
    size_t capacity = n + n / 8 < UINT32_MAX ? (size_t)(n + n / 8) : UINT32_MAX;
    free(v->photons);
    v->photons = vf_huge_alloc(capacity * sizeof(photon));
    v->photon_capacity = v->photons ? (uint32_t)capacity : 0;
    if (v->upg) {
      free(v->photon_source);
      v->photon_source = malloc(capacity * sizeof *v->photon_source);
      if (v->photon_source == NULL) v->photon_capacity = 0;
    }
    if (radius_free) {
      free(v->photon_c_vc);
      v->photon_c_vc = malloc(capacity * sizeof *v->photon_c_vc);
      if (v->photon_c_vc == NULL) v->photon_capacity = 0;
    }
    if (v->photon_capacity == 0) return VF_ENOMEM;
  }
  /* Borrowed from the grid until its next build; its pad past n reads as zeros, ignored. */
  v->merge_points = (merge_point *)vf_hashgrid_points_writable(v->grid);
  vf_pool_run(v->pool, (n + GATHER_CHUNK - 1) / GATHER_CHUNK, gather_task, v);
  return VF_OK;
}

/* Below this the copies keep their pages: for a small image, faulting them in again every
 * iteration would cost more than their memory is worth; for a large one, the memory
 * matters and zeroing the pages again is a small part of the iteration (docs/BENCHMARKS.md,
 * "Memory"). */
#define RELEASE_MIN_BYTES ((size_t)64 << 20)

void vf_vertex_merging_release(vf_vcm *v) {
  size_t n = vf_hashgrid_count(v->grid);
  if (n * (sizeof(photon) + sizeof(merge_point)) < RELEASE_MIN_BYTES) return;
  vf_huge_release(v->photons, n * sizeof(photon));
  vf_hashgrid_release_points(v->grid); /* the merge points */
  v->merge_points = NULL;
}

/* ---------------------------------------------------------------------------------------- */
/* Phase 3: the reference query                                                              */

vf_vec3 vf_vertex_merging_one(const vf_vcm *v, const vertex_merging_query *q, uint32_t k) {
  uint32_t length_shape = v->merge_points[k].path_length_shape;
  if ((int)(length_shape & ((1u << VERTEX_LENGTH_BITS) - 1u)) + q->path_length > v->settings.max_path_length)
    return vf_vec3_splat(0.0f);
  const photon *ph = &v->photons[k];
  float cos_camera, camera_pdf, camera_rev_pdf;
  vf_vec3 f = vf_bsdf_evaluate(&q->bsdf, ph->direction, &cos_camera, &camera_pdf, &camera_rev_pdf);
  if (vf_is_zero(f)) return f;
  float w = 1.0f; /* ppm merges unweighted */
  if (!v->t.ppm) {
    /* The reverse step is taken at the light vertex: its Russian roulette applies. */
    camera_rev_pdf *= v->shape_continuation[length_shape >> VERTEX_LENGTH_BITS] / q->bsdf.continuation;
    vf_mis light = vf_photon_mis(v, k);
    w = vf_mis_weight_merge(&light, &q->mis, &q->merge.mis, camera_pdf, camera_rev_pdf); /* eq. (38)-(39) */
  }
  return vf_scale(vf_mul(f, ph->throughput), w);
}

/* SmallVCM's range query: the grid hands out the candidate ranges of the cells around q
 * (every light vertex within the radius lies in one of them); each candidate within the
 * radius is merged, in the grid's order. */
vf_vec3 vf_vertex_merging_estimate(const vf_vcm *v, const vertex_merging_query *q) {
  vf_index_range ranges[VF_HASHGRID_MAX_RANGES];
  int num_ranges = vf_hashgrid_candidates(v->grid, q->position, ranges);
  vf_vec3 sum = vf_vec3_splat(0.0f);
  for (int r = 0; r < num_ranges; r++)
    for (uint32_t k = ranges[r].begin; k < ranges[r].end; k++) {
      const merge_point *p = &v->merge_points[k];
      if (vf_vertex_merging_within(q->merge.radius_sq, p->x, p->y, p->z, q->position))
        sum = vf_add(sum, vf_vertex_merging_one(v, q, k));
    }
  return vf_scale(sum, q->merge.vm_normalization); /* 1 / (pi r^2 n_light), eq. (20) */
}

void vf_vertex_merging_run_tile(vf_vcm *v, int thread, float *tile_rgb) {
  if (v->upg) {
    vf_gathering_pass_run_tile(v, thread, tile_rgb);
    return;
  }
#ifdef VF_MERGE_PIPELINE
  vf_merge_pipeline_run(v, thread, tile_rgb);
#else
  thread_scratch *ts = &v->scratch[thread];
  for (uint32_t i = 0; i < ts->num_queries; i++) {
    const vertex_merging_query *q = &ts->queries[i];
    vf_vec3 contrib = vf_mul(q->throughput, vf_vertex_merging_estimate(v, q));
    float *rgb = &tile_rgb[3 * (size_t)q->tile_pixel];
    rgb[0] += contrib.x;
    rgb[1] += contrib.y;
    rgb[2] += contrib.z;
  }
  ts->num_queries = 0;
#endif
}
