/* Physics of the whole renderer: the furnace and the agreement of independent algorithms. */
#include "check.h"
#include "feature_scene.h"
#include "render_util.h"
#include "worker/scene/builtin.h"
#include "worker/scene/json.h"
#include "worker/scene/load.h"

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* The sampler the physics is checked with: main runs the furnace and the agreement of
 * pt, bpt and vcm with each (common/sampler.h), the rest with the default. */
static vf_sampler_kind sampler_under_test = VF_SAMPLER_SOBOL;

static const vf_algorithm all_algorithms[] = {VF_ALGO_VCM, VF_ALGO_BPT, VF_ALGO_PT, VF_ALGO_LT,
                                             VF_ALGO_PPM, VF_ALGO_BPM, VF_ALGO_AUTO, VF_ALGO_UPG};

/* A closed enclosure of albedo a whose walls all emit Le: every path of up to L segments
 * sees Le (1 + a + ... + a^(L-1)) = Le (1 - a^L) / (1 - a), which is 1 - 0.5^L here. */
static void test_furnace_every_algorithm_gives_the_analytic_value(void) {
  vf_scene *scene;
  CHECK_INT_EQ(vf_scene_load("furnace", &scene), VF_OK);
  if (check_failed_in_case) return;
  enum { N = 64 };
  for (size_t a = 0; a < sizeof all_algorithms / sizeof *all_algorithms; a++) {
    vf_settings s = scene->settings;
    s.algorithm = all_algorithms[a];
    s.sampler = sampler_under_test;
    vf_vcm_stats stats = {0};
    double mean = NAN, se = NAN;
    CHECK_INT_EQ(render_block_estimates(scene, &s, 2, N, 1, &mean, &se, &stats), VF_OK);
    double exact = 1.0 - pow(0.5, s.max_path_length);
    printf("  furnace %-4s %-11s mean %.5f +- %.5f (exact %.5f), %llu non-finite\n", vf_algorithm_name(s.algorithm),
           vf_sampler_name(s.sampler), mean, se, exact, (unsigned long long)stats.nonfinite);
    CHECK_NEAR(mean, exact, 3.0 * se);
    CHECK(se < 0.005); /* the check above must have teeth */
    CHECK_INT_EQ(stats.nonfinite, 0);
  }
  vf_scene_destroy(scene);
}

/* Renders `algorithm` on `scene` and returns per-block means and standard errors. Each
 * algorithm gets its own seed, so the estimates compared are independent. Under the
 * sanitizers (tests/sanitize.sh looks for memory errors and non-finite samples, not for
 * statistics) the same paths, blocks and iterations on a sixteenth of the pixels, whose
 * agreement is printed, not checked (AGREE): blocks of 16 pixels estimate heavy-tailed
 * blocks' spread too unsteadily for a 5-sigma rule. The release run checks it. */
#ifdef __SANITIZE_ADDRESS__
enum { RES = 32 };
#define AGREE(x) ((void)(x))
#else
enum { RES = 128 };
#define AGREE(x) CHECK(x)
#endif
enum { BLOCKS = 8, NB = BLOCKS * BLOCKS, ITERATIONS = 128 };

/* The merge radius of block_estimates' renders. */
static vf_radius_mode radius_under_test = VF_RADIUS_GLOBAL;

static void block_estimates(const vf_scene *scene, vf_algorithm algorithm, double mean[NB], double se[NB]) {
  vf_settings s = scene->settings;
  s.algorithm = algorithm;
  s.radius = vf_algorithm_merges(algorithm) ? radius_under_test : VF_RADIUS_GLOBAL;
  s.width = s.height = RES;
  s.seed = 1000 + (uint64_t)algorithm;
  s.sampler = sampler_under_test;
  vf_vcm_stats stats = {0};
  CHECK_INT_EQ(render_block_estimates(scene, &s, 2, ITERATIONS, BLOCKS, mean, se, &stats), VF_OK);
  CHECK_INT_EQ(stats.nonfinite, 0);
}

/* block_estimates at the scene's own size, for the showcase's wide frame, with upg's side. */
static void showcase_blocks(const vf_scene *scene, vf_algorithm algorithm, vf_gather_side side, double mean[NB],
                            double se[NB]) {
  vf_settings s = scene->settings;
  s.algorithm = algorithm;
  s.gather = side;
  s.seed = 3000 + 2 * (uint64_t)algorithm + (uint64_t)side;
  s.sampler = sampler_under_test;
  vf_vcm_stats stats = {0};
  CHECK_INT_EQ(render_block_estimates(scene, &s, 2, ITERATIONS, BLOCKS, mean, se, &stats), VF_OK);
  CHECK_INT_EQ(stats.nonfinite, 0);
}

/* Every pair of the algorithms' independent estimates agrees (blocks_agree). */
static void check_agreement(const char *scene_name, const vf_scene *scene, const vf_algorithm *algorithms, int n) {
  double mean[6][NB], se[6][NB];
  for (int a = 0; a < n; a++) block_estimates(scene, algorithms[a], mean[a], se[a]);
  for (int i = 0; i < n; i++)
    for (int j = i + 1; j < n; j++)
      AGREE(blocks_agree(scene_name, vf_algorithm_name(algorithms[i]), vf_algorithm_name(algorithms[j]), mean[i],
                         se[i], mean[j], se[j], NB));
}

/* Replaces the mirror and glass lobes by white diffuse ones. */
static void make_specular_diffuse(vf_scene *scene) {
  for (int i = 0; i < scene->num_materials; i++) {
    vf_material *m = &scene->materials[i];
    if (vf_is_zero(m->mirror) && vf_is_zero(m->dielectric)) continue;
    m->mirror = m->dielectric = vf_vec3_splat(0.0f);
    m->diffuse = vf_vec3_splat(0.6f);
  }
}

/* With area and environment lights every path can be sampled by an emission hit, so path
 * tracing, BPT and VCM estimate the same image; in cornell-bulb the lamp is inside glass
 * (see test_light_inside_glass_agrees); cornell-dof sees the box through a thin lens. */
static void test_pt_bpt_vcm_agree_on_area_and_environment_variants(void) {
  const char *names[] = {"cornell", "cornell-env", "cornell-bulb", "cornell-dof"};
  const vf_algorithm algorithms[] = {VF_ALGO_PT, VF_ALGO_BPT, VF_ALGO_VCM, VF_ALGO_UPG};
  for (int i = 0; i < 4; i++) {
    vf_scene *scene;
    CHECK_INT_EQ(vf_scene_load(names[i], &scene), VF_OK);
    if (check_failed_in_case) return;
    check_agreement(names[i], scene, algorithms, 4);
    vf_scene_destroy(scene);
  }
}

/* Point, spot and directional lights are deltas: path tracing cannot sample caustics from
 * them (L S+ D E: neither light sampling through glass nor hitting the light works), and
 * BPT cannot sample caustics seen through the spheres (L S+ D S+ E: no vertex pair to
 * connect). Merging samples both, so on the scenes as built VCM must agree with
 * bidirectional photon mapping, an independent estimator of those paths; and with the
 * spheres made diffuse, where every algorithm samples every path, pt, bpt and vcm agree,
 * and on the spot light's scene light tracing too (the light is invisible: lt samples
 * every path). */
