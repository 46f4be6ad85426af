/* Shading of mesh points from their barycentrics: worker/render/surface.h. */
#include "surface.h"

#include "texture_lookup.h"

#include <math.h>
#include <string.h>

static vf_vec3 vertex3(const float *a, uint32_t i) { return vf_vec3_make(a[3 * (size_t)i], a[3 * (size_t)i + 1], a[3 * (size_t)i + 2]); }

vf_vec3 vf_surface_triangle_normal(const vf_shape *sh, uint32_t prim) {
  const uint32_t *tri = &sh->indices[3 * (size_t)prim];
  vf_vec3 p0 = vertex3(sh->positions, tri[0]), p1 = vertex3(sh->positions, tri[1]), p2 = vertex3(sh->positions, tri[2]);
  vf_vec3 n = vf_cross(vf_sub(p1, p0), vf_sub(p2, p0));
  float len = vf_length(n);
  return len > 0.0f ? vf_scale(n, 1.0f / len) : vf_vec3_splat(0.0f);
}

static void interpolate_uv(const float *uvs, const uint32_t *tri, float u, float v, float st[2]) {
  const float *a = &uvs[2 * (size_t)tri[0]], *b = &uvs[2 * (size_t)tri[1]], *c = &uvs[2 * (size_t)tri[2]];
  float w = 1.0f - u - v;
  st[0] = w * a[0] + u * b[0] + v * c[0];
  st[1] = w * a[1] + u * b[1] + v * c[1];
}

void vf_surface_uv(const vf_shape *sh, uint32_t prim, float u, float v, float st[4]) {
  st[0] = st[1] = st[2] = st[3] = 0.0f;
  if (sh->uvs == NULL) return;
  const uint32_t *tri = &sh->indices[3 * (size_t)prim];
  interpolate_uv(sh->uvs, tri, u, v, st);
  if (sh->uvs1 != NULL) interpolate_uv(sh->uvs1, tri, u, v, st + 2);
  else st[2] = st[0], st[3] = st[1];
}

/* Where slot ts reads: its uv set, through its KHR_texture_transform. */
static void slot_st(const vf_texture_slot *ts, const float st[4], float out[2]) {
  const float *in = ts->uv_set == 1 ? st + 2 : st;
  if (!ts->has_transform) {
    out[0] = in[0], out[1] = in[1];
    return;
  }
  const float *m = ts->transform;
  out[0] = m[0] * in[0] + m[1] * in[1] + m[2];
  out[1] = m[3] * in[0] + m[4] * in[1] + m[5];
}

/* RGBA of a material's slot at st; NULL when the slot has no texture. */
static const float *slot_lookup(const vf_scene *scene, const vf_material *m, int slot, int srgb, const float st[4],
                                float out[4]) {
  const vf_texture_slot *ts = &m->textures[slot];
  if (ts->texture == 0) return NULL;
  float at[2];
  slot_st(ts, st, at);
  vf_texture_lookup(&scene->textures[ts->texture - 1], at[0], at[1], ts->wrap_s, ts->wrap_t, srgb, out);
  return out;
}

static float unit_clamp(float x) { return x > 0.0f ? (x < 1.0f ? x : 1.0f) : 0.0f; }

static vf_vec3 scale_clamped(vf_vec3 c, const float t[4]) {
  return vf_vec3_make(unit_clamp(c.x * t[0]), unit_clamp(c.y * t[1]), unit_clamp(c.z * t[2]));
}

