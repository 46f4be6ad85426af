/* Shading normals, textures and cut-outs (worker/render/surface.h, vf_bsdf_setup_shading), tested
 * on physics and on identities, never on pixels of an earlier run:
 * 1. with a shading normal, the value a camera sub-path's vertex evaluates for (fix a,
 *    gen b) equals the value a light sub-path's vertex evaluates for (fix b, gen a), and
 *    each side's direct density is the other's reverse one: the same path vertex gets the
 *    same contribution and densities from every technique (worker/render/bsdf.h);
 * 2. sampling reports the density and value that evaluation gives for the sampled
 *    direction, and never a direction through the geometric surface of an opaque material;
 * 3. f cos of the folded value is f_s |gen.ns| for radiance and the adjoint of Veach's
 *    thesis eq. 5.19 for importance;
 * 4. the geometric normal of an interpolated hit is the winding's, as Embree's;
 * 5. cut-outs: rays pass through holes, closest hits and occlusion alike;
 * 6. path tracing, light tracing, BPT and VCM agree per image block on smooth-normal
 *    meshes, textured diffuse and glTF materials (and an emission texture), a normal map,
 *    an alpha cut-out, rough glass on a smooth-normal mesh, and all of them together with
 *    a thin lens and a spot light. */
#include "check.h"
#include "feature_scene.h"
#include "render_util.h"
#include "worker/render/bsdf.h"
#include "worker/render/surface.h"

#include "common/rng.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- 1-3: the shading-normal BSDF ---- */

static vf_vec3 random_direction(vf_rng *r) {
  float z = 1.0f - 2.0f * vf_rng_float(r), phi = 2.0f * (float)M_PI * vf_rng_float(r);
  float s = sqrtf(fmaxf(0.0f, 1.0f - z * z));
  return vf_vec3_make(s * cosf(phi), s * sinf(phi), z);
}

/* A shading normal tilted from ng by up to ~50 degrees. */
static vf_vec3 tilted(vf_vec3 ng, vf_rng *r) {
  return vf_normalize(vf_add(ng, vf_scale(random_direction(r), 0.8f * vf_rng_float(r))));
}

static vf_material reflecting_material(int k) {
  vf_material m;
  memset(&m, 0, sizeof m);
  m.phong_exponent = m.ior = 1.0f;
  switch (k) {
  case 0: m.diffuse = vf_vec3_make(0.7f, 0.5f, 0.3f); break;
  case 1:
    m.diffuse = vf_vec3_splat(0.3f);
    m.glossy = vf_vec3_splat(0.5f);
    m.phong_exponent = 30.0f;
    break;
  case 2:
    m.gltf = 1;
    m.base_color = vf_vec3_make(0.8f, 0.6f, 0.2f);
    m.metallic = 0.3f;
    m.roughness = 0.5f;
    break;
  default:
    m.conductor = vf_vec3_splat(0.9f);
    m.roughness = 0.4f;
    break;
  }
  return m;
}

static double rel(double a, double b) { return fabs(a - b) / fmax(1e-30, fmax(fabs(a), fabs(b))); }

static void test_shading_bsdf_is_the_same_from_both_sub_paths(void) {
  vf_rng r = vf_rng_for_path(7, 0, 0, 0);
  int compared = 0;
  double worst_f = 0.0, worst_pdf = 0.0;
  for (int k = 0; k < 4; k++) {
    vf_material m = reflecting_material(k);
    vf_bsdf_lobes lobes;
    vf_bsdf_lobes_of(&m, &lobes);
    for (int i = 0; i < 4000; i++) {
      vf_vec3 ng = random_direction(&r), ns = tilted(ng, &r);
      vf_vec3 a = random_direction(&r), b = random_direction(&r);
      vf_bsdf camera, light;
      if (!vf_bsdf_setup_shading(&camera, &m, &lobes, ng, ns, a)) continue;
      if (!vf_bsdf_setup_shading(&light, &m, &lobes, ng, ns, b)) continue;
      camera.radiance = 1;
      float cc, cp, cr, lc, lp, lr;
      vf_vec3 fc = vf_bsdf_evaluate(&camera, b, &cc, &cp, &cr);
      vf_vec3 fl = vf_bsdf_evaluate(&light, a, &lc, &lp, &lr);
      CHECK(vf_is_zero(fc) == vf_is_zero(fl));
      /* The cosines the renderer sees are geometric. */
      CHECK_NEAR(cc, fabsf(vf_dot(ng, b)), 1e-6);
      CHECK_NEAR(lc, fabsf(vf_dot(ng, a)), 1e-6);
      if (vf_is_zero(fc)) {
        /* zero exactly when a direction lies on different sides of the two surfaces */
        int split = (vf_dot(ng, a) > 0) != (vf_dot(ns, a) > 0) || (vf_dot(ng, b) > 0) != (vf_dot(ns, b) > 0) ||
                    (vf_dot(ng, a) > 0) != (vf_dot(ng, b) > 0);
        if (k != 1) CHECK(split); /* Phong is zero outside its lobe too */
        continue;
      }
      compared++;
      for (int c = 0; c < 3; c++) worst_f = fmax(worst_f, rel(vf_vec3_get(fc, c), vf_vec3_get(fl, c)));
      worst_pdf = fmax(worst_pdf, fmax(rel(cp, lr), rel(cr, lp)));
      /* 3: f cos is f_s |b.ns| for the camera's vertex; for the light's, the adjoint. */
      vf_bsdf plain;
      vf_bsdf_init(&plain, &m, ns, a);
      float pc;
      vf_vec3 fs = vf_bsdf_evaluate(&plain, b, &pc, NULL, NULL);
      CHECK_NEAR(fc.x * cc, fs.x * fabsf(vf_dot(ns, b)), 1e-4 * fs.x * fabsf(vf_dot(ns, b)) + 1e-7);
      /* the light's vertex: fix b, gen a; f_s |fix.ns| |gen.ng| / |fix.ng| */
      double adjoint = fs.x * fabs(vf_dot(ns, b)) * fabs(vf_dot(ng, a)) / fabs(vf_dot(ng, b));
      CHECK_NEAR(fl.x * lc, adjoint, 1e-4 * adjoint + 1e-7);
    }
  }
  printf("  %d pairs: worst relative difference of f %.2g, of densities %.2g\n", compared, worst_f, worst_pdf);
  CHECK(compared > 4000);
  CHECK(worst_f < 1e-4);
  CHECK(worst_pdf < 1e-4);
}

