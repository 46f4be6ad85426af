/* Light sources as the VCM estimator sees them (tech. rep. sections 4-5): each can emit a
 * light sub-path's first vertex (emit), be sampled from a surface point for next-event
 * estimation (illuminate), and report the radiance a camera ray finds on it (radiance).
 * Every call returns the densities the MIS weights need:
 *   emission_pdf_w  density of emitting that (position, direction) from the light: area
 *                   density times solid-angle density (for infinite lights: the direction's
 *                   solid-angle density times the density on the scene's disk);
 *   direct_pdf_a    density of picking that position by illuminate, in area measure (for
 *                   infinite lights: of picking the direction, in solid angle; 1 for delta
 *                   lights, which illuminate picks deterministically);
 *   direct_pdf_w    direct_pdf_a converted to solid angle at the receiving point.
 * None of them include the light-selection probability (vf_light.pick_probability).
 *
 * Kinds: area lights (emissive triangle meshes and spheres, one-sided, cosine emission),
 * point lights (delta position), spot lights (delta position, emitting into a cone with
 * KHR_lights_punctual's smooth falloff, sampled uniformly over the cone's solid angle),
 * directional lights (delta direction, infinite), and one
 * environment light (infinite) that unites the constant background and the
 * latitude-longitude map: radiance(d) = background + scale * map(d), importance sampled by
 * the map's luminance when there is a map.
 *
 * An area light whose material has a clear coat (KHR_materials_clearcoat, "Emission": the
 * coat darkens what the surface beneath it emits) emits its radiance times
 * 1 - clearcoat F_c(|n_c . w|) towards w, F_c Schlick's of F0 0.04 (worker/render/bsdf.h's
 * T, the coat's one passage), clearcoat and the coat's normal n_c those of its BSDF at the
 * point (vf_light_coat). Every value these functions report includes the factor; no
 * density changes (emission still samples the cosine, so a light sub-path's first weight
 * carries the factor of its direction). Light selection by power ignores the coat. */
#ifndef VF_LIGHT_H
#define VF_LIGHT_H

#include "../../common/vec3.h"
#include "microfacet.h"
#include "sampling.h"
#include "../scene/scene.h"

#include <math.h>
#include <stdint.h>

typedef enum {
  VF_LIGHT_AREA_MESH,
  VF_LIGHT_AREA_SPHERE,
  VF_LIGHT_POINT,
  VF_LIGHT_SPOT,
  VF_LIGHT_DIRECTIONAL,
  VF_LIGHT_ENVIRONMENT
} vf_light_kind;

typedef struct vf_envmap vf_envmap;

/* A triangle of an area mesh light as sampling reads it: its corners and unit normal in
 * one record, instead of an index and three vertex lookups and a cross product per sample. */
typedef struct {
  vf_vec3 a, b, c, normal;
} vf_light_triangle;

typedef struct {
  vf_light_kind kind;
  float pick_probability;
  vf_vec3 radiance;          /* area: Le; point: intensity; spot: intensity on the axis; directional: irradiance */
  const vf_shape *shape;     /* area lights; borrowed from the scene */
  float *triangle_cdf;       /* area meshes: cumulative triangle areas / total, owned */
  uint32_t *triangle_guide;  /* area meshes: its guide, num_triangles buckets (vf_cdf_guided), owned */
  vf_light_triangle *triangles; /* area meshes: per triangle, owned */
  float area, inv_area;
  vf_vec3 position;          /* point and spot */
  vf_vec3 direction;         /* directional: direction of travel; spot: its axis */
  vf_frame frame;            /* directional and spot: frame around direction */
  float cos_outer;           /* spot: cosine of the outer cone's half-angle; nothing beyond */
  float falloff_scale;       /* spot: 1 / (cos inner - cos outer), the falloff's slope in cos */
  float one_minus_cos_outer; /* spot: 1 - cos_outer, without cancellation for narrow cones */
  float cone_pdf_w;          /* spot: 1 / (2 pi (1 - cos_outer)), emission's solid-angle density */
  const vf_envmap *envmap;   /* environment: NULL for a constant background */
  int is_delta, is_finite;
  /* Area meshes whose material has an emission texture or a cut-out: radiance is then
   * `radiance` times vf_light_emission_factor at the point (worker/render/surface.h). */
  int textured;
  int coated;                /* area lights whose material has a clear coat (see the top) */
  const vf_scene *scene;     /* textured and coated lights: borrowed */
} vf_light;

