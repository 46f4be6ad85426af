#include "light.h"

#include "../../common/error.h"
#include "sampling.h"
#include "surface.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Latitude-longitude environment: radiance per texel and a piecewise-constant 2D
 * distribution over (u, v) proportional to luminance times sin(theta), so that directions
 * are sampled in proportion to their contribution over the sphere. */
struct vf_envmap {
  int width, height;
  vf_vec3 *radiance;   /* background + scale * map, per texel */
  float *row_cdf;      /* height + 1 */
  float *column_cdf;   /* height rows of width + 1 */
  uint32_t *row_guide; /* height buckets (vf_cdf_guided) */
  uint32_t *column_guide; /* height rows of column_buckets */
  int column_buckets;  /* a quarter of the width: 1 byte a texel, a walk of 4 entries on average */
  float integral;      /* of the unnormalised density over [0,1]^2 */
  int rotated;         /* the scene's envmap_rotation applies */
  float rotation[3][3];
};

/* A world direction as the map's own (R^T d), and back (R d): a rotation keeps solid
 * angles, so densities need no Jacobian. */
static vf_vec3 map_of_world(const vf_envmap *e, vf_vec3 d) {
  if (!e->rotated) return d;
  const float(*r)[3] = e->rotation;
  return vf_vec3_make(r[0][0] * d.x + r[1][0] * d.y + r[2][0] * d.z, r[0][1] * d.x + r[1][1] * d.y + r[2][1] * d.z,
                      r[0][2] * d.x + r[1][2] * d.y + r[2][2] * d.z);
}

static vf_vec3 world_of_map(const vf_envmap *e, vf_vec3 d) {
  if (!e->rotated) return d;
  const float(*r)[3] = e->rotation;
  return vf_vec3_make(r[0][0] * d.x + r[0][1] * d.y + r[0][2] * d.z, r[1][0] * d.x + r[1][1] * d.y + r[1][2] * d.z,
                      r[2][0] * d.x + r[2][1] * d.y + r[2][2] * d.z);
}

static float triangle_area(const vf_shape *s, uint32_t t) {
  const uint32_t *i = &s->indices[3 * (size_t)t];
  const float *a = &s->positions[3 * (size_t)i[0]], *b = &s->positions[3 * (size_t)i[1]],
              *c = &s->positions[3 * (size_t)i[2]];
  vf_vec3 e1 = vf_vec3_make(b[0] - a[0], b[1] - a[1], b[2] - a[2]);
  vf_vec3 e2 = vf_vec3_make(c[0] - a[0], c[1] - a[1], c[2] - a[2]);
  return 0.5f * vf_length(vf_cross(e1, e2));
}

static vf_vec3 direction_of_uv(float u, float v) {
  float theta = v * VF_PI, phi = (u - 0.5f) * 2.0f * VF_PI;
  float st = sinf(theta);
  return vf_vec3_make(st * sinf(phi), cosf(theta), -st * cosf(phi));
}

static void uv_of_direction(vf_vec3 d, float *u, float *v) {
  *u = 0.5f + atan2f(d.x, -d.z) * (0.5f * VF_INV_PI);
  *v = acosf(fmaxf(-1.0f, fminf(1.0f, d.y))) * VF_INV_PI;
}

void vf_cdf_guide(const float *cdf, int n, uint32_t *guide, int m) {
  for (int k = 0; k < m; k++) guide[k] = (uint32_t)vf_cdf_search(cdf, n, (float)k / (float)m);
}

static void envmap_destroy(vf_envmap *e) {
  if (e == NULL) return;
  free(e->radiance);
  free(e->row_cdf);
  free(e->column_cdf);
  free(e->row_guide);
  free(e->column_guide);
  free(e);
}

