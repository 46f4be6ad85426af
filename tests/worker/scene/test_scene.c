#include "check.h"
#include "common/error.h"
#include "common/image.h"
#include "worker/scene/scene.h"
#include "worker/scene/background.h"
#include "worker/scene/builtin.h"
#include "worker/scene/load.h"

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#define SCENES VF_SOURCE_DIR "/tests/scenes"

/* ---- helpers ------------------------------------------------------------------------------ */

static vf_scene *load_ok(const char *name) {
  vf_scene *s = NULL;
  int err = vf_scene_load(name, &s);
  if (err != VF_OK) CHECK_FAIL_("loading %s: %s", name, vf_error_detail(err));
  return s;
}

static vf_vec3 vertex(const vf_shape *s, uint32_t v) {
  return vf_vec3_make(s->positions[3 * v], s->positions[3 * v + 1], s->positions[3 * v + 2]);
}

/* Unnormalised geometric normal (counter-clockwise front) and centroid of triangle t. */
static vf_vec3 triangle_normal(const vf_shape *s, uint32_t t, vf_vec3 *centroid) {
  vf_vec3 a = vertex(s, s->indices[3 * t]), b = vertex(s, s->indices[3 * t + 1]), c = vertex(s, s->indices[3 * t + 2]);
  if (centroid) *centroid = vf_scale(vf_add(vf_add(a, b), c), 1.0f / 3.0f);
  return vf_cross(vf_sub(b, a), vf_sub(c, a));
}

/* Six times the signed volume enclosed: positive when a closed mesh faces outwards. */
static double signed_volume6(const vf_shape *s) {
  double v = 0.0;
  for (uint32_t t = 0; t < s->num_triangles; t++) {
    vf_vec3 a = vertex(s, s->indices[3 * t]), b = vertex(s, s->indices[3 * t + 1]), c = vertex(s, s->indices[3 * t + 2]);
    v += vf_dot(a, vf_cross(b, c));
  }
  return v;
}

static const vf_shape *shape_named(const vf_scene *s, const char *name) {
  for (int i = 0; i < s->num_shapes; i++)
    if (strcmp(s->shapes[i].name, name) == 0) return &s->shapes[i];
  CHECK_FAIL_("no shape named '%s'", name);
  return NULL;
}

static int has_vertex(const vf_shape *s, float x, float y, float z) {
  for (uint32_t v = 0; v < s->num_vertices; v++)
    if (fabsf(s->positions[3 * v] - x) < 1e-5f && fabsf(s->positions[3 * v + 1] - y) < 1e-5f &&
        fabsf(s->positions[3 * v + 2] - z) < 1e-5f)
      return 1;
  return 0;
}

static char *read_all(const char *path) {
  FILE *f = fopen(path, "rb");
  if (f == NULL) return NULL;
  char *buf = calloc(1, 1 << 20);
  size_t n = fread(buf, 1, (1 << 20) - 1, f);
  buf[n] = '\0';
  fclose(f);
  return buf;
}

static void write_all(const char *path, const char *text) {
  FILE *f = fopen(path, "wb");
  CHECK(f != NULL);
  if (f == NULL) return;
  fputs(text, f);
  fclose(f);
}

static void copy_file(const char *from, const char *to) {
  char *text = read_all(from);
  CHECK(text != NULL);
  if (text) write_all(to, text);
  free(text);
}

/* Replaces the first occurrence of `from` in text (in place when lengths match). */
static void replace_once(char *text, const char *from, const char *to) {
  char *p = strstr(text, from);
  CHECK(p != NULL && strlen(from) == strlen(to));
  if (p) memcpy(p, to, strlen(to));
}

/* A fresh directory under /tmp; removed by remove_tree. */
static void make_temp_dir(char dir[64]) {
  snprintf(dir, 64, "/tmp/test_scene.XXXXXX");
  CHECK(mkdtemp(dir) != NULL);
}

static void remove_tree(const char *dir) {
  char cmd[256];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
  CHECK_INT_EQ(system(cmd), 0);
}

/* ---- built-in scenes ---------------------------------------------------------------------- */

static void test_every_builtin_loads_with_sane_bounds(void) {
  for (const char *const *name = vf_scene_builtin_names(); *name; name++) {
    vf_scene *s = load_ok(*name);
    if (s == NULL) continue;
    char source[80];
    snprintf(source, sizeof source, "builtin:%s", *name);
    CHECK_STR_CONTAINS(s->source, source);
    vf_vec3 center;
    float radius;
    vf_scene_bounding_sphere(s, &center, &radius);
    if (strcmp(*name, "corridor") == 0) {
      /* The corridor: [-1,1] x [0,2.5] x [-24,1]. */
      CHECK_NEAR(center.x, 0.0, 1e-5);
      CHECK_NEAR(center.y, 1.25, 1e-5);
      CHECK_NEAR(center.z, -11.5, 1e-5);
      CHECK_NEAR(radius, 0.5 * sqrt(4.0 + 2.5 * 2.5 + 25.0 * 25.0), 1e-4);
    } else {
      /* Every other built-in lives in the box [-1,1]^3. */
      CHECK_NEAR(vf_length(center), 0.0, 1e-5);
      CHECK_NEAR(radius, sqrtf(3.0f), 1e-5);
    }
    CHECK(s->num_shapes >= 1 && s->num_materials >= 1);
    CHECK_NEAR(vf_length(s->camera.forward), 1.0, 1e-6);
    CHECK_NEAR(vf_dot(s->camera.forward, s->camera.up), 0.0, 1e-6);
    CHECK_INT_EQ(vf_settings_validate(&s->settings), VF_OK);
    for (int m = 0; m < s->num_materials; m++) {
      const vf_material *mt = &s->materials[m];
      vf_vec3 sum = vf_add(vf_add(mt->diffuse, mt->glossy), vf_add(mt->mirror, mt->dielectric));
      CHECK(vf_max_component(sum) <= 1.0f);
    }
    vf_scene_destroy(s);
  }
}

