/* Whole-scene import (worker/scene/import.c): a glTF 2.0 file and an OBJ+MTL written here,
 * checked field by field against what they say (world positions through a node hierarchy,
 * normals by the inverse transpose, the uv convention, cameras, lights, every material
 * parameter and texture slot), their notes, and bad files refused naming file and problem. */
#include "check.h"
#include "common/error.h"
#include "worker/scene/scene.h"
#include "worker/scene/load.h"

#include <png.h>

#include <dirent.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

/* ---- fixtures ---------------------------------------------------------------------------- */

static char dir[64];

static void path_of(char *out, size_t n, const char *name) { snprintf(out, n, "%s/%s", dir, name); }

static void write_file(const char *name, const void *bytes, size_t n) {
  char p[256];
  path_of(p, sizeof p, name);
  FILE *f = fopen(p, "wb");
  CHECK(f != NULL && fwrite(bytes, 1, n, f) == n);
  if (f) fclose(f);
}

static void write_png(const char *name, int channels, const uint8_t *texels, int w, int h) {
  char p[256];
  png_image img;
  memset(&img, 0, sizeof img);
  img.version = PNG_IMAGE_VERSION;
  img.width = (png_uint_32)w;
  img.height = (png_uint_32)h;
  img.format = channels == 1 ? PNG_FORMAT_GRAY : channels == 3 ? PNG_FORMAT_RGB : PNG_FORMAT_RGBA;
  path_of(p, sizeof p, name);
  CHECK(png_image_write_to_file(&img, p, 0, texels, 0, NULL));
}

/* One triangle with normals, uvs and tangents; `nan` spoils a normal (1), a uv (2) or two
 * tangents (3). */
static void write_buffer(int nan) {
  float b[38] = {0, 0, 0, 1, 0, 0, 0, 1, 0,                      /* positions, offset 0 */
                 0.6f, 0, 0.8f, 0, 0, 1, 0, 0, 1,                /* normals, 36 */
                 0, 0, 1, 0, 0, 1,                               /* uvs (glTF: t = 0 top), 72 */
                 1, 0, 0, 1, 1, 0, 0, 1, 1, 0, 0, -1};           /* tangents, 96 */
  if (nan == 1) b[12] = NAN; /* vertex 1's normal */
  if (nan == 2) b[20] = INFINITY; /* vertex 1's u */
  if (nan == 3) b[24] = 2.0f, b[32] = 0.0f; /* vertex 0's tangent of length 2, vertex 2's zero */
  uint8_t bytes[152] = {0};
  memcpy(bytes, b, 144);
  const uint16_t idx[3] = {0, 1, 2};
  memcpy(bytes + 144, idx, 6);
  write_file("model.bin", bytes, 150);
}

static void write_textures(void) {
  const uint8_t rgba[16] = {255, 0, 0, 255, 0, 255, 0, 0, 0, 0, 255, 255, 255, 255, 255, 0};
  const uint8_t rgb[12] = {0, 128, 255, 0, 64, 32, 0, 255, 0, 0, 0, 0};
  const uint8_t normal[12] = {128, 128, 255, 128, 128, 255, 128, 128, 255, 128, 128, 255};
  const uint8_t grey[4] = {10, 200, 90, 30};
  write_png("base.png", 4, rgba, 2, 2);
  write_png("mr.png", 3, rgb, 2, 2);
  write_png("nrm.png", 3, normal, 2, 2);
  write_png("normal map.png", 3, normal, 2, 2); /* the glTF names it by URI: "normal%20map.png" */
  write_png("bump.png", 1, grey, 2, 2);
}

/* The glTF of the test: `accessors` replaces the accessor list when given (broken ones). */
static const char gltf_head[] =
    "{\"asset\": {\"version\": \"2.0\"},\n"
    " \"extensionsUsed\": [\"KHR_lights_punctual\", \"KHR_materials_emissive_strength\",\n"
    "   \"KHR_materials_transmission\", \"KHR_materials_ior\", \"KHR_materials_iridescence\", \"KHR_texture_transform\"],\n"
    " \"scene\": 0, \"scenes\": [{\"nodes\": [0, 2, 3, 4, 5, 6, 7]}],\n"
    " \"nodes\": [\n"
    "  {\"name\": \"Parent\", \"translation\": [10, 0, 0], \"scale\": [2, 2, 2], \"children\": [1]},\n"
    "  {\"name\": \"Child\", \"mesh\": 0, \"rotation\": [0, 0, 0.70710678, 0.70710678]},\n"
    "  {\"name\": \"Squash\", \"mesh\": 1, \"scale\": [2, 1, 1]},\n"
    "  {\"name\": \"CamNode\", \"camera\": 0, \"translation\": [0, 1, 5]},\n"
    "  {\"name\": \"TopCam\", \"camera\": 1, \"translation\": [0, 10, 0], \"rotation\": [-0.70710678, 0, 0, 0.70710678]},\n"
    "  {\"name\": \"PointNode\", \"translation\": [1, 2, 3], \"extensions\": {\"KHR_lights_punctual\": {\"light\": 0}}},\n"
    "  {\"name\": \"SpotNode\", \"translation\": [0, 5, 0], \"rotation\": [-0.70710678, 0, 0, 0.70710678],\n"
    "   \"extensions\": {\"KHR_lights_punctual\": {\"light\": 1}}},\n"
    "  {\"name\": \"SunNode\", \"rotation\": [-0.70710678, 0, 0, 0.70710678], \"extensions\": {\"KHR_lights_punctual\": {\"light\": 2}}}],\n"
    " \"cameras\": [{\"type\": \"perspective\", \"perspective\": {\"yfov\": 0.8, \"aspectRatio\": 1.5, \"znear\": 0.1}},\n"
    "   {\"type\": \"perspective\", \"perspective\": {\"yfov\": 0.5, \"aspectRatio\": 1.0, \"znear\": 0.1}}],\n"
    " \"extensions\": {\"KHR_lights_punctual\": {\"lights\": [\n"
    "   {\"type\": \"point\", \"color\": [1, 0.5, 0.25], \"intensity\": 100},\n"
    "   {\"type\": \"spot\", \"intensity\": 50, \"spot\": {\"innerConeAngle\": 0.2, \"outerConeAngle\": 0.5}},\n"
    "   {\"type\": \"directional\", \"intensity\": 3}]}},\n"
    " \"meshes\": [{\"name\": \"Tri\", \"primitives\": [{\"attributes\": {\"POSITION\": 0, \"NORMAL\": 1, \"TEXCOORD_0\": 2,\n"
    "   \"TANGENT\": 3}, \"indices\": 4, \"material\": 0}]},\n"
    "  {\"name\": \"GlassTri\", \"primitives\": [{\"attributes\": {\"POSITION\": 0, \"NORMAL\": 1}, \"indices\": 4, \"material\": 1}]}],\n"
    " \"materials\": [\n"
    "  {\"name\": \"Red\", \"pbrMetallicRoughness\": {\"baseColorFactor\": [0.8, 0.2, 0.1, 0.5], \"metallicFactor\": 0.3,\n"
    "     \"roughnessFactor\": 0.6, \"baseColorTexture\": {\"index\": 0}, \"metallicRoughnessTexture\": {\"index\": 1}},\n"
    "   \"normalTexture\": {\"index\": 2, \"scale\": 0.7}, \"emissiveTexture\": {\"index\": 1},\n"
    "   \"emissiveFactor\": [1, 0.5, 0], \"alphaMode\": \"MASK\", \"alphaCutoff\": 0.3,\n"
    "   \"extensions\": {\"KHR_materials_emissive_strength\": {\"emissiveStrength\": 4}}},\n"
    "  {\"name\": \"Glass\", \"pbrMetallicRoughness\": {\"baseColorFactor\": [0.9, 0.95, 1, 1], \"roughnessFactor\": 0.1},\n"
    "   \"extensions\": {\"KHR_materials_transmission\": {\"transmissionFactor\": 1}, \"KHR_materials_ior\": {\"ior\": 1.45}}}],\n"
    " \"samplers\": [{\"wrapS\": 33071, \"wrapT\": 33648}],\n"
    " \"images\": [{\"uri\": \"base.png\"}, {\"uri\": \"mr.png\"}, {\"uri\": \"normal%20map.png\"}],\n"
    " \"textures\": [{\"source\": 0, \"sampler\": 0}, {\"source\": 1}, {\"source\": 2}],\n"
    " \"buffers\": [{\"uri\": \"model.bin\", \"byteLength\": 150}],\n";