static int envmap_create(const vf_scene *scene, vf_envmap **out) {
  const vf_image *img = &scene->envmap;
  vf_envmap *e = calloc(1, sizeof *e);
  if (e == NULL) return VF_ENOMEM;
  int w = img->width, h = img->height;
  e->width = w;
  e->height = h;
  e->rotated = scene->envmap_rotated;
  memcpy(e->rotation, scene->envmap_rotation, sizeof e->rotation);
  e->radiance = malloc((size_t)w * h * sizeof *e->radiance);
  e->row_cdf = malloc(((size_t)h + 1) * sizeof(float));
  e->column_cdf = malloc((size_t)h * ((size_t)w + 1) * sizeof(float));
  e->column_buckets = (w + 3) / 4;
  e->row_guide = malloc((size_t)h * sizeof *e->row_guide);
  e->column_guide = malloc((size_t)h * (size_t)e->column_buckets * sizeof *e->column_guide);
  if (!e->radiance || !e->row_cdf || !e->column_cdf || !e->row_guide || !e->column_guide) {
    envmap_destroy(e);
    return VF_ENOMEM;
  }
  double total = 0.0;
  e->row_cdf[0] = 0.0f;
  for (int y = 0; y < h; y++) {
    float sin_theta = sinf(((float)y + 0.5f) / (float)h * VF_PI);
    float *cdf = &e->column_cdf[(size_t)y * (w + 1)];
    double row = 0.0;
    cdf[0] = 0.0f;
    for (int x = 0; x < w; x++) {
      const float *p = &img->rgb[3 * ((size_t)y * w + x)];
      vf_vec3 c = vf_add(scene->background, vf_mul(scene->envmap_scale, vf_vec3_make(p[0], p[1], p[2])));
      e->radiance[(size_t)y * w + x] = c;
      row += fmax(0.0, vf_luminance(c)) * sin_theta;
      cdf[x + 1] = (float)row;
    }
    for (int x = 1; x <= w; x++) cdf[x] = row > 0.0 ? (float)(cdf[x] / row) : (float)x / (float)w;
    cdf[w] = 1.0f;
    total += row / w;
    e->row_cdf[y + 1] = (float)total;
  }
  if (!(total > 0.0)) {
    envmap_destroy(e);
    return vf_error_set(VF_ESCENE, "%s: the environment map is black", scene->source);
  }
  for (int y = 1; y <= h; y++) e->row_cdf[y] = (float)(e->row_cdf[y] / total);
  e->row_cdf[h] = 1.0f;
  vf_cdf_guide(e->row_cdf, h, e->row_guide, h);
  for (int y = 0; y < h; y++)
    vf_cdf_guide(&e->column_cdf[(size_t)y * (w + 1)], w, &e->column_guide[(size_t)y * e->column_buckets],
                 e->column_buckets);
  e->integral = (float)(total / h);
  *out = e;
  return VF_OK;
}

/* Density over [0,1]^2 of texel (x, y). */
static float envmap_pdf_uv(const vf_envmap *e, int x, int y) {
  float row = e->row_cdf[y + 1] - e->row_cdf[y];
  const float *cdf = &e->column_cdf[(size_t)y * (e->width + 1)];
  float col = cdf[x + 1] - cdf[x];
  return row * col * (float)e->width * (float)e->height;
}

static void texel_of_uv(const vf_envmap *e, float u, float v, int *x, int *y) {
  *x = (int)fminf(fmaxf(u * (float)e->width, 0.0f), (float)(e->width - 1));
  *y = (int)fminf(fmaxf(v * (float)e->height, 0.0f), (float)(e->height - 1));
}

/* Radiance and solid-angle density of the environment towards direction d (into the scene
 * is -d: d points from the scene to the sky). */
static vf_vec3 environment_lookup(const vf_lights *ls, const vf_light *l, vf_vec3 d, float *pdf_w) {
  const vf_envmap *e = l->envmap;
  if (e == NULL) {
    *pdf_w = VF_UNIFORM_SPHERE_PDF_W;
    return l->radiance;
  }
  float u, v;
  int x, y;
  uv_of_direction(map_of_world(e, d), &u, &v);
  texel_of_uv(e, u, v, &x, &y);
  float sin_theta = sinf(v * VF_PI);
  *pdf_w = sin_theta > 0.0f ? envmap_pdf_uv(e, x, y) / (2.0f * VF_PI * VF_PI * sin_theta) : 0.0f;
  (void)ls;
  return e->radiance[(size_t)y * e->width + x];
}

/* Samples a sky direction d (pointing away from the scene) with its solid-angle density.
 * The density and radiance are those of the returned direction as environment_lookup sees
 * it, so sampling and lookup agree exactly even where rounding moves d across a texel edge. */
