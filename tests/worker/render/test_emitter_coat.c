/* An emitter under a clear coat (worker/render/light.h, KHR_materials_clearcoat's
 * "Emission": the coat passes 1 - clearcoat F_c(|n_c . v|) of what the surface beneath it
 * emits, F_c Schlick's of F0 0.04):
 * 1. coated emitters seen straight through an orthographic camera, tilted by several
 *    angles, read emission x (1 - c F_c(cos theta)): path tracing, BPT and VCM (the
 *    camera's rays hit them; the emitters' own points are projected onto the camera by
 *    light tracing alone) exactly, light tracing within its statistical error;
 * 2. path tracing, light tracing, BPT, VCM and upg agree per image block on a room lit by
 *    a coated quad of bent vertex normals (the coat's normal is the shading normal) whose
 *    coat's weight and normal vary by textures, and a coated sphere, both seen directly at grazing angles, so every way an emitter's value
 *    enters a path (emission hits, light samples, emitted light sub-paths, their projection
 *    onto the camera, upg's joins to the light) carries the coat the same way.
 * 3. a coated quad whose vertex normals all lean 70 degrees from its facet (the coat's
 *    normal n_s): every way the light reports its radiance (a camera ray's hit, a light
 *    sample from a receiver, an emitted direction) carries 1 - c F_c(|n_s . w|) exactly,
 *    and pt and light tracing read it through the camera.
 * The scenes are JSON written here, with the JSON material fields of the coat. */
#include "check.h"
#include "render_util.h"

#include "common/image.h"
#include "common/rng.h"
#include "common/settings.h"
#include "worker/render/light.h"
#include "worker/scene/load.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char dir[64];

static vf_scene *load_json(const char *name, const char *json) {
  char p[256];
  snprintf(p, sizeof p, "%s/%s", dir, name);
  FILE *f = fopen(p, "wb");
  CHECK(f != NULL && fwrite(json, 1, strlen(json), f) == strlen(json));
  if (f) fclose(f);
  vf_scene *s = NULL;
  int err = vf_scene_load(p, &s);
  if (err != VF_OK) CHECK_FAIL_("%s: %s", p, vf_error_detail(err));
  return s;
}

static double coat_fresnel(double c) { return 0.04 + 0.96 * pow(1.0 - c, 5.0); }

/* ---- 1. seen straight on and at an angle ---- */

/* Two rows of four quads 1.4 on a side, turned about the vertical by ANGLES: the top row
 * under a coat of weight 1, the bottom one of 0.5, over a black Specular-0 base, emitting
 * EMISSION; seen by an orthographic camera 8 x 4 wide along -z, one pixel 1/32. */
enum { W = 256, H = 128, QUADS = 8 };
static const double ANGLES[4] = {0.0, 40.0, 65.0, 80.0}, COATS[2] = {1.0, 0.5}, HALF = 0.7;
static const float EMISSION[3] = {2.0f, 1.0f, 0.5f};

static vf_scene *angles_scene(void) {
  static char json[8192];
  size_t n = (size_t)snprintf(json, sizeof json,
                              "{\"camera\": {\"type\": \"orthographic\", \"position\": [0, 0, 5], \"forward\": [0, 0, -1],"
                              " \"width\": 8, \"resolution\": [%d, %d]},\n \"materials\": {\n"
                              "  \"coat1\": {\"base_color\": [0, 0, 0], \"metallic\": 0, \"roughness\": 1, \"specular\": 0,"
                              " \"clearcoat\": 1},\n"
                              "  \"coat05\": {\"base_color\": [0, 0, 0], \"metallic\": 0, \"roughness\": 1, \"specular\": 0,"
                              " \"clearcoat\": 0.5, \"clearcoat_roughness\": 0.4}},\n \"shapes\": [\n",
                              W, H);
  for (int q = 0; q < QUADS; q++) {
    double a = ANGLES[q % 4] * M_PI / 180.0, xc = -3.0 + 2.0 * (q % 4), yc = q < 4 ? 1.0 : -1.0;
    double c = cos(a) * HALF, s = sin(a) * HALF; /* the local x axis turned about +y: (cos, 0, -sin) */
    n += (size_t)snprintf(json + n, sizeof json - n,
                          "  {\"type\": \"mesh\", \"material\": \"%s\", \"emission\": [%g, %g, %g], \"positions\": ["
                          "%.9g, %.9g, %.9g,  %.9g, %.9g, %.9g,  %.9g, %.9g, %.9g,  %.9g, %.9g, %.9g],"
                          " \"indices\": [0, 1, 2, 0, 2, 3]}%s\n",
                          q < 4 ? "coat1" : "coat05", EMISSION[0], EMISSION[1], EMISSION[2], xc - c, yc - HALF, s,
                          xc + c, yc - HALF, -s, xc + c, yc + HALF, -s, xc - c, yc + HALF, s, q + 1 < QUADS ? "," : "");
  }
  snprintf(json + n, sizeof json - n, " ]}\n");
  return load_json("angles.json", json);
}