static void test_cornell_walls_face_inwards_and_light_faces_down(void) {
  vf_scene *s = load_ok("cornell");
  if (s == NULL) return;
  CHECK_INT_EQ(s->num_shapes, 8); /* 5 walls, 2 spheres, 1 light */
  CHECK_INT_EQ(s->num_point_lights + s->num_directional_lights, 0);
  const char *walls[] = {"floor", "ceiling", "back", "left", "right"};
  for (int w = 0; w < 5; w++) {
    const vf_shape *sh = shape_named(s, walls[w]);
    if (sh == NULL) continue;
    CHECK_INT_EQ(sh->num_triangles, 2);
    for (uint32_t t = 0; t < sh->num_triangles; t++) {
      vf_vec3 centroid, n = triangle_normal(sh, t, &centroid);
      CHECK(vf_dot(n, vf_neg(centroid)) > 0.0f);
    }
  }
  /* The front, z = +1, is open: no vertex of any wall is there except on its edges. */
  const vf_shape *back = shape_named(s, "back");
  if (back) CHECK_NEAR(back->positions[2], -1.0, 0.0);
  const vf_shape *light = shape_named(s, "light");
  if (light) {
    CHECK(!vf_is_zero(light->emission));
    for (uint32_t t = 0; t < light->num_triangles; t++) {
      vf_vec3 n = vf_normalize(triangle_normal(light, t, NULL));
      CHECK_NEAR(n.y, -1.0, 1e-6);
    }
    CHECK_NEAR(light->positions[1], 0.98, 1e-6);
  }
  const vf_shape *mirror = shape_named(s, "mirror ball"), *glass = shape_named(s, "glass ball");
  if (mirror && glass) {
    CHECK_INT_EQ(mirror->kind, VF_SHAPE_SPHERE);
    CHECK_NEAR(mirror->radius, 0.35, 1e-6);
    CHECK_NEAR(mirror->center.x, -0.45, 1e-6);
    CHECK_NEAR(s->materials[mirror->material].mirror.x, 0.95, 1e-6);
    CHECK_NEAR(glass->center.z, 0.25, 1e-6);
    CHECK_NEAR(s->materials[glass->material].ior, 1.6, 1e-6);
    CHECK_NEAR(s->materials[glass->material].dielectric.y, 1.0, 0.0);
  }
  const vf_shape *floor_ = shape_named(s, "floor");
  if (floor_) CHECK_NEAR(s->materials[floor_->material].phong_exponent, 40.0, 0.0);
  CHECK_NEAR(s->camera.position.z, 3.6, 1e-6);
  CHECK_NEAR(s->camera.forward.z, -1.0, 1e-6);
  CHECK_NEAR(s->camera.up.y, 1.0, 1e-6);
  CHECK_NEAR(s->camera.vertical_fov_degrees, 38.0, 0.0);
  CHECK_INT_EQ(s->settings.width, 512);
  CHECK_INT_EQ(s->settings.height, 512);
  CHECK_INT_EQ(s->settings_given, VF_SET_RESOLUTION);
  vf_scene_destroy(s);
}

static void test_cornell_variants_have_their_lights(void) {
  vf_scene *s = load_ok("cornell-point");
  if (s) {
    CHECK_INT_EQ(s->num_point_lights, 1);
    CHECK_NEAR(s->point_lights[0].position.y, 0.85, 1e-6);
    for (int i = 0; i < s->num_shapes; i++) CHECK(vf_is_zero(s->shapes[i].emission));
    vf_scene_destroy(s);
  }
  if ((s = load_ok("cornell-sun")) != NULL) {
    CHECK_INT_EQ(s->num_directional_lights, 1);
    vf_vec3 expect = vf_normalize(vf_vec3_make(-0.35f, -0.55f, -0.75f)), d = s->directional_lights[0].direction;
    CHECK_NEAR(vf_dot(d, expect), 1.0, 1e-6);
    CHECK(d.z < 0.0f); /* travels into the box through the open front */
    CHECK_NEAR(s->directional_lights[0].irradiance.x, 3.0, 0.0);
    vf_scene_destroy(s);
  }
  if ((s = load_ok("cornell-env")) != NULL) {
    CHECK_NEAR(s->background.x + s->background.y + s->background.z, 3.0, 0.0);
    CHECK_INT_EQ(s->envmap.width, 0);
    vf_scene_destroy(s);
  }
}

static void test_furnace_is_a_closed_inward_emitting_cube(void) {
  vf_scene *s = load_ok("furnace");
  if (s == NULL) return;
  CHECK_INT_EQ(s->num_shapes, 1);
  const vf_shape *cube = &s->shapes[0];
  CHECK_INT_EQ(cube->num_triangles, 12);
  CHECK_NEAR(cube->emission.x, 0.5, 0.0);
  CHECK_NEAR(s->materials[cube->material].diffuse.y, 0.5, 0.0);
  double area = 0.0;
  for (uint32_t t = 0; t < cube->num_triangles; t++) {
    vf_vec3 centroid, n = triangle_normal(cube, t, &centroid);
    CHECK(vf_dot(n, vf_neg(centroid)) > 0.0f); /* towards the origin */
    area += 0.5 * vf_length(n);
  }
  CHECK_NEAR(area, 24.0, 1e-5);
  CHECK(signed_volume6(cube) < 0.0); /* closed and inward: the enclosed volume counts negative */
  CHECK_NEAR(signed_volume6(cube), -6.0 * 8.0, 1e-4);
  CHECK_NEAR(vf_length(s->camera.position), 0.0, 0.0);
  CHECK_NEAR(s->camera.forward.z, -1.0, 0.0);
  CHECK_NEAR(s->camera.vertical_fov_degrees, 60.0, 0.0);
  CHECK_INT_EQ(s->settings.width, 128);
  CHECK_INT_EQ(s->settings.max_path_length, 64);
  CHECK(s->settings_given & VF_SET_MAX_PATH_LENGTH);
  vf_scene_destroy(s);
}