static void test_shading_bsdf_samples_what_it_evaluates_and_never_leaks(void) {
  vf_rng r = vf_rng_for_path(8, 0, 0, 0);
  int sampled = 0;
  for (int k = 0; k < 4; k++) {
    vf_material m = reflecting_material(k);
    vf_bsdf_lobes lobes;
    vf_bsdf_lobes_of(&m, &lobes);
    for (int i = 0; i < 4000; i++) {
      vf_vec3 ng = random_direction(&r), ns = tilted(ng, &r), fix = random_direction(&r);
      vf_bsdf b;
      if (!vf_bsdf_setup_shading(&b, &m, &lobes, ng, ns, fix)) continue;
      b.radiance = (int)(i & 1);
      float rnd[3] = {vf_rng_float(&r), vf_rng_float(&r), vf_rng_float(&r)};
      vf_vec3 gen;
      float pdf, rev, cos_gen, e_cos, e_pdf, e_rev;
      unsigned event;
      vf_vec3 f = vf_bsdf_sample(&b, rnd, &gen, &pdf, &rev, &cos_gen, &event);
      if (vf_is_zero(f)) continue;
      sampled++;
      /* on the side of fix: an opaque surface is never crossed */
      CHECK((vf_dot(ng, gen) > 0) == (vf_dot(ng, fix) > 0));
      vf_vec3 fe = vf_bsdf_evaluate(&b, gen, &e_cos, &e_pdf, &e_rev);
      CHECK_NEAR(e_pdf, pdf, 1e-6 * pdf);
      CHECK_NEAR(e_rev, rev, 1e-6 * rev);
      CHECK_NEAR(e_cos, cos_gen, 1e-7);
      CHECK_NEAR(fe.y, f.y, 1e-6 * f.y);
    }
  }
  printf("  %d sampled directions checked\n", sampled);
  CHECK(sampled > 8000);
}

/* ---- 4, 5: hits ---- */

static void test_interpolated_hits_have_the_winding_normal_and_cutouts_have_holes(void) {
  vf_scene *s = feature_scene(FEATURE_SMOOTH | FEATURE_CUTOUT);
  if (s == NULL) return;
  vf_accel *a;
  CHECK_INT_EQ(vf_accel_create(s, &a), VF_OK);
  if (check_failed_in_case) return;
  int grating = find_shape(s, "grating"), through = 0, stopped = 0;
  /* Rays straight down through the grating: through a hole they reach the floor. */
  for (int i = 0; i < 60; i++)
    for (int j = 0; j < 60; j++) {
      float x = -0.59f + 1.18f * (i + 0.5f) / 60, z = -0.59f + 1.18f * (j + 0.5f) / 60;
      vf_hit h;
      CHECK(vf_accel_intersect(a, vf_vec3_make(x, 0.9f, z), vf_vec3_make(0, -1, 0), INFINITY, &h));
      /* uv = ((x + 0.6) / 1.2, (z + 0.6) / 1.2), texel (6 u, 6 v): a hole where x + y is even */
      int tx = (int)((x + 0.6f) / 1.2f * 6), ty = (int)((z + 0.6f) / 1.2f * 6), open = ((tx + ty) & 1) == 0;
      int blocked = vf_accel_occluded(a, vf_vec3_make(x, 0.9f, z), vf_vec3_make(0, -0.6f, 0), 1.0f);
      if (open) {
        CHECK(h.shape != (uint32_t)grating);
        CHECK(!blocked);
        through++;
      } else {
        CHECK_INT_EQ((int)h.shape, grating);
        CHECK(blocked);
        stopped++;
      }
    }
  CHECK(through > 1000 && stopped > 1000);
  /* Hits on the smooth balls: the normal points out of the ball, like Embree's Ng would. */
  int left = find_shape(s, "white ball");
  for (int i = 0; i < 100; i++) {
    vf_vec3 center = vf_vec3_make(-0.45f, -0.65f, -0.35f);
    vf_vec3 org = vf_add(center, vf_scale(vf_normalize(vf_vec3_make(sinf((float)i), 0.3f, cosf((float)i * 0.7f))), 0.9f));
    vf_hit h;
    if (!vf_accel_intersect(a, org, vf_sub(center, org), INFINITY, &h) || (int)h.shape != left) continue;
    CHECK(vf_dot(h.normal, vf_sub(h.position, center)) > 0.0f);
    CHECK(h.u >= 0.0f && h.v >= 0.0f && h.u + h.v <= 1.0f + 1e-6f);
  }
  vf_accel_destroy(a);
  vf_scene_destroy(s);
}

