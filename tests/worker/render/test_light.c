/* Light sampling densities: what illuminate() reports for a sampled point or direction must
 * be what a ray that finds the same point or direction reports (otherwise MIS weights are
 * wrong even though each technique alone is unbiased), and every density must integrate to
 * one over its domain. */
#include "check.h"
#include "common/error.h"
#include "common/image.h"
#include "common/rng.h"
#include "worker/render/light.h"
#include "worker/render/sampling.h"
#include "worker/scene/scene.h"
#include "worker/scene/json.h"
#include "worker/scene/load.h"
#include "worker/scene/builtin.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* An environment map with a bright spot and a gradient, written to a temporary file and
 * loaded through a scene file, as a user would. */
static vf_scene *environment_scene(char *dir, size_t n) {
  snprintf(dir, n, "/tmp/vf_test_light_XXXXXX");
  if (mkdtemp(dir) == NULL) return NULL;
  char map[512], scene_path[512];
  snprintf(map, sizeof map, "%s/sky.exr", dir);
  snprintf(scene_path, sizeof scene_path, "%s/scene.json", dir);
  vf_image sky;
  if (vf_image_alloc(&sky, 48, 24) != VF_OK) return NULL;
  for (int y = 0; y < 24; y++)
    for (int x = 0; x < 48; x++) {
      float *p = &sky.rgb[3 * (y * 48 + x)];
      p[0] = p[1] = p[2] = 0.1f + (float)x / 48.0f;
      if (x == 30 && y == 5) p[0] = p[1] = p[2] = 500.0f;
    }
  CHECK_INT_EQ(vf_image_write_exr(map, &sky), VF_OK);
  vf_image_destroy(&sky);
  FILE *f = fopen(scene_path, "w");
  if (f == NULL) return NULL;
  fputs("{\"camera\": {\"position\": [0, 0, 3], \"target\": [0, 0, 0], \"fov\": 40},"
        " \"materials\": {\"m\": {\"diffuse\": [0.5, 0.5, 0.5]}},"
        " \"shapes\": [{\"type\": \"sphere\", \"material\": \"m\", \"center\": [0, 0, 0], \"radius\": 1},"
        "  {\"type\": \"mesh\", \"material\": \"m\", \"emission\": [2, 2, 2],"
        "   \"positions\": [-1,2,-1, 1,2,-1, 1,2,1, -1,2,1], \"indices\": [0,1,2, 0,2,3]},"
        "  {\"type\": \"sphere\", \"material\": \"m\", \"center\": [2, 1, 0], \"radius\": 0.2, \"emission\": [5, 5, 5]}],"
        " \"lights\": [{\"type\": \"environment\", \"file\": \"sky.exr\"}]}",
        f);
  fclose(f);
  vf_scene *s = NULL;
  CHECK_INT_EQ(vf_scene_load(scene_path, &s), VF_OK);
  unlink(map);
  unlink(scene_path);
  rmdir(dir);
  return s;
}

static const vf_light *light_of_kind(const vf_lights *ls, vf_light_kind kind) {
  for (int i = 0; i < ls->count; i++)
    if (ls->lights[i].kind == kind) return &ls->lights[i];
  return NULL;
}

/* For sampled directions, the environment's lookup density equals the sampled density, and
 * the density integrates to 1 over the sphere (importance estimate with uniform sampling). */