static vf_vec3 environment_sample(const vf_lights *ls, const vf_light *l, float u1, float u2, vf_vec3 *d,
                                  float *pdf_w) {
  const vf_envmap *e = l->envmap;
  if (e == NULL) {
    *d = vf_sample_uniform_sphere(u1, u2);
    *pdf_w = VF_UNIFORM_SPHERE_PDF_W;
    return l->radiance;
  }
  int y = vf_cdf_guided(e->row_cdf, e->height, e->row_guide, e->height, u2);
  const float *cdf = &e->column_cdf[(size_t)y * (e->width + 1)];
  int x = vf_cdf_guided(cdf, e->width, &e->column_guide[(size_t)y * e->column_buckets], e->column_buckets, u1);
  /* Position within the texel from the leftover of each uniform number. */
  float fy = (u2 - e->row_cdf[y]) / fmaxf(e->row_cdf[y + 1] - e->row_cdf[y], 1e-30f);
  float fx = (u1 - cdf[x]) / fmaxf(cdf[x + 1] - cdf[x], 1e-30f);
  float u = ((float)x + fminf(fx, 0.999f)) / (float)e->width;
  float v = ((float)y + fminf(fy, 0.999f)) / (float)e->height;
  *d = world_of_map(e, direction_of_uv(u, v));
  return environment_lookup(ls, l, *d, pdf_w);
}

/* A spot's intensity relative to its axis in direction cos_theta from it:
 * KHR_lights_punctual's falloff, the square of the linear ramp in cos(theta) from 0 at the
 * outer cone to 1 at the inner one. */
static float spot_falloff(const vf_light *l, float cos_theta) {
  float t = (cos_theta - l->cos_outer) * l->falloff_scale;
  t = t < 1.0f ? vf_fmaxf_zero(t) : 1.0f;
  return t * t;
}

static void set_up_spot(vf_light *l, const vf_point_light_desc *d) {
  double inner = d->inner_cone_angle, outer = d->outer_cone_angle;
  double one_minus_cos_outer = 2.0 * sin(0.5 * outer) * sin(0.5 * outer);
  l->direction = vf_normalize(d->direction);
  l->frame = vf_frame_from_normal(l->direction);
  l->cos_outer = (float)cos(outer);
  l->falloff_scale = (float)(1.0 / (cos(inner) - cos(outer)));
  l->one_minus_cos_outer = (float)one_minus_cos_outer;
  l->cone_pdf_w = (float)(1.0 / (2.0 * M_PI * one_minus_cos_outer));
}

static float estimated_power(const vf_lights *ls, const vf_light *l) {
  float disk = VF_PI * ls->scene_radius * ls->scene_radius;
  switch (l->kind) {
  case VF_LIGHT_AREA_MESH:
  case VF_LIGHT_AREA_SPHERE: return VF_PI * l->area * vf_luminance(l->radiance);
  case VF_LIGHT_POINT: return 4.0f * VF_PI * vf_luminance(l->radiance);
  case VF_LIGHT_SPOT: {
    /* The falloff integrated over the sphere: 2 pi times (1 - cos inner) at full intensity
     * plus a third of (cos inner - cos outer) under the quadratic ramp. */
    float ramp = 1.0f / l->falloff_scale;
    return 2.0f * VF_PI * (l->one_minus_cos_outer - ramp + ramp / 3.0f) * vf_luminance(l->radiance);
  }
  case VF_LIGHT_DIRECTIONAL: return disk * vf_luminance(l->radiance);
  case VF_LIGHT_ENVIRONMENT: {
    float mean = l->envmap ? l->envmap->integral : vf_luminance(l->radiance);
    return disk * VF_PI * mean;
  }
  }
  return 0.0f;
}

