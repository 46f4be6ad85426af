/* glTF files rendered as their extensions define them (worker/scene/import*.c with the
 * renderer): KHR_materials_specular's Fresnel against the specification's formulas, an
 * emitter of black base and Specular 0 reading exactly its emission, and the light units
 * of KHR_lights_punctual beside KHR_materials_emissive_strength: the lamp's and the
 * emitter's contributions on a matte wall against their closed forms, within statistical
 * error. The glTF file is written here; nothing is read from elsewhere. */
#include "check.h"
#include "render_util.h"

#include "common/settings.h"
#include "worker/render/bsdf.h"
#include "worker/render/camera.h"
#include "worker/render/microfacet.h"
#include "worker/render/surface.h"
#include "worker/scene/load.h"

#include <png.h>

#include <dirent.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char dir[64];

static void write_file(const char *name, const void *bytes, size_t n) {
  char p[256];
  snprintf(p, sizeof p, "%s/%s", dir, name);
  FILE *f = fopen(p, "wb");
  CHECK(f != NULL && fwrite(bytes, 1, n, f) == n);
  if (f) fclose(f);
}

/* ---- the specification's formulas --------------------------------------------------------- */

static vf_vec3 unit(double x, double y, double z) {
  double n = sqrt(x * x + y * y + z * z);
  return vf_vec3_make((float)(x / n), (float)(y / n), (float)(z / n));
}

/* f of material m for (fix, gen) about the normal +z. */
static vf_vec3 eval(const vf_material *m, vf_vec3 fix, vf_vec3 gen) {
  vf_bsdf b;
  CHECK(vf_bsdf_init(&b, m, vf_vec3_make(0, 0, 1), fix));
  float c;
  return vf_bsdf_evaluate(&b, gen, &c, NULL, NULL);
}

/* KHR_materials_specular, "Implementation": dielectric_f0 = min(F0 specularColor, 1)
 * specular, dielectric_f90 = specular, F_d = mix(f0, f90, (1 - VdotH)^5), the material
 * mix(F_d specular_brdf + (1 - max F_d) diffuse_brdf, metal_brdf, metallic). The GGX term
 * D G / (4 |cos| |cos|) comes from the same roughness's Fresnel-one conductor. */
static void test_specular_fresnel_is_the_specifications(void) {
  const float base[3] = {0.6f, 0.5f, 0.4f}, f0_colour[3] = {0.2f, 0.06f, 1.5f}, specular = 0.6f, metallic = 0.3f;
  vf_material m = {.gltf = 1, .base_color = vf_vec3_make(base[0], base[1], base[2]), .metallic = metallic,
                   .roughness = 0.35f, .specular_set = 1, .specular = specular,
                   .specular_f0 = vf_vec3_make(f0_colour[0], f0_colour[1], f0_colour[2])};
  vf_material ggx = {.conductor = vf_vec3_splat(1.0f), .roughness = 0.35f};
  static const double dirs[][6] = {{0.3, 0.1, 1, -0.4, 0.2, 1}, {0.9, 0, 0.3, -0.2, -0.5, 1}, {0.1, 0.8, 0.5, 0.7, -0.6, 0.2}};
  for (int d = 0; d < 3; d++) {
    vf_vec3 fix = unit(dirs[d][0], dirs[d][1], dirs[d][2]), gen = unit(dirs[d][3], dirs[d][4], dirs[d][5]);
    vf_vec3 h = vf_normalize(vf_add(fix, gen));
    double w = pow(1.0 - vf_dot(fix, h), 5.0), spec = vf_vec3_get(eval(&ggx, fix, gen), 0), fd[3], fd_max = 0.0;
    for (int k = 0; k < 3; k++) {
      double d0 = fmin(f0_colour[k], 1.0) * specular;
      fd[k] = d0 + (specular - d0) * w;
      fd_max = fmax(fd_max, fd[k]);
    }
    vf_vec3 f = eval(&m, fix, gen);
    for (int k = 0; k < 3; k++) {
      double metal = base[k] + (1.0 - base[k]) * w;
      double expected = (1.0 - metallic) * (fd[k] * spec + (1.0 - fd_max) * base[k] / M_PI) + metallic * metal * spec;
      CHECK_NEAR(vf_vec3_get(f, k), expected, 2e-6 * expected + 1e-7);
    }
  }
  /* Specular 0 (Blender's Specular 0, glTF's "a pure diffuse material"): Lambert exactly,
   * and no specular lobe to select. */
  vf_material matte = {.gltf = 1, .base_color = vf_vec3_make(0.8f, 0.7f, 0.6f), .roughness = 0.5f, .specular_set = 1,
                       .specular = 0.0f, .specular_f0 = vf_vec3_splat(0.04f)};
  vf_bsdf_lobes lobes;
  vf_bsdf_lobes_of(&matte, &lobes);
  CHECK_NEAR(lobes.lobe_probability[VF_LOBE_ROUGH_CONDUCTOR], 0.0, 0.0);
  for (int d = 0; d < 3; d++) {
    vf_vec3 f = eval(&matte, unit(dirs[d][0], dirs[d][1], dirs[d][2]), unit(dirs[d][3], dirs[d][4], dirs[d][5]));
    CHECK_NEAR(f.x, 0.8f * VF_INV_PI, 1e-7);
    CHECK_NEAR(f.z, 0.6f * VF_INV_PI, 1e-7);
  }
  /* Without the extension (specular_set 0) the core specification's 0.04 and 1. */
  vf_material core = {.gltf = 1, .base_color = vf_vec3_make(0.8f, 0.7f, 0.6f), .roughness = 0.5f};
  vf_material same = core;
  same.specular_set = 1, same.specular = 1.0f, same.specular_f0 = vf_vec3_splat(0.04f);
  vf_vec3 a = eval(&core, unit(0.3, 0.1, 1), unit(-0.4, 0.2, 1)), b = eval(&same, unit(0.3, 0.1, 1), unit(-0.4, 0.2, 1));
  CHECK_NEAR(a.x, b.x, 0.0);
}