static void test_delta_light_variants_agree(void) {
  const char *names[] = {"cornell-point", "cornell-sun", "cornell-spot"};
  /* upg merges as vcm the caustic light vertices that neither side can join: with them it
   * samples what vcm samples */
  const vf_algorithm complete[] = {VF_ALGO_BPM, VF_ALGO_VCM, VF_ALGO_UPG};
  const vf_algorithm all[] = {VF_ALGO_PT, VF_ALGO_BPT, VF_ALGO_VCM, VF_ALGO_UPG, VF_ALGO_LT};
  for (int i = 0; i < 3; i++) {
    vf_scene *scene;
    CHECK_INT_EQ(vf_scene_load(names[i], &scene), VF_OK);
    if (check_failed_in_case) return;
    check_agreement(names[i], scene, complete, 3);
    make_specular_diffuse(scene);
    check_agreement(names[i], scene, all, i == 2 ? 5 : 4); /* light tracing on the spot */
    vf_scene_destroy(scene);
  }
}

/* An environment map with a small bright region (importance sampling must find it), an
 * emissive sphere, a glossy and a glass sphere on a floor: every path can end on a light by
 * an emission hit, so path tracing, BPT and VCM estimate the same image. */
static void test_environment_map_and_sphere_light_agree(void) {
  char dir[] = "/tmp/vf_test_env_XXXXXX";
  CHECK(mkdtemp(dir) != NULL);
  char map_path[256], scene_path[256];
  snprintf(map_path, sizeof map_path, "%s/sky.exr", dir);
  snprintf(scene_path, sizeof scene_path, "%s/scene.json", dir);
  vf_image sky;
  CHECK_INT_EQ(vf_image_alloc(&sky, 64, 32), VF_OK);
  for (int y = 0; y < 32; y++)
    for (int x = 0; x < 64; x++) {
      float *p = &sky.rgb[3 * (y * 64 + x)];
      float up = 1.0f - (float)y / 32.0f;
      p[0] = 0.2f + 0.3f * up;
      p[1] = 0.3f + 0.3f * up;
      p[2] = 0.5f + 0.4f * up;
      if (y >= 6 && y < 8 && x >= 40 && x < 42) p[0] = p[1] = p[2] = 400.0f; /* a small sun */
    }
  CHECK_INT_EQ(vf_image_write_exr(map_path, &sky), VF_OK);
  vf_image_destroy(&sky);
  FILE *f = fopen(scene_path, "w");
  CHECK(f != NULL);
  if (f == NULL) return;
  fputs("{\"camera\": {\"position\": [0, 1.2, 4], \"target\": [0, 0.4, 0], \"fov\": 45, \"resolution\": [128, 128]},\n"
        " \"materials\": {\"floor\": {\"diffuse\": [0.6, 0.6, 0.6]},\n"
        "   \"shiny\": {\"diffuse\": [0.2, 0.1, 0.1], \"glossy\": [0.6, 0.6, 0.6], \"exponent\": 30},\n"
        "   \"glass\": {\"dielectric\": [1, 1, 1], \"ior\": 1.5}, \"lamp\": {}},\n"
        " \"shapes\": [\n"
        "   {\"type\": \"mesh\", \"material\": \"floor\", \"positions\": [-3,0,-3, 3,0,-3, 3,0,3, -3,0,3],\n"
        "    \"indices\": [0,2,1, 0,3,2]},\n"
        "   {\"type\": \"sphere\", \"material\": \"shiny\", \"center\": [-0.7, 0.5, 0], \"radius\": 0.5},\n"
        "   {\"type\": \"sphere\", \"material\": \"glass\", \"center\": [0.6, 0.45, 0.4], \"radius\": 0.45},\n"
        "   {\"type\": \"sphere\", \"material\": \"lamp\", \"center\": [0.2, 1.6, -0.8], \"radius\": 0.15,\n"
        "    \"emission\": [20, 16, 12]}],\n"
        " \"lights\": [{\"type\": \"environment\", \"file\": \"sky.exr\"}]}\n",
        f);
  fclose(f);
  vf_scene *scene;
  CHECK_INT_EQ(vf_scene_load(scene_path, &scene), VF_OK);
  if (check_failed_in_case) return;
  const vf_algorithm algorithms[] = {VF_ALGO_PT, VF_ALGO_BPT, VF_ALGO_VCM};
  check_agreement("environment", scene, algorithms, 3);
  vf_scene_destroy(scene);
  unlink(map_path);
  unlink(scene_path);
  rmdir(dir);
}

/* A lamp inside a glass ball of material `glass` (a JSON material), on a floor before a wall,
 * checked for agreement of pt, bpt and vcm under `name`. */
static void check_lamp_in_glass(const char *name, const char *glass) {
  char text[2048];
  snprintf(text, sizeof text,
           "{\"camera\": {\"position\": [0, 1.0, 3.5], \"target\": [0, 0.5, 0], \"fov\": 45, \"resolution\": [128, 128]},"
           " \"materials\": {\"white\": {\"diffuse\": [0.7, 0.7, 0.7]}, \"glass\": %s, \"lamp\": {}},"
           " \"shapes\": ["
           "   {\"type\": \"mesh\", \"material\": \"white\", \"positions\": [-3,0,-2, 3,0,-2, 3,0,3, -3,0,3,"
           "    -3,3,-2, 3,3,-2], \"indices\": [0,2,1, 0,3,2, 0,1,5, 0,5,4]},"
           "   {\"type\": \"sphere\", \"material\": \"glass\", \"center\": [0, 0.6, 0], \"radius\": 0.5},"
           "   {\"type\": \"sphere\", \"material\": \"lamp\", \"center\": [0.1, 0.7, 0], \"radius\": 0.25,"
           "    \"emission\": [4, 4, 4]}]}",
           glass);
  vf_scene *scene = NULL;
  CHECK_INT_EQ(vf_scene_parse(text, strlen(text), name, ".", NULL, 0, &scene), VF_OK);
  if (check_failed_in_case) return;
  const vf_algorithm algorithms[] = {VF_ALGO_PT, VF_ALGO_BPT, VF_ALGO_VCM};
  check_agreement(name, scene, algorithms, 3);
  vf_scene_destroy(scene);
}

/* A lamp inside a glass ball: every path from it to the camera crosses the glass an odd
 * number of times, so radiance (camera sub-paths) and flux (light sub-paths) differ by
 * 1/ior^2 at the crossing that does not cancel (worker/render/bsdf.h). Path tracing reaches the
 * lamp only by emission hits through the glass, light tracing never sees the glass from the
 * camera side, BPT and VCM mix both: they agree only if each side transports its own
 * quantity. Without the camera side's 1/eta^2, pt was 2.25 times too bright. */