/* Pixels whose whole footprint lies on quad q, one pixel in from its edges. */
static int on_quad(int q, int px, int py) {
  double a = ANGLES[q % 4] * M_PI / 180.0, xc = -3.0 + 2.0 * (q % 4), yc = q < 4 ? 1.0 : -1.0;
  double x0 = -4.0 + px / 32.0, x1 = x0 + 1.0 / 32.0, y1 = 2.0 - py / 32.0, y0 = y1 - 1.0 / 32.0, m = 1.0 / 32.0;
  double hw = cos(a) * HALF;
  return x0 >= xc - hw + m && x1 <= xc + hw - m && y0 >= yc - HALF + m && y1 <= yc + HALF - m;
}

typedef struct {
  double sum[QUADS][3], sum2[QUADS][3];
  double lo[QUADS][3], hi[QUADS][3]; /* extremes of single pixels of single iterations */
  int pixels[QUADS];
} quad_stats;

static void add_quads(void *ctx, int i, const float *cam, const float *light) {
  quad_stats *qs = ctx;
  for (int q = 0; q < QUADS; q++) {
    double m[3] = {0, 0, 0};
    int count = 0;
    for (int py = 0; py < H; py++)
      for (int px = 0; px < W; px++) {
        if (!on_quad(q, px, py)) continue;
        size_t p = (size_t)py * W + px;
        for (int k = 0; k < 3; k++) {
          double v = (double)cam[3 * p + k] + light[3 * p + k];
          m[k] += v;
          if (i == 0 && count == 0) qs->lo[q][k] = qs->hi[q][k] = v;
          qs->lo[q][k] = fmin(qs->lo[q][k], v);
          qs->hi[q][k] = fmax(qs->hi[q][k], v);
        }
        count++;
      }
    qs->pixels[q] = count;
    for (int k = 0; k < 3; k++) {
      qs->sum[q][k] += m[k] / count;
      qs->sum2[q][k] += (m[k] / count) * (m[k] / count);
    }
  }
}

static void check_angles(vf_algorithm algorithm, int iterations) {
  vf_scene *scene = angles_scene();
  if (scene == NULL) return;
  vf_settings st = scene->settings;
  st.algorithm = algorithm;
  st.width = W, st.height = H;
  st.max_path_length = 1; /* the emitters seen, nothing they light */
  st.sampler = VF_SAMPLER_INDEPENDENT; /* independent iterations: their spread is the error */
  st.seed = 77 + (uint64_t)algorithm;
  static quad_stats qs;
  memset(&qs, 0, sizeof qs);
  vf_vcm_stats stats = {0};
  CHECK_INT_EQ(render_iterations(scene, &st, 2, 0, iterations, add_quads, &qs, &stats), VF_OK);
  CHECK_INT_EQ(stats.nonfinite, 0);
  for (int q = 0; q < QUADS; q++) {
    double cos_theta = cos(ANGLES[q % 4] * M_PI / 180.0), transmit = 1.0 - COATS[q / 4] * coat_fresnel(cos_theta);
    CHECK(qs.pixels[q] >= 40);
    for (int k = 0; k < 3; k++) {
      double expected = EMISSION[k] * transmit, mean = qs.sum[q][k] / iterations;
      double se = sqrt(fmax(qs.sum2[q][k] / iterations - mean * mean, 0.0) / (iterations - 1));
      if (algorithm != VF_ALGO_LT) { /* every pixel of every iteration, to rounding */
        CHECK_NEAR(qs.lo[q][k], expected, 2e-6 * expected);
        CHECK_NEAR(qs.hi[q][k], expected, 2e-6 * expected);
      } else {
        CHECK_NEAR(mean, expected, 5.0 * se + 1e-6 * expected);
      }
      if (k == 0 && getenv("VF_TEST_VERBOSE"))
        printf("  %s: coat %.1f at %2.0f deg: %.6f +- %.6f, expected %.6f (1 - c F_c = %.6f)\n",
               vf_algorithm_name(algorithm), COATS[q / 4], ANGLES[q % 4], mean, se, expected, transmit);
    }
  }
  vf_scene_destroy(scene);
}