static const char good_accessors[] =
    " \"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": 144}, {\"buffer\": 0, \"byteOffset\": 144, \"byteLength\": 6}],\n"
    " \"accessors\": [\n"
    "  {\"bufferView\": 0, \"byteOffset\": 0, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\", \"min\": [0,0,0], \"max\": [1,1,0]},\n"
    "  {\"bufferView\": 0, \"byteOffset\": 36, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\"},\n"
    "  {\"bufferView\": 0, \"byteOffset\": 72, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC2\"},\n"
    "  {\"bufferView\": 0, \"byteOffset\": 96, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC4\"},\n"
    "  {\"bufferView\": 1, \"byteOffset\": 0, \"componentType\": 5123, \"count\": 3, \"type\": \"SCALAR\"}]}\n";

static void write_gltf(const char *accessors) {
  char text[8192];
  snprintf(text, sizeof text, "%s%s", gltf_head, accessors ? accessors : good_accessors);
  write_file("model.gltf", text, strlen(text));
}

static void fresh_dir(void) {
  snprintf(dir, sizeof dir, "/tmp/test_import.XXXXXX");
  CHECK(mkdtemp(dir) != NULL);
  write_textures();
  write_buffer(0);
  write_gltf(NULL);
}

static void remove_dir(void) {
  DIR *d = opendir(dir);
  struct dirent *e;
  char p[512];
  while (d && (e = readdir(d)) != NULL) {
    if (e->d_name[0] == '.') continue;
    snprintf(p, sizeof p, "%s/%s", dir, e->d_name);
    unlink(p);
  }
  if (d) closedir(d);
  rmdir(dir);
}

static vf_scene *load(const char *name, const char *camera) {
  char p[256];
  vf_scene *s = NULL;
  path_of(p, sizeof p, name);
  int err = vf_scene_load_camera(p, camera, &s);
  if (err != VF_OK) CHECK_FAIL_("loading %s: %s", p, vf_error_detail(err));
  return s;
}

/* The error loading `name` (with `camera`): its code, and its detail into `detail`. */
static int load_error(const char *name, const char *camera, char *detail, size_t n) {
  char p[256];
  vf_scene *s = NULL;
  path_of(p, sizeof p, name);
  int err = vf_scene_load_camera(p, camera, &s);
  snprintf(detail, n, "%s", err == VF_OK ? "(loaded)" : vf_error_detail(err));
  vf_scene_destroy(s);
  return err;
}

static const vf_shape *shape_named(const vf_scene *s, const char *name) {
  for (int i = 0; s && i < s->num_shapes; i++)
    if (strcmp(s->shapes[i].name, name) == 0) return &s->shapes[i];
  CHECK_FAIL_("no shape named '%s'", name);
  return NULL;
}

static int material_named(const vf_scene *s, const char *name) {
  for (int i = 0; s && i < s->num_materials; i++)
    if (strcmp(s->materials[i].name, name) == 0) return i;
  CHECK_FAIL_("no material named '%s'", name);
  return 0;
}

/* The vertex of s at (x, y, z), or -1. */
static int vertex_at(const vf_shape *s, float x, float y, float z) {
  for (uint32_t v = 0; s && v < s->num_vertices; v++)
    if (fabsf(s->positions[3 * v] - x) < 1e-5f && fabsf(s->positions[3 * v + 1] - y) < 1e-5f &&
        fabsf(s->positions[3 * v + 2] - z) < 1e-5f)
      return (int)v;
  CHECK_FAIL_("no vertex at (%g, %g, %g)", x, y, z);
  return -1;
}

#define CHECK_VEC(v, ex, ey, ez, tol)                                                                 \
  do {                                                                                                \
    CHECK_NEAR((v).x, ex, tol);                                                                        \
    CHECK_NEAR((v).y, ey, tol);                                                                        \
    CHECK_NEAR((v).z, ez, tol);                                                                        \
  } while (0)

/* ---- glTF -------------------------------------------------------------------------------- */

static void test_gltf_node_hierarchy_moves_positions_normals_and_tangents(void) {
  vf_scene *s = load("model.gltf", NULL);
  const vf_shape *tri = shape_named(s, "Tri"), *squash = shape_named(s, "GlassTri");
  if (tri == NULL || squash == NULL) goto done;
  CHECK_INT_EQ(s->num_shapes, 2);
  CHECK_INT_EQ(tri->num_triangles, 1);
  /* Child: translate (10, 0, 0) x scale 2 (parent) x rotate 90 degrees about z. */
  int v0 = vertex_at(tri, 10, 0, 0), v1 = vertex_at(tri, 10, 2, 0), v2 = vertex_at(tri, 8, 0, 0);
  CHECK(tri->normals != NULL && tri->uvs != NULL && tri->tangents != NULL);
  if (v0 < 0 || v1 < 0 || v2 < 0 || !tri->normals || !tri->uvs || !tri->tangents) goto done;
  /* (0.6, 0, 0.8) rotated about z: (0, 0.6, 0.8). */
  CHECK_NEAR(tri->normals[3 * v0], 0.0, 1e-6);
  CHECK_NEAR(tri->normals[3 * v0 + 1], 0.6, 1e-6);
  CHECK_NEAR(tri->normals[3 * v0 + 2], 0.8, 1e-6);
  /* The file's uvs are glTF's (t = 0 the top row): kept as they were written. */
  CHECK_NEAR(tri->uvs[2 * v1], 1.0, 1e-6);
  CHECK_NEAR(tri->uvs[2 * v1 + 1], 0.0, 1e-6);
  CHECK_NEAR(tri->uvs[2 * v2], 0.0, 1e-6);
  CHECK_NEAR(tri->uvs[2 * v2 + 1], 1.0, 1e-6);
  /* Tangent (1, 0, 0) rotated: (0, 1, 0); w as in the file. */
  CHECK_NEAR(tri->tangents[4 * v0 + 1], 1.0, 1e-6);
  CHECK_NEAR(tri->tangents[4 * v0 + 3], 1.0, 0);
  CHECK_NEAR(tri->tangents[4 * v2 + 3], -1.0, 0);
  /* Squash: scale (2, 1, 1). The normal goes by the inverse transpose, diag(1/2, 1, 1). */
  int s0 = vertex_at(squash, 0, 0, 0);
  CHECK(vertex_at(squash, 2, 0, 0) >= 0);
  CHECK(squash->uvs == NULL && squash->tangents == NULL); /* the file gives it none */
  if (s0 < 0 || !squash->normals) goto done;
  double len = sqrt(0.3 * 0.3 + 0.8 * 0.8);
  CHECK_NEAR(squash->normals[3 * s0], 0.3 / len, 1e-6);
  CHECK_NEAR(squash->normals[3 * s0 + 2], 0.8 / len, 1e-6);
done:
  vf_scene_destroy(s);
}

static void test_gltf_camera_by_default_name_and_index(void) {
  vf_scene *s = load("model.gltf", NULL);
  if (s == NULL) return;
  CHECK_VEC(s->camera.position, 0, 1, 5, 1e-6);
  CHECK_VEC(s->camera.forward, 0, 0, -1, 1e-6);
  CHECK_VEC(s->camera.up, 0, 1, 0, 1e-6);
  CHECK_NEAR(s->camera.vertical_fov_degrees, 0.8 * 180.0 / M_PI, 1e-4);
  CHECK_INT_EQ(s->settings.width, 1280); /* aspect 1.5 */
  CHECK_INT_EQ(s->settings.height, 853);
  vf_scene_destroy(s);
  const char *picks[] = {"TopCam", "1"};
  for (int i = 0; i < 2; i++) {
    s = load("model.gltf", picks[i]);
    if (s == NULL) continue;
    CHECK_VEC(s->camera.position, 0, 10, 0, 1e-6);
    CHECK_VEC(s->camera.forward, 0, -1, 0, 1e-6);
    CHECK_VEC(s->camera.up, 0, 0, -1, 1e-6);
    CHECK_NEAR(s->camera.vertical_fov_degrees, 0.5 * 180.0 / M_PI, 1e-4);
    CHECK_INT_EQ(s->settings.height, 1280);
    vf_scene_destroy(s);
  }
}

/* An orthographic glTF camera: its view is 2 xmag wide in its node's space (glTF's
 * projection maps [-xmag, xmag] to the image), so the node's scale scales it, and xmag /
 * ymag is the image's aspect ratio. A file whose first camera is orthographic is seen
 * through it. The mesh's node has the camera node's name: the camera still takes its own
 * node's transform. */
static void test_gltf_orthographic_camera(void) {
  static const char text[] =
      "{\"asset\": {\"version\": \"2.0\"}, \"scene\": 0, \"scenes\": [{\"nodes\": [0, 1]}],\n"
      " \"nodes\": [{\"name\": \"Ortho\", \"mesh\": 0},\n"
      "  {\"name\": \"Ortho\", \"camera\": 0, \"translation\": [0, 0, 5], \"scale\": [3, 3, 3],"
      "   \"rotation\": [0, 0.38268343, 0, 0.92387953]}],\n"
      " \"cameras\": [{\"type\": \"orthographic\", \"orthographic\": {\"xmag\": 2, \"ymag\": 1, \"znear\": 0.1,"
      "   \"zfar\": 100}}],\n"
      " \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}}]}],\n"
      " \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\","
      "   \"min\": [-1, -1, 0], \"max\": [1, 1, 0]}],\n"
      " \"bufferViews\": [{\"buffer\": 0, \"byteLength\": 36}],\n"
      " \"buffers\": [{\"byteLength\": 36, \"uri\": "
      "\"data:application/octet-stream;base64,AACAvwAAgL8AAAAAAACAPwAAgL8AAAAAAAAAAAAAgD8AAAAA\"}]}\n";
  write_file("ortho.gltf", text, strlen(text));
  vf_scene *s = load("ortho.gltf", NULL);
  if (s == NULL) return;
  CHECK_NEAR(s->camera.view_width, 2.0 * 2.0 * 3.0, 1e-5);
  CHECK_NEAR(s->camera.vertical_fov_degrees, 0.0, 0.0);
  CHECK_VEC(s->camera.position, 0, 0, 5, 1e-6);
  /* Turned 45 degrees about +y: glTF's -z view axis becomes (-1, 0, -1) / sqrt 2. */
  CHECK_VEC(s->camera.forward, -0.70710678, 0, -0.70710678, 1e-6);
  CHECK_VEC(s->camera.up, 0, 1, 0, 1e-6);
  CHECK_INT_EQ(s->settings.width, 1280); /* xmag / ymag = 2 */
  CHECK_INT_EQ(s->settings.height, 640);
  CHECK(s->notes == NULL || strstr(s->notes, "orthographic") == NULL); /* nothing dropped */
  vf_scene_destroy(s);
}

static void test_gltf_lights_point_spot_directional(void) {
  vf_scene *s = load("model.gltf", NULL);
  if (s == NULL) return;
  CHECK_INT_EQ(s->num_point_lights, 2);
  CHECK_INT_EQ(s->num_directional_lights, 1);
  if (s->num_point_lights == 2 && s->num_directional_lights == 1) {
    const vf_point_light_desc *p = &s->point_lights[0], *spot = &s->point_lights[1];
    CHECK(!p->is_spot);
    CHECK_VEC(p->position, 1, 2, 3, 1e-6);
    CHECK_VEC(p->intensity, 100 / 683.0, 50 / 683.0, 25 / 683.0, 1e-7); /* Blender's reading: W/sr = cd / 683 */
    CHECK(spot->is_spot);
    CHECK_VEC(spot->position, 0, 5, 0, 1e-6);
    CHECK_VEC(spot->direction, 0, -1, 0, 1e-6);
    CHECK_VEC(spot->intensity, 50 / 683.0, 50 / 683.0, 50 / 683.0, 1e-7);
    CHECK_NEAR(spot->inner_cone_angle, 0.2, 1e-6); /* half-angles, as glTF */
    CHECK_NEAR(spot->outer_cone_angle, 0.5, 1e-6);
    CHECK_VEC(s->directional_lights[0].direction, 0, -1, 0, 1e-6);
    CHECK_VEC(s->directional_lights[0].irradiance, 3, 3, 3, 1e-6); /* lux read as W/m^2, as Blender's sun */
  }
  /* The file has an emitter beside its punctual lights: the reading is printed. */
  CHECK_STR_CONTAINS(s ? s->notes : NULL, "model.gltf: light units: punctual lights in W/sr = candela / 683 beside "
                                          "emission as written (Blender's reading)");
  vf_scene_destroy(s);
  /* "light_units": "photometric" reads candela as written, beside the same emission. */
  const char json[] = "{\"import\": [{\"file\": \"model.gltf\", \"light_units\": \"photometric\"}]}";
  write_file("photometric.json", json, sizeof json - 1);
  s = load("photometric.json", NULL);
  if (s != NULL && s->num_point_lights == 2) {
    CHECK_VEC(s->point_lights[0].intensity, 100, 50, 25, 1e-4);
    CHECK_VEC(s->directional_lights[0].irradiance, 3, 3, 3, 1e-6);
    CHECK_STR_CONTAINS(s->notes, "punctual lights in candela beside emission as written (photometric)");
  }
  vf_scene_destroy(s);
  const char bad[] = "{\"import\": [{\"file\": \"model.gltf\", \"light_units\": \"lumens\"}]}";
  write_file("bad_units.json", bad, sizeof bad - 1);
  char detail[512];
  CHECK_INT_EQ(load_error("bad_units.json", NULL, detail, sizeof detail), VF_ESCENE);
  CHECK_STR_CONTAINS(detail, "import[0].light_units: expected \"blender\" or \"photometric\", found 'lumens'");
}

static void test_gltf_materials_every_parameter_and_texture_slot(void) {
  vf_scene *s = load("model.gltf", NULL);
  if (s == NULL) return;
  const vf_material *red = &s->materials[material_named(s, "Red")], *glass = &s->materials[material_named(s, "Glass")];
  CHECK(red->gltf);
  CHECK_VEC(red->base_color, 0.8, 0.2, 0.1, 1e-6);
  CHECK_NEAR(red->metallic, 0.3, 1e-6);
  CHECK_NEAR(red->roughness, 0.6, 1e-6);
  CHECK_NEAR(red->alpha, 0.5, 1e-6);
  CHECK_NEAR(red->alpha_cutoff, 0.3, 1e-6);
  CHECK_INT_EQ(red->alpha_channel, 3);
  CHECK_NEAR(red->normal_scale, 0.7, 1e-6);
  CHECK_INT_EQ(s->num_textures, 3);
  const vf_texture_slot *t = red->textures;
  CHECK(t[VF_TEXTURE_COLOR].texture > 0 && t[VF_TEXTURE_ROUGHNESS_METALLIC].texture > 0 &&
        t[VF_TEXTURE_NORMAL].texture > 0 && t[VF_TEXTURE_EMISSION].texture > 0);
  CHECK_INT_EQ(t[VF_TEXTURE_ALPHA].texture, t[VF_TEXTURE_COLOR].texture); /* alpha of the base colour */
  CHECK_INT_EQ(t[VF_TEXTURE_EMISSION].texture, t[VF_TEXTURE_ROUGHNESS_METALLIC].texture); /* one image, one texture */
  CHECK_INT_EQ(t[VF_TEXTURE_COLOR].wrap_s, VF_WRAP_CLAMP);
  CHECK_INT_EQ(t[VF_TEXTURE_COLOR].wrap_t, VF_WRAP_MIRROR);
  CHECK_INT_EQ(t[VF_TEXTURE_NORMAL].wrap_s, VF_WRAP_REPEAT);
  if (t[VF_TEXTURE_COLOR].texture > 0 && t[VF_TEXTURE_COLOR].texture <= s->num_textures) {
    const vf_texture *base = &s->textures[t[VF_TEXTURE_COLOR].texture - 1];
    CHECK_INT_EQ(base->width, 2);
    CHECK_INT_EQ(base->channels, 4);
    CHECK_STR_CONTAINS(base->name, "base.png");
  }
  /* A URI is percent-decoded (glTF 2.0, "URIs"; RFC 3986): %20 names the file with a space. */
  if (t[VF_TEXTURE_NORMAL].texture > 0 && t[VF_TEXTURE_NORMAL].texture <= s->num_textures)
    CHECK_STR_CONTAINS(s->textures[t[VF_TEXTURE_NORMAL].texture - 1].name, "normal map.png");
  /* Emission = emissiveFactor x KHR_materials_emissive_strength, on the shape. */
  const vf_shape *tri = shape_named(s, "Tri");
  if (tri) CHECK_VEC(tri->emission, 4, 2, 0, 1e-6);
  /* Transmission 1 with KHR_materials_ior: a rough dielectric tinted by the base colour. */
  CHECK(!glass->gltf);
  CHECK_VEC(glass->dielectric, 0.9, 0.95, 1.0, 1e-6);
  CHECK_NEAR(glass->ior, 1.45, 1e-6);
  CHECK_NEAR(glass->roughness, 0.1, 1e-6);
  CHECK_NEAR(glass->alpha_cutoff, 0.0, 0);
  vf_scene_destroy(s);
}

static void test_gltf_notes_list_what_is_not_rendered(void) {
  vf_scene *s = load("model.gltf", NULL);
  if (s == NULL) return;
  CHECK_STR_CONTAINS(s->notes, "model.gltf: extension KHR_materials_iridescence is not supported");
  CHECK(s->notes && strstr(s->notes, "KHR_texture_transform") == NULL); /* supported: not noted */
  CHECK(s->notes && strstr(s->notes, "KHR_materials_ior") == NULL);
  CHECK(s->notes && strstr(s->notes, "KHR_lights_punctual") == NULL);
  vf_scene_destroy(s);
}

static void test_json_scene_imports_with_transform_and_material_override(void) {
  const char json[] =
      "{\"materials\": {\"Red\": {\"diffuse\": [0.1, 0.2, 0.3]}},\n"
      " \"import\": [{\"file\": \"model.gltf\", \"transform\": {\"translate\": [0, 0, -100]}, \"camera\": \"TopCam\"}]}\n";
  write_file("scene.json", json, sizeof json - 1);
  vf_scene *s = load("scene.json", NULL);
  if (s == NULL) return;
  const vf_shape *tri = shape_named(s, "Tri");
  if (tri) {
    CHECK(vertex_at(tri, 10, 2, -100) >= 0);
    CHECK_INT_EQ(tri->material, 0); /* the JSON's "Red" */
    CHECK_VEC(s->materials[tri->material].diffuse, 0.1, 0.2, 0.3, 1e-7);
    CHECK(vf_is_zero(tri->emission)); /* the file's material, emission included, is replaced */
  }
  CHECK_INT_EQ(s->num_textures, 0); /* only "Red" used textures */
  CHECK_VEC(s->camera.position, 0, 10, -100, 1e-5);
  CHECK_VEC(s->point_lights[0].position, 1, 2, -97, 1e-5);
  vf_scene_destroy(s);
  /* A scene with a camera of its own cannot choose an imported one as well. */
  const char both[] = "{\"camera\": {\"position\": [0, 0, 5], \"target\": [0, 0, 0], \"fov\": 40},\n"
                      " \"import\": [{\"file\": \"model.gltf\", \"camera\": 0}]}\n";
  write_file("both.json", both, sizeof both - 1);
  char detail[1024];
  CHECK_INT_EQ(load_error("both.json", NULL, detail, sizeof detail), VF_ESCENE);
  CHECK_STR_CONTAINS(detail, "import[0].camera: the scene has a 'camera' already");
}

static void test_model_text_is_the_json_that_imports_it(void) {
  char *text = NULL;
  size_t len = 0;
  CHECK_INT_EQ(vf_scene_model_text("/some/dir/a \"b\".glb", "Cam 1", &text, &len), VF_OK);
  CHECK_STR_CONTAINS(text, "{\"import\":[{\"file\":\"a \\\"b\\\".glb\",\"camera\":\"Cam 1\"}]}");
  free(text);
  CHECK(vf_scene_is_model_file("x/Y.GLTF") && vf_scene_is_model_file("a.obj") && !vf_scene_is_model_file("a.json"));
}

/* ---- OBJ + MTL ------------------------------------------------------------------------------ */

static void write_obj(void) {
  const char obj[] = "mtllib model.mtl\n"
                     "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
                     "vt 0 0\nvt 1 0\nvt 0 1\n"
                     "vn 0 0 2\n"
                     "o plastic\nusemtl plastic\nf 1/1/1 2/2/1 3/3/1\n"
                     "o glass\nusemtl glass\nf 1/1/1 2/2/1 4/3/1\n"
                     "o leaf\nusemtl leaf\nf 1/1/1 3/2/1 4/3/1\n";
  const char mtl[] = "newmtl plastic\nKd 0.5 0.4 0.3\nKs 0.6 0.6 0.6\nNs 50\nKe 0 0 0\nillum 2\n"
                     "newmtl glass\nKd 0 0 0\nNi 1.33\nillum 7\n"
                     "newmtl leaf\nKd 1 1 1\nKe 0.5 0.5 0.5\nmap_Kd base.png\nmap_d base.png\nmap_Bump bump.png\nnorm nrm.png\n"
                     "map_Ks mr.png\n";
  write_file("model.obj", obj, sizeof obj - 1);
  write_file("model.mtl", mtl, sizeof mtl - 1);
}

static void test_obj_mtl_materials_uvs_and_notes(void) {
  write_obj();
  vf_scene *s = load("model.obj", NULL);
  if (s == NULL) return;
  CHECK_INT_EQ(s->num_shapes, 3);
  const vf_material *plastic = &s->materials[material_named(s, "plastic")];
  const vf_material *glass = &s->materials[material_named(s, "glass")], *leaf = &s->materials[material_named(s, "leaf")];
  /* Kd + Ks = 1.1 in red: both scaled by 1/1.1. */
  CHECK_VEC(plastic->diffuse, 0.5 / 1.1, 0.4 / 1.1, 0.3 / 1.1, 1e-6);
  CHECK_VEC(plastic->glossy, 0.6 / 1.1, 0.6 / 1.1, 0.6 / 1.1, 1e-6);
  CHECK_NEAR(plastic->phong_exponent, 50, 0);
  CHECK(!plastic->gltf);
  CHECK_VEC(glass->dielectric, 1, 1, 1, 0);
  CHECK_NEAR(glass->ior, 1.33, 1e-6);
  CHECK(vf_is_zero(glass->diffuse));
  CHECK(leaf->textures[VF_TEXTURE_COLOR].texture > 0);
  CHECK_INT_EQ(leaf->textures[VF_TEXTURE_ALPHA].texture, leaf->textures[VF_TEXTURE_COLOR].texture);
  CHECK_INT_EQ(leaf->alpha_channel, 3);
  CHECK_NEAR(leaf->alpha_cutoff, 0.5, 0);
  CHECK(leaf->textures[VF_TEXTURE_NORMAL].texture > 0); /* norm */
  const vf_shape *sh = shape_named(s, "leaf");
  if (sh) CHECK_VEC(sh->emission, 0.5, 0.5, 0.5, 0);
  sh = shape_named(s, "plastic");
  if (sh && sh->uvs && sh->normals) {
    /* OBJ's vt has v = 0 at the bottom of an image: t = 1 - v. */
    int v = vertex_at(sh, 1, 0, 0);
    CHECK_NEAR(sh->uvs[2 * v], 1.0, 0);
    CHECK_NEAR(sh->uvs[2 * v + 1], 1.0, 0);
    CHECK_NEAR(sh->normals[3 * v + 2], 1.0, 0); /* vn 0 0 2, normalised */
  } else {
    CHECK_FAIL_("%s", "the plastic shape has no uvs or normals");
  }
  CHECK_STR_CONTAINS(s->notes, "Kd + Ks above 1 are scaled down");
  CHECK_STR_CONTAINS(s->notes, "specular (map_Ks) textures are not supported");
  CHECK_STR_CONTAINS(s->notes, "no camera: a default camera");
  /* The default camera sees the whole bounds. */
  CHECK(s->camera.position.z > 1.0f && s->camera.forward.z < 0.0f);
  vf_scene_destroy(s);
}

static void test_obj_bump_map_that_is_a_height_map_is_noted(void) {
  const char obj[] = "mtllib bump.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl m\nf 1/1 2/2 3/3\n";
  const char mtl[] = "newmtl m\nKd 0.5 0.5 0.5\nKe 1 1 1\nmap_Bump bump.png\n";
  write_file("bump.obj", obj, sizeof obj - 1);
  write_file("bump.mtl", mtl, sizeof mtl - 1);
  vf_scene *s = load("bump.obj", NULL);
  if (s == NULL) return;
  CHECK_STR_CONTAINS(s->notes, "bump.obj: bump maps that are height maps are not supported");
  CHECK_INT_EQ(s->materials[0].textures[VF_TEXTURE_NORMAL].texture, 0);
  vf_scene_destroy(s);
}

/* ---- KHR_materials_specular's textures, which Assimp does not load ---------------------------- */

static size_t png_bytes(uint8_t *out, size_t cap, const uint8_t *rgba, int w, int h) {
  png_image img;
  memset(&img, 0, sizeof img);
  img.version = PNG_IMAGE_VERSION, img.width = (png_uint_32)w, img.height = (png_uint_32)h, img.format = PNG_FORMAT_RGBA;
  png_alloc_size_t n = cap;
  CHECK(png_image_write_to_memory(&img, out, &n, 0, rgba, 0, NULL));
  return n;
}

static void base64(const uint8_t *in, size_t n, char *out) {
  static const char a[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  size_t o = 0;
  for (size_t i = 0; i < n; i += 3) {
    uint32_t v = (uint32_t)in[i] << 16 | (i + 1 < n ? (uint32_t)in[i + 1] << 8 : 0) | (i + 2 < n ? in[i + 2] : 0);
    out[o++] = a[v >> 18 & 63], out[o++] = a[v >> 12 & 63];
    out[o++] = i + 1 < n ? a[v >> 6 & 63] : '=';
    out[o++] = i + 2 < n ? a[v & 63] : '=';
  }
  out[o] = '\0';
}

/* A .glb whose specularTexture is a PNG in its binary chunk and whose specularColorTexture is
 * a data URI: both read from the file's JSON into the material's slots, with their samplers,
 * as the images they are (texels compared). */
static void test_glb_specular_textures_from_buffer_view_and_data_uri(void) {
  const uint8_t spec_rgba[8] = {0, 0, 0, 64, 0, 0, 0, 255}, colour_rgba[8] = {255, 128, 0, 255, 0, 0, 255, 255};
  uint8_t png1[512], png2[512];
  size_t n1 = png_bytes(png1, sizeof png1, spec_rgba, 2, 1), n2 = png_bytes(png2, sizeof png2, colour_rgba, 2, 1);
  char uri[1024];
  base64(png2, n2, uri);
  /* BIN: positions (36 bytes), indices (6, padded to 8), the PNG (padded to 4) */
  const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const uint16_t idx[3] = {0, 1, 2};
  uint8_t bin[1024] = {0};
  memcpy(bin, pos, 36);
  memcpy(bin + 36, idx, 6);
  memcpy(bin + 44, png1, n1);
  uint32_t bin_len = (uint32_t)((44 + n1 + 3) & ~(size_t)3);
  char json[4096];
  int jn = snprintf(json, sizeof json,
      "{\"asset\": {\"version\": \"2.0\"}, \"extensionsUsed\": [\"KHR_materials_specular\"],"
      " \"scene\": 0, \"scenes\": [{\"nodes\": [0]}], \"nodes\": [{\"mesh\": 0}],"
      " \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 1, \"material\": 0}]}],"
      " \"materials\": [{\"name\": \"Spec\", \"pbrMetallicRoughness\": {\"metallicFactor\": 0}, \"extensions\": {"
      "\"KHR_materials_specular\": {\"specularFactor\": 0.5, \"specularTexture\": {\"index\": 0},"
      " \"specularColorTexture\": {\"index\": 1}}}}],"
      " \"samplers\": [{\"wrapS\": 33648, \"wrapT\": 33071}],"
      " \"textures\": [{\"source\": 0, \"sampler\": 0}, {\"source\": 1}],"
      " \"images\": [{\"bufferView\": 2, \"mimeType\": \"image/png\"}, {\"uri\": \"data:image/png;base64,%s\"}],"
      " \"buffers\": [{\"byteLength\": %u}],"
      " \"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": 36}, {\"buffer\": 0, \"byteOffset\": 36, \"byteLength\": 6},"
      " {\"buffer\": 0, \"byteOffset\": 44, \"byteLength\": %zu}],"
      " \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\", \"min\": [0, 0, 0], \"max\": [1, 1, 0]},"
      " {\"bufferView\": 1, \"componentType\": 5123, \"count\": 3, \"type\": \"SCALAR\"}]}",
      uri, bin_len, n1);
  while (jn % 4) json[jn++] = ' ';
  uint8_t glb[8192];
  uint32_t total = 12 + 8 + (uint32_t)jn + 8 + bin_len, h[5] = {0x46546C67u, 2, total, (uint32_t)jn, 0x4E4F534Au};
  memcpy(glb, h, 20);
  memcpy(glb + 20, json, (size_t)jn);
  uint32_t bh[2] = {bin_len, 0x004E4942u};
  memcpy(glb + 20 + jn, bh, 8);
  memcpy(glb + 28 + jn, bin, bin_len);
  write_file("spec.glb", glb, total);
  vf_scene *s = load("spec.glb", NULL);
  if (s == NULL) return;
  const vf_material *m = &s->materials[material_named(s, "Spec")];
  CHECK(m->gltf && m->specular_set);
  CHECK_NEAR(m->specular, 0.5, 0);
  CHECK_NEAR(m->specular_f0.x, 0.04, 1e-7);
  const vf_texture_slot *ts = &m->textures[VF_TEXTURE_SPECULAR], *tc = &m->textures[VF_TEXTURE_SPECULAR_COLOR];
  CHECK(ts->texture > 0 && tc->texture > 0 && ts->texture != tc->texture);
  CHECK_INT_EQ(ts->wrap_s, VF_WRAP_MIRROR);
  CHECK_INT_EQ(ts->wrap_t, VF_WRAP_CLAMP);
  CHECK_INT_EQ(tc->wrap_s, VF_WRAP_REPEAT);
  if (ts->texture > 0 && tc->texture > 0) {
    const vf_texture *a = &s->textures[ts->texture - 1], *b = &s->textures[tc->texture - 1];
    CHECK_STR_CONTAINS(a->name, "spec.glb#image0");
    CHECK_STR_CONTAINS(b->name, "spec.glb#image1");
    CHECK(a->width == 2 && a->channels == 4 && !a->is_float && ((const uint8_t *)a->texels)[3] == 64);
    CHECK(b->width == 2 && b->channels == 4 && !b->is_float && ((const uint8_t *)b->texels)[1] == 128);
  }
  vf_scene_destroy(s);
}

/* ---- repairs -------------------------------------------------------------------------------- */

/* A NaN normal is repaired from its face (Blender recomputes such normals) and counted in a
 * note; so is a zero one (Debian's spider.obj and BoxBadNormals.glb have them); a
 * degenerate triangle is skipped and counted. */
static void test_bad_normals_repaired_and_degenerate_faces_skipped_with_notes(void) {
  write_buffer(1); /* vertex 1's normal x is NaN */
  vf_scene *s = load("model.gltf", NULL);
  if (s != NULL) {
    const vf_shape *tri = shape_named(s, "Tri");
    int v1 = vertex_at(tri, 10, 2, 0); /* (1, 0, 0) turned by 90 degrees about z, scaled 2, moved by 10 */
    if (tri && tri->normals && v1 >= 0) { /* the triangle's own normal, +z, through the node's rotation */
      CHECK_NEAR(tri->normals[3 * v1], 0.0, 1e-6);
      CHECK_NEAR(tri->normals[3 * v1 + 1], 0.0, 1e-6);
      CHECK_NEAR(tri->normals[3 * v1 + 2], 1.0, 1e-6);
    }
    /* counted per mesh: the accessor serves the file's two meshes */
    CHECK_STR_CONTAINS(s->notes, "model.gltf: 2 vertex normals that were zero or not finite were repaired from their faces");
  }
  vf_scene_destroy(s);
  /* A zero tangent becomes its face's direction of increasing s, (1, 0, 0) in the file,
   * (0, 1, 0) through the node's rotation, bitangent N x T (w = +1); a long one is
   * normalised; each counted. */
  write_buffer(3);
  s = load("model.gltf", NULL);
  if (s != NULL) {
    const vf_shape *tri = shape_named(s, "Tri");
    int v2 = vertex_at(tri, 8, 0, 0), v0 = vertex_at(tri, 10, 0, 0);
    if (tri && tri->tangents && v2 >= 0 && v0 >= 0) {
      CHECK_NEAR(tri->tangents[4 * v2], 0.0, 1e-6);
      CHECK_NEAR(tri->tangents[4 * v2 + 1], 1.0, 1e-6);
      CHECK_NEAR(tri->tangents[4 * v2 + 3], 1.0, 0);
      CHECK_NEAR(tri->tangents[4 * v0 + 1], 1.0, 1e-6); /* unit after the transform */
    }
    CHECK_STR_CONTAINS(s->notes, "model.gltf: 1 tangents that were zero, not finite or along the normal were repaired");
    CHECK_STR_CONTAINS(s->notes, "model.gltf: 1 tangents not of unit length were normalised");
  }
  vf_scene_destroy(s);
  write_buffer(0);
  const char obj[] = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nvn 0 0 0\nvn 0 0 2\n"
                     "f 1//1 2//2 3//2\nf 1//1 2//2 4//2\n"; /* the second has its corners on a line */
  write_file("bad.obj", obj, sizeof obj - 1);
  s = load("bad.obj", NULL);
  if (s != NULL && s->num_shapes == 1) {
    CHECK_INT_EQ(s->shapes[0].num_triangles, 1);
    CHECK_STR_CONTAINS(s->notes, "bad.obj: 1 degenerate triangles (zero area) were skipped");
    CHECK_STR_CONTAINS(s->notes, "bad.obj: 2 vertex normals that were zero or not finite were repaired from their faces");
    CHECK_STR_CONTAINS(s->notes, "bad.obj: 4 vertex normals not of unit length were normalised");
    for (uint32_t v = 0; s->shapes[0].normals && v < s->shapes[0].num_vertices; v++)
      CHECK_NEAR(s->shapes[0].normals[3 * v + 2], 1.0, 1e-6);
  }
  vf_scene_destroy(s);
}

/* ---- what a model without camera or lights gets --------------------------------------------- */

/* A model without a camera is seen from the side of its bounds' largest projected area: a
 * polygon in a plane x = const from +x (from +z it rendered blank), a floor from above;
 * the note names the side. */
static void test_default_camera_faces_the_largest_projected_side(void) {
  const char wall[] = "v 0 0 0\nv 0 0 2\nv 0 1 2\nv 0 1 0\nf 1 2 3 4\n";
  write_file("wall_x.obj", wall, sizeof wall - 1);
  vf_scene *s = load("wall_x.obj", NULL);
  if (s != NULL) {
    CHECK_STR_CONTAINS(s->notes, "no camera: a default camera looks at the scene's bounds from +x, the side of their "
                                 "largest projected area");
    CHECK(s->camera.forward.x < -0.9f && fabsf(s->camera.forward.z) < 1e-6f);
    CHECK(s->camera.position.x > 1.0f);
  }
  vf_scene_destroy(s);
  const char floor[] = "v -3 0 -3\nv -3 0 3\nv 3 0.5 3\nv 3 0.5 -3\nf 1 2 3 4\n";
  write_file("floor.obj", floor, sizeof floor - 1);
  s = load("floor.obj", NULL);
  if (s != NULL) {
    CHECK_STR_CONTAINS(s->notes, "from +y");
    CHECK_VEC(s->camera.forward, 0, -1, 0, 1e-6);
    CHECK_VEC(s->camera.up, 0, 0, -1, 1e-6);
  }
  vf_scene_destroy(s);
}

/* Emitters alone that give almost no light: the scene is also lit by the default white
 * background, with the figures in a note; bright ones not. A 10 x 10 white floor and a
 * 0.1 x 0.1 label of radiance 1 facing it from a height of 1: 0.0314 W, of which the floor
 * gets about 0.0314 / 2 over 100 m^2, a radiance of about 5e-5 on white. Radiance 1e5
 * lights it; so does radiance 1 turned away from the floor not (its light meets nothing).
 * A JSON scene importing the file with a "lights" field (even empty) keeps its lights
 * alone and is warned that the image will be dark. */
static void test_dim_emitters_get_the_default_background(void) {
  const char obj[] = "mtllib dim.mtl\nv -5 0 -5\nv -5 0 5\nv 5 0 5\nv 5 0 -5\nv 0 1 0\nv 0.1 1 0\nv 0.1 1 -0.1\nv 0 1 -0.1\n"
                     "usemtl white\nf 1 2 3 4\nusemtl label\nf 5 8 7 6\n"; /* the label faces down */
  const char dim[] = "newmtl white\nKd 0.8 0.8 0.8\nnewmtl label\nKd 0 0 0\nKe 1 1 1\n";
  const char bright[] = "newmtl white\nKd 0.8 0.8 0.8\nnewmtl label\nKd 0 0 0\nKe 100000 100000 100000\n";
  write_file("dim.obj", obj, sizeof obj - 1);
  write_file("dim.mtl", dim, sizeof dim - 1);
  vf_scene *s = load("dim.obj", NULL);
  if (s != NULL) {
    CHECK_STR_CONTAINS(s->notes, "dim emitters: the only lights are emissive surfaces of 0.0314 W in all, whose light "
                                 "reaches the other surfaces at a radiance of about");
    CHECK_STR_CONTAINS(s->notes, "the scene is also lit by a white background of radiance 1");
    CHECK(strstr(s->notes, "no light:") == NULL && strstr(s->notes, "will be dark") == NULL);
    CHECK_VEC(s->background, 1, 1, 1, 0);
  }
  vf_scene_destroy(s);
  const char keep[] = "{\"import\": [{\"file\": \"dim.obj\"}], \"lights\": []}";
  write_file("dim_keep.json", keep, sizeof keep - 1);
  s = load("dim_keep.json", NULL);
  if (s != NULL) {
    CHECK_STR_CONTAINS(s->notes, "warning: the image will be dark: the only lights are emissive surfaces of 0.0314 W "
                                 "in all, whose light reaches the other surfaces at a radiance of about");
    CHECK(vf_is_zero(s->background));
  }
  vf_scene_destroy(s);
  write_file("dim.mtl", bright, sizeof bright - 1);
  s = load("dim.obj", NULL);
  if (s != NULL) CHECK((s->notes == NULL || strstr(s->notes, "dim emitters") == NULL) && vf_is_zero(s->background));
  vf_scene_destroy(s);
  const char away[] = "mtllib dim.mtl\nv -5 0 -5\nv -5 0 5\nv 5 0 5\nv 5 0 -5\nv 0 1 0\nv 0.1 1 0\nv 0.1 1 -0.1\nv 0 1 -0.1\n"
                      "usemtl white\nf 1 2 3 4\nusemtl label\nf 5 6 7 8\n"; /* the bright label faces up */
  write_file("away.obj", away, sizeof away - 1);
  s = load("away.obj", NULL);
  if (s != NULL) CHECK_STR_CONTAINS(s->notes, "dim emitters");
  vf_scene_destroy(s);
}

/* ---- bad input ------------------------------------------------------------------------------ */

static void test_bad_files_are_refused_naming_file_and_problem(void) {
  char detail[1024];
  CHECK_INT_EQ(load_error("model.gltf", "Nope", detail, sizeof detail), VF_ESCENE);
  CHECK_STR_CONTAINS(detail, "model.gltf: --camera: no camera 'Nope' in model.gltf (its cameras: 0 'CamNode', 1 'TopCam')");
  CHECK_INT_EQ(load_error("model.gltf", "7", detail, sizeof detail), VF_ESCENE);
  CHECK_STR_CONTAINS(detail, "no camera '7'");

  write_buffer(2);
  CHECK_INT_EQ(load_error("model.gltf", NULL, detail, sizeof detail), VF_EMESH);
  CHECK_STR_CONTAINS(detail, "model.gltf: vertex 1 has a non-finite texture coordinate");
  write_buffer(0);

  const char *broken[] = {
      /* a buffer view beyond its buffer */
      " \"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 100, \"byteLength\": 144}, {\"buffer\": 0, \"byteOffset\": 144, \"byteLength\": 6}],\n",
      /* an accessor counting more elements than its view holds */
      " \"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": 144}, {\"buffer\": 0, \"byteOffset\": 144, \"byteLength\": 6}],\n"};
  for (int i = 0; i < 2; i++) {
    char acc[4096];
    const char *rest = strstr(good_accessors, " \"accessors\"");
    snprintf(acc, sizeof acc, "%s%s", broken[i], rest);
    if (i == 1) { /* count 3 -> 3000 for the positions */
      char *count = strstr(acc, "\"count\": 3,");
      memmove(count + 14, count + 11, strlen(count + 11) + 1);
      memcpy(count, "\"count\": 3000,", 14);
    }
    write_gltf(acc);
    int err = load_error("model.gltf", NULL, detail, sizeof detail);
    CHECK_INT_EQ(err, VF_EMESH);
    CHECK_STR_CONTAINS(detail, "cannot read 'model.gltf'");
    printf("  broken accessor %d: %s\n", i, detail);
  }
  write_gltf(NULL);

  char p[256];
  path_of(p, sizeof p, "normal map.png");
  unlink(p);
  CHECK_INT_EQ(load_error("model.gltf", NULL, detail, sizeof detail), VF_ENOENT);
  CHECK_STR_CONTAINS(detail, "model.gltf: material 'Red'");
  CHECK_STR_CONTAINS(detail, "normal map.png"); /* the file the URI names, decoded */
  write_textures();
}

/* ---- notes: each once per file ---------------------------------------------------------------- */

static int occurrences(const char *text, const char *needle) {
  int n = 0;
  for (const char *p = text ? strstr(text, needle) : NULL; p != NULL; p = strstr(p + 1, needle)) n++;
  return n;
}

/* Two materials above Kd + Ks = 1: one note naming the file's largest sum, not one per
 * material each claiming to be the largest. */
static void test_obj_kd_ks_noted_once_with_the_largest_sum(void) {
  const char obj[] = "mtllib sums.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
                     "o a\nusemtl a\nf 1 2 3\no b\nusemtl b\nf 1 2 4\no c\nusemtl c\nf 1 3 4\n";
  const char mtl[] = "newmtl a\nKd 0.6 0.6 0.6\nKs 0.6 0.6 0.6\nillum 2\n"
                     "newmtl b\nKd 0.9 0.5 0.5\nKs 0.6 0.6 0.6\nillum 2\n"
                     "newmtl c\nKd 0.2 0.2 0.2\nKs 0.1 0.1 0.1\nillum 2\n";
  write_file("sums.obj", obj, sizeof obj - 1);
  write_file("sums.mtl", mtl, sizeof mtl - 1);
  vf_scene *s = load("sums.obj", NULL);
  if (s == NULL) return;
  CHECK_INT_EQ(occurrences(s->notes, "Kd + Ks above 1"), 1);
  CHECK_STR_CONTAINS(s->notes, "sums.obj: materials with Kd + Ks above 1 are scaled down to 1 (the largest sum: 1.5)");
  vf_scene_destroy(s);
}

/* KHR_texture_transform on Khronos's TextureTransformTest: each material's base colour slot
 * reads at T(offset) R(rotation) S(scale) (s, t), R = [cos sin; -sin cos], checked at three
 * points against the specification's matrices; no note. */
static void test_gltf_texture_transform_read_per_slot(void) {
  const char *p = "/usr/share/assimp/models/glTF2/textureTransform/TextureTransformTest.gltf";
  if (access(p, R_OK) != 0) {
    printf("  SKIP: %s not installed (apt-get install assimp-testmodels)\n", p);
    return;
  }
  vf_scene *s = NULL;
  int err = vf_scene_load(p, &s);
  if (err != VF_OK) CHECK_FAIL_("%s: %s", p, vf_error_detail(err));
  if (s == NULL) return;
  CHECK(s->notes == NULL || strstr(s->notes, "transform") == NULL);
  static const struct {
    const char *name;
    double ox, oy, rotation, sx, sy;
  } cases[] = {{"Offset U", 0.5, 0, 0, 1, 1},          {"Offset V", 0, 0.5, 0, 1, 1},
               {"Offset UV", 0.5, 0.5, 0, 1, 1},       {"Rotation", 0, 0, 0.39269908169872414, 1, 1},
               {"Scale", 0, 0, 0, 1.5, 1.5},           {"All", -0.2, -0.1, 0.3, 1.5, 1.5}};
  static const double points[3][2] = {{0, 0}, {1, 0}, {0.25, 0.75}};
  for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
    const vf_texture_slot *ts = &s->materials[material_named(s, cases[i].name)].textures[VF_TEXTURE_COLOR];
    CHECK(ts->texture > 0 && ts->has_transform);
    CHECK_INT_EQ(ts->uv_set, 0);
    double c = cos(cases[i].rotation), sn = sin(cases[i].rotation);
    for (int k = 0; k < 3; k++) {
      double u = points[k][0] * cases[i].sx, v = points[k][1] * cases[i].sy;
      double eu = c * u + sn * v + cases[i].ox, ev = -sn * u + c * v + cases[i].oy;
      const float *m = ts->transform;
      CHECK_NEAR(m[0] * points[k][0] + m[1] * points[k][1] + m[2], eu, 1e-6);
      CHECK_NEAR(m[3] * points[k][0] + m[4] * points[k][1] + m[5], ev, 1e-6);
    }
  }
  const vf_texture_slot *plain = &s->materials[material_named(s, "Correct")].textures[VF_TEXTURE_COLOR];
  CHECK(plain->texture > 0 && !plain->has_transform);
  vf_scene_destroy(s);
}

/* KHR_materials_clearcoat and KHR_materials_sheen: factors clamped to [0, 1], every texture
 * in its slot with its uv set and KHR_texture_transform, the coat normal's scale; a layer
 * whose factor is zero loads no texture; no note for either extension. */
static void test_gltf_clearcoat_and_sheen_fields_and_textures(void) {
  static const char *const text =
      "{\"asset\": {\"version\": \"2.0\"}, \"extensionsUsed\": [\"KHR_materials_clearcoat\", \"KHR_materials_sheen\","
      " \"KHR_texture_transform\"],"
      " \"scene\": 0, \"scenes\": [{\"nodes\": [0, 1]}], \"nodes\": [{\"mesh\": 0}, {\"mesh\": 1}],"
      " \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0, \"TEXCOORD_0\": 2}, \"indices\": 1, \"material\": 0}]},"
      " {\"primitives\": [{\"attributes\": {\"POSITION\": 0, \"TEXCOORD_0\": 2}, \"indices\": 1, \"material\": 1}]}],"
      " \"materials\": [{\"name\": \"Layers\", \"extensions\": {"
      "  \"KHR_materials_clearcoat\": {\"clearcoatFactor\": 0.8, \"clearcoatRoughnessFactor\": 1.7,"
      "   \"clearcoatTexture\": {\"index\": 0}, \"clearcoatRoughnessTexture\": {\"index\": 1, \"texCoord\": 1},"
      "   \"clearcoatNormalTexture\": {\"index\": 2, \"scale\": 0.5}},"
      "  \"KHR_materials_sheen\": {\"sheenColorFactor\": [0.9, 1.5, -1], \"sheenRoughnessFactor\": 0.3,"
      "   \"sheenColorTexture\": {\"index\": 0, \"extensions\": {\"KHR_texture_transform\": {\"scale\": [2, 3]}}},"
      "   \"sheenRoughnessTexture\": {\"index\": 0}}}},"
      "  {\"name\": \"Off\", \"extensions\": {\"KHR_materials_clearcoat\": {\"clearcoatTexture\": {\"index\": 0}},"
      "   \"KHR_materials_sheen\": {\"sheenRoughnessFactor\": 0.5, \"sheenColorTexture\": {\"index\": 0}}}}],"
      " \"textures\": [{\"source\": 0}, {\"source\": 1}, {\"source\": 2}],"
      " \"images\": [{\"uri\": \"base.png\"}, {\"uri\": \"mr.png\"}, {\"uri\": \"nrm.png\"}],"
      " \"buffers\": [{\"uri\": \"model.bin\", \"byteLength\": 150}],"
      " \"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": 36},"
      " {\"buffer\": 0, \"byteOffset\": 144, \"byteLength\": 6}, {\"buffer\": 0, \"byteOffset\": 72, \"byteLength\": 24}],"
      " \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\","
      " \"min\": [0, 0, 0], \"max\": [1, 1, 0]}, {\"bufferView\": 1, \"componentType\": 5123, \"count\": 3, \"type\": \"SCALAR\"},"
      " {\"bufferView\": 2, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC2\"}]}";
  write_file("layers.gltf", text, strlen(text));
  vf_scene *s = load("layers.gltf", NULL);
  if (s == NULL) return;
  CHECK(s->notes == NULL || (strstr(s->notes, "clearcoat") == NULL && strstr(s->notes, "sheen") == NULL));
  const vf_material *m = &s->materials[material_named(s, "Layers")];
  CHECK(m->gltf);
  CHECK_NEAR(m->clearcoat, 0.8, 1e-7);
  CHECK_NEAR(m->clearcoat_roughness, 1.0, 0); /* clamped */
  CHECK_NEAR(m->clearcoat_normal_scale, 0.5, 0);
  CHECK_NEAR(m->sheen_color.x, 0.9, 1e-7);
  CHECK_NEAR(m->sheen_color.y, 1.0, 0);
  CHECK_NEAR(m->sheen_color.z, 0.0, 0);
  CHECK_NEAR(m->sheen_roughness, 0.3, 1e-7);
  const vf_texture_slot *t = m->textures;
  CHECK(t[VF_TEXTURE_CLEARCOAT].texture > 0 && t[VF_TEXTURE_CLEARCOAT_ROUGHNESS].texture > 0 &&
        t[VF_TEXTURE_CLEARCOAT_NORMAL].texture > 0 && t[VF_TEXTURE_SHEEN_COLOR].texture > 0 &&
        t[VF_TEXTURE_SHEEN_ROUGHNESS].texture > 0);
  CHECK(t[VF_TEXTURE_CLEARCOAT].texture == t[VF_TEXTURE_SHEEN_COLOR].texture); /* the same image, once */
  CHECK(t[VF_TEXTURE_CLEARCOAT_NORMAL].texture != t[VF_TEXTURE_CLEARCOAT].texture);
  CHECK_INT_EQ(t[VF_TEXTURE_CLEARCOAT_ROUGHNESS].uv_set, 1);
  CHECK_INT_EQ(t[VF_TEXTURE_CLEARCOAT].uv_set, 0);
  CHECK(t[VF_TEXTURE_SHEEN_COLOR].has_transform && !t[VF_TEXTURE_CLEARCOAT].has_transform);
  CHECK_NEAR(t[VF_TEXTURE_SHEEN_COLOR].transform[0], 2.0, 1e-6);
  CHECK_NEAR(t[VF_TEXTURE_SHEEN_COLOR].transform[4], 3.0, 1e-6);
  /* the defaults (factors 0) disable both layers: their textures are not loaded */
  const vf_material *off = &s->materials[material_named(s, "Off")];
  CHECK(off->clearcoat == 0.0f && vf_is_zero(off->sheen_color));
  CHECK(off->textures[VF_TEXTURE_CLEARCOAT].texture == 0 && off->textures[VF_TEXTURE_SHEEN_COLOR].texture == 0);
  vf_scene_destroy(s);
}