static void test_environment_sampling_density_is_consistent_and_normalised(void) {
  char dir[64];
  vf_scene *s = environment_scene(dir, sizeof dir);
  vf_lights *ls = NULL;
  if (s == NULL) return;
  CHECK_INT_EQ(vf_lights_create(s, &ls), VF_OK);
  const vf_light *env = ls ? light_of_kind(ls, VF_LIGHT_ENVIRONMENT) : NULL;
  CHECK(env != NULL);
  if (env == NULL) return;
  vf_rng rng = vf_rng_for_path(3, 0, 0, VF_STREAM_TEST);
  double max_rel = 0.0;
  for (int i = 0; i < 20000; i++) {
    float rnd[2] = {vf_rng_float(&rng), vf_rng_float(&rng)};
    vf_vec3 dir_to_light, lp, ln;
    float dist, pdf_w, emission_pdf, cos_light;
    vf_vec3 le = vf_light_illuminate(ls, env, vf_vec3_splat(0.0f), rnd, &dir_to_light, &dist, &lp, &ln, &pdf_w,
                                     &emission_pdf, &cos_light);
    if (vf_is_zero(le)) continue;
    float lookup_pdf, lookup_emission;
    vf_vec3 l2 = vf_light_radiance_environment(ls, env, dir_to_light, &lookup_pdf, &lookup_emission);
    max_rel = fmax(max_rel, fabs(lookup_pdf - pdf_w) / pdf_w);
    CHECK_NEAR(l2.x, le.x, 1e-6 * le.x);
  }
  printf("  sampled vs looked-up density: max relative difference %.2e\n", max_rel);
  CHECK(max_rel < 1e-5);
  /* Integral of the density over the sphere, by midpoint quadrature in (theta, phi) on a
   * grid ten times finer than the map's texels: exact but for the rows at the poles. */
  const int nt = 240, np = 480;
  double integral = 0.0;
  for (int i = 0; i < nt; i++)
    for (int j = 0; j < np; j++) {
      double theta = (i + 0.5) * M_PI / nt, phi = (j + 0.5) * 2.0 * M_PI / np - M_PI;
      vf_vec3 d = vf_vec3_make((float)(sin(theta) * sin(phi)), (float)cos(theta), (float)(-sin(theta) * cos(phi)));
      float pdf, emission;
      vf_light_radiance_environment(ls, env, d, &pdf, &emission);
      integral += pdf * sin(theta) * (M_PI / nt) * (2.0 * M_PI / np);
    }
  printf("  integral of the environment density over the sphere: %.6f\n", integral);
  CHECK_NEAR(integral, 1.0, 2e-3);
  vf_lights_destroy(ls);
  vf_scene_destroy(s);
}

/* For area lights (a quad and a sphere), illuminate's solid-angle density equals the area
 * density a ray hitting the same point reports, converted: pdf_w = pdf_a d^2 / cos. */
static void test_area_light_densities_agree_with_hits(void) {
  char dir[64];
  vf_scene *s = environment_scene(dir, sizeof dir);
  vf_lights *ls = NULL;
  if (s == NULL) return;
  CHECK_INT_EQ(vf_lights_create(s, &ls), VF_OK);
  if (ls == NULL) return;
  vf_rng rng = vf_rng_for_path(4, 0, 0, VF_STREAM_TEST);
  const vf_light_kind kinds[] = {VF_LIGHT_AREA_MESH, VF_LIGHT_AREA_SPHERE};
  for (int k = 0; k < 2; k++) {
    const vf_light *l = light_of_kind(ls, kinds[k]);
    CHECK(l != NULL);
    if (l == NULL) continue;
    vf_vec3 receiver = vf_vec3_make(0.3f, -0.5f, 0.2f);
    int used = 0;
    double max_rel = 0.0;
    for (int i = 0; i < 20000; i++) {
      float rnd[2] = {vf_rng_float(&rng), vf_rng_float(&rng)};
      vf_vec3 d, lp, ln;
      float dist, pdf_w, emission_pdf, cos_light;
      vf_vec3 le = vf_light_illuminate(ls, l, receiver, rnd, &d, &dist, &lp, &ln, &pdf_w, &emission_pdf, &cos_light);
      if (vf_is_zero(le)) continue;
      float pdf_a, hit_emission_pdf;
      vf_vec3 l2 = vf_light_radiance_area(l, d, ln, &pdf_a, &hit_emission_pdf);
      double converted = pdf_a * dist * dist / cos_light;
      max_rel = fmax(max_rel, fabs(converted - pdf_w) / pdf_w);
      max_rel = fmax(max_rel, fabs(hit_emission_pdf - emission_pdf) / emission_pdf);
      CHECK_NEAR(l2.x, le.x, 1e-6);
      used++;
    }
    printf("  %s light: %d samples, max relative density difference %.2e\n", k ? "sphere" : "quad", used, max_rel);
    CHECK(used > 1000);
    CHECK(max_rel < 1e-4);
  }
  vf_lights_destroy(ls);
  vf_scene_destroy(s);
}

