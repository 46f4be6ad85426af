/* Test scenes with the features of worker/render/surface.h, built from the Cornell family in
 * memory (tests/worker/render/test_surface.c, tests/worker/render/test_mis.c): coarse smooth-normal balls, textures of
 * every slot, a normal map and an alpha cut-out. The textures are made texel by texel here,
 * so the scenes need no files. */
#ifndef VF_TEST_FEATURE_SCENE_H
#define VF_TEST_FEATURE_SCENE_H

#include "check.h"
#include "common/error.h"
#include "worker/scene/scene.h"
#include "worker/scene/load.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>


/* A latitude-longitude sphere mesh of `rows` x 2 rows segments with the sphere's normals
 * and coordinates (s along longitude, t from the north pole): coarse, so that shading
 * normals differ from the facets by up to ~15 degrees. */
static void make_uv_sphere(vf_shape *s, vf_vec3 c, float radius, int rows) {
  int cols = 2 * rows;
  uint32_t nv = (uint32_t)((rows + 1) * (cols + 1)), nt = (uint32_t)(2 * rows * cols);
  s->kind = VF_SHAPE_MESH;
  s->num_vertices = nv;
  s->num_triangles = nt;
  s->positions = malloc(3 * nv * sizeof(float));
  s->normals = malloc(3 * nv * sizeof(float));
  s->uvs = malloc(2 * nv * sizeof(float));
  s->indices = malloc(3 * nt * sizeof(uint32_t));
  uint32_t v = 0, t = 0;
  for (int i = 0; i <= rows; i++)
    for (int j = 0; j <= cols; j++, v++) {
      double theta = M_PI * i / rows, phi = 2 * M_PI * j / cols;
      vf_vec3 n = vf_vec3_make((float)(sin(theta) * cos(phi)), (float)cos(theta), (float)(-sin(theta) * sin(phi)));
      vf_vec3 p = vf_add(c, vf_scale(n, radius));
      memcpy(&s->positions[3 * v], &p, 3 * sizeof(float));
      memcpy(&s->normals[3 * v], &n, 3 * sizeof(float));
      s->uvs[2 * v] = (float)j / cols;
      s->uvs[2 * v + 1] = (float)i / rows;
    }
  for (int i = 0; i < rows; i++)
    for (int j = 0; j < cols; j++) {
      uint32_t a = (uint32_t)(i * (cols + 1) + j), b = a + 1, d = a + (uint32_t)cols + 1, e = d + 1;
      /* counter-clockwise seen from outside */
      uint32_t tri[6] = {a, d, b, b, d, e};
      memcpy(&s->indices[3 * t], tri, sizeof tri);
      t += 2;
    }
}

static int find_shape(const vf_scene *s, const char *name) {
  for (int i = 0; i < s->num_shapes; i++)
    if (strcmp(s->shapes[i].name, name) == 0) return i;
  return -1;
}

/* Texture coordinates for a wall from two of its position's coordinates, `repeat` times
 * across the wall's [-1, 1] extent. */
static void wall_uvs(vf_shape *s, int axis_s, int axis_t, float repeat) {
  s->uvs = malloc(2 * s->num_vertices * sizeof(float));
  for (uint32_t v = 0; v < s->num_vertices; v++) {
    s->uvs[2 * v] = (s->positions[3 * v + axis_s] + 1.0f) * 0.5f * repeat;
    s->uvs[2 * v + 1] = (1.0f - s->positions[3 * v + axis_t]) * 0.5f * repeat;
  }
}

/* Appends texture (w x h, channels, 8-bit texels from fn(x, y, c)) and returns its slot
 * value (1 + index). */
static int add_texture(vf_scene *s, int w, int h, int channels, int is_float, float (*fn)(int, int, int)) {
  s->textures = realloc(s->textures, (size_t)(s->num_textures + 1) * sizeof *s->textures);
  vf_texture *t = &s->textures[s->num_textures];
  memset(t, 0, sizeof *t);
  t->width = (uint32_t)w;
  t->height = (uint32_t)h;
  t->channels = channels;
  t->is_float = is_float;
  t->texels = malloc((size_t)w * h * channels * (is_float ? sizeof(float) : 1));
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++)
      for (int c = 0; c < channels; c++) {
        size_t k = ((size_t)y * w + x) * channels + c;
        float value = fn(x, y, c);
        if (is_float)
          ((float *)t->texels)[k] = value;
        else
          ((uint8_t *)t->texels)[k] = (uint8_t)lrintf(value * 255.0f);
      }
  return ++s->num_textures;
}