/* The JSON scene's glTF model takes the same extension: "specular", "specular_color" and
 * "ior" give specular_f0 = ((ior - 1) / (ior + 1))^2 specular_color; none of them, the core
 * model (specular_set 0); a negative colour is refused naming the field. */
static void test_json_gltf_material_specular_fields(void) {
  const char json[] = "{\"camera\": {\"position\": [0, 0, 5], \"target\": [0, 0, 0], \"fov\": 40},\n"
                      " \"materials\": {\"a\": {\"base_color\": [0.5, 0.5, 0.5], \"metallic\": 0, \"roughness\": 0.5,\n"
                      "   \"specular\": 0.25, \"specular_color\": [1, 0.5, 2], \"ior\": 1.6},\n"
                      "  \"b\": {\"base_color\": [0.5, 0.5, 0.5], \"metallic\": 0, \"roughness\": 0.5}},\n"
                      " \"shapes\": [{\"type\": \"sphere\", \"center\": [0, 0, 0], \"radius\": 1, \"material\": \"a\"},\n"
                      "  {\"type\": \"sphere\", \"center\": [3, 0, 0], \"radius\": 1, \"material\": \"b\", \"emission\": [1, 1, 1]}]}\n";
  write_file("spec.json", json, sizeof json - 1);
  char p[256];
  snprintf(p, sizeof p, "%s/spec.json", dir);
  vf_scene *s = NULL;
  int err = vf_scene_load(p, &s);
  if (err != VF_OK) CHECK_FAIL_("%s: %s", p, vf_error_detail(err));
  if (s != NULL) {
    double r = 0.6 / 2.6, f0 = r * r;
    CHECK(s->materials[0].specular_set && !s->materials[1].specular_set);
    CHECK_NEAR(s->materials[0].specular, 0.25, 0);
    CHECK_NEAR(s->materials[0].specular_f0.x, f0, 1e-7);
    CHECK_NEAR(s->materials[0].specular_f0.y, 0.5 * f0, 1e-7);
    CHECK_NEAR(s->materials[0].specular_f0.z, 2.0 * f0, 1e-7);
  }
  vf_scene_destroy(s);
  const char bad[] = "{\"camera\": {\"position\": [0, 0, 5], \"target\": [0, 0, 0], \"fov\": 40},\n"
                     " \"materials\": {\"a\": {\"base_color\": [0.5, 0.5, 0.5], \"metallic\": 0, \"roughness\": 0.5,\n"
                     "   \"specular_color\": [1, -0.5, 2]}},\n"
                     " \"shapes\": [{\"type\": \"sphere\", \"center\": [0, 0, 0], \"radius\": 1, \"material\": \"a\", \"emission\": [1, 1, 1]}]}\n";
  write_file("bad_spec.json", bad, sizeof bad - 1);
  snprintf(p, sizeof p, "%s/bad_spec.json", dir);
  s = NULL;
  err = vf_scene_load(p, &s);
  CHECK_INT_EQ(err, VF_ESCENE);
  CHECK_STR_CONTAINS(vf_error_detail(err), "materials.a.specular_color: negative colour");
  vf_scene_destroy(s);
}