/* Emission from an area light is uniform in area and cosine distributed in direction: its
 * density is cos / (pi * area), so cos / pdf is pi * area for every emitted ray. */
static void test_area_emission_density_integrates(void) {
  char dir[64];
  vf_scene *s = environment_scene(dir, sizeof dir);
  vf_lights *ls = NULL;
  if (s == NULL) return;
  CHECK_INT_EQ(vf_lights_create(s, &ls), VF_OK);
  const vf_light *l = ls ? light_of_kind(ls, VF_LIGHT_AREA_MESH) : NULL;
  if (l == NULL) return;
  vf_rng rng = vf_rng_for_path(5, 0, 0, VF_STREAM_TEST);
  double sum = 0.0, sum2 = 0.0;
  const int n = 100000;
  for (int i = 0; i < n; i++) {
    float rnd[4] = {vf_rng_float(&rng), vf_rng_float(&rng), vf_rng_float(&rng), vf_rng_float(&rng)};
    vf_vec3 p, d, nrm;
    float emission_pdf, direct_pdf, cos_light;
    vf_light_emit(ls, l, rnd, &p, &d, &nrm, &emission_pdf, &direct_pdf, &cos_light);
    double v = cos_light / emission_pdf;
    sum += v;
    sum2 += v * v;
  }
  double mean = sum / n, se = sqrt((sum2 / n - mean * mean) / n) + 1e-12;
  printf("  emitted cos/pdf: %.5f +- %.5f, expected pi * area = %.5f\n", mean, se, M_PI * l->area);
  CHECK_NEAR(mean, M_PI * l->area, 5.0 * se + 1e-6);
  vf_lights_destroy(ls);
  vf_scene_destroy(s);
}

/* Picking a triangle of an emissive mesh: the guided walk gives the binary search's triangle
 * and rescaled number for every u, on a mesh of unequal triangles with degenerate ones among
 * them, and over a grid of u each triangle's share is its share of the area. Coarser guides
 * (the environment map's) and walks from any start give the search's answer too. */