#ifdef __SANITIZE_ADDRESS__
enum { ANGLE_ITERATIONS = 8 };
#else
enum { ANGLE_ITERATIONS = 48 };
#endif

static void test_path_tracing_reads_the_coats_transmittance_exactly(void) { check_angles(VF_ALGO_PT, 4); }
static void test_light_tracing_projects_the_coated_emission(void) { check_angles(VF_ALGO_LT, ANGLE_ITERATIONS); }
static void test_bpt_and_vcm_read_the_same_value(void) {
  check_angles(VF_ALGO_BPT, 4);
  check_angles(VF_ALGO_VCM, 4);
}

/* ---- 2. independent algorithms agree ---- */

#ifdef __SANITIZE_ADDRESS__
enum { RES = 32 };
#else
enum { RES = 64 };
#endif
enum { BLOCKS = 8, NB = BLOCKS * BLOCKS, ITERATIONS = 128 };

/* A floor and a back wall, lit only by a coated quad whose vertex normals lean away from
 * its facet by up to 40 degrees (rough coat 0.3 over a dark plastic, its weight from 0.1
 * to 1 and its normal tilted by up to 35 degrees by 4 x 4 textures) and a coated sphere
 * (smooth coat 0.7), both seen from the camera at angles from straight on to grazing. */
static const char ROOM[] =
    "{\"camera\": {\"position\": [0, 1.2, 4], \"target\": [0, 0.35, 0], \"fov\": 50},\n"
    " \"materials\": {\n"
    "  \"floor\": {\"diffuse\": [0.6, 0.6, 0.6]},\n"
    "  \"wall\": {\"base_color\": [0.5, 0.6, 0.4], \"metallic\": 0, \"roughness\": 0.6},\n"
    "  \"lamp\": {\"base_color\": [0.2, 0.15, 0.1], \"metallic\": 0, \"roughness\": 0.5, \"clearcoat\": 1,"
    " \"clearcoat_roughness\": 0.3, \"clearcoat_texture\": {\"file\": \"coat.exr\", \"wrap\": \"clamp\"},"
    " \"clearcoat_normal_texture\": {\"file\": \"coat_normal.exr\", \"wrap\": \"clamp\"}},\n"
    "  \"globe\": {\"base_color\": [0.1, 0.1, 0.2], \"metallic\": 0, \"roughness\": 0.6, \"clearcoat\": 0.7}},\n"
    " \"shapes\": [\n"
    "  {\"type\": \"mesh\", \"material\": \"floor\", \"positions\": [-3, 0, -3,  -3, 0, 2,  3, 0, 2,  3, 0, -3],"
    " \"indices\": [0, 1, 2, 0, 2, 3]},\n"
    "  {\"type\": \"mesh\", \"material\": \"wall\", \"positions\": [-3, 0, -2,  3, 0, -2,  3, 3, -2,  -3, 3, -2],"
    " \"indices\": [0, 1, 2, 0, 2, 3]},\n"
    "  {\"type\": \"mesh\", \"material\": \"lamp\", \"emission\": [4, 3, 2],"
    " \"positions\": [-1.6, 0.05, -1.2,  -0.4, 0.05, -0.6,  -0.4, 1.0, -0.6,  -1.6, 1.0, -1.2],"
    " \"normals\": [-0.7, 0.3, 1,  0.3, -0.1, 1,  0.2, 0.4, 0.8,  -0.9, 0.2, 0.7],"
    " \"uvs\": [0, 1,  1, 1,  1, 0,  0, 0],"
    " \"indices\": [0, 1, 2, 0, 2, 3]},\n"
    "  {\"type\": \"sphere\", \"material\": \"globe\", \"center\": [0.9, 0.45, -0.5], \"radius\": 0.4,"
    " \"emission\": [2, 2.5, 4]}\n"
    " ]}\n";

/* The lamp's coat textures: R of coat.exr the weight, 0.1 to 1 over its 4 x 4 texels; the
 * texels of coat_normal.exr tangent-space normals tilted by up to 35 degrees. */