/* ---- a file as Blender exports it ------------------------------------------------------------- */

/* Wall: y = 0, [-4, 4]^2, facing +y, Specular 0 base 0.8. Glow: a square of half side 0.25 at
 * y = 2 facing down, black base, Specular 0, emission (1, 0.9, 0.8) x 30. A point light of
 * 2174 cd (Blender's 40 W) at (0, 1, 0). Cameras: "WallCam" at (0, 1.5, 3) aimed at the origin
 * with a field of 0.004 rad; "UpCam" at (0, 0.5, 0) looking up into the emitter. */
#define LAMP_CD 2174.0
#define LAMP_H 1.0
#define GLOW_H 2.0
#define GLOW_B 0.25
#define GLOW_L 27.0 /* the mean of (30, 27, 24) */
#define WALL_ALBEDO 0.8

static void write_scene(void) {
  const float b = (float)GLOW_B, h = (float)GLOW_H;
  float pos[24] = {-4, 0, -4, -4, 0, 4, 4, 0, 4, 4, 0, -4, -b, h, -b, b, h, -b, b, h, b, -b, h, b};
  uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
  uint8_t bytes[108];
  memcpy(bytes, pos, 96);
  memcpy(bytes + 96, idx, 12);
  write_file("room.bin", bytes, sizeof bytes);
  double pitch = atan2(1.5, 3.0);
  char text[6000];
  snprintf(text, sizeof text,
           "{\"asset\": {\"version\": \"2.0\", \"generator\": \"test_gltf\"},\n"
           " \"extensionsUsed\": [\"KHR_lights_punctual\", \"KHR_materials_emissive_strength\", \"KHR_materials_specular\"],\n"
           " \"scene\": 0, \"scenes\": [{\"nodes\": [0, 1, 2, 3, 4]}],\n"
           " \"nodes\": [{\"name\": \"Wall\", \"mesh\": 0}, {\"name\": \"Glow\", \"mesh\": 1},\n"
           "  {\"name\": \"Lamp\", \"translation\": [0, %g, 0], \"extensions\": {\"KHR_lights_punctual\": {\"light\": 0}}},\n"
           "  {\"name\": \"WallCam\", \"camera\": 0, \"translation\": [0, 1.5, 3], \"rotation\": [%.17g, 0, 0, %.17g]},\n"
           "  {\"name\": \"UpCam\", \"camera\": 1, \"translation\": [0, 0.5, 0], \"rotation\": [0.70710678118654757, 0, 0, 0.70710678118654757]}],\n"
           " \"cameras\": [{\"name\": \"Wall\", \"type\": \"perspective\", \"perspective\": {\"yfov\": 0.004, \"aspectRatio\": 1, \"znear\": 0.01}},\n"
           "  {\"name\": \"Up\", \"type\": \"perspective\", \"perspective\": {\"yfov\": 0.2, \"aspectRatio\": 1, \"znear\": 0.01}}],\n"
           " \"extensions\": {\"KHR_lights_punctual\": {\"lights\": [{\"type\": \"point\", \"intensity\": %g}]}},\n"
           " \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 2, \"material\": 0}]},\n"
           "  {\"primitives\": [{\"attributes\": {\"POSITION\": 1}, \"indices\": 2, \"material\": 1}]}],\n"
           " \"materials\": [\n"
           "  {\"name\": \"Wall\", \"pbrMetallicRoughness\": {\"baseColorFactor\": [%g, %g, %g, 1], \"metallicFactor\": 0, \"roughnessFactor\": 1},\n"
           "   \"extensions\": {\"KHR_materials_specular\": {\"specularFactor\": 0}}},\n"
           "  {\"name\": \"Glow\", \"pbrMetallicRoughness\": {\"baseColorFactor\": [0, 0, 0, 1], \"metallicFactor\": 0, \"roughnessFactor\": 0.5},\n"
           "   \"emissiveFactor\": [1, 0.9, 0.8], \"extensions\": {\"KHR_materials_emissive_strength\": {\"emissiveStrength\": 30},\n"
           "   \"KHR_materials_specular\": {\"specularFactor\": 0}}}],\n"
           " \"buffers\": [{\"uri\": \"room.bin\", \"byteLength\": 108}],\n"
           " \"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": 96}, {\"buffer\": 0, \"byteOffset\": 96, \"byteLength\": 12}],\n"
           " \"accessors\": [{\"bufferView\": 0, \"byteOffset\": 0, \"componentType\": 5126, \"count\": 4, \"type\": \"VEC3\", \"min\": [-4, 0, -4], \"max\": [4, 0, 4]},\n"
           "  {\"bufferView\": 0, \"byteOffset\": 48, \"componentType\": 5126, \"count\": 4, \"type\": \"VEC3\", \"min\": [-%g, %g, -%g], \"max\": [%g, %g, %g]},\n"
           "  {\"bufferView\": 1, \"byteOffset\": 0, \"componentType\": 5123, \"count\": 6, \"type\": \"SCALAR\"}]}\n",
           LAMP_H, -sin(pitch / 2), cos(pitch / 2), LAMP_CD, WALL_ALBEDO, WALL_ALBEDO, WALL_ALBEDO, GLOW_B, GLOW_H, GLOW_B,
           GLOW_B, GLOW_H, GLOW_B);
  write_file("room.gltf", text, strlen(text));
}