static int add_area_light(vf_lights *ls, const vf_scene *scene, const vf_shape *s, vf_light *l) {
  memset(l, 0, sizeof *l);
  l->shape = s;
  if (s->kind == VF_SHAPE_MESH) {
    const vf_material *m = &scene->materials[s->material];
    l->textured = m->textures[VF_TEXTURE_EMISSION].texture != 0 || m->alpha_cutoff > 0.0f;
  }
  if (s->material >= 0) {
    const vf_material *m = &scene->materials[s->material];
    l->coated = m->gltf && m->clearcoat > 0.0f;
    l->scene = scene;
  }
  l->radiance = s->emission;
  l->is_finite = 1;
  if (s->kind == VF_SHAPE_SPHERE) {
    l->kind = VF_LIGHT_AREA_SPHERE;
    l->area = 4.0f * VF_PI * s->radius * s->radius;
  } else {
    l->kind = VF_LIGHT_AREA_MESH;
    l->triangle_cdf = malloc(((size_t)s->num_triangles + 1) * sizeof(float));
    l->triangle_guide = malloc((size_t)s->num_triangles * sizeof *l->triangle_guide);
    l->triangles = malloc((size_t)s->num_triangles * sizeof *l->triangles);
    if (l->triangle_cdf == NULL || l->triangle_guide == NULL || l->triangles == NULL) return VF_ENOMEM;
    for (uint32_t t = 0; t < s->num_triangles; t++) {
      const uint32_t *i = &s->indices[3 * (size_t)t];
      const float *a = &s->positions[3 * (size_t)i[0]], *b = &s->positions[3 * (size_t)i[1]],
                  *c = &s->positions[3 * (size_t)i[2]];
      vf_light_triangle *lt = &l->triangles[t];
      lt->a = vf_vec3_make(a[0], a[1], a[2]);
      lt->b = vf_vec3_make(b[0], b[1], b[2]);
      lt->c = vf_vec3_make(c[0], c[1], c[2]);
      lt->normal = vf_normalize(vf_cross(vf_sub(lt->b, lt->a), vf_sub(lt->c, lt->a)));
    }
    double sum = 0.0;
    l->triangle_cdf[0] = 0.0f;
    for (uint32_t t = 0; t < s->num_triangles; t++) {
      sum += triangle_area(s, t);
      l->triangle_cdf[t + 1] = (float)sum;
    }
    for (uint32_t t = 1; t <= s->num_triangles; t++) l->triangle_cdf[t] = (float)(l->triangle_cdf[t] / sum);
    l->triangle_cdf[s->num_triangles] = 1.0f;
    vf_cdf_guide(l->triangle_cdf, (int)s->num_triangles, l->triangle_guide, (int)s->num_triangles);
    l->area = (float)sum;
  }
  (void)ls;
  if (!(l->area > 0.0f)) return vf_error_set(VF_ESCENE, "emissive shape '%s' has zero area", s->name);
  l->inv_area = 1.0f / l->area;
  return VF_OK;
}

int vf_lights_create(const vf_scene *scene, vf_lights **out) {
  int err = VF_ENOMEM;
  vf_lights *ls = calloc(1, sizeof *ls);
  if (ls == NULL) return VF_ENOMEM;
  vf_scene_bounding_sphere(scene, &ls->scene_center, &ls->scene_radius);
  ls->environment = -1;
  int has_env = !vf_is_zero(scene->background) || scene->envmap.width > 0;
  int max = scene->num_shapes + scene->num_point_lights + scene->num_directional_lights + 1;
  ls->lights = calloc((size_t)max, sizeof *ls->lights);
  ls->shape_light = malloc((size_t)(scene->num_shapes ? scene->num_shapes : 1) * sizeof(int));
  ls->pick_cdf = calloc((size_t)max, sizeof(float));
  if (!ls->lights || !ls->shape_light || !ls->pick_cdf) goto fail;
  for (int i = 0; i < scene->num_shapes; i++) {
    ls->shape_light[i] = -1;
    if (vf_is_zero(scene->shapes[i].emission)) continue;
    if ((err = add_area_light(ls, scene, &scene->shapes[i], &ls->lights[ls->count])) != VF_OK) goto fail;
    ls->shape_light[i] = ls->count++;
  }
  for (int i = 0; i < scene->num_point_lights; i++) {
    vf_light *l = &ls->lights[ls->count++];
    const vf_point_light_desc *d = &scene->point_lights[i];
    l->kind = d->is_spot ? VF_LIGHT_SPOT : VF_LIGHT_POINT;
    l->position = d->position;
    l->radiance = d->intensity;
    l->is_delta = l->is_finite = 1;
    if (d->is_spot) set_up_spot(l, d);
  }
  for (int i = 0; i < scene->num_directional_lights; i++) {
    vf_light *l = &ls->lights[ls->count++];
    l->kind = VF_LIGHT_DIRECTIONAL;
    l->direction = vf_normalize(scene->directional_lights[i].direction);
    l->frame = vf_frame_from_normal(l->direction);
    l->radiance = scene->directional_lights[i].irradiance;
    l->is_delta = 1;
  }
  if (has_env) {
    vf_light *l = &ls->lights[ls->count];
    l->kind = VF_LIGHT_ENVIRONMENT;
    l->radiance = scene->background;
    if (scene->envmap.width > 0) {
      if ((err = envmap_create(scene, &ls->envmap)) != VF_OK) goto fail;
      l->envmap = ls->envmap;
    }
    ls->environment = ls->count++;
  }
  if (ls->count == 0) {
    err = vf_error_set(VF_ESCENE, "%s: the scene has no light", scene->source);
    goto fail;
  }
  double total = 0.0;
  for (int i = 0; i < ls->count; i++) total += estimated_power(ls, &ls->lights[i]);
  double acc = 0.0;
  for (int i = 0; i < ls->count; i++) {
    double p = 0.5 / ls->count + (total > 0.0 ? 0.5 * estimated_power(ls, &ls->lights[i]) / total : 0.5 / ls->count);
    ls->lights[i].pick_probability = (float)p;
    acc += p;
    ls->pick_cdf[i] = (float)acc;
  }
  ls->pick_cdf[ls->count - 1] = 1.0f;
  *out = ls;
  return VF_OK;
fail:
  vf_lights_destroy(ls);
  return err;
}