/* Khronos's ClearCoatTest (Debian's assimp-testmodels): each row's coated material as its
 * JSON says, the coat's textures in their slots. */
static void test_clearcoat_test_model_loads_its_coats(void) {
  const char *p = "/usr/share/assimp/models/glTF2/ClearCoat-glTF/ClearCoatTest.gltf";
  if (access(p, R_OK) != 0) {
    printf("  SKIP: %s not installed (apt-get install assimp-testmodels)\n", p);
    return;
  }
  vf_scene *s = NULL;
  int err = vf_scene_load(p, &s);
  if (err != VF_OK) CHECK_FAIL_("%s: %s", p, vf_error_detail(err));
  if (s == NULL) return;
  CHECK(s->notes == NULL || strstr(s->notes, "KHR_materials_clearcoat") == NULL);
  const vf_material *simple = &s->materials[material_named(s, "Simple_Coated")];
  CHECK_NEAR(simple->clearcoat, 1.0, 0);
  CHECK_NEAR(simple->clearcoat_roughness, 0.03, 1e-7);
  CHECK(s->materials[material_named(s, "Partial_Coated")].textures[VF_TEXTURE_CLEARCOAT].texture > 0);
  const vf_material *rough = &s->materials[material_named(s, "RoughVariations_Coated")];
  CHECK(rough->clearcoat_roughness == 1.0f && rough->textures[VF_TEXTURE_CLEARCOAT_ROUGHNESS].texture > 0);
  const vf_material *coat_normal = &s->materials[material_named(s, "CoatNorm_Coated")];
  CHECK(coat_normal->textures[VF_TEXTURE_CLEARCOAT_NORMAL].texture > 0 && coat_normal->textures[VF_TEXTURE_NORMAL].texture == 0);
  const vf_material *base_normal = &s->materials[material_named(s, "BaseNorm_Coated")];
  CHECK(base_normal->textures[VF_TEXTURE_NORMAL].texture > 0 && base_normal->textures[VF_TEXTURE_CLEARCOAT_NORMAL].texture == 0);
  CHECK(s->materials[material_named(s, "Simple_Base")].clearcoat == 0.0f);
  vf_scene_destroy(s);
}