static vf_scene *load_room(const char *camera) {
  char p[256];
  vf_scene *s = NULL;
  snprintf(p, sizeof p, "%s/room.gltf", dir);
  int err = vf_scene_load_camera(p, camera, &s);
  if (err != VF_OK) CHECK_FAIL_("loading %s: %s", p, vf_error_detail(err));
  return s;
}

static void settings_for(vf_settings *st, int side, uint64_t seed) {
  vf_settings_default(st);
  st->algorithm = VF_ALGO_PT; /* the emitter's pixels come from the emission hit alone */
  st->sampler = VF_SAMPLER_INDEPENDENT;
  st->width = st->height = side;
  st->max_path_length = 4;
  st->seed = seed;
}

/* Every pixel of the emitter, seen head on, is its emission: Specular 0 and a black base
 * reflect nothing of the lamp below it (with F0 0.04 it reflected the lamp). */
static void test_black_specular_zero_emitter_reads_exactly_its_emission(void) {
  vf_scene *s = load_room("UpCam");
  if (s == NULL) return;
  const vf_shape *glow = NULL;
  for (int i = 0; i < s->num_shapes; i++)
    if (!vf_is_zero(s->shapes[i].emission)) glow = &s->shapes[i];
  CHECK(glow != NULL);
  if (glow == NULL) goto done;
  CHECK_NEAR(glow->emission.x, 30.0, 1e-5);
  CHECK_NEAR(glow->emission.y, 27.0, 1e-5);
  CHECK_NEAR(glow->emission.z, 24.0, 1e-5);
  vf_settings st;
  settings_for(&st, 8, 11);
  vf_accel *accel = NULL;
  vf_pool *pool = NULL;
  vf_vcm *vcm = NULL;
  float cam[3 * 64], light[3 * 64];
  vf_vcm_stats stats = {0};
  CHECK_INT_EQ(vf_accel_create(s, &accel), VF_OK);
  CHECK_INT_EQ(vf_pool_create(1, &pool), VF_OK);
  CHECK_INT_EQ(vf_vcm_create(s, accel, &st, pool, &vcm), VF_OK);
  int off = 0;
  for (int it = 0; vcm && it < 16; it++) {
    CHECK_INT_EQ(vf_vcm_iteration(vcm, (uint64_t)it, cam, light, &stats), VF_OK);
    for (int p = 0; p < 64; p++)
      for (int k = 0; k < 3; k++) off += cam[3 * p + k] + light[3 * p + k] != vf_vec3_get(glow->emission, k);
  }
  CHECK_INT_EQ(off, 0);
  vf_vcm_destroy(vcm);
  vf_pool_destroy(pool);
  vf_accel_destroy(accel);
done:
  vf_scene_destroy(s);
}

/* Irradiance at (x, 0, z) on the wall from the lamp, Blender's reading: I / 683 W/sr. */
static double lamp_irradiance(double x, double z) {
  double r2 = x * x + z * z + LAMP_H * LAMP_H;
  return LAMP_CD / 683.0 * LAMP_H / (r2 * sqrt(r2));
}