static void test_light_inside_glass_agrees(void) {
  check_lamp_in_glass("lamp in glass", "{\"dielectric\": [1, 1, 1], \"ior\": 1.5}");
}

/* The microfacet lobes are not deltas, so every technique reaches every path through them,
 * and connections and merges evaluate them: cornell-rough (a glTF floor, rough gold, rough
 * glass), and the lamp inside rough glass, where a connection or merge across the glass
 * needs the radiance BTDF on the camera side and its adjoint, eta^2 times it, on the light
 * side (worker/render/bsdf.h); with either side's form on both, bpt and vcm are off by 2.25. */
static void test_pt_bpt_vcm_agree_on_rough_materials(void) {
  vf_scene *scene;
  CHECK_INT_EQ(vf_scene_load("cornell-rough", &scene), VF_OK);
  if (check_failed_in_case) return;
  const vf_algorithm algorithms[] = {VF_ALGO_PT, VF_ALGO_BPT, VF_ALGO_VCM, VF_ALGO_UPG};
  check_agreement("cornell-rough", scene, algorithms, 4);
  vf_scene_destroy(scene);
  check_lamp_in_glass("lamp in rough glass", "{\"dielectric\": [1, 1, 1], \"ior\": 1.5, \"roughness\": 0.3}");
}

/* Light tracing through the thin lens (t = 1 to a sampled lens point, W_e over the lens
 * density) against path tracing, on cornell-dof with the spheres made diffuse so that light
 * tracing, which never connects at a specular vertex, samples every path. */
/* The built-in `name` with its mirror and glass made diffuse, so that light tracing samples
 * every path: the n algorithms agree on it (check_agreement, labelled "NAME d"). */
static void agrees_with_diffuse_balls(const char *name, const vf_algorithm *algorithms, int n) {
  vf_scene *scene;
  CHECK_INT_EQ(vf_scene_load(name, &scene), VF_OK);
  if (check_failed_in_case) return;
  make_specular_diffuse(scene);
  char label[64];
  snprintf(label, sizeof label, "%s d", name);
  check_agreement(label, scene, algorithms, n);
  vf_scene_destroy(scene);
}

static void test_light_tracing_agrees_through_the_thin_lens(void) {
  const vf_algorithm algorithms[] = {VF_ALGO_PT, VF_ALGO_LT};
  agrees_with_diffuse_balls("cornell-dof", algorithms, 2);
}

/* The orthographic camera (tech. rep. sec. 5.2) in every technique that touches it: on
 * cornell-ortho with the spheres made diffuse, so that light tracing (t = 1 to each light
 * vertex's foot on the view plane) samples every path, pt, lt, bpt, vcm and upg agree. */
static void test_orthographic_camera_agrees(void) {
  const vf_algorithm algorithms[] = {VF_ALGO_PT, VF_ALGO_LT, VF_ALGO_BPT, VF_ALGO_VCM, VF_ALGO_UPG};
  agrees_with_diffuse_balls("cornell-ortho", algorithms, 5);
}

/* A merge radius per pixel (tech. rep. sec. 6.1): every merging algorithm still estimates
 * the image. The furnace, whose camera at the centre of the cube sees its walls from 1 to
 * 1.7 away, so that the radii differ across the image, gives its analytic value; on
 * cornell (and, with the default sampler, cornell-rough) vcm and upg with radii per pixel
 * agree with bpt. */
static void test_radius_per_pixel_keeps_the_furnace_and_the_agreement(void) {
  vf_scene *scene;
  CHECK_INT_EQ(vf_scene_load("furnace", &scene), VF_OK);
  if (check_failed_in_case) return;
  const vf_algorithm merging[] = {VF_ALGO_VCM, VF_ALGO_UPG, VF_ALGO_PPM, VF_ALGO_BPM};
  for (int a = 0; a < 4; a++) {
    vf_settings s = scene->settings;
    s.algorithm = merging[a];
    s.radius = VF_RADIUS_PER_PIXEL;
    s.sampler = sampler_under_test;
    vf_vcm_stats stats = {0};
    double mean = NAN, se = NAN;
    CHECK_INT_EQ(render_block_estimates(scene, &s, 2, 64, 1, &mean, &se, &stats), VF_OK);
    double exact = 1.0 - pow(0.5, s.max_path_length);
    printf("  furnace %-4s radius per pixel: mean %.5f +- %.5f (exact %.5f)\n", vf_algorithm_name(s.algorithm), mean,
           se, exact);
    CHECK_NEAR(mean, exact, 3.0 * se);
    CHECK(se < 0.005);
    CHECK_INT_EQ(stats.nonfinite, 0);
  }
  vf_scene_destroy(scene);
  const char *names[] = {"cornell", "cornell-rough"};
  for (int i = 0; i < (sampler_under_test == VF_SAMPLER_SOBOL ? 2 : 1); i++) {
    CHECK_INT_EQ(vf_scene_load(names[i], &scene), VF_OK);
    if (check_failed_in_case) return;
    radius_under_test = VF_RADIUS_PER_PIXEL;
    const vf_algorithm algorithms[] = {VF_ALGO_BPT, VF_ALGO_VCM, VF_ALGO_UPG};
    char label[64];
    snprintf(label, sizeof label, "%s, radius per pixel", names[i]);
    check_agreement(label, scene, algorithms, 3);
    radius_under_test = VF_RADIUS_GLOBAL;
    vf_scene_destroy(scene);
  }
}

/* Per-block means and standard errors of `algorithm` on a scene given as JSON text. */
static void text_block_estimates(const char *text, vf_algorithm algorithm, double mean[NB], double se[NB]) {
  vf_scene *scene = NULL;
  CHECK_INT_EQ(vf_scene_parse(text, strlen(text), "emitter", ".", NULL, 0, &scene), VF_OK);
  if (scene == NULL) return;
  block_estimates(scene, algorithm, mean, se);
  vf_scene_destroy(scene);
}

/* A square emitter of radiance 1 facing the camera at distance 2, nothing else but the
 * top-level fields `more` (or ""); the camera has the lens `lens` (JSON fields, or "" for a
 * pinhole). */
static void emitter_scene(char *text, size_t n, const char *lens, const char *more) {
  snprintf(text, n,
           "{\"camera\": {\"position\": [0, 0, 0], \"forward\": [0, 0, -1], \"fov\": 40, \"resolution\": [128, 128]%s},"
           " \"materials\": {\"black\": {}}, \"shapes\": [{\"type\": \"mesh\", \"material\": \"black\","
           "  \"emission\": [1, 1, 1], \"positions\": [-0.4,-0.4,-2, 0.4,-0.4,-2, 0.4,0.4,-2, -0.4,0.4,-2],"
           "  \"indices\": [0,1,2, 0,2,3]}]%s}",
           lens, more);
}

/* Blocks within their combined standard error, plus an absolute 1e-5 for blocks both
 * algorithms see without noise (a pinhole or lens camera that sees only the emitter). */