/* A clear coat at a point of an area light: its weight (clearcoat, its texture applied;
 * 0: no coat) and its unit normal n_c (the sign does not matter). */
typedef struct {
  float weight;
  vf_vec3 normal;
} vf_light_coat;

/* The coat's transmittance towards unit direction dir: 1 - weight F_c(|n_c . dir|). */
static inline float vf_light_coat_transmit(const vf_light_coat *c, vf_vec3 dir) {
  float cos_c = fabsf(vf_dot(c->normal, dir));
  cos_c = cos_c < 1.0f ? cos_c : 1.0f;
  return 1.0f - c->weight * (VF_GLTF_DIELECTRIC_F0 + (1.0f - VF_GLTF_DIELECTRIC_F0) * vf_fresnel_schlick_weight(cos_c));
}

/* The coat of coated area light l at barycentrics (u, v) of triangle t (a sphere: at the
 * point of unit normal n, t, u and v unused); n is the point's unit geometric normal. */
vf_light_coat vf_light_coat_at(const vf_light *l, uint32_t t, float u, float v, vf_vec3 n);

typedef struct {
  vf_light *lights;
  int count;
  int *shape_light;          /* per scene shape: its light index, or -1 */
  int environment;           /* index of the environment light, or -1 */
  vf_vec3 scene_center;
  float scene_radius;
  float *pick_cdf;           /* count entries */
  vf_envmap *envmap;         /* owned */
} vf_lights;

/* Builds the lights of a scene, with selection probabilities half uniform and half in
 * proportion to estimated power (so neither a dim nearby light nor a bright sun starves). */
int vf_lights_create(const vf_scene *scene, vf_lights **out);
void vf_lights_destroy(vf_lights *lights);

/* Picks a light with one uniform number. Inline: it runs once per light sub-path and once
 * per light sample, and is a few instructions for a scene's handful of lights. */
static inline const vf_light *vf_lights_pick(const vf_lights *ls, float u) {
  int lo = 0, hi = ls->count - 1;
  while (lo < hi) {
    int mid = (lo + hi) / 2;
    if (ls->pick_cdf[mid] <= u) lo = mid + 1;
    else hi = mid;
  }
  return &ls->lights[lo];
}

/* First index i with cdf[i + 1] > u, for a cdf of n + 1 entries from 0 to 1. */
static inline int vf_cdf_search(const float *cdf, int n, float u) {
  int lo = 0, hi = n - 1;
  while (lo < hi) {
    int mid = (lo + hi) / 2;
    if (cdf[mid + 1] <= u) lo = mid + 1;
    else hi = mid;
  }
  return lo;
}

/* vf_cdf_search's answer for u in [0, 1], found by walking from index i: a step or two
 * when i is close to it. Walking back while cdf[i] > u ends at or before the answer (every
 * index after it has cdf[i] >= cdf[answer + 1] > u); walking on while cdf[i + 1] <= u then
 * ends on it. */
static inline int vf_cdf_walk(const float *cdf, int n, float u, int i) {
  while (i > 0 && cdf[i] > u) i--;
  while (i < n - 1 && cdf[i + 1] <= u) i++;
  return i;
}

/* Fills guide[0..m) for vf_cdf_guided over a cdf of n + 1 entries. */
void vf_cdf_guide(const float *cdf, int n, uint32_t *guide, int m);