static void write_coat_textures(void) {
  vf_image w = {0}, n = {0};
  CHECK_INT_EQ(vf_image_alloc(&w, 4, 4), VF_OK);
  CHECK_INT_EQ(vf_image_alloc(&n, 4, 4), VF_OK);
  for (int i = 0; i < 16; i++) {
    w.rgb[3 * i] = w.rgb[3 * i + 1] = w.rgb[3 * i + 2] = 0.1f + 0.06f * (float)((i * 7) % 16);
    double tilt = 35.0 * M_PI / 180.0 * ((i * 5) % 16) / 15.0, phi = 2.0 * M_PI * i / 16.0;
    n.rgb[3 * i] = (float)(0.5 + 0.5 * sin(tilt) * cos(phi));
    n.rgb[3 * i + 1] = (float)(0.5 + 0.5 * sin(tilt) * sin(phi));
    n.rgb[3 * i + 2] = (float)(0.5 + 0.5 * cos(tilt));
  }
  char p[256];
  snprintf(p, sizeof p, "%s/coat.exr", dir);
  CHECK_INT_EQ(vf_image_write_exr(p, &w), VF_OK);
  snprintf(p, sizeof p, "%s/coat_normal.exr", dir);
  CHECK_INT_EQ(vf_image_write_exr(p, &n), VF_OK);
  vf_image_destroy(&w);
  vf_image_destroy(&n);
}

static void test_algorithms_agree_on_coated_emitters(void) {
  write_coat_textures();
  vf_scene *scene = load_json("room.json", ROOM);
  if (scene == NULL) return;
  const vf_algorithm all[] = {VF_ALGO_PT, VF_ALGO_LT, VF_ALGO_BPT, VF_ALGO_VCM, VF_ALGO_UPG};
  enum { N = sizeof all / sizeof all[0] };
  static double mean[N][NB], se[N][NB];
  for (int a = 0; a < N; a++) {
    vf_settings st = scene->settings;
    st.algorithm = all[a];
    st.width = st.height = RES;
    st.max_path_length = 4;
    st.seed = 9100 + (uint64_t)all[a];
    vf_vcm_stats stats = {0};
    CHECK_INT_EQ(render_block_estimates(scene, &st, 2, ITERATIONS, BLOCKS, mean[a], se[a], &stats), VF_OK);
    CHECK_INT_EQ(stats.nonfinite, 0);
  }
  for (int i = 0; i < N; i++)
    for (int j = i + 1; j < N; j++)
      CHECK(blocks_agree("coated emitters", vf_algorithm_name(all[i]), vf_algorithm_name(all[j]), mean[i], se[i], mean[j],
                         se[j], NB));
  vf_scene_destroy(scene);
}

/* ---- 3. the coat's normal is the shading normal ---- */

static const double BENT_DEGREES = 70.0;

/* The quad [-1, 1]^2 at z = 0 facing +z, its vertex normals (sin 70, 0, cos 70), coat 1
 * over a black base, emitting (3, 2, 1); seen by an orthographic camera along -z. */
static vf_scene *bent_scene(void) {
  static char json[2048];
  double a = BENT_DEGREES * M_PI / 180.0;
  snprintf(json, sizeof json,
           "{\"camera\": {\"type\": \"orthographic\", \"position\": [0, 0, 5], \"forward\": [0, 0, -1], \"width\": 4,"
           " \"resolution\": [64, 64]},\n"
           " \"materials\": {\"coat\": {\"base_color\": [0, 0, 0], \"metallic\": 0, \"roughness\": 1, \"specular\": 0,"
           " \"clearcoat\": 1}},\n"
           " \"shapes\": [{\"type\": \"mesh\", \"material\": \"coat\", \"emission\": [3, 2, 1],"
           " \"positions\": [-1, -1, 0,  1, -1, 0,  1, 1, 0,  -1, 1, 0], \"indices\": [0, 1, 2, 0, 2, 3],"
           " \"normals\": [%.9g, 0, %.9g,  %.9g, 0, %.9g,  %.9g, 0, %.9g,  %.9g, 0, %.9g]}]}\n",
           sin(a), cos(a), sin(a), cos(a), sin(a), cos(a), sin(a), cos(a));
  return load_json("bent.json", json);
}

static double bent_transmit(vf_vec3 w) {
  double a = BENT_DEGREES * M_PI / 180.0, c = fabs(sin(a) * w.x + cos(a) * w.z) / vf_length(w);
  return 1.0 - coat_fresnel(fmin(c, 1.0));
}