static void test_knot_is_a_large_outward_tube_inside_the_box(void) {
  vf_scene *s = load_ok("knot");
  if (s == NULL) return;
  const vf_shape *knot = shape_named(s, "knot");
  if (knot) {
    CHECK(knot->num_triangles >= 100000);
    CHECK_INT_EQ(knot->num_triangles, 115200);
    CHECK(signed_volume6(knot) > 0.0);
    for (uint32_t v = 0; v < knot->num_vertices; v++)
      for (int k = 0; k < 3; k++) CHECK(fabsf(knot->positions[3 * v + k]) < 0.99f);
    CHECK_NEAR(s->materials[knot->material].phong_exponent, 80.0, 0.0);
  }
  CHECK_INT_EQ(s->num_shapes, 7); /* walls, knot, light: no spheres */
  for (int i = 0; i < s->num_shapes; i++) CHECK_INT_EQ(s->shapes[i].kind, VF_SHAPE_MESH);
  vf_scene_destroy(s);
}

static void test_builtin_hashes_are_stable_and_distinct(void) {
  const char *const *names = vf_scene_builtin_names();
  uint8_t first[32][32];
  int n = 0;
  for (; names[n] && n < 32; n++) {
    vf_scene *a = load_ok(names[n]), *b = load_ok(names[n]);
    if (a && b) CHECK(memcmp(a->hash, b->hash, 32) == 0);
    if (a) memcpy(first[n], a->hash, 32);
    vf_scene_destroy(a);
    vf_scene_destroy(b);
  }
  for (int i = 0; i < n; i++)
    for (int j = i + 1; j < n; j++) CHECK(memcmp(first[i], first[j], 32) != 0);
}

/* ---- scene files ---------------------------------------------------------------------------- */

static void test_file_scene_loads_meshes_and_applies_transforms(void) {
  vf_scene *s = load_ok(SCENES "/good/meshes.json");
  if (s == NULL) return;
  CHECK_INT_EQ(s->num_shapes, 4);
  CHECK_INT_EQ(s->num_materials, 3);
  /* OBJ unit square, scaled by 2 and moved by (-1, 0, -1). */
  const vf_shape *quad = shape_named(s, "quad");
  if (quad) {
    CHECK_INT_EQ(quad->num_triangles, 2);
    CHECK_INT_EQ(quad->num_vertices, 4);
    CHECK(has_vertex(quad, -1, 0, -1) && has_vertex(quad, 1, 0, -1) && has_vertex(quad, 1, 2, -1) &&
          has_vertex(quad, -1, 2, -1));
    vf_vec3 n = triangle_normal(quad, 0, NULL);
    CHECK(n.z > 0.0f);
  }
  /* PLY triangle: scale (1,2,3), then 90 degrees about +z, then up by 2 in z. */
  const vf_shape *tri = shape_named(s, "tri");
  if (tri) {
    CHECK_INT_EQ(tri->num_triangles, 1);
    CHECK(has_vertex(tri, 0, 0, 2));
    CHECK(has_vertex(tri, 0, 1, 2));
    CHECK(has_vertex(tri, -2, 0, 2));
    CHECK(triangle_normal(tri, 0, NULL).z > 0.0f);
    CHECK_NEAR(s->materials[tri->material].glossy.x, 0.5, 1e-6);
  }
  /* A mirroring matrix keeps the triangle facing the way it faced in the file. */
  const vf_shape *mirrored = shape_named(s, "mirrored");
  if (mirrored) {
    CHECK(has_vertex(mirrored, -1, 0, 0));
    CHECK(triangle_normal(mirrored, 0, NULL).z > 0.0f);
  }
  const vf_shape *bulb = shape_named(s, "bulb");
  if (bulb) {
    CHECK_NEAR(bulb->center.y, 3.0, 1e-6);
    CHECK_NEAR(bulb->radius, 0.25, 1e-6);
    CHECK_NEAR(bulb->emission.x, 4.0, 0.0);
  }
  CHECK_NEAR(s->bounds_max.y, 3.25, 1e-6);
  CHECK_NEAR(s->bounds_min.x, -2.0, 1e-6);
  CHECK_NEAR(s->camera.forward.z, -1.0, 1e-6);
  CHECK_INT_EQ(s->settings.algorithm, VF_ALGO_BPT);
  CHECK_INT_EQ(s->settings.max_path_length, 8);
  CHECK_INT_EQ(s->settings.seed, 42);
  CHECK_INT_EQ(s->settings.width, 320);
  CHECK_INT_EQ(s->settings.height, 240);
  CHECK_INT_EQ(s->settings_given, VF_SET_ALGORITHM | VF_SET_MAX_PATH_LENGTH | VF_SET_SEED | VF_SET_RESOLUTION);
  CHECK_NEAR(s->settings.alpha, 0.75, 0.0); /* default kept */
  CHECK_INT_EQ(s->num_point_lights, 1);
  vf_scene_destroy(s);
}

static void test_gltf_node_transform_and_scene_transform_compose(void) {
  vf_scene *s = load_ok(SCENES "/good/gltf.json");
  if (s == NULL) return;
  const vf_shape *tri = &s->shapes[0];
  CHECK_INT_EQ(tri->num_triangles, 1);
  /* The file's node moves the triangle to z = 5, the scene's transform by +1 in x. */
  CHECK(has_vertex(tri, 1, 0, 5) && has_vertex(tri, 2, 0, 5) && has_vertex(tri, 1, 1, 5));
  CHECK(triangle_normal(tri, 0, NULL).z > 0.0f);
  CHECK_INT_EQ(s->settings_given, 0);
  CHECK_INT_EQ(s->settings.width, 512);
  CHECK_STR_CONTAINS(s->shapes[0].name, "tri");
  vf_scene_destroy(s);
}

/* DIR/scene.json: one emitting mesh shape read from DIR/FILE; its path into path. */
static void write_mesh_scene(const char *dir, const char *file, char *path, size_t n) {
  char text[512];
  snprintf(text, sizeof text,
           "{\"camera\": {\"position\": [0, 0, 10], \"target\": [0, 0, 0], \"fov\": 30},"
           " \"materials\": {\"white\": {\"diffuse\": [0.5, 0.5, 0.5]}},"
           " \"shapes\": [{\"type\": \"mesh\", \"file\": \"%s\", \"material\": \"white\","
           " \"emission\": [1, 1, 1]}]}\n",
           file);
  snprintf(path, n, "%s/scene.json", dir);
  write_all(path, text);
}