/* pi x the form factor from a point to the rectangle [0, a] x [0, b] parallel to it at
 * height c with a corner above it (odd in a and b), the classic closed form. */
static double corner(double a, double b, double c) {
  double x = a / c, y = b / c, sx = sqrt(1 + x * x), sy = sqrt(1 + y * y);
  return 0.5 * (x / sx * atan(y / sx) + y / sy * atan(x / sy));
}

/* Irradiance at (x, 0, z) from the glowing square of radiance GLOW_L above the origin. */
static double glow_irradiance(double x, double z) {
  double x0 = -GLOW_B - x, x1 = GLOW_B - x, z0 = -GLOW_B - z, z1 = GLOW_B - z;
  return GLOW_L * (corner(x1, z1, GLOW_H) - corner(x0, z1, GLOW_H) - corner(x1, z0, GLOW_H) + corner(x0, z0, GLOW_H));
}

/* The film's expected mean: WALL_ALBEDO / pi x the irradiance, averaged over the pixels'
 * footprints on the wall (8 x 8 points per pixel, through the renderer's own camera). */
static void expected_wall(const vf_scene *s, int side, double *lamp, double *glow) {
  vf_camera cam;
  vf_camera_init(&cam, &s->camera, side, side);
  double sl = 0.0, sg = 0.0;
  int n = 0;
  for (int y = 0; y < 8 * side; y++)
    for (int x = 0; x < 8 * side; x++) {
      vf_vec3 d = vf_camera_image_point(&cam, (x + 0.5f) / 8.0f, (y + 0.5f) / 8.0f);
      double t = -s->camera.position.y / d.y, px = s->camera.position.x + t * d.x, pz = s->camera.position.z + t * d.z;
      sl += lamp_irradiance(px, pz);
      sg += glow_irradiance(px, pz);
      n++;
    }
  *lamp = WALL_ALBEDO / M_PI * sl / n;
  *glow = WALL_ALBEDO / M_PI * sg / n;
}

static int render_mean_with(const vf_scene *s, vf_algorithm algorithm, int side, int iterations, double *mean,
                            double *se) {
  vf_settings st;
  settings_for(&st, side, 7);
  st.algorithm = algorithm;
  st.radius_factor = 1e-4; /* vcm: a merge disc of 6e-4 on the wall, where the irradiance is flat to 1e-6 */
  double *v = malloc((size_t)iterations * sizeof *v);
  vf_vcm_stats stats = {0};
  if (v == NULL) return VF_ENOMEM;
  int err = render_block_means(s, &st, 2, 0, iterations, 1, v, &stats);
  if (err == VF_OK) mean_and_standard_error(v, iterations, 1, 0, mean, se);
  free(v);
  return err;
}

static int render_mean(const vf_scene *s, int side, int iterations, double *mean, double *se) {
  return render_mean_with(s, VF_ALGO_PT, side, iterations, mean, se);
}

/* The lamp's and the emitter's contributions to the matte wall rendered apart (the other
 * light switched off in the loaded scene): each against its closed form, and their ratio
 * against the closed forms' (Blender's: 2174 cd / 683 beside emission 30 as written),
 * within five standard errors. The literal reading (candela as W/sr) is 683 times off. */
static void test_lamp_to_emitter_ratio_on_a_matte_wall(void) {
  vf_scene *lamp = load_room("WallCam"), *glow = load_room("WallCam");
  if (lamp == NULL || glow == NULL) goto done;
  CHECK_INT_EQ(lamp->num_point_lights, 1);
  for (int i = 0; i < lamp->num_shapes; i++) lamp->shapes[i].emission = vf_vec3_splat(0.0f);
  glow->num_point_lights = 0;
  const int side = 16;
  double e_lamp, e_glow, m_lamp, se_lamp, m_glow, se_glow;
  expected_wall(lamp, side, &e_lamp, &e_glow);
  CHECK_INT_EQ(render_mean(lamp, side, 64, &m_lamp, &se_lamp), VF_OK);
  CHECK_INT_EQ(render_mean(glow, side, 256, &m_glow, &se_glow), VF_OK);
  printf("  wall radiance: lamp %.6f +- %.6f (expected %.6f), emitter %.6f +- %.6f (expected %.6f)\n", m_lamp, se_lamp,
         e_lamp, m_glow, se_glow, e_glow);
  /* The lamp's estimate varies only with the pixel positions: its error bar is tiny, and
   * float sums over 256 pixels add about 1e-6 relative. */
  CHECK_NEAR(m_lamp, e_lamp, 5.0 * se_lamp + 1e-5 * e_lamp);
  CHECK_NEAR(m_glow, e_glow, 5.0 * se_glow);
  double ratio = m_lamp / m_glow, expected = e_lamp / e_glow;
  double se_ratio = ratio * sqrt(pow(se_lamp / m_lamp, 2) + pow(se_glow / m_glow, 2));
  printf("  lamp / emitter: %.5f +- %.5f, expected %.5f (the literal reading: %.1f)\n", ratio, se_ratio, expected,
         expected * 683.0);
  CHECK_NEAR(ratio, expected, 5.0 * se_ratio + 1e-5 * expected);
done:
  vf_scene_destroy(lamp);
  vf_scene_destroy(glow);
}