/* vf_cdf_search's answer for u in [0, 1] through a guide of m buckets, guide[k] the answer
 * for u = k / m (vf_cdf_guide): one load, then a walk past the cdf entries in u's bucket,
 * n / m of them on average over uniform u. A binary search instead takes log2(n)
 * dependent loads: 15 of a 70 KB table for a mesh of 17688 triangles. */
static inline int vf_cdf_guided(const float *cdf, int n, const uint32_t *guide, int m, float u) {
  float x = u * (float)m;
  int k = x > 0.0f ? (x < (float)m ? (int)x : m - 1) : 0;
  return vf_cdf_walk(cdf, n, u, (int)guide[k]);
}

/* vf_cdf_search's answer for u in [0, 1] over a short cdf (n of a few entries), without a
 * branch on the data: the number of entries cdf[1..n-1] at most u, which for a
 * non-decreasing cdf is the last index i with cdf[i] <= u, the first with cdf[i + 1] > u.
 * A walk or a search there mispredicts a branch on every other sample: the quad light of
 * the Cornell box is two triangles. */
#define VF_CDF_SHORT 8
static inline int vf_cdf_count(const float *cdf, int n, float u) {
  int i = 0;
  for (int k = 1; k < n; k++) i += cdf[k] <= u;
  return i;
}

/* Picks a triangle of area mesh l in proportion to area with uniform number *u, and
 * replaces *u by its rescaling to [0, 1) within the chosen triangle's interval, a fresh
 * uniform number. The triangle is vf_cdf_search's over triangle_cdf, counted for a mesh of
 * a few triangles, else found through a guide of one bucket per triangle. */
static inline uint32_t vf_light_pick_triangle(const vf_light *l, float *u) {
  int n = (int)l->shape->num_triangles;
  int t = n <= VF_CDF_SHORT ? vf_cdf_count(l->triangle_cdf, n, *u)
                            : vf_cdf_guided(l->triangle_cdf, n, l->triangle_guide, n, *u);
  float lo = l->triangle_cdf[t], hi = l->triangle_cdf[t + 1];
  float rescaled = (*u - lo) / (hi - lo);
  /* fminf(rescaled, 0.99999994f) without its libm call (see vf_fmaxf_zero): the same value,
   * a NaN included. */
  *u = hi > lo ? (rescaled < 0.99999994f ? rescaled : 0.99999994f) : 0.5f;
  return (uint32_t)t;
}

/* Uniform point on a triangle of an area mesh. */
static inline vf_vec3 vf_light_triangle_point_at(const vf_light_triangle *tri, float u1, float u2, float *bu,
                                                  float *bv) {
  vf_sample_triangle(u1, u2, bu, bv);
  return vf_add(vf_add(vf_scale(tri->a, 1.0f - *bu - *bv), vf_scale(tri->b, *bu)), vf_scale(tri->c, *bv));
}

static inline vf_vec3 vf_light_triangle_point(const vf_light_triangle *tri, float u1, float u2) {
  float bu, bv;
  return vf_light_triangle_point_at(tri, u1, u2, &bu, &bv);
}

/* What a textured area light's texture and cut-out make of its radiance at barycentrics
 * (u, v) of triangle t (weights of its vertices b and c). */
vf_vec3 vf_light_emission_factor(const vf_light *l, uint32_t t, float u, float v);

/* What a textured or coated area light's texture, cut-out and coat make of its radiance
 * towards unit direction dir (away from the light) at barycentrics (u, v) of triangle t
 * (a sphere: at its point of unit normal n), n the point's unit geometric normal. */
vf_vec3 vf_light_emission_factor_toward(const vf_light *l, uint32_t t, float u, float v, vf_vec3 n, vf_vec3 dir);