/* Identical vertices are joined for an OBJ file, whose importer gives every corner of a face
 * a vertex of its own: two quads sharing an edge keep 6 of their 8. An indexed glTF quad
 * whose fifth vertex repeats its first keeps all five: joining would not change a ray's
 * result, and on a large indexed file it costs more than the rest of the load. */
static void test_obj_vertices_joined_indexed_gltf_vertices_kept(void) {
  static const char gltf[] =
      "{\"asset\": {\"version\": \"2.0\"}, \"scene\": 0, \"scenes\": [{\"nodes\": [0]}],"
      " \"nodes\": [{\"mesh\": 0}], \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0},"
      " \"indices\": 1, \"mode\": 4}]}],"
      " \"buffers\": [{\"byteLength\": 72, \"uri\": \"data:application/octet-stream;base64,"
      "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAACAPwAAgD8AAAAAAAAAAAAAgD8AAAAAAAAAAAAAAAAAAAAAAAABAAIABAACAAMA\"}],"
      " \"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": 60, \"target\": 34962},"
      " {\"buffer\": 0, \"byteOffset\": 60, \"byteLength\": 12, \"target\": 34963}],"
      " \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 5, \"type\": \"VEC3\","
      " \"min\": [0, 0, 0], \"max\": [1, 1, 0]},"
      " {\"bufferView\": 1, \"componentType\": 5123, \"count\": 6, \"type\": \"SCALAR\"}]}\n";
  char dir[64], path[256];
  make_temp_dir(dir);
  snprintf(path, sizeof path, "%s/quad.gltf", dir);
  write_all(path, gltf);
  write_mesh_scene(dir, "quad.gltf", path, sizeof path);
  vf_scene *s = load_ok(path);
  if (s) {
    CHECK_INT_EQ(s->shapes[0].num_triangles, 2);
    CHECK_INT_EQ(s->shapes[0].num_vertices, 5);
  }
  vf_scene_destroy(s);
  snprintf(path, sizeof path, "%s/quads.obj", dir);
  write_all(path, "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nv 1 1 0\nv 2 1 0\nf 1 2 5 4\nf 2 3 6 5\n");
  write_mesh_scene(dir, "quads.obj", path, sizeof path);
  if ((s = load_ok(path)) != NULL) {
    CHECK_INT_EQ(s->shapes[0].num_triangles, 4);
    CHECK_INT_EQ(s->shapes[0].num_vertices, 6);
  }
  vf_scene_destroy(s);
  remove_tree(dir);
}

static void test_hash_ignores_path_and_layout_but_sees_one_value(void) {
  char dir[64], path[256];
  make_temp_dir(dir);
  snprintf(path, sizeof path, "%s/meshes", dir);
  CHECK_INT_EQ(mkdir(path, 0700), 0);
  snprintf(path, sizeof path, "%s/meshes/quad.obj", dir);
  copy_file(SCENES "/good/meshes/quad.obj", path);
  snprintf(path, sizeof path, "%s/meshes/tri.ply", dir);
  copy_file(SCENES "/good/meshes/tri.ply", path);
  snprintf(path, sizeof path, "%s/copy.json", dir);
  copy_file(SCENES "/good/meshes.json", path);

  vf_scene *original = load_ok(SCENES "/good/meshes.json"), *copy = load_ok(path);
  char *text = read_all(SCENES "/good/meshes.json");
  if (original && copy && text) {
    char a[65], b[65];
    vf_scene_hash_hex(original, a);
    vf_scene_hash_hex(copy, b);
    CHECK_INT_EQ(strlen(a), 64);
    CHECK_STR_CONTAINS(a, b);
    CHECK(strcmp(original->source, copy->source) != 0);

    /* Other whitespace and another field order inside an object: same content. */
    char *reordered = strdup(text), *relaid = malloc(strlen(text) * 2 + 1), *o = relaid;
    replace_once(reordered, "\"target\": [0, 1, 0], \"up\": [0, 1, 0]", "\"up\": [0, 1, 0], \"target\": [0, 1, 0]");
    for (const char *p = reordered; *p; p++) {
      *o++ = *p;
      if (*p == ',') *o++ = '\n';
    }
    *o = '\0';
    free(reordered);
    snprintf(path, sizeof path, "%s/relaid.json", dir);
    write_all(path, relaid);
    vf_scene *r = load_ok(path);
    if (r) CHECK(memcmp(r->hash, original->hash, 32) == 0);
    vf_scene_destroy(r);
    free(relaid);

    /* One albedo channel changed. */
    replace_once(text, "[0.8, 0.8, 0.8]", "[0.8, 0.8, 0.7]");
    snprintf(path, sizeof path, "%s/changed.json", dir);
    write_all(path, text);
    vf_scene *changed = load_ok(path);
    if (changed) CHECK(memcmp(changed->hash, original->hash, 32) != 0);
    vf_scene_destroy(changed);

    /* A mesh file's content is part of the scene too. */
    snprintf(path, sizeof path, "%s/meshes/tri.ply", dir);
    char *ply = read_all(SCENES "/good/meshes/tri.ply");
    replace_once(ply, "\n0 1 0\n", "\n0 2 0\n");
    write_all(path, ply);
    free(ply);
    snprintf(path, sizeof path, "%s/copy.json", dir);
    vf_scene *moved = load_ok(path);
    if (moved) CHECK(memcmp(moved->hash, original->hash, 32) != 0);
    vf_scene_destroy(moved);

    /* Recomputing gives the stored hash. */
    uint8_t before[32];
    memcpy(before, original->hash, 32);
    vf_scene_hash(original);
    CHECK(memcmp(before, original->hash, 32) == 0);
  }
  free(text);
  vf_scene_destroy(original);
  vf_scene_destroy(copy);
  remove_tree(dir);
}