/* Debian's assimp-testmodels with zero vertex normals (refused whole before) load with a
 * note and render: every pixel finite, the model seen (some pixel differs from the white
 * background of the default light). */
static void test_debian_models_with_bad_normals_render(void) {
  static const char *const models[] = {"/usr/share/assimp/models/OBJ/spider.obj",
                                       "/usr/share/assimp/models/glTF2/BoxBadNormals-glTF-Binary/BoxBadNormals.glb"};
  for (int i = 0; i < 2; i++) {
    if (access(models[i], R_OK) != 0) {
      printf("  SKIP: %s not installed (apt-get install assimp-testmodels)\n", models[i]);
      continue;
    }
    vf_scene *s = NULL;
    int err = vf_scene_load(models[i], &s);
    if (err != VF_OK) CHECK_FAIL_("%s: %s", models[i], vf_error_detail(err));
    if (s == NULL) continue;
    CHECK_STR_CONTAINS(s->notes, "vertex normals that were zero or not finite were repaired from their faces");
    vf_settings st;
    settings_for(&st, 32, 3);
    st.algorithm = VF_ALGO_VCM;
    double v[2 * 16];
    CHECK_INT_EQ(render_block_means(s, &st, 2, 0, 2, 4, v, &(vf_vcm_stats){0}), VF_OK);
    int finite = 1, differs = 0;
    for (int b = 0; b < 32; b++) finite &= isfinite(v[b]), differs |= fabs(v[b] - 1.0) > 0.05;
    CHECK(finite && differs);
    printf("  %s: rendered; notes:\n%s", models[i], s->notes);
    vf_scene_destroy(s);
  }
}

/* ---- texture coordinates and vertex colours ------------------------------------------------ */

/* One triangle (0,0,0) (1,0,0) (0,1,0) facing +z with uv set 0 at s = 0.75 and set 1 at
 * s = 0.25 everywhere, and vertex colours; a 2 x 1 texture, red then green, clamped. Meshes
 * A, B, C, D with materials reading set 1, set 1 shifted by KHR_texture_transform's offset
 * 0.5, set 0, and no texture but COLOR_0. Every material Specular 0: f = base colour / pi. */
