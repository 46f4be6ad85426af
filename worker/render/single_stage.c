/* The single-stage iteration of vcm: single_stage.h. */
#include "single_stage.h"

#include "../../common/clock.h"
#include "../../common/error.h"
#include "camera_pass.h"
#include "fused_pass.h"
#include "light_pass.h"
#include "vertex_merging.h"

#include <stdlib.h>
#include <string.h>

void vf_single_stage_keep_tile(vf_vcm *v, int thread, const camera_tile *tile) {
  light_chunk *k = &v->kept[tile->index];
  uint32_t n = v->chunks[tile->index].num_vertices;
  free(k->vertices);
  k->vertices = NULL;
  k->num_vertices = k->vertex_capacity = 0;
  k->out_of_memory = 0;
  if (n == 0) return;
  /* Aligned to the cache line as the light pass's lists are: the grid's gather reads one
   * vertex a line. */
  k->vertices = aligned_alloc(64, (size_t)n * sizeof(light_vertex));
  if (k->vertices == NULL) {
    k->out_of_memory = 1;
    return;
  }
  memcpy(k->vertices, v->scratch[thread].tile_vertices, (size_t)n * sizeof(light_vertex));
  k->num_vertices = k->vertex_capacity = n;
}

void vf_single_stage_trim(vf_vcm *v) {
  if (v->kept)
    for (uint32_t c = 0; c < v->num_chunks; c++) {
      free(v->kept[c].vertices);
      v->kept[c] = (light_chunk){0};
    }
  v->kept_valid = 0;
}

/* The light sub-paths of the iteration before, traced as that iteration's pass traced
 * them (light tracing included, so that every random number is drawn as there; its
 * splats are dropped), into the lists. */
static void previous_task(void *ctx, size_t task, int thread) {
  vf_vcm *v = ctx;
  camera_tile tile = vf_camera_pass_tile(v, (uint32_t)task);
  vf_light_pass_tile(v, thread, &tile);
  vf_single_stage_keep_tile(v, thread, &tile);
}

static int trace_previous(vf_vcm *v) {
  uint64_t iteration = v->iteration;
  v->iteration = iteration - 1; /* wraps at 0: "iteration -1" has streams of its own */
  vf_pool_run(v->pool, v->num_chunks, previous_task, v);
  v->iteration = iteration;
  /* Its refused splats are not this iteration's samples. */
  for (int t = 0; t < vf_pool_threads(v->pool); t++) v->stats[t].nonfinite = 0;
  for (uint32_t c = 0; c < v->num_chunks; c++)
    if (v->kept[c].out_of_memory) return vf_error_set(VF_ENOMEM, "out of memory storing light vertices");
  return VF_OK;
}

/* The grid over the lists (the light vertices of the iteration before) with this
 * iteration's radius; the lists are then freed, the grid's copies holding what merging
 * reads. Sets num_vertices to the grid's count, which the camera pass tests. */
static int build_grid(vf_vcm *v) {
  uint64_t total = 0;
  uint32_t largest = 0;
  for (uint32_t c = 0; c < v->num_chunks; c++) {
    total += v->kept[c].num_vertices;
    if (v->kept[c].num_vertices > largest) largest = v->kept[c].num_vertices;
  }
  unsigned shift = 0;
  while (shift < 32 && ((uint64_t)1 << shift) < largest) shift++;
  if (shift >= 32 || ((uint64_t)v->num_chunks << shift) > (uint64_t)UINT32_MAX + 1)
    return vf_error_set(VF_ENOMEM, "%llu light vertices in one iteration: more than the grid can index",
                        (unsigned long long)total);
  v->num_vertices = (uint32_t)total;
  int err = VF_OK;
  if (total > 0) err = vf_vertex_merging_build_grid(v, v->kept, shift);
  for (uint32_t c = 0; c < v->num_chunks; c++) {
    free(v->kept[c].vertices);
    v->kept[c] = (light_chunk){0};
  }
  v->kept_valid = 0;
  if (err != VF_OK) v->num_vertices = 0;
  return err;
}

int vf_single_stage_iteration(vf_vcm *v, vf_vcm_stats *stats) {
  int threads = vf_pool_threads(v->pool);
  double t0 = vf_seconds_now();
  int err;
  if (!(v->kept_valid && v->kept_iteration == v->iteration - 1)) {
    vf_single_stage_trim(v);
    if ((err = trace_previous(v)) != VF_OK) return err;
  }
  double t1 = vf_seconds_now();
  if ((err = build_grid(v)) != VF_OK) return err;
  double t2 = vf_seconds_now();
  for (int t = 0; t < threads; t++) v->stats[t].light_seconds = 0.0;
  vf_fused_pass_run(v);
  double t3 = vf_seconds_now();
  for (uint32_t c = 0; c < v->num_chunks; c++)
    if (v->kept[c].out_of_memory) {
      vf_single_stage_trim(v);
      return vf_error_set(VF_ENOMEM, "out of memory storing light vertices");
    }
  v->kept_valid = 1;
  v->kept_iteration = v->iteration;
  if ((err = vf_light_pass_finish(v)) != VF_OK) return err;
  vf_vertex_merging_release(v);
  double t4 = vf_seconds_now(), light = 0.0;
  for (int t = 0; t < threads; t++) light += v->stats[t].light_seconds;
  light /= threads; /* the tiles' light sub-paths, as a share of the pass's wall time */
  if (light > t3 - t2) light = t3 - t2;
  stats->light_seconds += (t1 - t0) + light + (t4 - t3);
  stats->grid_seconds += t2 - t1;
  stats->camera_seconds += t3 - t2 - light;
  return VF_OK;
}