void vf_lights_destroy(vf_lights *ls) {
  if (ls == NULL) return;
  if (ls->lights)
    for (int i = 0; i < ls->count; i++) {
      free(ls->lights[i].triangle_cdf);
      free(ls->lights[i].triangle_guide);
      free(ls->lights[i].triangles);
    }
  free(ls->lights);
  free(ls->shape_light);
  free(ls->pick_cdf);
  envmap_destroy(ls->envmap);
  free(ls);
}

/* vf_light_pick_triangle for area lights: spheres need no pick, and u stays unchanged. */
static uint32_t pick_triangle(const vf_light *l, float *u) {
  return l->kind == VF_LIGHT_AREA_MESH ? vf_light_pick_triangle(l, u) : 0;
}

/* Uniform point on triangle t of an area light (or on the sphere), with its normal. Inline,
 * or GCC keeps it out of line and both results go through memory once per light sample. */
static inline void sample_area(const vf_light *l, uint32_t t, float u1, float u2, vf_vec3 *p, vf_vec3 *n) {
  const vf_shape *s = l->shape;
  if (l->kind == VF_LIGHT_AREA_SPHERE) {
    vf_vec3 d = vf_sample_uniform_sphere(u1, u2);
    *n = d;
    *p = vf_add(s->center, vf_scale(d, s->radius));
    return;
  }
  const vf_light_triangle *tri = &l->triangles[t];
  *p = vf_light_triangle_point(tri, u1, u2);
  *n = tri->normal;
}

