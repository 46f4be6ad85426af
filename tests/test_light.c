/* Light sampling densities: what illuminate() reports for a sampled point or direction must
 * be what a ray that finds the same point or direction reports (otherwise MIS weights are
 * wrong even though each technique alone is unbiased), and every density must integrate to
 * one over its domain. */
#include "check.h"
#include "common/error.h"
#include "common/image.h"
#include "common/rng.h"
#include "worker/light.h"
#include "worker/sampling.h"
#include "worker/scene.h"

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

int main(void) {
  RUN(test_environment_sampling_density_is_consistent_and_normalised);
  RUN(test_area_light_densities_agree_with_hits);
  RUN(test_area_emission_density_integrates);
  return check_finish();
}