static void test_environment_map_is_loaded_and_hashed(void) {
  char dir[64], exr[256], json[256];
  make_temp_dir(dir);
  vf_image img = {0, 0, NULL};
  CHECK_INT_EQ(vf_image_alloc(&img, 8, 4), VF_OK);
  for (int i = 0; i < 3 * 8 * 4; i++) img.rgb[i] = 0.25f * (float)(i % 5);
  snprintf(exr, sizeof exr, "%s/sky.exr", dir);
  CHECK_INT_EQ(vf_image_write_exr(exr, &img), VF_OK);
  const char *scene =
      "{\"camera\": {\"position\": [0, 0, 3], \"forward\": [0, 0, -1], \"fov\": 40},\n"
      " \"materials\": {\"white\": {\"diffuse\": [0.5, 0.5, 0.5]}},\n"
      " \"shapes\": [{\"type\": \"sphere\", \"center\": [0, 0, 0], \"radius\": 1, \"material\": \"white\"}],\n"
      " \"lights\": [{\"type\": \"environment\", \"file\": \"sky.exr\", \"scale\": [2, 2, 2]}]}\n";
  snprintf(json, sizeof json, "%s/env.json", dir);
  write_all(json, scene);
  vf_scene *s = load_ok(json);
  if (s) {
    CHECK_INT_EQ(s->envmap.width, 8);
    CHECK_INT_EQ(s->envmap.height, 4);
    CHECK_NEAR(s->envmap.rgb[7], img.rgb[7], 1e-6);
    CHECK_NEAR(s->envmap_scale.y, 2.0, 0.0);
    CHECK_INT_EQ(s->settings_given, 0);
    CHECK_INT_EQ(s->settings.width, 512); /* default resolution */
    uint8_t before[32];
    memcpy(before, s->hash, 32);
    s->envmap.rgb[0] += 1.0f; /* the pixels are hashed */
    vf_scene_hash(s);
    CHECK(memcmp(before, s->hash, 32) != 0);
    vf_scene_destroy(s);
  }
  img.rgb[5] = -1.0f;
  CHECK_INT_EQ(vf_image_write_exr(exr, &img), VF_OK);
  s = NULL;
  int err = vf_scene_load(json, &s);
  CHECK_INT_EQ(err, VF_ESCENE);
  CHECK_STR_CONTAINS(vf_error_detail(err), "env.json: lights[0].file: pixel (1, 0) of 'sky.exr' is negative");
  CHECK(unlink(exr) == 0);
  err = vf_scene_load(json, &s);
  CHECK_INT_EQ(err, VF_ENOENT);
  CHECK_STR_CONTAINS(vf_error_detail(err), "env.json: lights[0].file: cannot open 'sky.exr'");
  CHECK(s == NULL);
  vf_image_destroy(&img);
  remove_tree(dir);
}

/* ---- bad scenes ----------------------------------------------------------------------------- */

/* Codes other than VF_ESCENE: mesh content is VF_EMESH, missing files VF_ENOENT. */
static int expected_code(const char *file) {
  static const struct {
    const char *file;
    int code;
  } codes[] = {{"missing_mesh.json", VF_ENOENT},
               {"nan_vertex.json", VF_EMESH},
               {"corrupt_mesh.json", VF_EMESH},
               {"out_of_range_obj.json", VF_EMESH},
               {"medium_missing_grid.json", VF_ENOENT}};
  for (size_t i = 0; i < sizeof codes / sizeof codes[0]; i++)
    if (strcmp(codes[i].file, file) == 0) return codes[i].code;
  return VF_ESCENE;
}

static void test_every_bad_scene_fails_naming_file_and_field(void) {
  FILE *f = fopen(SCENES "/bad/EXPECTED.txt", "r");
  CHECK(f != NULL);
  if (f == NULL) return;
  char line[512];
  int count = 0;
  while (fgets(line, sizeof line, f)) {
    line[strcspn(line, "\n")] = '\0';
    char *tab = strchr(line, '\t');
    CHECK(tab != NULL);
    if (tab == NULL) continue;
    *tab = '\0';
    char path[1024];
    snprintf(path, sizeof path, "%s/bad/%s", SCENES, line);
    vf_scene *s = (vf_scene *)&count; /* must stay untouched on failure */
    vf_error_clear();
    int err = vf_scene_load(path, &s);
    if (err != expected_code(line))
      CHECK_FAIL_("%s: code %d (%s) != expected %d (%s)", line, err, vf_strerror(err), expected_code(line),
                  vf_strerror(expected_code(line)));
    CHECK(s == (vf_scene *)&count);
    if (err == VF_OK) vf_scene_destroy(s);
    CHECK_STR_CONTAINS(vf_error_detail(err), tab + 1);
    count++;
  }
  fclose(f);
  CHECK(count >= 20);

  /* Every .json in bad/ has its line in EXPECTED.txt. */
  char *expected = read_all(SCENES "/bad/EXPECTED.txt");
  DIR *d = opendir(SCENES "/bad");
  CHECK(d != NULL && expected != NULL);
  for (struct dirent *e; d && expected && (e = readdir(d)) != NULL;) {
    size_t n = strlen(e->d_name);
    if (n < 5 || strcmp(e->d_name + n - 5, ".json") != 0) continue;
    char key[300];
    snprintf(key, sizeof key, "%s\t", e->d_name);
    CHECK_STR_CONTAINS(expected, key);
  }
  if (d) closedir(d);
  free(expected);
}