static void check_blocks_agree(const char *what, const double a[NB], const double sa[NB], const double b[NB],
                               const double sb[NB]) {
  double max_z = 0.0;
  int bad = 0;
  for (int k = 0; k < NB; k++) {
    double tol = 5.0 * sqrt(sa[k] * sa[k] + sb[k] * sb[k]) + 1e-5;
    if (!(fabs(a[k] - b[k]) <= tol)) bad++;
    double se = sqrt(sa[k] * sa[k] + sb[k] * sb[k]);
    if (se > 0.0) max_z = fmax(max_z, fabs(a[k] - b[k]) / se);
  }
  printf("  %-34s max |z| %.2f, %d blocks off\n", what, max_z, bad);
  CHECK_INT_EQ(bad, 0);
}

/* Seen through a thin lens, an emitter in the plane in focus makes the pinhole's image,
 * block by block, whether traced from the camera (pt: rays through the lens, in focus) or
 * from the light (lt: its points projected through sampled lens points, weighted by W_e);
 * out of focus, a uniform emitter's image is still its radiance wherever the blur circle
 * lies inside it and nothing where it lies outside, and the blur keeps the image's total. */
static void test_emitter_through_the_thin_lens_has_its_radiance(void) {
  char pinhole[1024], in_focus[1024], out_of_focus[1024];
  emitter_scene(pinhole, sizeof pinhole, "", "");
  emitter_scene(in_focus, sizeof in_focus, ", \"aperture\": 0.2, \"focus_distance\": 2", "");
  emitter_scene(out_of_focus, sizeof out_of_focus, ", \"aperture\": 0.2, \"focus_distance\": 4", "");
  static double m[5][NB], se[5][NB];
  text_block_estimates(pinhole, VF_ALGO_PT, m[0], se[0]);
  text_block_estimates(in_focus, VF_ALGO_PT, m[1], se[1]);
  text_block_estimates(in_focus, VF_ALGO_LT, m[2], se[2]);
  text_block_estimates(out_of_focus, VF_ALGO_PT, m[3], se[3]);
  text_block_estimates(out_of_focus, VF_ALGO_LT, m[4], se[4]);
  if (check_failed_in_case) return;
  check_blocks_agree("in focus: lens pt vs pinhole pt", m[1], se[1], m[0], se[0]);
  check_blocks_agree("in focus: lens lt vs pinhole pt", m[2], se[2], m[0], se[0]);
  check_blocks_agree("out of focus: lens lt vs lens pt", m[4], se[4], m[3], se[3]);
  /* The emitter spans +-35 px around the centre of the 128-pixel image, the blur circle of
   * its edges 8.8 px at focus 4: the central 2 x 2 blocks see radiance 1 from every lens
   * point, the corner blocks nothing. */
  const int centre[] = {3 * BLOCKS + 3, 3 * BLOCKS + 4, 4 * BLOCKS + 3, 4 * BLOCKS + 4};
  const int corner[] = {0, BLOCKS - 1, NB - BLOCKS, NB - 1};
  for (int i = 0; i < 4; i++) {
    for (int a = 0; a < 5; a++) CHECK_NEAR(m[a][corner[i]], 0.0, 1e-6);
    for (int a = 0; a < 4; a += a ? 2 : 1) CHECK_NEAR(m[a][centre[i]], 1.0, 1e-5); /* pt (0, 1, 3): exact */
    CHECK_NEAR(m[2][centre[i]], 1.0, 5.0 * se[2][centre[i]]);
    CHECK_NEAR(m[4][centre[i]], 1.0, 5.0 * se[4][centre[i]]);
  }
  double total[5] = {0}, total_se[5] = {0};
  for (int a = 0; a < 5; a++) {
    for (int k = 0; k < NB; k++) total[a] += m[a][k] / NB, total_se[a] += se[a][k] * se[a][k] / (NB * NB);
    total_se[a] = sqrt(total_se[a]);
  }
  printf("  image mean: pinhole %.5f, in focus %.5f (lt %.5f), out of focus %.5f (lt %.5f); exact %.5f\n", total[0],
         total[1], total[2], total[3], total[4], 0.8 * 0.8 / (4.0 * 4.0 * tan(20.0 * M_PI / 180.0) * tan(20.0 * M_PI / 180.0)));
  for (int a = 1; a < 5; a++) CHECK_NEAR(total[a], total[0], 5.0 * sqrt(total_se[a] * total_se[a] + total_se[0] * total_se[0]) + 1e-5);
  /* A camera ray through the lens that hits nothing sees the background, unweighted (no
   * other technique sees the sky directly): 0.25 in the corners, still 1 in the centre. */
  char sky[1200];
  emitter_scene(sky, sizeof sky, ", \"aperture\": 0.2, \"focus_distance\": 4",
                ", \"lights\": [{\"type\": \"background\", \"radiance\": [0.25, 0.25, 0.25]}]");
  const vf_algorithm sky_algorithms[] = {VF_ALGO_PT, VF_ALGO_VCM};
  for (int a = 0; a < 2; a++) {
    text_block_estimates(sky, sky_algorithms[a], m[0], se[0]);
    for (int i = 0; i < 4; i++) {
      CHECK_NEAR(m[0][corner[i]], 0.25, 1e-6);
      CHECK_NEAR(m[0][centre[i]], 1.0, 1e-5);
    }
  }
}

/* An orthographic camera sees radiance, whatever the distance and the tilt: a square
 * emitter of radiance 1, 0.8 wide, 2 in front of a view 1 wide, turned 60 degrees about the
 * vertical, projects to 0.4 x 0.8 of the view. Path tracing reads 1 exactly in the blocks
 * it covers, 0 where it does not; light tracing (its points linked to their feet on the
 * view plane, with the density cos / pixel^2) reads the same within its error, and both
 * integrate to the projected area, 0.32 of the image. */