static float checker(int x, int y, int c) { return ((x + y) & 1) ? (c == 0 ? 0.9f : 0.5f) : 0.15f; }
static float holes(int x, int y, int c) { (void)c; return ((x + y) & 1) ? 1.0f : 0.0f; }
static float roughness_metallic(int x, int y, int c) { return c == 1 ? 0.2f + 0.1f * (float)((x * 3 + y) % 8) : ((x / 2 + y) & 1); }
/* A field of bumps: tangent-space normals tilted up to ~35 degrees, encoded as (n + 1) / 2. */
static float bumps(int x, int y, int c) {
  double nx = 0.5 * sin(2 * M_PI * x / 8.0), ny = 0.5 * cos(2 * M_PI * y / 8.0), nz = 1.0;
  double len = sqrt(nx * nx + ny * ny + nz * nz), n[3] = {nx / len, ny / len, nz / len};
  return (float)(0.5 * (n[c] + 1.0));
}

enum {
  FEATURE_SMOOTH = 1,
  FEATURE_TEXTURED = 2,
  FEATURE_NORMAL_MAP = 4,
  FEATURE_CUTOUT = 8,
  FEATURE_ROUGH_GLASS = 16, /* the left ball (smooth with FEATURE_SMOOTH) of rough glass */
  FEATURE_LENS = 32,        /* a thin lens focused on the balls */
  FEATURE_SPOT = 64,        /* a spot light beside the area light */
};

/* cornell-diffuse with the features asked for: FEATURE_SMOOTH makes the balls coarse meshes with
 * vertex normals; FEATURE_TEXTURED gives the floor a checker diffuse texture and the right ball a
 * glTF material with base colour and roughness-metallic textures, and the light an emission
 * texture; FEATURE_NORMAL_MAP bumps the
 * back wall; FEATURE_CUTOUT puts a grating with square holes under the light; the rest as
 * their names say. */