/* ---- 6: independent algorithms agree ---- */

enum { RES = 64, BLOCKS = 8, NB = BLOCKS * BLOCKS, ITERATIONS = 96 };

static void block_estimates(const vf_scene *scene, vf_algorithm algorithm, double mean[NB], double se[NB]) {
  vf_settings s = scene->settings;
  s.algorithm = algorithm;
  s.width = s.height = RES;
  s.max_path_length = 6;
  s.seed = 3000 + (uint64_t)algorithm;
  vf_vcm_stats stats = {0};
  /* Light tracing through glass sees the glass's caustics as rare bright splats: its
   * block estimates are heavy-tailed, and 48 batches of two estimate their spread too
   * unsteadily for a 5-sigma test (render_util.h). It is also the cheapest technique: four
   * times the iterations steady its error bars. */
  int iterations = algorithm == VF_ALGO_LT ? 4 * ITERATIONS : ITERATIONS;
  CHECK_INT_EQ(render_block_estimates(scene, &s, 2, iterations, BLOCKS, mean, se, &stats), VF_OK);
  CHECK_INT_EQ(stats.nonfinite, 0);
}

static void check_agreement(const char *what, unsigned features) {
  /* A spot light behind rough glass makes caustics that path tracing cannot sample (its
   * light samples are shadowed by the glass and it cannot hit a point): without pt then. */
  const vf_algorithm all[] = {VF_ALGO_PT, VF_ALGO_LT, VF_ALGO_BPT, VF_ALGO_VCM};
  const vf_algorithm *algorithms = features & FEATURE_SPOT ? all + 1 : all;
  const int N = features & FEATURE_SPOT ? 3 : 4;
  vf_scene *scene = feature_scene(features);
  if (scene == NULL || check_failed_in_case) return;
  static double mean[4][NB], se[4][NB];
  for (int a = 0; a < N; a++) block_estimates(scene, algorithms[a], mean[a], se[a]);
  for (int i = 0; i < N; i++)
    for (int j = i + 1; j < N; j++)
      CHECK(blocks_agree(what, vf_algorithm_name(algorithms[i]), vf_algorithm_name(algorithms[j]), mean[i], se[i],
                         mean[j], se[j], NB));
  vf_scene_destroy(scene);
}

static void test_algorithms_agree_on_smooth_meshes(void) { check_agreement("smooth", FEATURE_SMOOTH); }
static void test_algorithms_agree_on_textures(void) { check_agreement("textured", FEATURE_TEXTURED); }
static void test_algorithms_agree_on_a_normal_map(void) { check_agreement("normal map", FEATURE_NORMAL_MAP); }
static void test_algorithms_agree_through_a_cutout(void) { check_agreement("cut-out", FEATURE_CUTOUT); }
static void test_algorithms_agree_through_smooth_rough_glass(void) {
  check_agreement("smooth glass", FEATURE_SMOOTH | FEATURE_ROUGH_GLASS);
}
static void test_algorithms_agree_on_everything_together(void) {
  check_agreement("all", FEATURE_SMOOTH | FEATURE_TEXTURED | FEATURE_NORMAL_MAP | FEATURE_CUTOUT |
                             FEATURE_ROUGH_GLASS | FEATURE_LENS | FEATURE_SPOT);
}

int main(void) {
  RUN(test_shading_bsdf_is_the_same_from_both_sub_paths);
  RUN(test_shading_bsdf_samples_what_it_evaluates_and_never_leaks);
  RUN(test_interpolated_hits_have_the_winding_normal_and_cutouts_have_holes);
  RUN(test_algorithms_agree_on_smooth_meshes);
  RUN(test_algorithms_agree_on_textures);
  RUN(test_algorithms_agree_on_a_normal_map);
  RUN(test_algorithms_agree_through_a_cutout);
  RUN(test_algorithms_agree_through_smooth_rough_glass);
  RUN(test_algorithms_agree_on_everything_together);
  return check_finish();
}