void vf_surface_material(const vf_scene *scene, const vf_material *base, const float st[4], vf_material *out) {
  *out = *base;
  float t[4];
  if (slot_lookup(scene, base, VF_TEXTURE_COLOR, 1, st, t)) {
    if (base->gltf)
      out->base_color = scale_clamped(base->base_color, t);
    else
      out->diffuse = scale_clamped(base->diffuse, t);
  }
  if (slot_lookup(scene, base, VF_TEXTURE_ROUGHNESS_METALLIC, 0, st, t)) {
    out->roughness = unit_clamp(base->roughness * t[1]);
    out->metallic = unit_clamp(base->metallic * t[2]);
  }
  /* KHR_materials_specular: specularTexture's alpha scales specular, specularColorTexture's
   * RGB the F0 colour (min(F0 colour, 1) is taken in bsdf.c). */
  if (slot_lookup(scene, base, VF_TEXTURE_SPECULAR, 0, st, t)) out->specular = unit_clamp(base->specular * t[3]);
  if (slot_lookup(scene, base, VF_TEXTURE_SPECULAR_COLOR, 1, st, t))
    out->specular_f0 = vf_vec3_make(fmaxf(base->specular_f0.x * t[0], 0.0f), fmaxf(base->specular_f0.y * t[1], 0.0f),
                                    fmaxf(base->specular_f0.z * t[2], 0.0f));
  /* KHR_materials_clearcoat: R of clearcoatTexture, G of clearcoatRoughnessTexture;
   * KHR_materials_sheen: RGB of sheenColorTexture (sRGB), A of sheenRoughnessTexture. */
  if (slot_lookup(scene, base, VF_TEXTURE_CLEARCOAT, 0, st, t)) out->clearcoat = unit_clamp(base->clearcoat * t[0]);
  if (slot_lookup(scene, base, VF_TEXTURE_CLEARCOAT_ROUGHNESS, 0, st, t))
    out->clearcoat_roughness = unit_clamp(base->clearcoat_roughness * t[1]);
  if (slot_lookup(scene, base, VF_TEXTURE_SHEEN_COLOR, 1, st, t))
    out->sheen_color = scale_clamped(base->sheen_color, t);
  if (slot_lookup(scene, base, VF_TEXTURE_SHEEN_ROUGHNESS, 0, st, t))
    out->sheen_roughness = unit_clamp(base->sheen_roughness * t[3]);
}

/* The tangent of the normal map's frame at the point: the vertex tangents interpolated, or
 * the direction of increasing s on the triangle; *sign is the bitangent's handedness (+1:
 * the bitangent cross(n, tangent) points towards decreasing t, "up" in the image, which is
 * where a normal map's green channel points). 0 when the triangle has no usable frame. */
static int tangent_at(const vf_shape *sh, uint32_t prim, float u, float v, vf_vec3 n, vf_vec3 *tangent, float *sign) {
  const uint32_t *tri = &sh->indices[3 * (size_t)prim];
  vf_vec3 t;
  if (sh->tangents != NULL) {
    const float *a = &sh->tangents[4 * (size_t)tri[0]], *b = &sh->tangents[4 * (size_t)tri[1]],
                *c = &sh->tangents[4 * (size_t)tri[2]];
    float w = 1.0f - u - v;
    t = vf_vec3_make(w * a[0] + u * b[0] + v * c[0], w * a[1] + u * b[1] + v * c[1], w * a[2] + u * b[2] + v * c[2]);
    *sign = a[3] < 0.0f ? -1.0f : 1.0f;
  } else {
    if (sh->uvs == NULL) return 0;
    vf_vec3 p0 = vertex3(sh->positions, tri[0]), p1 = vertex3(sh->positions, tri[1]), p2 = vertex3(sh->positions, tri[2]);
    const float *a = &sh->uvs[2 * (size_t)tri[0]], *b = &sh->uvs[2 * (size_t)tri[1]], *c = &sh->uvs[2 * (size_t)tri[2]];
    float ds1 = b[0] - a[0], dt1 = b[1] - a[1], ds2 = c[0] - a[0], dt2 = c[1] - a[1];
    float det = ds1 * dt2 - ds2 * dt1;
    if (!(fabsf(det) > 0.0f)) return 0;
    vf_vec3 e1 = vf_sub(p1, p0), e2 = vf_sub(p2, p0);
    /* dp/ds and dp/dt from p1 - p0 = ds1 dp/ds + dt1 dp/dt, p2 - p0 likewise. */
    t = vf_scale(vf_sub(vf_scale(e1, dt2), vf_scale(e2, dt1)), 1.0f / det);
    vf_vec3 dpdt = vf_scale(vf_sub(vf_scale(e2, ds1), vf_scale(e1, ds2)), 1.0f / det);
    *sign = vf_dot(vf_cross(n, t), dpdt) > 0.0f ? -1.0f : 1.0f;
  }
  /* Gram-Schmidt against the normal. */
  t = vf_sub(t, vf_scale(n, vf_dot(n, t)));
  float len = vf_length(t);
  if (!(len > 0.0f) || !isfinite(len)) return 0;
  *tangent = vf_scale(t, 1.0f / len);
  return 1;
}