static void test_triangle_pick_is_the_cdf_search_and_follows_area(void) {
  enum { N = 300 };
  size_t cap = 64 * N + 512;
  char *text = malloc(cap);
  if (text == NULL) return;
  /* A strip of N triangles along x with widths growing and shrinking; every 7th has zero width. */
  size_t len = (size_t)snprintf(text, cap,
                                "{\"camera\": {\"position\": [0, 0, 3], \"target\": [0, 0, 0], \"fov\": 40},"
                                " \"materials\": {\"m\": {\"diffuse\": [0.5, 0.5, 0.5]}},"
                                " \"shapes\": [{\"type\": \"mesh\", \"material\": \"m\", \"emission\": [1, 1, 1], \"positions\": [");
  double x = 0.0, width[N];
  for (int t = 0; t < N; t++) {
    double w = t % 7 == 3 ? 0.0 : 0.01 + 0.05 * (1.0 + sin(0.1 * t)) * (t % 5 + 1);
    width[t] = w;
    len += (size_t)snprintf(text + len, cap - len, "%s%.6f,0,0, %.6f,0,0, %.6f,1,0", t ? ", " : "", x, x + w, x);
    x += w;
  }
  len += (size_t)snprintf(text + len, cap - len, "], \"indices\": [");
  for (int t = 0; t < N; t++) len += (size_t)snprintf(text + len, cap - len, "%s%d,%d,%d", t ? ", " : "", 3 * t, 3 * t + 1, 3 * t + 2);
  snprintf(text + len, cap - len, "]}]}");
  vf_scene *s = NULL;
  vf_lights *ls = NULL;
  CHECK_INT_EQ(vf_scene_parse(text, strlen(text), "strip.json", ".", NULL, 0, &s), VF_OK);
  free(text);
  if (s == NULL) return;
  CHECK_INT_EQ(vf_lights_create(s, &ls), VF_OK);
  const vf_light *l = ls ? light_of_kind(ls, VF_LIGHT_AREA_MESH) : NULL;
  CHECK(l != NULL);
  if (l != NULL) {
    CHECK_INT_EQ((int)l->shape->num_triangles, N);
    /* Every u of a fine grid, the bucket edges k / N and the floats beside them, 0 and 1. */
    enum { GRID = 200000 };
    static unsigned count[N];
    int mismatches = 0, picked_degenerate = 0;
    for (int i = -3 * N - 2; i <= GRID; i++) {
      float u;
      if (i >= 0)
        u = ((float)i + 0.5f) / (float)GRID;
      else {
        int k = (-i - 1) / 3, side = (-i - 1) % 3;
        u = (float)k / (float)N;
        if (side == 1) u = nextafterf(u, 0.0f);
        if (side == 2) u = nextafterf(u, 1.0f);
        if (k == N) u = side == 0 ? 1.0f : nextafterf(1.0f, 0.0f);
      }
      float guided = u, searched = u;
      uint32_t t = vf_light_pick_triangle(l, &guided);
      int expect = vf_cdf_search(l->triangle_cdf, N, searched);
      float lo = l->triangle_cdf[expect], hi = l->triangle_cdf[expect + 1];
      float rescaled = (searched - lo) / (hi - lo);
      searched = hi > lo ? fminf(rescaled, 0.99999994f) : 0.5f;
      if ((int)t != expect || guided != searched) mismatches++;
      if (i >= 0) count[t]++;
      if (!(hi > lo)) picked_degenerate++;
    }
    /* Coarser guides, as the environment map's columns have (a quarter of the entries),
     * down to one bucket. */
    const int buckets[] = {N / 4, 7, 1};
    int coarse_wrong = 0;
    for (size_t b = 0; b < sizeof buckets / sizeof *buckets; b++) {
      uint32_t guide[N];
      vf_cdf_guide(l->triangle_cdf, N, guide, buckets[b]);
      for (int i = 0; i <= 20000; i++) {
        float u = (float)i / 20000.0f;
        coarse_wrong += vf_cdf_guided(l->triangle_cdf, N, guide, buckets[b], u) != vf_cdf_search(l->triangle_cdf, N, u);
      }
    }
    CHECK_INT_EQ(coarse_wrong, 0);
    /* The walk itself from every start, as a bad guide would give it. */
    vf_rng rng = vf_rng_for_path(6, 0, 0, VF_STREAM_TEST);
    int walks_wrong = 0;
    for (int i = 0; i < 1000; i++) {
      float u = i == 0 ? 0.0f : i == 1 ? 1.0f : vf_rng_float(&rng);
      int expect = vf_cdf_search(l->triangle_cdf, N, u);
      for (int start = 0; start < N; start++) walks_wrong += vf_cdf_walk(l->triangle_cdf, N, u, start) != expect;
      /* The count that short meshes take, degenerate triangles included, over every prefix. */
      for (int n = 1; n <= N; n++) walks_wrong += vf_cdf_count(l->triangle_cdf, n, u) != vf_cdf_search(l->triangle_cdf, n, u);
    }
    printf("  %d triangles, %d picks: %d differ from the binary search, %d degenerate triangles picked;"
           " walks from every start and counts: %d wrong\n", N, GRID + 3 * N + 3, mismatches, picked_degenerate, walks_wrong);
    CHECK_INT_EQ(walks_wrong, 0);
    CHECK_INT_EQ(mismatches, 0);
    CHECK_INT_EQ(picked_degenerate, 0);
    /* A grid point per 1 / GRID of u: each triangle's count is its area (width / 2) over
     * the strip's (x / 2) times GRID, to within the two grid cells its interval's ends can
     * cut and the float rounding of the cumulative areas. */
    double worst = 0.0;
    for (int t = 0; t < N; t++) worst = fmax(worst, fabs((double)count[t] - width[t] / x * GRID));
    printf("  largest difference of a triangle's picks from its area share: %.2f of %d\n", worst, GRID);
    CHECK(worst <= 2.0);
  }
  vf_lights_destroy(ls);
  vf_scene_destroy(s);
}