vf_vec3 vf_light_emit_any(const vf_lights *ls, const vf_light *l, const float rnd[4], vf_vec3 *position,
                          vf_vec3 *direction, vf_vec3 *normal, float *emission_pdf_w, float *direct_pdf_a,
                          float *cos_light, vf_light_coat *coat) {
  switch (l->kind) {
  case VF_LIGHT_AREA_MESH:
  case VF_LIGHT_AREA_SPHERE: {
    vf_vec3 n;
    float u = rnd[0];
    uint32_t t = pick_triangle(l, &u);
    sample_area(l, t, rnd[1], rnd[2], position, &n);
    vf_vec3 energy = vf_light_emit_area_point(l, n, rnd[3], u, direction, normal, emission_pdf_w, direct_pdf_a,
                                              cos_light);
    if (l->coated) { /* a sphere: the coat's normal is its own */
      *coat = vf_light_coat_at(l, t, 0.0f, 0.0f, n);
      energy = vf_scale(energy, vf_light_coat_transmit(coat, *direction));
    }
    return energy;
  }
  case VF_LIGHT_POINT:
    *position = l->position;
    *direction = vf_sample_uniform_sphere(rnd[0], rnd[1]);
    *normal = *direction;
    *emission_pdf_w = VF_UNIFORM_SPHERE_PDF_W;
    *direct_pdf_a = 1.0f;
    *cos_light = 1.0f;
    return l->radiance;
  case VF_LIGHT_SPOT: {
    /* Uniform over the outer cone's solid angle: 1 - cos(theta) uniform in [0, 1 - cos_outer). */
    float one_minus_cos = rnd[0] * l->one_minus_cos_outer, cos_theta = 1.0f - one_minus_cos;
    float sin_theta = sqrtf(vf_fmaxf_zero(one_minus_cos * (2.0f - one_minus_cos))), phi = 2.0f * VF_PI * rnd[1];
    *position = l->position;
    *direction = vf_frame_to_world(&l->frame, vf_vec3_make(sin_theta * cosf(phi), sin_theta * sinf(phi), cos_theta));
    *normal = *direction;
    *emission_pdf_w = l->cone_pdf_w;
    *direct_pdf_a = 1.0f;
    *cos_light = 1.0f;
    return vf_scale(l->radiance, spot_falloff(l, cos_theta));
  }
  case VF_LIGHT_DIRECTIONAL: {
    float x, y;
    vf_sample_concentric_disk(rnd[0], rnd[1], &x, &y);
    float r = ls->scene_radius;
    *position = vf_add(ls->scene_center, vf_scale(vf_add(vf_neg(l->direction),
                                                         vf_add(vf_scale(l->frame.s, x), vf_scale(l->frame.t, y))), r));
    *direction = l->direction;
    *normal = l->direction;
    *emission_pdf_w = 1.0f / (VF_PI * r * r);
    *direct_pdf_a = 1.0f;
    *cos_light = 1.0f;
    return l->radiance;
  }
  case VF_LIGHT_ENVIRONMENT: {
    vf_vec3 sky;
    float pdf_w;
    vf_vec3 radiance = environment_sample(ls, l, rnd[0], rnd[1], &sky, &pdf_w);
    vf_vec3 dir = vf_neg(sky);
    vf_frame f = vf_frame_from_normal(dir);
    float x, y, r = ls->scene_radius;
    vf_sample_concentric_disk(rnd[2], rnd[3], &x, &y);
    *position = vf_add(ls->scene_center, vf_scale(vf_add(sky, vf_add(vf_scale(f.s, x), vf_scale(f.t, y))), r));
    *direction = dir;
    *normal = dir;
    *emission_pdf_w = pdf_w / (VF_PI * r * r);
    *direct_pdf_a = pdf_w;
    *cos_light = 1.0f;
    return pdf_w > 0.0f ? radiance : vf_vec3_splat(0.0f);
  }
  }
  return vf_vec3_splat(0.0f);
}

vf_vec3 vf_light_illuminate_any(const vf_lights *ls, const vf_light *l, vf_vec3 receiver, const float rnd[2],
                                vf_vec3 *dir_to_light, float *distance, vf_vec3 *light_point,
                                vf_vec3 *light_normal, float *direct_pdf_w, float *emission_pdf_w,
                                float *cos_at_light) {
  vf_vec3 zero = vf_vec3_splat(0.0f);
  switch (l->kind) {
  case VF_LIGHT_AREA_MESH:
  case VF_LIGHT_AREA_SPHERE: {
    vf_vec3 p, n;
    float u = rnd[0];
    uint32_t t = pick_triangle(l, &u);
    sample_area(l, t, u, rnd[1], &p, &n);
    vf_vec3 le = vf_light_illuminate_area_point(l, receiver, p, n, dir_to_light, distance, light_point, light_normal,
                                                direct_pdf_w, emission_pdf_w, cos_at_light);
    if (l->coated && !vf_is_zero(le)) { /* a sphere: the coat's normal is its own */
      vf_light_coat coat = vf_light_coat_at(l, t, 0.0f, 0.0f, n);
      le = vf_scale(le, vf_light_coat_transmit(&coat, vf_neg(*dir_to_light)));
    }
    return le;
  }
  case VF_LIGHT_POINT:
  case VF_LIGHT_SPOT: {
    vf_vec3 d = vf_sub(l->position, receiver);
    float dist2 = vf_length_sq(d);
    float dist = sqrtf(dist2);
    if (!(dist > 0.0f)) return zero;
    *dir_to_light = vf_scale(d, 1.0f / dist);
    *distance = dist;
    *light_point = l->position;
    *light_normal = vf_neg(*dir_to_light);
    *direct_pdf_w = dist2;
    *cos_at_light = 1.0f;
    if (l->kind == VF_LIGHT_POINT) {
      *emission_pdf_w = VF_UNIFORM_SPHERE_PDF_W;
      return l->radiance;
    }
    /* The light sub-path's density of this direction, the cone's (tech. rep. eq. 45, 48). */
    float cos_theta = vf_dot(l->direction, *light_normal);
    *emission_pdf_w = l->cone_pdf_w;
    return cos_theta > l->cos_outer ? vf_scale(l->radiance, spot_falloff(l, cos_theta)) : zero;
  }
  case VF_LIGHT_DIRECTIONAL:
    *dir_to_light = vf_neg(l->direction);
    *distance = INFINITY;
    *direct_pdf_w = 1.0f;
    *emission_pdf_w = 1.0f / (VF_PI * ls->scene_radius * ls->scene_radius);
    *cos_at_light = 1.0f;
    return l->radiance;
  case VF_LIGHT_ENVIRONMENT: {
    vf_vec3 sky;
    float pdf_w;
    vf_vec3 radiance = environment_sample(ls, l, rnd[0], rnd[1], &sky, &pdf_w);
    if (!(pdf_w > 0.0f)) return zero;
    *dir_to_light = sky;
    *distance = INFINITY;
    *direct_pdf_w = pdf_w;
    *emission_pdf_w = pdf_w / (VF_PI * ls->scene_radius * ls->scene_radius);
    *cos_at_light = 1.0f;
    return radiance;
  }
  }
  return zero;
}