/* The interpolated normal turned by the normal map of slot `slot`, scaled by `scale`. */
static vf_vec3 mapped_normal(const vf_scene *scene, const vf_shape *sh, uint32_t prim, float u, float v,
                             const float st[4], vf_vec3 ng, int slot, float scale) {
  vf_vec3 n = ng;
  if (sh->normals != NULL) {
    const uint32_t *tri = &sh->indices[3 * (size_t)prim];
    float w = 1.0f - u - v;
    vf_vec3 s = vf_add(vf_add(vf_scale(vertex3(sh->normals, tri[0]), w), vf_scale(vertex3(sh->normals, tri[1]), u)),
                       vf_scale(vertex3(sh->normals, tri[2]), v));
    float len = vf_length(s);
    if (len > 0.0f && isfinite(len)) n = vf_scale(s, 1.0f / len);
  }
  const vf_material *m = &scene->materials[sh->material];
  float texel[4];
  vf_vec3 tangent;
  float sign;
  if (slot_lookup(scene, m, slot, 0, st, texel) && tangent_at(sh, prim, u, v, n, &tangent, &sign)) {
    vf_vec3 bitangent = vf_scale(vf_cross(n, tangent), sign);
    float x = (2.0f * texel[0] - 1.0f) * scale, y = (2.0f * texel[1] - 1.0f) * scale;
    float z = 2.0f * texel[2] - 1.0f;
    vf_vec3 mapped = vf_add(vf_add(vf_scale(tangent, x), vf_scale(bitangent, y)), vf_scale(n, z));
    float len = vf_length(mapped);
    if (len > 0.0f && isfinite(len) && z > 0.0f) n = vf_scale(mapped, 1.0f / len);
  }
  return n;
}

vf_vec3 vf_surface_shading_normal(const vf_scene *scene, const vf_shape *sh, uint32_t prim, float u, float v,
                                  const float st[4], vf_vec3 ng) {
  return mapped_normal(scene, sh, prim, u, v, st, ng, VF_TEXTURE_NORMAL, scene->materials[sh->material].normal_scale);
}

int vf_surface_bsdf(vf_bsdf *b, const vf_scene *scene, const vf_bsdf_lobes *lobes, uint32_t shape, uint32_t prim,
                    float u, float v, vf_vec3 ng, vf_vec3 world_fix) {
  const vf_shape *sh = &scene->shapes[shape];
  const vf_material *m = &scene->materials[sh->material];
  float st[4];
  vf_surface_uv(sh, prim, u, v, st);
  vf_vec3 ns = vf_surface_shading_normal(scene, sh, prim, u, v, st, ng);
  const vf_bsdf_lobes *l = &lobes[sh->material];
  vf_material textured;
  vf_bsdf_lobes here;
  const vf_material *values = m;
  if (vf_material_textured(m) || sh->colors != NULL) {
    vf_surface_material(scene, m, st, &textured);
    if (sh->colors != NULL) { /* COLOR_0 multiplies the base colour (glTF 2.0, 3.7.2.1), or the diffuse albedo */
      const uint32_t *tri = &sh->indices[3 * (size_t)prim];
      float w = 1.0f - u - v;
      vf_vec3 col = vf_add(vf_add(vf_scale(vertex3(sh->colors, tri[0]), w), vf_scale(vertex3(sh->colors, tri[1]), u)),
                           vf_scale(vertex3(sh->colors, tri[2]), v));
      if (m->gltf) textured.base_color = vf_mul(textured.base_color, col);
      else textured.diffuse = vf_mul(textured.diffuse, col);
    }
    vf_bsdf_lobes_of(&textured, &here);
    here.continuation = l->continuation; /* a function of the material alone: see surface.h */
    here.black = here.black || !(here.continuation > 0.0f);
    values = &textured;
    l = &here;
  }
  int ok = vf_bsdf_setup_shading(b, values, l, ng, ns, world_fix);
  /* KHR_materials_clearcoat: the coat's normal is the mesh's, or its own normal map's, never
   * the base's normal map. */
  if (ok && b->layered && b->coat_weight > 0.0f &&
      (m->textures[VF_TEXTURE_NORMAL].texture != 0 || m->textures[VF_TEXTURE_CLEARCOAT_NORMAL].texture != 0))
    vf_bsdf_set_coat_normal(b, mapped_normal(scene, sh, prim, u, v, st, ng, VF_TEXTURE_CLEARCOAT_NORMAL,
                                             m->clearcoat_normal_scale),
                            world_fix);
  b->material = m; /* the untextured fields are the same; the textured ones were copied */
  return ok;
}