static void test_emitter_seen_orthographically_has_its_radiance(void) {
  static const char text[] =
      "{\"camera\": {\"type\": \"orthographic\", \"position\": [0, 0, 0], \"forward\": [0, 0, -1], \"width\": 1,"
      "  \"resolution\": [128, 128]}, \"materials\": {\"black\": {}},"
      " \"shapes\": [{\"type\": \"mesh\", \"material\": \"black\", \"emission\": [1, 1, 1],"
      "  \"positions\": [-0.2,-0.4,-2.34641016, 0.2,-0.4,-1.65358984, 0.2,0.4,-1.65358984, -0.2,0.4,-2.34641016],"
      "  \"indices\": [0,1,2, 0,2,3]}]}";
  vf_scene *scene = NULL;
  CHECK_INT_EQ(vf_scene_parse(text, sizeof text - 1, "ortho emitter", ".", NULL, 0, &scene), VF_OK);
  if (scene == NULL) return;
  static double m[2][NB], se[2][NB];
  block_estimates(scene, VF_ALGO_PT, m[0], se[0]);
  block_estimates(scene, VF_ALGO_LT, m[1], se[1]);
  vf_scene_destroy(scene);
  if (check_failed_in_case) return;
  check_blocks_agree("orthographic emitter: lt vs pt", m[1], se[1], m[0], se[0]);
  /* x in [-0.2, 0.2] of the view's [-0.5, 0.5]: pixels 38.4 .. 89.6, blocks 3 and 4 whole;
   * y in [-0.4, 0.4]: pixels 12.8 .. 115.2, block rows 1 .. 6 whole. */
  double total[2] = {0}, total_se[2] = {0};
  for (int b = 0; b < NB; b++) {
    int bx = b % BLOCKS, by = b / BLOCKS;
    int inside = (bx == 3 || bx == 4) && by >= 1 && by <= 6, outside = bx <= 1 || bx >= 6;
    if (inside) {
      CHECK_NEAR(m[0][b], 1.0, 1e-5);
      CHECK_NEAR(m[1][b], 1.0, 5.0 * se[1][b]);
    }
    if (outside) {
      CHECK_NEAR(m[0][b], 0.0, 0.0);
      CHECK_NEAR(m[1][b], 0.0, 0.0);
    }
    for (int a = 0; a < 2; a++) total[a] += m[a][b] / NB, total_se[a] += se[a][b] * se[a][b] / (NB * NB);
  }
  for (int a = 0; a < 2; a++) total_se[a] = sqrt(total_se[a]);
  printf("  image mean: pt %.5f +- %.5f, lt %.5f +- %.5f; exact 0.32000\n", total[0], total_se[0], total[1], total_se[1]);
  CHECK_NEAR(total[0], 0.32, 5.0 * total_se[0] + 1e-5);
  CHECK_NEAR(total[1], 0.32, 5.0 * total_se[1] + 1e-5);
  CHECK(total_se[1] < 0.01); /* the check above must have teeth */
}

/* A spot light 1 above a diffuse floor (albedo 0.5), the camera at the light looking down
 * the axis: a pixel whose ray leaves at theta from the axis sees radiance
 * (0.5 / pi) I f(theta) cos^3(theta) / h^2, f being KHR_lights_punctual's falloff. Each
 * block's mean is integrated over its pixels; the centre blocks (theta < 20 degrees,
 * inside the inner cone of 30) see the full intensity, the corner blocks (theta > 46
 * degrees, beyond the outer cone of 40) nothing. Vertex merging blurs the falloff by the
 * merge radius, a bias that vanishes with the radius: at the default radius (0.038 here,
 * weighted 0.98 against connections) the blocks across the outer cone's edge were 30%
 * too bright, so the scene asks for a radius 30 times smaller. */
static void test_spot_light_on_a_floor_has_the_analytic_radiance(void) {
  static const char text[] =
      "{\"camera\": {\"position\": [0, 1, 0], \"forward\": [0, -1, 0], \"up\": [0, 0, -1], \"fov\": 90,"
      "  \"resolution\": [128, 128]},"
      " \"materials\": {\"floor\": {\"diffuse\": [0.5, 0.5, 0.5]}},"
      " \"shapes\": [{\"type\": \"mesh\", \"material\": \"floor\", \"positions\": [-9,0,-9, 9,0,-9, 9,0,9, -9,0,9],"
      "  \"indices\": [0,2,1, 0,3,2]}],"
      " \"lights\": [{\"type\": \"spot\", \"position\": [0, 1, 0], \"direction\": [0, -1, 0], \"intensity\": [2, 2, 2],"
      "  \"inner_cone_angle\": 30, \"outer_cone_angle\": 40}], \"render\": {\"radius_factor\": 0.0001}}";
  const double inner = 30.0 * M_PI / 180.0, outer = 40.0 * M_PI / 180.0, I = 2.0, rho = 0.5;
  double exact[NB] = {0};
  const int sub = 8, px = RES / BLOCKS; /* sub x sub points per pixel */
  const double ipd = 0.5 * RES / tan(45.0 * M_PI / 180.0);
  for (int b = 0; b < NB; b++) {
    int bx = b % BLOCKS, by = b / BLOCKS;
    double sum = 0.0;
    for (int j = 0; j < px * sub; j++)
      for (int i = 0; i < px * sub; i++) {
        double x = bx * px + (i + 0.5) / sub - 0.5 * RES, y = by * px + (j + 0.5) / sub - 0.5 * RES;
        double c = ipd / sqrt(ipd * ipd + x * x + y * y);
        double t = (c - cos(outer)) / (cos(inner) - cos(outer));
        t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
        sum += rho / M_PI * I * t * t * c * c * c;
      }
    exact[b] = sum / (px * sub * px * sub);
  }
  vf_scene *scene = NULL;
  CHECK_INT_EQ(vf_scene_parse(text, sizeof text - 1, "spot floor", ".", NULL, 0, &scene), VF_OK);
  if (scene == NULL) return;
  const vf_algorithm algorithms[] = {VF_ALGO_PT, VF_ALGO_LT, VF_ALGO_BPT, VF_ALGO_VCM};
  for (int a = 0; a < 4; a++) {
    double mean[NB], se[NB], max_z = 0.0;
    block_estimates(scene, algorithms[a], mean, se);
    for (int b = 0; b < NB; b++) {
      double tol = 5.0 * se[b] + 2e-4 * exact[b] + 1e-7; /* the float image and the quadrature */
      max_z = fmax(max_z, fabs(mean[b] - exact[b]) / (se[b] + 1e-12));
      if (!(fabs(mean[b] - exact[b]) <= tol)) {
        printf("  %s block %d: %.6f +- %.6f, exact %.6f\n", vf_algorithm_name(algorithms[a]), b, mean[b], se[b], exact[b]);
        CHECK_NEAR(mean[b], exact[b], tol);
      }
    }
    int centre = 3 * BLOCKS + 3, corner = 0;
    printf("  spot floor %-3s: centre block %.6f (exact %.6f), corner %.2g, max |z| %.2f\n",
           vf_algorithm_name(algorithms[a]), mean[centre], exact[centre], mean[corner], max_z);
    CHECK_NEAR(mean[corner], 0.0, 0.0);
  }
  vf_scene_destroy(scene);
}

/* `auto` picks vcm where specular surfaces meet non-specular ones (SDS paths possible) and
 * pt where they do not (docs/BENCHMARKS.md, "Time against error"). */
