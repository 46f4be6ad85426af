/* A density grid made in code for the media tests (test_medium.c, test_upg_medium.c): a
 * smooth blob in [-1, 1]^3, 16^3 samples, to be tracked; the caller frees g->density and g. */
#ifndef VF_TEST_BLOB_GRID_H
#define VF_TEST_BLOB_GRID_H

#include "worker/render/medium.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>

static inline vf_density_grid *make_blob_grid(void) {
  vf_density_grid *g = calloc(1, sizeof *g);
  g->nx = g->ny = g->nz = 16;
  g->density = malloc(16 * 16 * 16 * sizeof(float));
  g->box_min = vf_vec3_make(-1.0f, -1.0f, -1.0f);
  g->box_max = vf_vec3_make(1.0f, 1.0f, 1.0f);
  g->max_density = 0.0f;
  for (uint32_t z = 0; z < 16; z++)
    for (uint32_t y = 0; y < 16; y++)
      for (uint32_t x = 0; x < 16; x++) {
        float px = (x + 0.5f) / 8.0f - 1.0f, py = (y + 0.5f) / 8.0f - 1.0f, pz = (z + 0.5f) / 8.0f - 1.0f;
        float d = 2.0f * expf(-2.0f * (px * px + py * py + pz * pz)) * (1.0f + 0.5f * sinf(5.0f * px));
        g->density[(z * 16 + y) * 16 + x] = d;
        if (d > g->max_density) g->max_density = d;
      }
  return g;
}

#endif