static vf_scene *feature_scene(unsigned features) {
  vf_scene *s;
  CHECK_INT_EQ(vf_scene_load("cornell-diffuse", &s), VF_OK);
  if (check_failed_in_case) return NULL;
  int left = find_shape(s, "white ball ball"), right = find_shape(s, "blue ball ball");
  if (left < 0) left = find_shape(s, "white ball");
  if (right < 0) right = find_shape(s, "blue ball");
  CHECK(left >= 0 && right >= 0);
  if (check_failed_in_case) return s;
  if (features & (FEATURE_SMOOTH | FEATURE_TEXTURED)) {
    vf_vec3 cl = s->shapes[left].center, cr = s->shapes[right].center;
    float rl = s->shapes[left].radius, rr = s->shapes[right].radius;
    make_uv_sphere(&s->shapes[left], cl, rl, 6);
    make_uv_sphere(&s->shapes[right], cr, rr, 8);
  }
  if (features & FEATURE_ROUGH_GLASS) {
    s->materials = realloc(s->materials, (size_t)(s->num_materials + 1) * sizeof *s->materials);
    vf_material *g = &s->materials[s->num_materials];
    memset(g, 0, sizeof *g);
    snprintf(g->name, sizeof g->name, "rough glass");
    g->phong_exponent = 1.0f;
    g->dielectric = vf_vec3_splat(1.0f);
    g->ior = 1.5f;
    g->roughness = 0.3f;
    g->alpha = g->normal_scale = 1.0f;
    s->shapes[left].material = s->num_materials++;
  }
  if (features & FEATURE_LENS) {
    s->camera.aperture = 0.08f;
    s->camera.focus_distance = 3.6f;
  }
  if (features & FEATURE_SPOT) {
    s->point_lights = realloc(s->point_lights, (size_t)(s->num_point_lights + 1) * sizeof *s->point_lights);
    vf_point_light_desc *l = &s->point_lights[s->num_point_lights++];
    memset(l, 0, sizeof *l);
    l->position = vf_vec3_make(-0.5f, 0.8f, 0.5f);
    l->direction = vf_normalize(vf_vec3_make(0.3f, -1.0f, -0.4f));
    l->intensity = vf_vec3_splat(2.0f);
    l->is_spot = 1;
    l->inner_cone_angle = 0.3f;
    l->outer_cone_angle = 0.6f;
  }
  /* room for two more materials */
  s->materials = realloc(s->materials, (size_t)(s->num_materials + 2) * sizeof *s->materials);
  if (features & FEATURE_TEXTURED) {
    int floor = find_shape(s, "floor");
    wall_uvs(&s->shapes[floor], 0, 2, 4.0f);
    vf_material *fm = &s->materials[s->shapes[floor].material];
    fm->diffuse = vf_vec3_splat(1.0f);
    fm->textures[VF_TEXTURE_COLOR].texture = add_texture(s, 4, 4, 3, 0, checker);
    vf_material *g = &s->materials[s->num_materials];
    memset(g, 0, sizeof *g);
    snprintf(g->name, sizeof g->name, "textured glTF");
    g->phong_exponent = g->ior = 1.0f;
    g->gltf = 1;
    g->base_color = vf_vec3_splat(1.0f);
    g->metallic = 1.0f;
    g->roughness = 1.0f;
    g->textures[VF_TEXTURE_COLOR].texture = add_texture(s, 8, 8, 3, 0, checker);
    g->textures[VF_TEXTURE_ROUGHNESS_METALLIC].texture = add_texture(s, 8, 8, 3, 0, roughness_metallic);
    s->shapes[right].material = s->num_materials++;
    /* the light emits through a checker of emission (its own material, which only emits) */
    int light = find_shape(s, "light");
    wall_uvs(&s->shapes[light], 0, 2, 3.0f);
    s->materials[s->shapes[light].material].textures[VF_TEXTURE_EMISSION].texture = add_texture(s, 2, 2, 3, 0, checker);
  }
  if (features & FEATURE_NORMAL_MAP) {
    int back = find_shape(s, "back");
    wall_uvs(&s->shapes[back], 0, 1, 2.0f);
    /* the back wall's own material, so the others keep theirs */
    vf_material *bm = &s->materials[s->num_materials];
    *bm = s->materials[s->shapes[back].material];
    snprintf(bm->name, sizeof bm->name, "bumpy");
    bm->normal_scale = 1.0f;
    bm->textures[VF_TEXTURE_NORMAL].texture = add_texture(s, 8, 8, 3, 1, bumps);
    s->shapes[back].material = s->num_materials++;
  }
  if (features & FEATURE_CUTOUT) {
    s->shapes = realloc(s->shapes, (size_t)(s->num_shapes + 1) * sizeof *s->shapes);
    vf_shape *g = &s->shapes[s->num_shapes];
    memset(g, 0, sizeof *g);
    snprintf(g->name, sizeof g->name, "grating");
    g->kind = VF_SHAPE_MESH;
    g->num_vertices = 4;
    g->num_triangles = 2;
    float p[12] = {-0.6f, 0.5f, -0.6f, 0.6f, 0.5f, -0.6f, 0.6f, 0.5f, 0.6f, -0.6f, 0.5f, 0.6f};
    float uv[8] = {0, 0, 1, 0, 1, 1, 0, 1};
    uint32_t idx[6] = {0, 2, 1, 0, 3, 2};
    g->positions = malloc(sizeof p);
    g->uvs = malloc(sizeof uv);
    g->indices = malloc(sizeof idx);
    memcpy(g->positions, p, sizeof p);
    memcpy(g->uvs, uv, sizeof uv);
    memcpy(g->indices, idx, sizeof idx);
    /* a grating of the walls' white with square holes: half its area is open */
    int white = s->shapes[find_shape(s, "ceiling")].material;
    s->materials = realloc(s->materials, (size_t)(s->num_materials + 1) * sizeof *s->materials);
    vf_material *gm = &s->materials[s->num_materials];
    *gm = s->materials[white];
    snprintf(gm->name, sizeof gm->name, "grating");
    gm->alpha = 1.0f;
    gm->alpha_cutoff = 0.5f;
    gm->alpha_channel = 0;
    gm->textures[VF_TEXTURE_ALPHA].texture = add_texture(s, 6, 6, 1, 0, holes);
    g->material = s->num_materials++;
    s->num_shapes++;
  }
  return s;
}

#endif