/* What vf_light_illuminate reports for point p, with unit normal n, picked on area light l. */
static inline vf_vec3 vf_light_illuminate_area_point(const vf_light *l, vf_vec3 receiver, vf_vec3 p, vf_vec3 n,
                                                     vf_vec3 *dir_to_light, float *distance, vf_vec3 *light_point,
                                                     vf_vec3 *light_normal, float *direct_pdf_w,
                                                     float *emission_pdf_w, float *cos_at_light) {
  vf_vec3 d = vf_sub(p, receiver);
  float dist2 = vf_length_sq(d);
  float dist = sqrtf(dist2);
  d = vf_scale(d, 1.0f / dist);
  float cos_n = -vf_dot(n, d);
  if (!(cos_n > 1e-7f) || !(dist > 0.0f)) return vf_vec3_splat(0.0f);
  *dir_to_light = d;
  *distance = dist;
  *light_point = p;
  *light_normal = n;
  *direct_pdf_w = l->inv_area * dist2 / cos_n;
  *emission_pdf_w = l->inv_area * cos_n * VF_INV_PI;
  *cos_at_light = cos_n;
  return l->radiance;
}

/* vf_light_illuminate for any kind of light; vf_light_illuminate calls it for all but
 * area meshes. */
vf_vec3 vf_light_illuminate_any(const vf_lights *ls, const vf_light *l, vf_vec3 receiver, const float rnd[2],
                                vf_vec3 *dir_to_light, float *distance, vf_vec3 *light_point,
                                vf_vec3 *light_normal, float *direct_pdf_w, float *emission_pdf_w,
                                float *cos_at_light);

/* Samples the light from `receiver`. *distance is the distance to the sampled point (INFINITY
 * for infinite lights); *light_point is that point (area, point and spot lights).
 * Area meshes, the common light, are sampled inline: every camera vertex samples a light,
 * and out of line the receiver and the seven results went through memory. */
static inline vf_vec3 vf_light_illuminate(const vf_lights *ls, const vf_light *l, vf_vec3 receiver,
                                          const float rnd[2], vf_vec3 *dir_to_light, float *distance,
                                          vf_vec3 *light_point, vf_vec3 *light_normal, float *direct_pdf_w,
                                          float *emission_pdf_w, float *cos_at_light) {
  if (l->kind != VF_LIGHT_AREA_MESH)
    return vf_light_illuminate_any(ls, l, receiver, rnd, dir_to_light, distance, light_point, light_normal,
                                   direct_pdf_w, emission_pdf_w, cos_at_light);
  float u = rnd[0], bu, bv;
  uint32_t t = vf_light_pick_triangle(l, &u);
  const vf_light_triangle *tri = &l->triangles[t];
  vf_vec3 le = vf_light_illuminate_area_point(l, receiver, vf_light_triangle_point_at(tri, u, rnd[1], &bu, &bv),
                                              tri->normal, dir_to_light, distance, light_point, light_normal,
                                              direct_pdf_w, emission_pdf_w, cos_at_light);
  if (__builtin_expect(l->textured, 0) && !vf_is_zero(le)) le = vf_mul(le, vf_light_emission_factor(l, t, bu, bv));
  if (__builtin_expect(l->coated, 0) && !vf_is_zero(le)) {
    vf_light_coat coat = vf_light_coat_at(l, t, bu, bv, tri->normal);
    le = vf_scale(le, vf_light_coat_transmit(&coat, vf_neg(*dir_to_light)));
  }
  return le;
}

/* What vf_light_emit reports for point p, with unit normal n, picked on area light l, and
 * uniform numbers u1, u2 for the direction. */
static inline vf_vec3 vf_light_emit_area_point(const vf_light *l, vf_vec3 n, float u1, float u2, vf_vec3 *direction,
                                               vf_vec3 *normal, float *emission_pdf_w, float *direct_pdf_a,
                                               float *cos_light) {
  float pdf;
  vf_vec3 local = vf_sample_cosine_hemisphere(u1, u2, &pdf);
  vf_frame f = vf_frame_from_normal(n);
  *direction = vf_frame_to_world(&f, local);
  *normal = n;
  *emission_pdf_w = pdf * l->inv_area;
  *direct_pdf_a = l->inv_area;
  *cos_light = local.z;
  return vf_scale(l->radiance, local.z);
}

