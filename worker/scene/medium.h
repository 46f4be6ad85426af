/* Participating media: what fills the space between surfaces (docs/SCENES.md, "Media").
 *
 * A medium absorbs and scatters light as it travels: per unit length and per RGB channel,
 * sigma_a of it is absorbed and sigma_s scattered, with a Henyey-Greenstein phase function
 * of asymmetry g in (-1, 1) (g > 0 scatters forwards). A homogeneous medium has the same
 * coefficients everywhere; a heterogeneous one scales both by a density in [0, inf) read
 * from a grid (vf_density_grid), zero outside the grid's box.
 *
 * Where the media are: the scene's own medium (vf_scene.medium, "the air": fog that fills
 * everything) and the interiors of closed shapes (vf_shape.interior). A shape with a medium
 * interface bounds a region: a ray that crosses its surface inwards (against the outward
 * normal) enters the shape's interior medium, one that crosses it outwards enters its
 * exterior (vf_shape.exterior: the interior of the innermost interface shape that contains
 * it, else the scene's medium). A shape without an interface changes no medium. Shapes with
 * an interface are closed (every edge shared by two triangles, consistently wound; spheres),
 * which the loader checks. A shape may have no material (vf_shape.material < 0, only with
 * an interface): its surface is index-matched, every ray passes straight through it, and it
 * only says where its interior medium is (fog in a box, smoke in its bounding volume).
 *
 * Pure data, like the rest of the scene model: the renderer's sampling and tracking live in
 * worker/render/medium.h. */
#ifndef VF_MEDIUM_H
#define VF_MEDIUM_H

#include "../../common/vec3.h"

#include <stdint.h>

/* A density grid: nx * ny * nz samples (x fastest, then y, then z) of a non-negative
 * density, at the centres of the cells of a world-space axis-aligned box divided evenly.
 * Density between samples is trilinear; outside the box it is zero (and half-way from the
 * outer samples to the box's faces the nearest sample's, clamped). */
typedef struct {
  uint32_t nx, ny, nz;
  float *density;       /* owned, nx * ny * nz, each finite and >= 0 */
  vf_vec3 box_min, box_max; /* world space, box_min < box_max in each axis */
  float max_density;    /* the largest sample: a majorant of the density everywhere */
  char source[512];     /* the file it came from ("" for a grid made in code); not hashed */
} vf_density_grid;

/* The largest grid a scene may load: samples and bytes of its densities. docs/SCENES.md
 * states it. */
#define VF_GRID_MAX_SAMPLES (512u * 512u * 512u)

typedef struct {
  char name[64];        /* the scene file's name for it; not hashed */
  vf_vec3 sigma_a;      /* absorption per unit length, >= 0 per channel */
  vf_vec3 sigma_s;      /* scattering per unit length, >= 0 per channel */
  float g;              /* Henyey-Greenstein asymmetry, in (-1, 1) */
  vf_density_grid *grid; /* owned; NULL: homogeneous */
} vf_medium;

/* Frees a medium's grid (not the medium itself, which lives in the scene's array). */
void vf_medium_release(vf_medium *medium);

#endif
