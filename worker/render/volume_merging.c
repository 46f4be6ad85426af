/* Vertex merging in participating media: volume_merging.h. */
#include "volume_merging.h"

#include "../../common/error.h"
#include "vertex_merging.h"
#include "wavefront.h"

#include <math.h>

#include <stdlib.h>

int vf_volume_merging_build(vf_vcm *v) {
  uint32_t n = 0;
  for (uint32_t c = 0; c < v->num_chunks; c++)
    for (uint32_t i = 0; i < v->chunks[c].num_vertices; i++) n += vertex_in_medium(&v->chunks[c].vertices[i]);
  if (n > v->medium_photon_capacity) {
    free(v->medium_photons);
    v->medium_photons = malloc((size_t)n * sizeof *v->medium_photons);
    v->medium_photon_capacity = v->medium_photons ? n : 0;
    if (v->medium_photons == NULL) return VF_ENOMEM;
  }
  uint32_t k = 0;
  for (uint32_t c = 0; c < v->num_chunks; c++)
    for (uint32_t i = 0; i < v->chunks[c].num_vertices; i++) {
      const light_vertex *lv = &v->chunks[c].vertices[i];
      if (!vertex_in_medium(lv)) continue;
      v->medium_photons[k++] = (medium_photon){lv->position, lv->throughput, lv->fix, lv->mis, lv->at.point.primitive,
                                               vertex_path_length(lv), c << v->chunk_shift | i};
    }
  v->num_medium_photons = n;
  if (v->volume_grid == NULL) {
    int err = vf_hashgrid_create(&v->volume_grid);
    if (err != VF_OK) return err;
  }
  if (n == 0) return VF_OK;
  return vf_hashgrid_build(v->volume_grid, v->medium_photons, sizeof(medium_photon), n, v->merge.radius, v->pool);
}

/* 1 / ((4/3) pi r^3 n_light): the ball's volume, for the light sub-paths of one iteration. */
static float normalization(const vf_vcm *v) {
  double r = v->radius_exact;
  return (float)(3.0 / (4.0 * M_PI * r * r * r * (double)v->merge.mis.light_paths));
}

/* Light vertex ph merged at the camera vertex of BSDF b and quantities cam, weighted, before
 * the normalisation. */
static vf_vec3 merge_one(const vf_vcm *v, const vf_bsdf *b, const vf_mis *cam, const medium_photon *ph) {
  float cos_camera, camera_pdf, camera_rev_pdf;
  vf_vec3 f = vf_bsdf_evaluate(b, ph->fix, &cos_camera, &camera_pdf, &camera_rev_pdf);
  if (vf_is_zero(f)) return f;
  float w = 1.0f; /* ppm merges unweighted */
  if (!v->t.ppm) {
    /* The reverse step is taken at the light vertex: its medium's Russian roulette. */
    camera_rev_pdf *= v->media[ph->medium].continuation / b->continuation;
    w = vf_mis_weight_merge_medium(&ph->mis, cam, &v->merge.mis, v->medium_merge, camera_pdf, camera_rev_pdf);
  }
  return vf_scale(vf_mul(f, ph->throughput), w);
}

vf_vec3 vf_volume_merging_estimate(const vf_vcm *v, const vf_bsdf *b, vf_vec3 position, const vf_mis *cam,
                                   int path_length) {
  vf_vec3 sum = vf_vec3_splat(0.0f);
  if (v->num_medium_photons == 0) return sum;
  vf_index_range ranges[VF_HASHGRID_MAX_RANGES];
  int num_ranges = vf_hashgrid_candidates(v->volume_grid, position, ranges);
  const vf_grid_point *points = vf_hashgrid_points(v->volume_grid);
  for (int r = 0; r < num_ranges; r++)
    for (uint32_t j = ranges[r].begin; j < ranges[r].end; j++) {
      const vf_grid_point *p = &points[j];
      if (!vf_vertex_merging_within(v->merge.radius_sq, p->x, p->y, p->z, position)) continue;
      const medium_photon *ph = &v->medium_photons[p->index];
      if (ph->path_length + path_length > v->settings.max_path_length) continue;
      sum = vf_add(sum, merge_one(v, b, cam, ph));
    }
  return vf_scale(sum, normalization(v));
}

vf_vec3 vf_volume_merging_one(const vf_vcm *v, const vf_bsdf *b, const vf_mis *cam, uint32_t k) {
  return vf_scale(merge_one(v, b, cam, &v->medium_photons[k]), normalization(v));
}

void vf_volume_merging_destroy(vf_vcm *v) {
  vf_hashgrid_destroy(v->volume_grid);
  free(v->medium_photons);
}