/* An OBJ face of n vertices on the unit circle (star: every other vertex at radius 0.4). */
static void write_polygon_obj(const char *name, int n, int star) {
  char p[256];
  path_of(p, sizeof p, name);
  FILE *f = fopen(p, "w");
  CHECK(f != NULL);
  if (f == NULL) return;
  for (int i = 0; i < n; i++) {
    double r = star && i % 2 ? 0.4 : 1.0, a = 2.0 * M_PI * i / n;
    fprintf(f, "v %.9f %.9f 0\n", r * cos(a), r * sin(a));
  }
  fprintf(f, "f");
  for (int i = 1; i <= n; i++) fprintf(f, " %d", i);
  fprintf(f, "\n");
  fclose(f);
}

/* A 100,000-vertex OBJ face (issue 41: Assimp's ear clipping never ended) loads in linear
 * time as a fan: n - 2 triangles covering the polygon's area (n/2) sin(2 pi / n) exactly; a
 * large face that is not convex is refused naming the file and the face; a non-convex
 * face below the bound still goes through Assimp's triangulation. */
static void test_obj_huge_face_is_a_fan_or_refused(void) {
  enum { N = 100000 };
  write_polygon_obj("disc.obj", N, 0);
  struct timespec t0, t1;
  clock_gettime(CLOCK_MONOTONIC, &t0);
  vf_scene *s = load("disc.obj", NULL);
  clock_gettime(CLOCK_MONOTONIC, &t1);
  double seconds = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
  printf("  a face of %d vertices: loaded in %.2f s\n", N, seconds);
  CHECK(seconds < 20.0);
  if (s != NULL && s->num_shapes == 1) {
    const vf_shape *sh = &s->shapes[0];
    /* a few fan triangles near the axes have their corners on a line in floats: skipped */
    char note[128];
    snprintf(note, sizeof note, "disc.obj: %u degenerate triangles (zero area) were skipped", N - 2 - sh->num_triangles);
    if (sh->num_triangles < N - 2) CHECK_STR_CONTAINS(s->notes, note);
    CHECK(sh->num_triangles + 64 >= N - 2);
    double area = 0.0;
    for (uint32_t t = 0; t < sh->num_triangles; t++) {
      const float *a = &sh->positions[3 * sh->indices[3 * t]], *b = &sh->positions[3 * sh->indices[3 * t + 1]],
                  *c = &sh->positions[3 * sh->indices[3 * t + 2]];
      area += 0.5 * (((double)b[0] - a[0]) * ((double)c[1] - a[1]) - ((double)b[1] - a[1]) * ((double)c[0] - a[0]));
    }
    CHECK_NEAR(area, 0.5 * N * sin(2.0 * M_PI / N), 1e-6);
  }
  vf_scene_destroy(s);
  char detail[1024];
  write_polygon_obj("star.obj", 5000, 1);
  CHECK_INT_EQ(load_error("star.obj", NULL, detail, sizeof detail), VF_EMESH);
  CHECK_STR_CONTAINS(detail, "star.obj");
  CHECK_STR_CONTAINS(detail, "face 0 of mesh 0 (5000 vertices) is not a convex planar polygon");
  write_polygon_obj("small_star.obj", 100, 1);
  s = load("small_star.obj", NULL);
  if (s != NULL) CHECK_INT_EQ(s->shapes[0].num_triangles, 98);
  vf_scene_destroy(s);
}