static void test_named_bad_cases_return_their_codes(void) {
  static const struct {
    const char *file;
    int code;
    const char *detail;
  } cases[] = {
      {"syntax.json", VF_ESCENE, "syntax.json: line 3: JSON syntax error near"},
      {"unknown_field.json", VF_ESCENE, "unknown_field.json: camera.positon: unknown field"},
      {"missing_mesh.json", VF_ENOENT, "missing_mesh.json: shapes[0].file: cannot open 'missing.obj'"},
      {"nan_vertex.json", VF_EMESH, "nan_vertex.json: shapes[0] (nan_vertex.ply): vertex 2 has a non-finite"},
      {"zero_area_light.json", VF_ESCENE, "zero_area_light.json: shapes[1]: emissive shape has zero area"},
      {"negative_radiance.json", VF_ESCENE, "negative_radiance.json: shapes[0].emission: negative radiance"},
      {"ior_zero.json", VF_ESCENE, "ior_zero.json: materials.glass.ior: must be > 0"},
      {"resolution_zero.json", VF_ESCENE, "resolution_zero.json: camera.resolution: must be positive"},
      {"index_out_of_range.json", VF_ESCENE, "index_out_of_range.json: shapes[0].indices[2]: index 3 out of range"},
      {"out_of_range_obj.json", VF_EMESH, "out_of_range_obj.json: shapes[0].file: cannot read 'out_of_range.obj'"},
      {"albedo_sum.json", VF_ESCENE, "albedo_sum.json: materials.hot: albedo sum of the lobes exceeds 1"},
      {"no_light.json", VF_ESCENE, "no_light.json: the scene has no light"},
      {"infinite_number.json", VF_ESCENE, "infinite_number.json: camera.fov: not a finite number"},
  };
  for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
    char path[512];
    snprintf(path, sizeof path, "%s/bad/%s", SCENES, cases[i].file);
    vf_scene *s = NULL;
    int err = vf_scene_load(path, &s);
    CHECK_INT_EQ(err, cases[i].code);
    CHECK(s == NULL);
    CHECK_STR_CONTAINS(vf_error_detail(err), cases[i].detail);
  }
}

static void test_missing_scene_file_and_unknown_builtin(void) {
  vf_scene *s = NULL;
  int err = vf_scene_load(SCENES "/no/such/scene.json", &s);
  CHECK_INT_EQ(err, VF_ENOENT);
  CHECK_STR_CONTAINS(vf_error_detail(err), "scene.json: cannot open");
  err = vf_scene_load("cornel", &s); /* a typo of a built-in is looked up as a file */
  CHECK_INT_EQ(err, VF_ENOENT);
  CHECK(s == NULL);
  vf_scene_destroy(NULL);
}

/* 200,000 materials and 20,000 shapes load in linear-logarithmic time (issue 41: the
 * duplicate-key check and the name lookups were quadratic, over 60 s). The bound is the
 * test's: 20 s on a loaded machine where the load takes about a second. */
static void test_many_materials_load_in_n_log_n(void) {
  enum { MATERIALS = 200000, SHAPES = 20000 };
  char path[] = "/tmp/test_scene_many.XXXXXX";
  int fd = mkstemp(path);
  FILE *f = fd >= 0 ? fdopen(fd, "w") : NULL;
  CHECK(f != NULL);
  if (f == NULL) return;
  fprintf(f, "{\"camera\": {\"position\": [0, 0, 5], \"target\": [0, 0, 0], \"fov\": 40},\n \"materials\": {");
  for (int i = 0; i < MATERIALS; i++) fprintf(f, "%s\"m%d\": {\"diffuse\": [0.5, 0.5, 0.5]}", i ? ", " : "", i);
  fprintf(f, "},\n \"shapes\": [");
  for (int i = 0; i < SHAPES; i++)
    fprintf(f, "%s{\"type\": \"mesh\", \"material\": \"m%d\", \"positions\": [%d, 0, 0, %d, 1, 0, %d, 0, 1], \"indices\": [0, 1, 2]}",
            i ? ", " : "", (i * 7919) % MATERIALS, i, i, i);
  fprintf(f, "],\n \"lights\": [{\"type\": \"background\", \"radiance\": [1, 1, 1]}]}\n");
  fclose(f);
  struct timespec t0, t1;
  clock_gettime(CLOCK_MONOTONIC, &t0);
  vf_scene *s = load_ok(path);
  clock_gettime(CLOCK_MONOTONIC, &t1);
  double seconds = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
  printf("  %d materials, %d shapes: loaded in %.2f s\n", MATERIALS, SHAPES, seconds);
  CHECK(seconds < 20.0);
  if (s != NULL) {
    CHECK_INT_EQ(s->num_materials, MATERIALS);
    CHECK_INT_EQ(s->num_shapes, SHAPES);
    CHECK_INT_EQ(s->shapes[SHAPES - 1].material, ((SHAPES - 1) * 7919) % MATERIALS); /* by name, in file order */
    CHECK_STR_CONTAINS(s->materials[s->shapes[123].material].name, "m");
  }
  vf_scene_destroy(s);
  /* A repeated key among many is still found, and named. */
  f = fopen(path, "w");
  if (f != NULL) {
    fprintf(f, "{\"camera\": {\"position\": [0, 0, 5], \"target\": [0, 0, 0], \"fov\": 40},\n \"materials\": {");
    for (int i = 0; i < 1000; i++) fprintf(f, "%s\"m%d\": {}", i ? ", " : "", i == 900 ? 17 : i);
    fprintf(f, "},\n \"shapes\": [{\"type\": \"sphere\", \"center\": [0, 0, 0], \"radius\": 1, \"material\": \"m1\", "
               "\"emission\": [1, 1, 1]}]}\n");
    fclose(f);
    s = NULL;
    int err = vf_scene_load(path, &s);
    CHECK_INT_EQ(err, VF_ESCENE);
    CHECK_STR_CONTAINS(vf_error_detail(err), "materials.m17: duplicate field");
    vf_scene_destroy(s);
  }
  unlink(path);
}

/* --background on any scene: a grey or R,G,B radiance replaces the background or map, an
 * EXR map replaces both with scale 1; the hash follows; bad specs change nothing. */