static void test_auto_chooses_by_the_scene(void) {
  static const struct {
    const char *scene;
    vf_algorithm requested, chosen;
  } cases[] = {{"cornell", VF_ALGO_AUTO, VF_ALGO_VCM},
               {"cornell-point", VF_ALGO_AUTO, VF_ALGO_VCM},
               {"cornell-sun", VF_ALGO_AUTO, VF_ALGO_VCM},
               {"cornell-env", VF_ALGO_AUTO, VF_ALGO_VCM},
               {"cornell-bulb", VF_ALGO_AUTO, VF_ALGO_VCM},
               {"knot", VF_ALGO_AUTO, VF_ALGO_PT},
               {"cornell-diffuse", VF_ALGO_AUTO, VF_ALGO_PT},
               {"cornell-glossy", VF_ALGO_AUTO, VF_ALGO_PT},
               {"furnace", VF_ALGO_AUTO, VF_ALGO_PT},
               {"cornell-rough", VF_ALGO_AUTO, VF_ALGO_PT},
               /* auto-unbiased: bpt where delta lobes are, pt under a light at infinity or
                * on diffuse surfaces alone, upg on glossy ones */
               {"cornell", VF_ALGO_AUTO_UNBIASED, VF_ALGO_BPT},
               {"cornell-sun", VF_ALGO_AUTO_UNBIASED, VF_ALGO_BPT},
               {"cornell-bulb", VF_ALGO_AUTO_UNBIASED, VF_ALGO_BPT},
               {"cornell-diffuse", VF_ALGO_AUTO_UNBIASED, VF_ALGO_PT},
               {"furnace", VF_ALGO_AUTO_UNBIASED, VF_ALGO_PT},
               {"cornell-glossy", VF_ALGO_AUTO_UNBIASED, VF_ALGO_UPG},
               {"cornell-rough", VF_ALGO_AUTO_UNBIASED, VF_ALGO_UPG}};
  for (size_t c = 0; c < sizeof cases / sizeof *cases; c++) {
    vf_scene *scene = NULL;
    vf_accel *accel = NULL;
    vf_pool *pool = NULL;
    vf_vcm *vcm = NULL;
    CHECK_INT_EQ(vf_scene_load(cases[c].scene, &scene), VF_OK);
    if (scene == NULL) return;
    vf_settings s = scene->settings;
    s.algorithm = cases[c].requested;
    s.width = s.height = 8;
    CHECK_INT_EQ(vf_accel_create(scene, &accel), VF_OK);
    CHECK_INT_EQ(vf_pool_create(1, &pool), VF_OK);
    if (accel && pool) CHECK_INT_EQ(vf_vcm_create(scene, accel, &s, pool, &vcm), VF_OK);
    if (vcm) {
      if (vf_vcm_algorithm(vcm) != cases[c].chosen)
        printf("  %s: %s chose %s, expected %s\n", cases[c].scene, vf_algorithm_name(cases[c].requested),
               vf_algorithm_name(vf_vcm_algorithm(vcm)), vf_algorithm_name(cases[c].chosen));
      CHECK_INT_EQ(vf_vcm_algorithm(vcm), cases[c].chosen);
    }
    vf_vcm_destroy(vcm);
    vf_pool_destroy(pool);
    vf_accel_destroy(accel);
    vf_scene_destroy(scene);
  }
}

/* One iteration's camera and light frames from a renderer of scene with settings s, with
 * merging limited to SSE2 or not; returns 0 on failure. */
static int iteration_frames(const vf_scene *scene, const vf_settings *s, int limit_simd, uint64_t iteration,
                            float *camera, float *light, const char **simd, vf_vcm_stats *out) {
  vf_accel *accel = NULL;
  vf_pool *pool = NULL;
  vf_vcm *vcm = NULL;
  int ok = 0;
  CHECK_INT_EQ(vf_accel_create(scene, &accel), VF_OK);
  CHECK_INT_EQ(vf_pool_create(2, &pool), VF_OK);
  if (accel && pool) CHECK_INT_EQ(vf_vcm_create(scene, accel, s, pool, &vcm), VF_OK);
  if (vcm) {
    if (limit_simd) vf_vcm_limit_simd(vcm);
    *simd = vf_vcm_merge_simd(vcm);
    vf_vcm_stats stats = {0};
    CHECK_INT_EQ(vf_vcm_iteration(vcm, iteration, camera, light, &stats), VF_OK);
    if (out) *out = stats;
    ok = !check_failed_in_case;
  }
  vf_vcm_destroy(vcm);
  vf_pool_destroy(pool);
  vf_accel_destroy(accel);
  return ok;
}

/* Merging's candidate tests, AVX-512 where the CPU has it and SSE2 on any x86-64, find the
 * same light vertices in the same order: the frames are the same bit for bit. On a CPU
 * without AVX-512 both renders use SSE2, and the test says so. */
static void test_merging_simd_paths_give_identical_frames(void) {
  static const char *scenes[] = {"cornell", "cornell-glossy", "cornell-env"};
  static const vf_algorithm algorithms[] = {VF_ALGO_VCM, VF_ALGO_BPM, VF_ALGO_PPM};
  enum { W = 128, H = 96 };
  static float camera[2][3 * W * H], light[2][3 * W * H];
  for (size_t c = 0; c < sizeof scenes / sizeof *scenes; c++) {
    vf_scene *scene = NULL;
    CHECK_INT_EQ(vf_scene_load(scenes[c], &scene), VF_OK);
    if (scene == NULL) return;
    for (size_t a = 0; a < sizeof algorithms / sizeof *algorithms; a++) {
      vf_settings s = scene->settings;
      s.algorithm = algorithms[a];
      s.width = W;
      s.height = H;
      const char *simd[2];
      for (uint64_t it = 0; it < 2; it++) {
        if (!iteration_frames(scene, &s, 0, it, camera[0], light[0], &simd[0], NULL) ||
            !iteration_frames(scene, &s, 1, it, camera[1], light[1], &simd[1], NULL))
          break;
        int same = memcmp(camera[0], camera[1], sizeof camera[0]) == 0 &&
                   memcmp(light[0], light[1], sizeof light[0]) == 0;
        if (!same || it == 0)
          printf("  %s %s iteration %llu: %s and %s merging %s\n", scenes[c], vf_algorithm_name(s.algorithm),
                 (unsigned long long)it, simd[0], simd[1], same ? "agree bit for bit" : "DIFFER");
        CHECK(same);
      }
    }
    vf_scene_destroy(scene);
  }
}

/* bpt traces the light sub-paths of each camera tile just before its camera sub-paths
 * (worker/render/camera_pass.c), vcm all of them first in runs of pixels (worker/render/light_pass.c):
 * both trace each pixel's light sub-path once, from the same numbers, so they store the
 * same vertices, on images whose sides are not multiples of the tile's. */
static void test_bpt_tiles_trace_the_light_sub_paths_of_vcm(void) {
  static const char *scenes[] = {"cornell", "cornell-glossy"};
  enum { W = 100, H = 70 };
  static float camera[3 * W * H], light[3 * W * H];
  for (size_t c = 0; c < sizeof scenes / sizeof *scenes; c++) {
    vf_scene *scene = NULL;
    CHECK_INT_EQ(vf_scene_load(scenes[c], &scene), VF_OK);
    if (scene == NULL) return;
    vf_settings s = scene->settings;
    s.width = W;
    s.height = H;
    for (uint64_t it = 0; it < 3; it++) {
      vf_vcm_stats bpt, vcm;
      const char *simd;
      s.algorithm = VF_ALGO_BPT;
      if (!iteration_frames(scene, &s, 0, it, camera, light, &simd, &bpt)) break;
      s.algorithm = VF_ALGO_VCM;
      if (!iteration_frames(scene, &s, 0, it, camera, light, &simd, &vcm)) break;
      if (bpt.light_vertices != vcm.light_vertices)
        printf("  %s iteration %llu: bpt stored %llu light vertices, vcm %llu\n", scenes[c], (unsigned long long)it,
               (unsigned long long)bpt.light_vertices, (unsigned long long)vcm.light_vertices);
      CHECK(bpt.light_vertices > 0);
      CHECK(bpt.light_vertices == vcm.light_vertices);
    }
    vf_scene_destroy(scene);
  }
}