/* ---- spot lights ------------------------------------------------------------------------ */

/* A scene of one floor and the spot light `light` (a JSON object); NULL when it does not
 * load, with the error code in *err and its detail in the thread's error. */
static vf_scene *spot_scene(const char *light, int *err) {
  char text[1024];
  snprintf(text, sizeof text,
           "{\"camera\": {\"position\": [0, 1, 3], \"target\": [0, 0, 0], \"fov\": 40},"
           " \"materials\": {\"m\": {\"diffuse\": [0.5, 0.5, 0.5]}},"
           " \"shapes\": [{\"type\": \"mesh\", \"material\": \"m\", \"positions\": [-5,0,-5, 5,0,-5, 5,0,5, -5,0,5],"
           "  \"indices\": [0,2,1, 0,3,2]}], \"lights\": [%s]}",
           light);
  vf_scene *s = NULL;
  *err = vf_scene_parse(text, strlen(text), "spot.json", ".", NULL, 0, &s);
  return s;
}

/* The spot light of spot_scene(light), with the scene and its lights; NULL after a failed
 * check. The caller destroys both, NULL or not. */
static const vf_light *spot_light(const char *light, vf_scene **scene, vf_lights **ls) {
  int err;
  *ls = NULL;
  *scene = spot_scene(light, &err);
  CHECK_INT_EQ(err, VF_OK);
  if (*scene == NULL) return NULL;
  CHECK_INT_EQ(vf_lights_create(*scene, ls), VF_OK);
  const vf_light *l = *ls ? light_of_kind(*ls, VF_LIGHT_SPOT) : NULL;
  CHECK(l != NULL);
  return l;
}

/* KHR_lights_punctual's falloff, written out: the square of the ramp from the outer cone's
 * cosine (0) to the inner's (1). */
static double gltf_falloff(double cos_theta, double inner, double outer) {
  double t = (cos_theta - cos(outer)) / (cos(inner) - cos(outer));
  t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
  return t * t;
}

/* Irradiance on the floor, E = I f(theta) cos / d^2, from what illuminate reports
 * (radiance, and direct_pdf_w = d^2 for a point): on the axis, in the falloff and outside
 * the outer cone. The emission density illuminate reports is the cone's. */
static void test_spot_irradiance_on_a_plane(void) {
  vf_scene *s;
  vf_lights *ls;
  const vf_light *l = spot_light("{\"type\": \"spot\", \"position\": [0, 2, 0], \"direction\": [0, -1, 0],"
                                 " \"intensity\": [3, 3, 3], \"inner_cone_angle\": 20, \"outer_cone_angle\": 35}",
                                 &s, &ls);
  const double inner = 20.0 * M_PI / 180.0, outer = 35.0 * M_PI / 180.0, h = 2.0, I = 3.0;
  const double cone_pdf = 1.0 / (2.0 * M_PI * (1.0 - cos(outer)));
  for (int i = 0; l != NULL && i <= 40; i++) {
    double x = h * tan(i * (M_PI / 180.0)); /* theta = i degrees from the axis */
    vf_vec3 receiver = vf_vec3_make((float)x, 0.0f, 0.0f), n = vf_vec3_make(0, 1, 0);
    const float rnd[2] = {0.3f, 0.7f};
    vf_vec3 d, lp, ln;
    float dist, pdf_w, emission_pdf, cos_light;
    vf_vec3 le = vf_light_illuminate(ls, l, receiver, rnd, &d, &dist, &lp, &ln, &pdf_w, &emission_pdf, &cos_light);
    double cos_theta = h / sqrt(h * h + x * x);
    double exact = I * gltf_falloff(cos_theta, inner, outer) * cos_theta * cos_theta * cos_theta / (h * h);
    double e = vf_is_zero(le) ? 0.0 : le.x * vf_dot(n, d) / pdf_w;
    if (i % 10 == 0 || i == 35) printf("  %2d degrees off the axis: irradiance %.6f, exact %.6f\n", i, e, exact);
    CHECK_NEAR(e, exact, 1e-5 * I / (h * h));
    if (i == 0) CHECK_NEAR(e, I / (h * h), 1e-6); /* the cone's centre: the full intensity */
    if (i >= 35) CHECK_NEAR(e, 0.0, 0.0);        /* outside the outer cone: nothing */
    if (!vf_is_zero(le)) CHECK_NEAR(emission_pdf, cone_pdf, 1e-6 * cone_pdf);
  }
  vf_lights_destroy(ls);
  vf_scene_destroy(s);
}