static void test_background_replaced_after_load(void) {
  vf_scene *s = load_ok("cornell-env");
  if (s == NULL) return;
  uint8_t before[32];
  memcpy(before, s->hash, 32);
  CHECK_INT_EQ(vf_scene_set_background(s, "0.5"), VF_OK);
  CHECK(s->background.x == 0.5f && s->background.z == 0.5f && s->envmap.width == 0);
  CHECK(memcmp(before, s->hash, 32) != 0);
  CHECK_INT_EQ(vf_scene_set_background(s, "1,0.5,0.25"), VF_OK);
  CHECK(s->background.x == 1.0f && s->background.y == 0.5f && s->background.z == 0.25f);
  static const char *const bad[] = {"1,2", "-1", "1,2,3,4", "nan", "sky.png", "0.5x"};
  for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
    int err = vf_scene_set_background(s, bad[i]);
    CHECK_INT_EQ(err, VF_EUSAGE);
    CHECK_STR_CONTAINS(vf_error_detail(err), "--background");
  }
  CHECK(s->background.y == 0.5f); /* unchanged by the refusals */
  char dir[64], exr[256];
  make_temp_dir(dir);
  vf_image img = {0, 0, NULL};
  CHECK_INT_EQ(vf_image_alloc(&img, 4, 2), VF_OK);
  for (int i = 0; i < 3 * 4 * 2; i++) img.rgb[i] = 0.125f * (float)i;
  snprintf(exr, sizeof exr, "%s/bg.EXR", dir);
  CHECK_INT_EQ(vf_image_write_exr(exr, &img), VF_OK);
  CHECK_INT_EQ(vf_scene_set_background(s, exr), VF_OK);
  CHECK(s->envmap.width == 4 && s->envmap.height == 2 && s->envmap_scale.x == 1.0f && vf_is_zero(s->background));
  if (s->envmap.rgb) CHECK_NEAR(s->envmap.rgb[5], 0.625, 0);
  unlink(exr);
  rmdir(dir);
  vf_image_destroy(&img);
  vf_scene_destroy(s);
}

/* ---- the glTF model's clear coat and sheen in JSON (docs/SCENES.md, "Rough materials") ---- */

/* The scene of one glTF material `m` (the text of its object's members) on a sphere, loaded
 * from dir; the error's detail in *detail (or "") when it is refused. */
static vf_scene *load_material(const char *dir, const char *m, char *detail, size_t n, int *code) {
  char path[256], json[2048];
  snprintf(json, sizeof json,
           "{\"camera\": {\"position\": [0, 0, 5], \"target\": [0, 0, 0], \"fov\": 40},\n"
           " \"materials\": {\"m\": {\"base_color\": [0.5, 0.4, 0.3], \"metallic\": 0, \"roughness\": 0.5%s%s}},\n"
           " \"shapes\": [{\"type\": \"sphere\", \"center\": [0, 0, 0], \"radius\": 1, \"material\": \"m\","
           " \"emission\": [1, 1, 1]}]}\n",
           m[0] ? ", " : "", m);
  snprintf(path, sizeof path, "%s/m.json", dir);
  write_all(path, json);
  vf_scene *s = NULL;
  int err = vf_scene_load(path, &s);
  snprintf(detail, n, "%s", err == VF_OK ? "" : vf_error_detail(err));
  *code = err;
  return s;
}