/* vf_light_emit for any kind of light; vf_light_emit calls it for all but area meshes. */
vf_vec3 vf_light_emit_any(const vf_lights *ls, const vf_light *l, const float rnd[4], vf_vec3 *position,
                          vf_vec3 *direction, vf_vec3 *normal, float *emission_pdf_w, float *direct_pdf_a,
                          float *cos_light, vf_light_coat *coat);

/* vf_light_emit, and the coat at the emitted point in *coat (weight 0 for a light without
 * one): the value returned includes the coat's factor towards the sampled direction, which
 * a connection from the same point in another direction replaces by its own. */
static inline vf_vec3 vf_light_emit_coated(const vf_lights *ls, const vf_light *l, const float rnd[4],
                                           vf_vec3 *position, vf_vec3 *direction, vf_vec3 *normal,
                                           float *emission_pdf_w, float *direct_pdf_a, float *cos_light,
                                           vf_light_coat *coat) {
  coat->weight = 0.0f;
  if (l->kind != VF_LIGHT_AREA_MESH)
    return vf_light_emit_any(ls, l, rnd, position, direction, normal, emission_pdf_w, direct_pdf_a, cos_light, coat);
  float u = rnd[0], bu, bv;
  uint32_t t = vf_light_pick_triangle(l, &u);
  const vf_light_triangle *tri = &l->triangles[t];
  *position = vf_light_triangle_point_at(tri, rnd[1], rnd[2], &bu, &bv);
  vf_vec3 energy = vf_light_emit_area_point(l, tri->normal, rnd[3], u, direction, normal, emission_pdf_w,
                                            direct_pdf_a, cos_light);
  if (__builtin_expect(l->textured, 0)) energy = vf_mul(energy, vf_light_emission_factor(l, t, bu, bv));
  if (__builtin_expect(l->coated, 0)) {
    *coat = vf_light_coat_at(l, t, bu, bv, tri->normal);
    energy = vf_scale(energy, vf_light_coat_transmit(coat, *direction));
  }
  return energy;
}

/* Emits the first vertex of a light sub-path with four uniform numbers. Area meshes are
 * handled inline, as in vf_light_illuminate. */
static inline vf_vec3 vf_light_emit(const vf_lights *ls, const vf_light *l, const float rnd[4], vf_vec3 *position,
                                    vf_vec3 *direction, vf_vec3 *normal, float *emission_pdf_w,
                                    float *direct_pdf_a, float *cos_light) {
  vf_light_coat coat;
  return vf_light_emit_coated(ls, l, rnd, position, direction, normal, emission_pdf_w, direct_pdf_a, cos_light,
                              &coat);
}

/* What a light's own point emits towards unit direction dir, relative to what vf_light_emit
 * returns there for its sampled direction: the factor (area lights: the cosine of dir
 * against the unit normal n; point lights: 1; spot lights: the falloff), 0 where it emits
 * nothing; *dir_pdf_w the emission's density of dir (vf_light_emit's emission_pdf_w over
 * its direct_pdf_a) and *cos_light its cosine. Area, point and spot lights: the lights
 * whose own point a connection can join (photon_gathering.h). */
float vf_light_emission_toward(const vf_light *l, vf_vec3 n, vf_vec3 dir, float *dir_pdf_w, float *cos_light);

/* Radiance of an area light hit at `point` with unit geometric normal `normal` by a ray of
 * direction ray_dir; zero from behind. A textured or coated light's radiance is this times
 * vf_light_emission_factor_toward at the hit's triangle and barycentrics. */
vf_vec3 vf_light_radiance_area(const vf_light *l, vf_vec3 ray_dir, vf_vec3 normal, float *direct_pdf_a,
                               float *emission_pdf_w);

/* Radiance of the environment seen along ray_dir (a ray that left the scene). */
vf_vec3 vf_light_radiance_environment(const vf_lights *ls, const vf_light *l, vf_vec3 ray_dir,
                                      float *direct_pdf_w, float *emission_pdf_w);

#endif