/* ---- the glTF sample models of Debian's assimp-testmodels --------------------------------------- */

static void test_assimp_testmodels_glTF2_load_with_notes(void) {
  static const char *const models[] = {"BoxTextured-glTF/BoxTextured.gltf", "BoxTextured-glTF-Binary/BoxTextured.glb",
                                       "BoxTextured-glTF-Embedded/BoxTextured.gltf", "cameras/Cameras.gltf",
                                       "2CylinderEngine-glTF-Binary/2CylinderEngine.glb",
                                       NULL};
  const char *root = "/usr/share/assimp/models/glTF2";
  if (access(root, R_OK) != 0) {
    printf("  skipped: %s not installed (apt-get install assimp-testmodels)\n", root);
    return;
  }
  int loaded = 0;
  for (int i = 0; models[i] != NULL; i++) {
    char p[512];
    snprintf(p, sizeof p, "%s/%s", root, models[i]);
    if (access(p, R_OK) != 0) continue;
    vf_scene *s = NULL;
    int err = vf_scene_load(p, &s);
    if (err != VF_OK) CHECK_FAIL_("%s: %s", p, vf_error_detail(err));
    if (s == NULL) continue;
    loaded++;
    CHECK(s->num_shapes > 0 && s->shapes[0].num_triangles > 0);
    CHECK(s->notes != NULL); /* at least the default camera or light */
    printf("  %s: %d shapes, %d materials, %d textures; notes:\n%s", models[i], s->num_shapes, s->num_materials,
           s->num_textures, s->notes ? s->notes : "");
    vf_scene_destroy(s);
  }
  CHECK(loaded > 0);
}