static void write_uv_scene(void) {
  float b[32] = {0, 0, 0, 1, 0, 0, 0, 1, 0,                       /* positions, offset 0 */
                 0.75f, 0.5f, 0.75f, 0.5f, 0.75f, 0.5f,           /* TEXCOORD_0, 36 */
                 0.25f, 0.5f, 0.25f, 0.5f, 0.25f, 0.5f,           /* TEXCOORD_1, 60 */
                 1, 0.5f, 0.25f, 0.5f, 1, 0, 0.2f, 0.4f, 0.8f};   /* COLOR_0, 84 */
  uint8_t bytes[128] = {0};
  memcpy(bytes, b, 120);
  const uint16_t idx[3] = {0, 1, 2};
  memcpy(bytes + 120, idx, 6);
  write_file("uv.bin", bytes, sizeof bytes);
  const uint8_t texels[6] = {255, 0, 0, 0, 255, 0};
  png_image img;
  memset(&img, 0, sizeof img);
  img.version = PNG_IMAGE_VERSION, img.width = 2, img.height = 1, img.format = PNG_FORMAT_RGB;
  char p[256];
  snprintf(p, sizeof p, "%s/rg.png", dir);
  CHECK(png_image_write_to_file(&img, p, 0, texels, 0, NULL));
  const char text[] =
      "{\"asset\": {\"version\": \"2.0\"}, \"extensionsUsed\": [\"KHR_materials_specular\", \"KHR_texture_transform\"],\n"
      " \"scene\": 0, \"scenes\": [{\"nodes\": [0, 1, 2, 3]}],\n"
      " \"nodes\": [{\"mesh\": 0}, {\"mesh\": 1}, {\"mesh\": 2}, {\"mesh\": 3}],\n"
      " \"meshes\": [\n"
      "  {\"name\": \"A\", \"primitives\": [{\"attributes\": {\"POSITION\": 0, \"TEXCOORD_0\": 1, \"TEXCOORD_1\": 2}, \"indices\": 4, \"material\": 0}]},\n"
      "  {\"name\": \"B\", \"primitives\": [{\"attributes\": {\"POSITION\": 0, \"TEXCOORD_0\": 1, \"TEXCOORD_1\": 2}, \"indices\": 4, \"material\": 1}]},\n"
      "  {\"name\": \"C\", \"primitives\": [{\"attributes\": {\"POSITION\": 0, \"TEXCOORD_0\": 1, \"TEXCOORD_1\": 2}, \"indices\": 4, \"material\": 2}]},\n"
      "  {\"name\": \"D\", \"primitives\": [{\"attributes\": {\"POSITION\": 0, \"COLOR_0\": 3}, \"indices\": 4, \"material\": 3}]}],\n"
      " \"materials\": [\n"
      "  {\"name\": \"Set1\", \"pbrMetallicRoughness\": {\"baseColorTexture\": {\"index\": 0, \"texCoord\": 1}, \"metallicFactor\": 0},\n"
      "   \"extensions\": {\"KHR_materials_specular\": {\"specularFactor\": 0}}},\n"
      "  {\"name\": \"Set1Shifted\", \"pbrMetallicRoughness\": {\"baseColorTexture\": {\"index\": 0, \"texCoord\": 1,\n"
      "     \"extensions\": {\"KHR_texture_transform\": {\"offset\": [0.5, 0]}}}, \"metallicFactor\": 0},\n"
      "   \"extensions\": {\"KHR_materials_specular\": {\"specularFactor\": 0}}},\n"
      "  {\"name\": \"Set0\", \"pbrMetallicRoughness\": {\"baseColorTexture\": {\"index\": 0}, \"metallicFactor\": 0},\n"
      "   \"extensions\": {\"KHR_materials_specular\": {\"specularFactor\": 0}}},\n"
      "  {\"name\": \"Colored\", \"pbrMetallicRoughness\": {\"baseColorFactor\": [0.8, 0.6, 0.4, 1], \"metallicFactor\": 0},\n"
      "   \"extensions\": {\"KHR_materials_specular\": {\"specularFactor\": 0}}}],\n"
      " \"samplers\": [{\"wrapS\": 33071, \"wrapT\": 33071}],\n"
      " \"images\": [{\"uri\": \"rg.png\"}], \"textures\": [{\"source\": 0, \"sampler\": 0}],\n"
      " \"buffers\": [{\"uri\": \"uv.bin\", \"byteLength\": 128}],\n"
      " \"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": 120}, {\"buffer\": 0, \"byteOffset\": 120, \"byteLength\": 6}],\n"
      " \"accessors\": [{\"bufferView\": 0, \"byteOffset\": 0, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\", \"min\": [0, 0, 0], \"max\": [1, 1, 0]},\n"
      "  {\"bufferView\": 0, \"byteOffset\": 36, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC2\"},\n"
      "  {\"bufferView\": 0, \"byteOffset\": 60, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC2\"},\n"
      "  {\"bufferView\": 0, \"byteOffset\": 84, \"componentType\": 5126, \"count\": 3, \"type\": \"VEC3\"},\n"
      "  {\"bufferView\": 1, \"byteOffset\": 0, \"componentType\": 5123, \"count\": 3, \"type\": \"SCALAR\"}]}\n";
  write_file("uv.gltf", text, sizeof text - 1);
}

/* f at barycentrics (0.2, 0.3) of shape `name`, seen and lit from fixed directions. */
static vf_vec3 f_at(const vf_scene *s, const vf_bsdf_lobes *lobes, const char *name) {
  for (int i = 0; i < s->num_shapes; i++) {
    if (strcmp(s->shapes[i].name, name) != 0) continue;
    vf_bsdf b;
    float c;
    CHECK(vf_surface_bsdf(&b, s, lobes, (uint32_t)i, 0, 0.2f, 0.3f, vf_vec3_make(0, 0, 1), unit(0.2, 0.1, 1)));
    return vf_bsdf_evaluate(&b, unit(-0.3, 0.2, 1), &c, NULL, NULL);
  }
  CHECK_FAIL_("no shape '%s'", name);
  return vf_vec3_splat(0.0f);
}