/* The power heuristic (--mis-beta): the weights of every technique still sum to 1
 * (test_mis checks the identity path by path), so the furnace keeps its value and the
 * combining algorithms still agree with path tracing under the balance heuristic. */
static void test_power_heuristic_keeps_the_furnace_and_the_agreement(void) {
  static const vf_algorithm combining[] = {VF_ALGO_VCM, VF_ALGO_BPT, VF_ALGO_BPM, VF_ALGO_PT};
  static const double betas[] = {2.0, 3.0};
  vf_scene *scene;
  CHECK_INT_EQ(vf_scene_load("furnace", &scene), VF_OK);
  if (check_failed_in_case) return;
  for (size_t b = 0; b < sizeof betas / sizeof *betas; b++)
    for (size_t a = 0; a < sizeof combining / sizeof *combining; a++) {
      vf_settings s = scene->settings;
      s.algorithm = combining[a];
      s.mis_beta = betas[b];
      vf_vcm_stats stats = {0};
      double mean = NAN, se = NAN;
      CHECK_INT_EQ(render_block_estimates(scene, &s, 2, 64, 1, &mean, &se, &stats), VF_OK);
      double exact = 1.0 - pow(0.5, s.max_path_length);
      printf("  furnace %-4s beta %g mean %.5f +- %.5f (exact %.5f)\n", vf_algorithm_name(s.algorithm), betas[b], mean,
             se, exact);
      CHECK_NEAR(mean, exact, 3.0 * se);
      CHECK(se < 0.005);
      CHECK_INT_EQ(stats.nonfinite, 0);
    }
  vf_scene_destroy(scene);

  const char *names[] = {"cornell", "cornell-rough"};
  for (int i = 0; i < (sampler_under_test == VF_SAMPLER_SOBOL ? 2 : 1); i++) {
    CHECK_INT_EQ(vf_scene_load(names[i], &scene), VF_OK);
    if (check_failed_in_case) return;
    double mean[3][NB], se[3][NB];
    block_estimates(scene, VF_ALGO_PT, mean[0], se[0]);
    scene->settings.mis_beta = 2.0;
    block_estimates(scene, VF_ALGO_VCM, mean[1], se[1]);
    scene->settings.mis_beta = 3.0;
    block_estimates(scene, VF_ALGO_BPT, mean[2], se[2]);
    AGREE(blocks_agree(names[i], "pt", "vcm beta 2", mean[0], se[0], mean[1], se[1], NB));
    AGREE(blocks_agree(names[i], "pt", "bpt beta 3", mean[0], se[0], mean[2], se[2], NB));
    vf_scene_destroy(scene);
  }
}

/* upg beside path tracing and bpt where neither of the scenes has a delta lobe: the glossy
 * box (Phong up to a sharp exponent) and the knot; every path is then gathered without
 * bias, and the three estimators agree block by block. */
static void test_upg_agrees_on_glossy_scenes(void) {
  const char *names[] = {"cornell-glossy", "knot"};
  const vf_algorithm algorithms[] = {VF_ALGO_PT, VF_ALGO_BPT, VF_ALGO_UPG};
  for (int i = 0; i < 2; i++) {
    vf_scene *scene;
    CHECK_INT_EQ(vf_scene_load(names[i], &scene), VF_OK);
    if (check_failed_in_case) return;
    check_agreement(names[i], scene, algorithms, 3);
    vf_scene_destroy(scene);
  }
}

/* The showcase courtyard (tests/bench/make_showcase.py at 20,000 triangles: every material
 * and texture feature, a spot and a sun) at a small size. Its sun and spot light the glass
 * and the water, whose caustics only merging and gathering sample: vcm and upg (both
 * sides) agree there; with its delta lobes made diffuse, pt and bpt agree with them too. */
static void test_upg_agrees_on_the_showcase(void) {
  char dir[] = "/tmp/vf_test_showcase_XXXXXX", cmd[512], path[256];
  CHECK(mkdtemp(dir) != NULL);
  if (check_failed_in_case) return;
  snprintf(cmd, sizeof cmd, "python3 %s/tests/bench/make_showcase.py %s --triangles 20000 >/dev/null 2>&1",
           VF_SOURCE_DIR, dir);
  /* python3 is a dependency (deploy/install-deps.sh): a generator that fails is a failure. */
  CHECK_INT_EQ(system(cmd), 0);
  snprintf(path, sizeof path, "%s/showcase.gltf", dir);
  vf_scene *scene = NULL;
  if (!check_failed_in_case) CHECK_INT_EQ(vf_scene_load(path, &scene), VF_OK);
  if (scene != NULL) {
#ifdef __SANITIZE_ADDRESS__
    scene->settings.width = 48, scene->settings.height = 27; /* as RES: memory errors, not statistics */
#else
    scene->settings.width = 96, scene->settings.height = 54;
#endif
    double mean[4][NB], se[4][NB];
    const vf_algorithm merging[] = {VF_ALGO_VCM, VF_ALGO_UPG};
    for (int a = 0; a < 2; a++) showcase_blocks(scene, merging[a], VF_GATHER_LIGHT, mean[a], se[a]);
    showcase_blocks(scene, VF_ALGO_UPG, VF_GATHER_CAMERA, mean[2], se[2]);
    /* Under the sanitizers the renders run for their memory errors and non-finite samples
     * (showcase_blocks checks those); the agreement is printed, not checked: at a quarter
     * of the pixels the showcase's few-sample blocks give pt standard errors that are
     * themselves too noisy for a 5-sigma rule (mean z^2 1.6 against pt where it is 0.9 at
     * full size). The full-size run checks it. */
#ifdef __SANITIZE_ADDRESS__
#define SHOWCASE_AGREE(x) ((void)(x))
#else
#define SHOWCASE_AGREE(x) CHECK(x)
#endif
    SHOWCASE_AGREE(blocks_agree("showcase", "vcm", "upg", mean[0], se[0], mean[1], se[1], NB));
    SHOWCASE_AGREE(blocks_agree("showcase", "vcm", "upg*", mean[0], se[0], mean[2], se[2], NB));
    make_specular_diffuse(scene);
    const vf_algorithm all[] = {VF_ALGO_PT, VF_ALGO_BPT, VF_ALGO_UPG, VF_ALGO_VCM};
    for (int a = 0; a < 4; a++) showcase_blocks(scene, all[a], VF_GATHER_LIGHT, mean[a], se[a]);
    for (int a = 0; a < 2; a++)
      SHOWCASE_AGREE(blocks_agree("showcase d", vf_algorithm_name(all[a]), "upg", mean[a], se[a], mean[2], se[2], NB));
    SHOWCASE_AGREE(blocks_agree("showcase d", "upg", "vcm", mean[2], se[2], mean[3], se[3], NB));
#undef SHOWCASE_AGREE
    vf_scene_destroy(scene);
  }
  snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
  if (system(cmd) != 0) printf("  could not remove %s\n", dir);
}