vf_vec3 vf_light_emission_factor(const vf_light *l, uint32_t t, float u, float v) {
  return vf_surface_emission_factor(l->scene, l->shape, t, u, v);
}

vf_light_coat vf_light_coat_at(const vf_light *l, uint32_t t, float u, float v, vf_vec3 n) {
  vf_light_coat c = {l->scene->materials[l->shape->material].clearcoat, n};
  if (l->kind == VF_LIGHT_AREA_MESH) vf_surface_coat(l->scene, l->shape, t, u, v, n, &c.weight, &c.normal);
  return c;
}

vf_vec3 vf_light_emission_factor_toward(const vf_light *l, uint32_t t, float u, float v, vf_vec3 n, vf_vec3 dir) {
  vf_vec3 f = l->textured ? vf_light_emission_factor(l, t, u, v) : vf_vec3_splat(1.0f);
  if (l->coated) {
    vf_light_coat c = vf_light_coat_at(l, t, u, v, n);
    f = vf_scale(f, vf_light_coat_transmit(&c, dir));
  }
  return f;
}

float vf_light_emission_toward(const vf_light *l, vf_vec3 n, vf_vec3 dir, float *dir_pdf_w, float *cos_light) {
  *dir_pdf_w = 0.0f;
  *cos_light = 1.0f;
  switch (l->kind) {
  case VF_LIGHT_AREA_MESH:
  case VF_LIGHT_AREA_SPHERE: {
    float c = vf_dot(n, dir);
    if (!(c > 0.0f)) return 0.0f;
    *dir_pdf_w = c * VF_INV_PI;
    *cos_light = c;
    return c;
  }
  case VF_LIGHT_POINT: *dir_pdf_w = VF_UNIFORM_SPHERE_PDF_W; return 1.0f;
  case VF_LIGHT_SPOT: {
    float c = vf_dot(l->direction, dir);
    if (!(c > l->cos_outer)) return 0.0f;
    *dir_pdf_w = l->cone_pdf_w;
    return spot_falloff(l, c);
  }
  default: return 0.0f;
  }
}

vf_vec3 vf_light_radiance_area(const vf_light *l, vf_vec3 ray_dir, vf_vec3 normal, float *direct_pdf_a,
                               float *emission_pdf_w) {
  float cos_out = -vf_dot(normal, ray_dir);
  if (!(cos_out > 0.0f)) return vf_vec3_splat(0.0f);
  *direct_pdf_a = l->inv_area;
  *emission_pdf_w = cos_out * VF_INV_PI * l->inv_area;
  return l->radiance;
}

vf_vec3 vf_light_radiance_environment(const vf_lights *ls, const vf_light *l, vf_vec3 ray_dir,
                                      float *direct_pdf_w, float *emission_pdf_w) {
  float pdf_w;
  vf_vec3 radiance = environment_lookup(ls, l, ray_dir, &pdf_w);
  *direct_pdf_w = pdf_w;
  *emission_pdf_w = pdf_w / (VF_PI * ls->scene_radius * ls->scene_radius);
  return radiance;
}