/* Emission samples the outer cone uniformly in solid angle: every direction lies inside it,
 * E[cos theta] = (1 + cos outer) / 2, the reported density is illuminate's for the same
 * direction, and the emitted power, the mean of intensity / pdf, is the falloff's integral
 * 2 pi I ((1 - cos inner) + (cos inner - cos outer) / 3). */
static void test_spot_emission_samples_the_cone(void) {
  vf_scene *s;
  vf_lights *ls;
  const vf_light *l = spot_light("{\"type\": \"spot\", \"position\": [0, 2, 0], \"direction\": [1, -1, 0],"
                                 " \"intensity\": [2, 2, 2], \"inner_cone_angle\": 10, \"outer_cone_angle\": 50}",
                                 &s, &ls);
  if (l == NULL) {
    vf_lights_destroy(ls);
    vf_scene_destroy(s);
    return;
  }
  const double inner = 10.0 * M_PI / 180.0, outer = 50.0 * M_PI / 180.0;
  const vf_vec3 axis = vf_normalize(vf_vec3_make(1, -1, 0));
  vf_rng rng = vf_rng_for_path(6, 0, 0, VF_STREAM_TEST);
  const int n = 200000;
  double sum = 0.0, sum2 = 0.0, sum_cos = 0.0, max_pdf_dev = 0.0;
  int outside = 0;
  for (int i = 0; i < n; i++) {
    float rnd[4] = {vf_rng_float(&rng), vf_rng_float(&rng), vf_rng_float(&rng), vf_rng_float(&rng)};
    vf_vec3 p, d, nrm;
    float emission_pdf, direct_pdf, cos_light;
    vf_vec3 le = vf_light_emit(ls, l, rnd, &p, &d, &nrm, &emission_pdf, &direct_pdf, &cos_light);
    double c = vf_dot(d, axis);
    outside += !(c >= cos(outer) - 1e-6);
    sum_cos += c;
    double v = le.x / emission_pdf;
    sum += v;
    sum2 += v * v;
    /* illuminate from a point along d sees the same direction, with the same density */
    vf_vec3 receiver = vf_add(p, vf_scale(d, 1.5f)), dl, lp, ln;
    float dist, pdf_w, illum_emission_pdf, cos_at;
    const float r2[2] = {0.5f, 0.5f};
    vf_vec3 li = vf_light_illuminate(ls, l, receiver, r2, &dl, &dist, &lp, &ln, &pdf_w, &illum_emission_pdf, &cos_at);
    if (!vf_is_zero(li)) max_pdf_dev = fmax(max_pdf_dev, fabs(illum_emission_pdf - emission_pdf) / emission_pdf);
    CHECK_NEAR(direct_pdf, 1.0, 0.0);
  }
  double mean = sum / n, se = sqrt((sum2 / n - mean * mean) / n);
  double power = 2.0 * M_PI * 2.0 * ((1.0 - cos(inner)) + (cos(inner) - cos(outer)) / 3.0);
  printf("  emitted intensity / pdf: %.5f +- %.5f, exact %.5f; mean cos %.5f, exact %.5f; %d outside the cone\n",
         mean, se, power, sum_cos / n, 0.5 * (1.0 + cos(outer)), outside);
  CHECK_INT_EQ(outside, 0);
  CHECK_NEAR(mean, power, 5.0 * se);
  CHECK_NEAR(sum_cos / n, 0.5 * (1.0 + cos(outer)), 5.0 * (1.0 - cos(outer)) / sqrt(12.0 * n));
  CHECK(max_pdf_dev < 1e-6);
  vf_lights_destroy(ls);
  vf_scene_destroy(s);
}

