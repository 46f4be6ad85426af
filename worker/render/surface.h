/* What a point of a mesh gives its shading beyond the triangle itself: the interpolated
 * vertex normal with its normal map (shading normals), texture coordinates, and the
 * textured values of the material there (worker/scene/material.h slots, worker/scene/texture.h).
 *
 * The renderer sets up the BSDF of a hit or a stored light vertex from (shape, triangle,
 * barycentrics) through vf_surface_bsdf when vf_surface_interpolated says the shape
 * needs it; every other hit keeps the plain set-up of its material (worker/render/bsdf.h), so a
 * scene without vertex normals or textures runs the code it ran before they existed. */
#ifndef VF_SURFACE_H
#define VF_SURFACE_H

#include "../../common/vec3.h"
#include "bsdf.h"
#include "../scene/scene.h"

#include <stdint.h>

/* Whether hits on shape `sh` are shaded from their barycentrics: a mesh with vertex normals
 * or vertex colours, or a material with a texture. */
static inline int vf_surface_interpolated(const vf_scene *scene, const vf_shape *sh) {
  return sh->kind == VF_SHAPE_MESH && sh->material >= 0 &&
         (sh->normals != NULL || sh->colors != NULL || vf_material_textured(&scene->materials[sh->material]));
}

/* The unit geometric normal of triangle `prim` of mesh sh, by its winding (counter-clockwise
 * about it, as the emission and Embree's Ng): the zero vector for a degenerate triangle.
 * Hits on interpolated shapes take their normal from here, not from Embree, so that a
 * light vertex rebuilt from (triangle, barycentrics) has the bits its hit had. */
vf_vec3 vf_surface_triangle_normal(const vf_shape *sh, uint32_t prim);

/* The texture coordinates at barycentrics (u, v) of triangle prim (weights 1 - u - v, u, v
 * of its vertices 0, 1, 2, as Embree reports them): uv set 0 in st[0..1], set 1 in
 * st[2..3] (set 0's again when the shape has no second set); zeros without coordinates.
 * Each texture slot reads its set through its transform (material.h). */
void vf_surface_uv(const vf_shape *sh, uint32_t prim, float u, float v, float st[4]);

/* The material at that point: `base` with its textures applied (COLOR multiplies diffuse,
 * or base_color in the glTF model; ROUGHNESS_METALLIC roughness and metallic), each
 * textured value clamped to [0, 1] so the material stays energy-conserving. */
void vf_surface_material(const vf_scene *scene, const vf_material *base, const float st[4], vf_material *out);

/* The shading normal at the point (unit): the interpolated vertex normal (the geometric
 * normal ng without vertex normals), turned by the material's normal map in the tangent
 * frame of the vertex tangents or, without them, of the texture coordinates. */
vf_vec3 vf_surface_shading_normal(const vf_scene *scene, const vf_shape *sh, uint32_t prim, float u, float v,
                                  const float st[4], vf_vec3 ng);

/* The BSDF at barycentrics (u, v) of triangle prim of shape `shape` with geometric normal
 * ng, for a path arriving from world_fix: textured material, shading normal, lobes. `lobes`
 * are the untextured materials' (vf_bsdf_lobes_of, one per material): a textured point
 * takes its Russian-roulette probability from them, so that it is a function of the
 * material alone, which vertex merging reads for a light vertex without its textures
 * (worker/render/vertex_merging.c). Returns 0 where nothing scatters, as vf_bsdf_setup. */
int vf_surface_bsdf(vf_bsdf *b, const vf_scene *scene, const vf_bsdf_lobes *lobes, uint32_t shape, uint32_t prim,
                    float u, float v, vf_vec3 ng, vf_vec3 world_fix);

/* Prefetching, for a renderer with several hits in hand (a wavefront): the loads that
 * vf_surface_bsdf at triangle prim will make, started now and not waited for, so that the
 * cache misses of all the hits overlap rather than each stalling its own shading.
 * vf_surface_prefetch_vertices starts those of the vertex normals, texture coordinates and
 * tangents; vf_surface_prefetch_texels, called after it for the same hits, reads the
 * texture coordinates and starts those of the texels of the shading slots (colour,
 * roughness-metallic, normal map). Neither changes anything the renderer computes. */
void vf_surface_prefetch_vertices(const vf_shape *sh, uint32_t prim);
void vf_surface_prefetch_texels(const vf_scene *scene, const vf_shape *sh, uint32_t prim, float u, float v);

/* KHR_materials_clearcoat at barycentrics (u, v) of triangle prim of mesh sh, geometric normal
 * ng: *weight the material's clearcoat times its texture's R, *normal the coat's unit normal
 * (the interpolated vertex normal turned by the coat's own normal map), as vf_surface_bsdf
 * sets the coat up. For the coat over an emitter (worker/render/light.h). */
void vf_surface_coat(const vf_scene *scene, const vf_shape *sh, uint32_t prim, float u, float v, vf_vec3 ng,
                     float *weight, vf_vec3 *normal);

/* Coverage of the material of sh at barycentrics (u, v) of triangle prim: 1 where it is
 * opaque, 0 in a hole (coverage below alpha_cutoff), for alpha cut-outs. */
int vf_surface_covered(const vf_scene *scene, const vf_shape *sh, uint32_t prim, float u, float v);

/* The factor the EMISSION texture (and a cut-out hole: zero) applies to the shape's
 * emitted radiance at the point; 1 without them. */
vf_vec3 vf_surface_emission_factor(const vf_scene *scene, const vf_shape *sh, uint32_t prim, float u, float v);

#endif