/* Unbiased photon gathering's reason to exist (worker/render/photon_gathering.h): with a
 * large merge radius that does not shrink (--radius-factor 0.05 --alpha 1), vcm's merging
 * is biased where surfaces meet (corners, edges: thesis sec. 4.3) and upg's gathering is
 * not, from either side. upg must agree with bpt, an unbiased estimator without merging, in
 * every block, and
 * vcm at the same radius must not: the test shows both, so it cannot pass by lacking the
 * power to see a bias. On cornell-diffuse, and on the same box with a rough glass ball, a
 * textured glTF ball, a checker-textured floor and normal maps on the floor and the back
 * wall (tests/worker/render/feature_scene.h). */
#ifdef __SANITIZE_ADDRESS__
/* Under the sanitizers (memory errors, not statistics) a short run on a quarter of the
 * pixels, whose agreement is printed (AGREE) and which cannot show vcm's bias: that check
 * is left out there. */
enum { BIAS_RES = 32, BIAS_ITERATIONS = 32, BIAS_POWER = 0 };
#else
enum { BIAS_RES = 64, BIAS_ITERATIONS = 512, BIAS_POWER = 1 };
#endif

static void fixed_radius_blocks(const vf_scene *scene, vf_algorithm algorithm, vf_gather_side side, double mean[NB],
                                double se[NB], vf_vcm_stats *stats) {
  vf_settings s = scene->settings;
  s.algorithm = algorithm;
  s.gather = side;
  s.width = s.height = BIAS_RES;
  s.radius_factor = 0.05;
  s.alpha = 1.0;
  s.seed = 2000 + (uint64_t)algorithm;
  CHECK_INT_EQ(render_block_estimates(scene, &s, 2, BIAS_ITERATIONS, BLOCKS, mean, se, stats), VF_OK);
  CHECK_INT_EQ(stats->nonfinite, 0);
}

static void check_gathering_is_unbiased(const char *what, const vf_scene *scene) {
  double mean[4][NB], se[4][NB];
  vf_vcm_stats bpt = {0}, upg[2] = {{0}, {0}}, vcm = {0};
  fixed_radius_blocks(scene, VF_ALGO_BPT, VF_GATHER_LIGHT, mean[0], se[0], &bpt);
  fixed_radius_blocks(scene, VF_ALGO_VCM, VF_GATHER_LIGHT, mean[1], se[1], &vcm);
  for (int side = 0; side < 2; side++) {
    const vf_vcm_stats *u = &upg[side];
    fixed_radius_blocks(scene, VF_ALGO_UPG, (vf_gather_side)side, mean[2 + side], se[2 + side], &upg[side]);
    printf("  %s, from the %s: upg gathered %llu light vertices (%.2f rays each), %llu merged as vcm, %llu truncated, "
           "%llu above their bound\n",
           what, vf_gather_name((vf_gather_side)side), (unsigned long long)u->upg_gatherings,
           (double)u->upg_rays / (double)u->upg_gatherings, (unsigned long long)u->upg_fallbacks,
           (unsigned long long)u->upg_truncated, (unsigned long long)u->upg_bound_exceeded);
    CHECK(u->upg_gatherings > 200u * BIAS_ITERATIONS * BIAS_RES * BIAS_RES / 4096u); /* 200 an iteration at 64x64 */
    CHECK_INT_EQ(u->upg_fallbacks, 0); /* no delta lobe, no light at infinity */
    CHECK_INT_EQ(u->upg_truncated, 0);
    CHECK_INT_EQ(u->upg_bound_exceeded, 0);
    AGREE(blocks_agree(what, "bpt", side ? "upg*" : "upg", mean[0], se[0], mean[2 + side], se[2 + side], NB));
  }
  if (BIAS_POWER) CHECK(!blocks_agree(what, "bpt", "vcm", mean[0], se[0], mean[1], se[1], NB));
}

static void test_gathering_is_unbiased_where_merging_is_not(void) {
  vf_scene *scene;
  CHECK_INT_EQ(vf_scene_load("cornell-diffuse", &scene), VF_OK);
  if (check_failed_in_case) return;
  check_gathering_is_unbiased("cornell-diffuse", scene);
  vf_scene_destroy(scene);
  scene = feature_scene(FEATURE_ROUGH_GLASS | FEATURE_TEXTURED | FEATURE_NORMAL_MAP);
  if (check_failed_in_case) return;
  /* the back wall's normal map on the floor too */
  int back = find_shape(scene, "back"), floor = find_shape(scene, "floor");
  vf_material *fm = &scene->materials[scene->shapes[floor].material];
  fm->textures[VF_TEXTURE_NORMAL] = scene->materials[scene->shapes[back].material].textures[VF_TEXTURE_NORMAL];
  fm->normal_scale = 1.0f;
  check_gathering_is_unbiased("rough, textured", scene);
  vf_scene_destroy(scene);
}

int main(void) {
  RUN(test_bpt_tiles_trace_the_light_sub_paths_of_vcm);
  RUN(test_merging_simd_paths_give_identical_frames);
  RUN(test_auto_chooses_by_the_scene);
  for (int k = 0; k < VF_SAMPLER_COUNT_; k++) {
    sampler_under_test = (vf_sampler_kind)k;
    printf("sampler %s\n", vf_sampler_name(sampler_under_test));
    RUN(test_furnace_every_algorithm_gives_the_analytic_value);
#ifdef __SANITIZE_ADDRESS__
    /* tests/sanitize.sh looks for memory errors, not statistics: the furnace has taken
     * every algorithm through this sampler; the agreement runs with the default only. */
    if (sampler_under_test != VF_SAMPLER_SOBOL) continue;
#endif
    RUN(test_pt_bpt_vcm_agree_on_area_and_environment_variants);
    RUN(test_orthographic_camera_agrees);
    RUN(test_radius_per_pixel_keeps_the_furnace_and_the_agreement);
  }
  sampler_under_test = VF_SAMPLER_SOBOL;
  RUN(test_delta_light_variants_agree);
  RUN(test_environment_map_and_sphere_light_agree);
  RUN(test_light_inside_glass_agrees);
  RUN(test_light_tracing_agrees_through_the_thin_lens);
  RUN(test_emitter_through_the_thin_lens_has_its_radiance);
  RUN(test_emitter_seen_orthographically_has_its_radiance);
  RUN(test_spot_light_on_a_floor_has_the_analytic_radiance);
  RUN(test_pt_bpt_vcm_agree_on_rough_materials);
  RUN(test_power_heuristic_keeps_the_furnace_and_the_agreement);
  RUN(test_upg_agrees_on_glossy_scenes);
  RUN(test_upg_agrees_on_the_showcase);
  RUN(test_gathering_is_unbiased_where_merging_is_not);
  return check_finish();
}