static void test_light_samples_and_emission_see_the_shading_normals_coat(void) {
  vf_scene *scene = bent_scene();
  if (scene == NULL) return;
  vf_lights *ls = NULL;
  CHECK_INT_EQ(vf_lights_create(scene, &ls), VF_OK);
  if (ls == NULL) goto done;
  const vf_light *l = &ls->lights[0];
  CHECK(l->coated && l->kind == VF_LIGHT_AREA_MESH);
  vf_rng rng = vf_rng_for_path(3, 0, 0, VF_STREAM_TEST);
  double worst_illuminate = 0.0, worst_emit = 0.0, lowest = 1.0;
  for (int i = 0; i < 2000; i++) {
    /* receivers all over the half-space in front, down to grazing */
    vf_vec3 receiver = vf_vec3_make(6.0f * vf_rng_float(&rng) - 3.0f, 6.0f * vf_rng_float(&rng) - 3.0f,
                                    0.05f + 3.0f * vf_rng_float(&rng));
    float rnd[4] = {vf_rng_float(&rng), vf_rng_float(&rng), vf_rng_float(&rng), vf_rng_float(&rng)};
    vf_vec3 d, lp, ln, p, emitted_dir, n;
    float dist, pdf_w, emission_pdf, cos_light, direct_pdf;
    vf_vec3 le = vf_light_illuminate(ls, l, receiver, rnd, &d, &dist, &lp, &ln, &pdf_w, &emission_pdf, &cos_light);
    if (!vf_is_zero(le)) {
      double t = bent_transmit(vf_neg(d));
      lowest = fmin(lowest, t);
      worst_illuminate = fmax(worst_illuminate, fabs(le.x / 3.0 - t));
      worst_illuminate = fmax(worst_illuminate, fabs(le.z / 1.0 - t));
    }
    vf_vec3 e = vf_light_emit(ls, l, rnd, &p, &emitted_dir, &n, &emission_pdf, &direct_pdf, &cos_light);
    worst_emit = fmax(worst_emit, fabs(e.y / 2.0 - cos_light * bent_transmit(emitted_dir)));
  }
  /* Errors relative to the emission: single precision's rounding of the direction and of
   * 1 - F_c, not relative to the transmittance, which falls to ~0 at grazing. */
  printf("  largest error per unit emission: light samples %.2e, emission %.2e (transmittance down to %.3f)\n",
         worst_illuminate, worst_emit, lowest);
  CHECK(worst_illuminate < 2e-6 && worst_emit < 2e-6);
  CHECK(lowest < 0.5); /* the directions reached the coat's grazing angles */
done:
  vf_lights_destroy(ls);
  vf_scene_destroy(scene);
}

/* Seen along -z through the shading normal 70 degrees off: 1 - F_c(cos 70) = 0.8415 of the
 * emission (the facet's normal would give 0.96), by pt exactly and by light tracing. */
static void test_camera_sees_the_shading_normals_coat(void) {
  vf_scene *scene = bent_scene();
  if (scene == NULL) return;
  double expected = 1.0 - coat_fresnel(cos(BENT_DEGREES * M_PI / 180.0));
  for (int a = 0; a < 2; a++) {
    vf_settings st = scene->settings;
    st.algorithm = a ? VF_ALGO_LT : VF_ALGO_PT;
    st.max_path_length = 1;
    st.sampler = VF_SAMPLER_INDEPENDENT;
    st.seed = 500 + (uint64_t)a;
    double mean[4], se[4];
    vf_vcm_stats stats = {0};
    /* 2 x 2 blocks of the 64 x 64 image: the quad fills the middle 32 x 32, a quarter of each */
    CHECK_INT_EQ(render_block_estimates(scene, &st, 2, a ? 32 : 4, 2, mean, se, &stats), VF_OK);
    for (int b = 0; b < 4; b++) { /* the blocks' RGB mean: a quarter covered by (3 + 2 + 1) / 3 */
      double want = 0.25 * 2.0 * expected;
      if (a == 0) CHECK_NEAR(mean[b], want, 1e-5 * want);
      else CHECK_NEAR(mean[b], want, 5.0 * se[b] + 1e-6);
    }
    printf("  %s: block mean %.6f +- %.6f, expected %.6f\n", a ? "lt" : "pt", mean[0], se[0], 0.25 * 2.0 * expected);
  }
  vf_scene_destroy(scene);
}

static void remove_dir(void) {
  static const char *const files[] = {"angles.json", "room.json", "coat.exr", "coat_normal.exr", "bent.json"};
  char p[256];
  for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
    snprintf(p, sizeof p, "%s/%s", dir, files[i]);
    unlink(p);
  }
  rmdir(dir);
}

int main(void) {
  snprintf(dir, sizeof dir, "/tmp/test_emitter_coat.XXXXXX");
  if (mkdtemp(dir) == NULL) return 1;
  RUN(test_path_tracing_reads_the_coats_transmittance_exactly);
  RUN(test_light_tracing_projects_the_coated_emission);
  RUN(test_bpt_and_vcm_read_the_same_value);
  RUN(test_algorithms_agree_on_coated_emitters);
  RUN(test_light_samples_and_emission_see_the_shading_normals_coat);
  RUN(test_camera_sees_the_shading_normals_coat);
  remove_dir();
  return check_finish();
}