int main(void) {
  fresh_dir();
  RUN(test_gltf_node_hierarchy_moves_positions_normals_and_tangents);
  RUN(test_gltf_camera_by_default_name_and_index);
  RUN(test_gltf_orthographic_camera);
  RUN(test_gltf_lights_point_spot_directional);
  RUN(test_gltf_materials_every_parameter_and_texture_slot);
  RUN(test_gltf_notes_list_what_is_not_rendered);
  RUN(test_json_scene_imports_with_transform_and_material_override);
  RUN(test_model_text_is_the_json_that_imports_it);
  RUN(test_obj_mtl_materials_uvs_and_notes);
  RUN(test_obj_bump_map_that_is_a_height_map_is_noted);
  RUN(test_bad_files_are_refused_naming_file_and_problem);
  RUN(test_obj_kd_ks_noted_once_with_the_largest_sum);
  RUN(test_gltf_texture_transform_read_per_slot);
  RUN(test_gltf_clearcoat_and_sheen_fields_and_textures);
  RUN(test_clearcoat_test_model_loads_its_coats);
  RUN(test_glb_specular_textures_from_buffer_view_and_data_uri);
  RUN(test_obj_huge_face_is_a_fan_or_refused);
  RUN(test_bad_normals_repaired_and_degenerate_faces_skipped_with_notes);
  RUN(test_default_camera_faces_the_largest_projected_side);
  RUN(test_dim_emitters_get_the_default_background);
  RUN(test_assimp_testmodels_glTF2_load_with_notes);
  if (getenv("KEEP_TMP") == NULL) remove_dir();
  else printf("kept %s\n", dir);
  return check_finish();
}