/* A texture asking for TEXCOORD_1 reads set 1 (red at s = 0.25), through its
 * KHR_texture_transform (offset 0.5: green), and one of set 0 reads set 0 (green); COLOR_0
 * multiplies the base colour by the colours interpolated at the point. */
static void test_texcoord_1_transform_and_vertex_colours_at_a_point(void) {
  write_uv_scene();
  char p[256];
  snprintf(p, sizeof p, "%s/uv.gltf", dir);
  vf_scene *s = NULL;
  int err = vf_scene_load(p, &s);
  if (err != VF_OK) CHECK_FAIL_("%s: %s", p, vf_error_detail(err));
  if (s == NULL) return;
  vf_bsdf_lobes *lobes = calloc((size_t)s->num_materials, sizeof *lobes);
  for (int i = 0; lobes && i < s->num_materials; i++) vf_bsdf_lobes_of(&s->materials[i], &lobes[i]);
  if (lobes != NULL) {
    const double k = 1.0 / M_PI;
    vf_vec3 a = f_at(s, lobes, "A"), b = f_at(s, lobes, "B"), c = f_at(s, lobes, "C"), d = f_at(s, lobes, "D");
    CHECK_NEAR(a.x, k, 1e-6);
    CHECK_NEAR(a.y, 0.0, 1e-6);
    CHECK_NEAR(b.x, 0.0, 1e-6);
    CHECK_NEAR(b.y, k, 1e-6);
    CHECK_NEAR(c.x, 0.0, 1e-6);
    CHECK_NEAR(c.y, k, 1e-6);
    const double w[3] = {0.5, 0.2, 0.3}, col[3][3] = {{1, 0.5, 0.25}, {0.5, 1, 0}, {0.2, 0.4, 0.8}}, base[3] = {0.8, 0.6, 0.4};
    for (int ch = 0; ch < 3; ch++) {
      double e = base[ch] * (w[0] * col[0][ch] + w[1] * col[1][ch] + w[2] * col[2][ch]) * k;
      CHECK_NEAR(vf_vec3_get(d, ch), e, 1e-6);
    }
  }
  CHECK(s->notes == NULL || strstr(s->notes, "colour") == NULL); /* applied, not noted */
  free(lobes);
  vf_scene_destroy(s);
}

/* The wall under both lights by bidirectional path tracing and by vcm: light tracing,
 * connections (and merging) through the Specular-0 materials give the closed forms' sum. */
static void test_wall_agrees_across_algorithms(void) {
  vf_scene *s = load_room("WallCam");
  if (s == NULL) return;
  const int side = 16;
  double e_lamp, e_glow;
  expected_wall(s, side, &e_lamp, &e_glow);
  static const vf_algorithm algorithms[] = {VF_ALGO_BPT, VF_ALGO_VCM};
  for (int a = 0; a < 2; a++) {
    double m, se;
    CHECK_INT_EQ(render_mean_with(s, algorithms[a], side, 128, &m, &se), VF_OK);
    printf("  %s: wall %.6f +- %.6f, expected %.6f\n", vf_algorithm_name(algorithms[a]), m, se, e_lamp + e_glow);
    CHECK_NEAR(m, e_lamp + e_glow, 5.0 * se + 1e-5 * (e_lamp + e_glow));
  }
  vf_scene_destroy(s);
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

int main(void) {
  snprintf(dir, sizeof dir, "/tmp/test_gltf.XXXXXX");
  if (mkdtemp(dir) == NULL) return 1;
  write_scene();
  RUN(test_specular_fresnel_is_the_specifications);
  RUN(test_json_gltf_material_specular_fields);
  RUN(test_black_specular_zero_emitter_reads_exactly_its_emission);
  RUN(test_lamp_to_emitter_ratio_on_a_matte_wall);
  RUN(test_wall_agrees_across_algorithms);
  RUN(test_debian_models_with_bad_normals_render);
  RUN(test_texcoord_1_transform_and_vertex_colours_at_a_point);
  if (getenv("KEEP_TMP") == NULL) remove_dir();
  else printf("kept %s\n", dir);
  return check_finish();
}