void vf_surface_coat(const vf_scene *scene, const vf_shape *sh, uint32_t prim, float u, float v, vf_vec3 ng,
                     float *weight, vf_vec3 *normal) {
  const vf_material *m = &scene->materials[sh->material];
  float st[4], t[4];
  vf_surface_uv(sh, prim, u, v, st);
  *weight = m->clearcoat;
  if (slot_lookup(scene, m, VF_TEXTURE_CLEARCOAT, 0, st, t)) *weight = unit_clamp(m->clearcoat * t[0]);
  *normal = mapped_normal(scene, sh, prim, u, v, st, ng, VF_TEXTURE_CLEARCOAT_NORMAL, m->clearcoat_normal_scale);
}

void vf_surface_prefetch_vertices(const vf_shape *sh, uint32_t prim) {
  const uint32_t *tri = &sh->indices[3 * (size_t)prim];
  for (int k = 0; k < 3; k++) {
    size_t i = tri[k];
    if (sh->normals != NULL) __builtin_prefetch(&sh->normals[3 * i]);
    if (sh->uvs != NULL) __builtin_prefetch(&sh->uvs[2 * i]);
    if (sh->tangents != NULL) __builtin_prefetch(&sh->tangents[4 * i]);
  }
}

void vf_surface_prefetch_texels(const vf_scene *scene, const vf_shape *sh, uint32_t prim, float u, float v) {
  static const int slots[] = {VF_TEXTURE_COLOR, VF_TEXTURE_ROUGHNESS_METALLIC, VF_TEXTURE_NORMAL};
  const vf_material *m = &scene->materials[sh->material];
  float st[4], at[2];
  int have_st = 0;
  for (size_t k = 0; k < sizeof slots / sizeof slots[0]; k++) {
    const vf_texture_slot *ts = &m->textures[slots[k]];
    if (ts->texture == 0) continue;
    if (!have_st) {
      vf_surface_uv(sh, prim, u, v, st);
      have_st = 1;
    }
    slot_st(ts, st, at);
    vf_texture_prefetch(&scene->textures[ts->texture - 1], at[0], at[1], ts->wrap_s, ts->wrap_t);
  }
}

int vf_surface_covered(const vf_scene *scene, const vf_shape *sh, uint32_t prim, float u, float v) {
  const vf_material *m = &scene->materials[sh->material];
  if (!(m->alpha_cutoff > 0.0f)) return 1;
  float coverage = m->alpha, st[4], at[2];
  const vf_texture_slot *ts = &m->textures[VF_TEXTURE_ALPHA];
  if (ts->texture != 0) {
    vf_surface_uv(sh, prim, u, v, st);
    slot_st(ts, st, at);
    coverage *= vf_texture_lookup_channel(&scene->textures[ts->texture - 1], at[0], at[1], ts->wrap_s, ts->wrap_t,
                                          m->alpha_channel & 3);
  }
  return coverage >= m->alpha_cutoff;
}

vf_vec3 vf_surface_emission_factor(const vf_scene *scene, const vf_shape *sh, uint32_t prim, float u, float v) {
  if (sh->kind != VF_SHAPE_MESH) return vf_vec3_splat(1.0f);
  const vf_material *m = &scene->materials[sh->material];
  if (!vf_surface_covered(scene, sh, prim, u, v)) return vf_vec3_splat(0.0f);
  float st[4], t[4];
  vf_surface_uv(sh, prim, u, v, st);
  if (!slot_lookup(scene, m, VF_TEXTURE_EMISSION, 1, st, t)) return vf_vec3_splat(1.0f);
  return vf_vec3_make(t[0], t[1], t[2]);
}