static void test_json_clearcoat_and_sheen_fields(void) {
  char dir[64], path[256], detail[512];
  int code;
  make_temp_dir(dir);
  /* Two small linear EXR textures: one in [0, 1], one with a texel of 2. */
  vf_image img = {0, 0, NULL};
  CHECK_INT_EQ(vf_image_alloc(&img, 2, 2), VF_OK);
  for (int i = 0; i < 12; i++) img.rgb[i] = 0.25f + 0.05f * (float)i;
  snprintf(path, sizeof path, "%s/layer.exr", dir);
  CHECK_INT_EQ(vf_image_write_exr(path, &img), VF_OK);
  img.rgb[4] = 2.0f;
  snprintf(path, sizeof path, "%s/over.exr", dir);
  CHECK_INT_EQ(vf_image_write_exr(path, &img), VF_OK);
  vf_image_destroy(&img);

  /* None of the fields: no layers, as before they existed. */
  vf_scene *plain = load_material(dir, "", detail, sizeof detail, &code);
  vf_scene *s = load_material(dir,
                              "\"clearcoat\": 0.75, \"clearcoat_roughness\": 0.2, \"clearcoat_texture\": \"layer.exr\","
                              " \"clearcoat_roughness_texture\": {\"file\": \"layer.exr\", \"wrap\": \"clamp\"},"
                              " \"clearcoat_normal_texture\": \"layer.exr\", \"clearcoat_normal_scale\": -0.5,"
                              " \"sheen_color\": [0.9, 0.5, 0], \"sheen_roughness\": 0.3,"
                              " \"sheen_color_texture\": \"layer.exr\", \"sheen_roughness_texture\": \"layer.exr\"",
                              detail, sizeof detail, &code);
  if (*detail) CHECK_FAIL_("%s", detail);
  if (plain != NULL && s != NULL) {
    const vf_material *p = &plain->materials[0], *m = &s->materials[0];
    CHECK(p->gltf && p->clearcoat == 0.0f && vf_is_zero(p->sheen_color) && p->textures[VF_TEXTURE_CLEARCOAT].texture == 0);
    CHECK(m->gltf);
    CHECK_NEAR(m->clearcoat, 0.75, 0);
    CHECK_NEAR(m->clearcoat_roughness, 0.2, 1e-7);
    CHECK_NEAR(m->clearcoat_normal_scale, -0.5, 0);
    CHECK_NEAR(m->sheen_color.x, 0.9, 1e-7);
    CHECK_NEAR(m->sheen_color.z, 0.0, 0);
    CHECK_NEAR(m->sheen_roughness, 0.3, 1e-7);
    static const int slots[] = {VF_TEXTURE_CLEARCOAT, VF_TEXTURE_CLEARCOAT_ROUGHNESS, VF_TEXTURE_CLEARCOAT_NORMAL,
                                VF_TEXTURE_SHEEN_COLOR, VF_TEXTURE_SHEEN_ROUGHNESS};
    for (size_t k = 0; k < sizeof slots / sizeof slots[0]; k++) CHECK(m->textures[slots[k]].texture == 1);
    CHECK_INT_EQ(m->textures[VF_TEXTURE_CLEARCOAT_ROUGHNESS].wrap_s, VF_WRAP_CLAMP);
    CHECK_INT_EQ(s->num_textures, 1); /* one file, decoded once */
    CHECK(memcmp(plain->hash, s->hash, 32) != 0);
  }
  vf_scene_destroy(s);
  /* A coat alone, then the same with a different weight: the hash sees the value; the
   * clear-coat normal scale defaults to 1. */
  s = load_material(dir, "\"clearcoat\": 0.5", detail, sizeof detail, &code);
  vf_scene *t = load_material(dir, "\"clearcoat\": 0.5000001", detail, sizeof detail, &code);
  if (s != NULL && t != NULL) {
    CHECK_NEAR(s->materials[0].clearcoat_normal_scale, 1.0, 0);
    CHECK(memcmp(s->hash, t->hash, 32) != 0);
  }
  vf_scene_destroy(s);
  vf_scene_destroy(t);
  vf_scene_destroy(plain);

  /* Refused, naming the field. */
  static const struct {
    const char *members, *message;
  } bad[] = {
      {"\"clearcoat\": 1.5", "materials.m.clearcoat: must be in [0, 1], found 1.5"},
      {"\"clearcoat\": -0.1", "materials.m.clearcoat: must be in [0, 1]"},
      {"\"clearcoat\": 1, \"clearcoat_roughness\": 2", "materials.m.clearcoat_roughness: must be in [0, 1], found 2"},
      {"\"clearcoat_roughness\": 0.3", "materials.m.clearcoat_roughness: needs a non-zero 'clearcoat'"},
      {"\"clearcoat\": 0, \"clearcoat_texture\": \"layer.exr\"",
       "materials.m.clearcoat_texture: needs a non-zero 'clearcoat' (0 is no coat)"},
      {"\"clearcoat\": 1, \"clearcoat_normal_scale\": 2",
       "materials.m.clearcoat_normal_scale: needs 'clearcoat_normal_texture'"},
      {"\"clearcoat\": 1, \"clearcoat_texture\": \"over.exr\"",
       "materials.m.clearcoat_texture: texel (1, 0) of 'over.exr' is 2 in channel 1, outside [0, 1]"},
      {"\"clearcoat\": 1, \"clearcoat_texture\": \"missing.png\"", "materials.m.clearcoat_texture"},
      {"\"clearcoat\": \"high\"", "materials.m.clearcoat: expected a number"},
      {"\"sheen_color\": [1.2, 0, 0]", "materials.m.sheen_color: exceeds 1 in a channel"},
      {"\"sheen_color\": [0.5, -1, 0]", "materials.m.sheen_color: negative colour"},
      {"\"sheen_color\": [0.5, 0.5]", "materials.m.sheen_color"},
      {"\"sheen_roughness\": 0.5", "materials.m.sheen_roughness: needs a non-zero 'sheen_color'"},
      {"\"sheen_color\": [0, 0, 0], \"sheen_color_texture\": \"layer.exr\"",
       "materials.m.sheen_color_texture: needs a non-zero 'sheen_color' (black is no sheen)"},
      {"\"sheen_color\": [1, 1, 1], \"sheen_roughness\": 1.01", "materials.m.sheen_roughness: must be in [0, 1]"},
      {"\"clearcoat_weight\": 1", "materials.m.clearcoat_weight: unknown field"},
  };
  for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
    vf_scene *b = load_material(dir, bad[i].members, detail, sizeof detail, &code);
    CHECK(b == NULL);
    CHECK_INT_EQ(code, strstr(bad[i].members, "missing") ? VF_ENOENT : VF_ESCENE);
    vf_scene_destroy(b);
    if (strstr(detail, bad[i].message) == NULL) CHECK_FAIL_("{%s}: '%s' lacks '%s'", bad[i].members, detail, bad[i].message);
  }
  /* The lobe materials have no layers: a coat there is an unknown field. */
  snprintf(path, sizeof path, "%s/lobes.json", dir);
  write_all(path, "{\"camera\": {\"position\": [0, 0, 5], \"target\": [0, 0, 0], \"fov\": 40},\n"
                  " \"materials\": {\"m\": {\"diffuse\": [0.5, 0.5, 0.5], \"clearcoat\": 1}},\n"
                  " \"shapes\": [{\"type\": \"sphere\", \"center\": [0, 0, 0], \"radius\": 1, \"material\": \"m\","
                  " \"emission\": [1, 1, 1]}]}\n");
  vf_scene *b = NULL;
  int err = vf_scene_load(path, &b);
  CHECK_INT_EQ(err, VF_ESCENE);
  CHECK_STR_CONTAINS(vf_error_detail(err), "materials.m.clearcoat: unknown field");
  vf_scene_destroy(b);
  remove_tree(dir);
}

int main(void) {
  RUN(test_json_clearcoat_and_sheen_fields);
  RUN(test_background_replaced_after_load);
  RUN(test_many_materials_load_in_n_log_n);
  RUN(test_every_builtin_loads_with_sane_bounds);
  RUN(test_cornell_walls_face_inwards_and_light_faces_down);
  RUN(test_cornell_variants_have_their_lights);
  RUN(test_furnace_is_a_closed_inward_emitting_cube);
  RUN(test_knot_is_a_large_outward_tube_inside_the_box);
  RUN(test_builtin_hashes_are_stable_and_distinct);
  RUN(test_file_scene_loads_meshes_and_applies_transforms);
  RUN(test_gltf_node_transform_and_scene_transform_compose);
  RUN(test_obj_vertices_joined_indexed_gltf_vertices_kept);
  RUN(test_hash_ignores_path_and_layout_but_sees_one_value);
  RUN(test_environment_map_is_loaded_and_hashed);
  RUN(test_every_bad_scene_fails_naming_file_and_field);
  RUN(test_named_bad_cases_return_their_codes);
  RUN(test_missing_scene_file_and_unknown_builtin);
  return check_finish();
}