/* Cone angles out of order, beyond 90 degrees or negative, and a zero axis, are refused
 * naming the field (the command line exits 2 on VF_ESCENE). */
static void test_spot_fields_are_validated(void) {
  static const struct {
    const char *light, *message;
  } cases[] = {
      {"{\"type\": \"spot\", \"position\": [0, 2, 0], \"direction\": [0, -1, 0], \"intensity\": [1, 1, 1],"
       " \"inner_cone_angle\": 40, \"outer_cone_angle\": 30}",
       "lights[0].inner_cone_angle: must be in [0, outer_cone_angle = 30) degrees, found 40"},
      {"{\"type\": \"spot\", \"position\": [0, 2, 0], \"direction\": [0, -1, 0], \"intensity\": [1, 1, 1],"
       " \"inner_cone_angle\": 30, \"outer_cone_angle\": 30}",
       "lights[0].inner_cone_angle: must be in [0, outer_cone_angle = 30) degrees, found 30"},
      {"{\"type\": \"spot\", \"position\": [0, 2, 0], \"direction\": [0, -1, 0], \"intensity\": [1, 1, 1],"
       " \"outer_cone_angle\": 95}",
       "lights[0].outer_cone_angle: must be in (0, 90] degrees, found 95"},
      {"{\"type\": \"spot\", \"position\": [0, 2, 0], \"direction\": [0, -1, 0], \"intensity\": [1, 1, 1],"
       " \"inner_cone_angle\": -5}",
       "lights[0].inner_cone_angle: must be in [0, outer_cone_angle = 45) degrees, found -5"},
      {"{\"type\": \"spot\", \"position\": [0, 2, 0], \"direction\": [0, 0, 0], \"intensity\": [1, 1, 1]}",
       "lights[0].direction: zero vector"},
      {"{\"type\": \"spot\", \"position\": [0, 2, 0], \"intensity\": [1, 1, 1]}",
       "lights[0]: missing field 'direction'"},
      {"{\"type\": \"point\", \"position\": [0, 2, 0], \"intensity\": [1, 1, 1], \"outer_cone_angle\": 30}",
       "lights[0].outer_cone_angle: unknown field"},
  };
  for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
    int err;
    vf_scene *s = spot_scene(cases[i].light, &err);
    CHECK(s == NULL);
    CHECK_INT_EQ(err, VF_ESCENE);
    CHECK_STR_CONTAINS(vf_error_detail(err), cases[i].message);
    vf_scene_destroy(s);
  }
  /* The defaults are glTF's: inner 0, outer 45 degrees. */
  int err;
  vf_scene *s = spot_scene("{\"type\": \"spot\", \"position\": [0, 2, 0], \"direction\": [0, -3, 0], \"intensity\": [1, 1, 1]}",
                           &err);
  CHECK_INT_EQ(err, VF_OK);
  if (s == NULL) return;
  CHECK_INT_EQ(s->point_lights[0].is_spot, 1);
  CHECK_NEAR(s->point_lights[0].inner_cone_angle, 0.0, 0.0);
  CHECK_NEAR(s->point_lights[0].outer_cone_angle, M_PI / 4.0, 1e-7);
  CHECK_NEAR(s->point_lights[0].direction.y, -1.0, 0.0);
  vf_scene_destroy(s);
}

int main(void) {
  RUN(test_environment_sampling_density_is_consistent_and_normalised);
  RUN(test_area_light_densities_agree_with_hits);
  RUN(test_area_emission_density_integrates);
  RUN(test_triangle_pick_is_the_cdf_search_and_follows_area);
  RUN(test_spot_irradiance_on_a_plane);
  RUN(test_spot_emission_samples_the_cone);
  RUN(test_spot_fields_are_validated);
  return check_finish();
}
