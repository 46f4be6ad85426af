/* Unbiased photon gathering in participating media (worker/render/photon_gathering.h, "In
 * media"; gathering_pass.c) against probability and against the other techniques:
 * 1. the estimator of 1/p_acc for a medium vertex L (its HG phase function times its
 *    continuation) and a target ball of radius r around x in a homogeneous medium that fills
 *    space: a tentative direction lands when the free flight drawn along it
 *    (vf_medium_sample_piece, the light sub-paths' own sampler: one channel of three with
 *    spectral MIS) scatters inside the ball. Then
 *        p_acc = integral over the cone of p_L(w) mean_c (exp(-sigma_c t0(w)) - exp(-sigma_c t1(w))) dw,
 *    [t0, t1] the ball's chord along w, which quadrature in the cone's angles computes
 *    apart from any sampler. The mean of the estimates, from the cone with the HG bound
 *    and from the phase function's own draws, is 1/p_acc within K_Z standard errors, and
 *    the bound is never exceeded; and the same in a density grid, whose flights delta
 *    tracking samples (the light sub-paths' own sampler again), against quadrature of its
 *    scattering density along each direction;
 * 2. the same for a Lambertian surface vertex L below a ceiling at height h, through a
 *    medium between: a direction lands when its flight passes the whole way to the ceiling
 *    (a flight that scatters first is a failure) and meets it within r of x. Then
 *        p_acc = integral over the disc of p_L(w(y)) cos_y / |y - L|^2 mean_c exp(-sigma_c |y - L|) dA;
 * 3. whole renders: upg in an infinite medium of albedo one around an emitting furnace
 *    (the furnace's value, 1, within 4 standard errors), and per-block agreement of upg
 *    with pt, bpt and vcm on the three built-ins with media (cornell-fog, cornell-smoke,
 *    cornell-tinted), chosen and judged as tests/worker/render/test_medium.c judges theirs;
 *    and a point light in fog with a large fixed merge radius, where vcm's kernel is biased
 *    and upg must agree with bpt all the same;
 * 4. reproducibility: an iteration of upg in media is a pure function of (seed, iteration,
 *    path): one thread and two give the same film bit for bit, and so do [0, k) + [k, N)
 *    merged against [0, N), with both samplers. */
#include "blob_grid.h"
#include "check.h"
#include "render_util.h"
#include "common/film.h"
#include "worker/render/bsdf.h"
#include "worker/render/medium.h"
#include "worker/render/photon_gathering.h"
#include "worker/scene/json.h"
#include "worker/scene/load.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define K_Z 4.0
#define GATHERINGS 20000
/* The phase function's own draws cost 1 / p_acc trials per gathering: they run where p_acc
 * is at least this (as tests/worker/render/test_upg.c). */
#define DRAWS_MIN_P_ACC 0.02

/* ---- 1/p_acc ------------------------------------------------------------------------------ */

typedef struct {
  const vf_medium_rt *m;
  vf_vec3 from, target;
  float radius;
  int surface;  /* case 2: land on the ceiling z = height */
  float height;
  vf_rng *rng;
} flight;

/* Whether direction dir's free flight from `from` lands (the top of this file). */
static int flight_lands(void *ctx, vf_vec3 dir) {
  flight *f = ctx;
  float t;
  vf_vec3 w;
  if (f->surface) {
    if (!(dir.z > 0.0f)) return 0;
    float d = (f->height - f->from.z) / dir.z;
    int event = vf_medium_sample_piece(f->m, f->from, dir, d, vf_rng_float(f->rng), f->rng, &t, &w);
    if (event != VF_PIECE_PASSED) return 0;
    vf_vec3 y = vf_add(f->from, vf_scale(dir, d));
    return vf_length_sq(vf_sub(y, f->target)) < f->radius * f->radius;
  }
  int event = vf_medium_sample_piece(f->m, f->from, dir, INFINITY, vf_rng_float(f->rng), f->rng, &t, &w);
  if (event != VF_PIECE_SCATTERED) return 0;
  vf_vec3 y = vf_add(f->from, vf_scale(dir, t));
  return vf_length_sq(vf_sub(y, f->target)) < f->radius * f->radius;
}

/* mean_c exp(-sigma_c t), the probability of a flight passing a length t (1 in a medium that
 * only absorbs: its flights are never stopped, its transmittance is a weight). */
static double pass_d(const vf_medium_rt *m, double t) {
  if (!m->scattering) return 1.0;
  return (exp(-m->sigma_t.x * t) + exp(-m->sigma_t.y * t) + exp(-m->sigma_t.z * t)) / 3.0;
}

/* Case 1's p_acc by quadrature: midpoints in the cone's angle theta (from its axis) and in
 * phi, the density p_L times the probability of scattering in the chord. */
static double p_acc_medium(const vf_bsdf *b, const vf_medium_rt *m, vf_vec3 from, vf_vec3 target, double r) {
  enum { NT = 2000, NP = 256 };
  vf_vec3 a = vf_sub(target, from);
  double dist = vf_length(a);
  vf_frame f = vf_frame_from_normal(vf_scale(a, (float)(1.0 / dist)));
  double theta_max = dist > r ? asin(r / dist) : M_PI;
  double sum = 0.0;
  for (int i = 0; i < NT; i++) {
    double theta = (i + 0.5) * theta_max / NT, st = sin(theta), ct = cos(theta);
    double h2 = r * r - dist * dist * st * st;
    if (!(h2 > 0.0)) continue;
    double t0 = fmax(0.0, dist * ct - sqrt(h2)), t1 = dist * ct + sqrt(h2);
    if (!(t1 > 0.0)) continue;
    double chord = pass_d(m, t0) - pass_d(m, t1);
    double ring = 0.0;
    for (int j = 0; j < NP; j++) {
      double phi = (j + 0.5) * 2.0 * M_PI / NP;
      vf_vec3 w = vf_frame_to_world(&f, vf_vec3_make((float)(st * cos(phi)), (float)(st * sin(phi)), (float)ct));
      float pdf;
      vf_bsdf_evaluate(b, vf_normalize(w), NULL, &pdf, NULL);
      ring += pdf;
    }
    sum += ring * (2.0 * M_PI / NP) * chord * st * (theta_max / NT);
  }
  return sum;
}

/* Case 2's p_acc by quadrature over the disc of radius r around x on the ceiling. */
static double p_acc_surface(const vf_bsdf *b, const vf_medium_rt *m, vf_vec3 from, vf_vec3 x, double r) {
  enum { NR = 800, NP = 512 };
  double sum = 0.0;
  for (int i = 0; i < NR; i++) {
    double rho = (i + 0.5) * r / NR;
    for (int j = 0; j < NP; j++) {
      double phi = (j + 0.5) * 2.0 * M_PI / NP;
      vf_vec3 y = vf_add(x, vf_vec3_make((float)(rho * cos(phi)), (float)(rho * sin(phi)), 0.0f));
      vf_vec3 d = vf_sub(y, from);
      double len = vf_length(d);
      vf_vec3 w = vf_scale(d, (float)(1.0 / len));
      float pdf;
      vf_bsdf_evaluate(b, w, NULL, &pdf, NULL);
      sum += pdf * w.z / (len * len) * pass_d(m, len) * rho * (r / NR) * (2.0 * M_PI / NP);
    }
  }
  return sum;
}

/* The mean and standard error of GATHERINGS estimates of 1/p_acc from each estimator, each
 * against 1/p_acc by quadrature; with teeth: a mean 5% off is rejected. */
static void check_inverse_acceptance(const char *what, const vf_bsdf *b, const vf_medium_rt *m, vf_vec3 from,
                                     vf_vec3 target, float r, int surface, float height, double p_acc, uint64_t seed) {
  vf_upg_source src = {b, NULL, vf_vec3_splat(0.0f)};
  vf_vec3 axis;
  float ch, omc;
  vf_upg_cone(from, target, r, &axis, &ch, &omc);
  float bound = vf_upg_bound(&src, axis, ch, omc);
  CHECK(bound > 0.0f && isfinite(bound));
  printf("  %-34s p_acc %.4g, |C| M / p_acc %.3g\n", what, p_acc, 2.0 * M_PI * omc * bound / p_acc);
  for (int draws = 0; draws < (p_acc >= DRAWS_MIN_P_ACC ? 2 : 1); draws++) {
    vf_rng rng = vf_rng_for_path(seed, (uint64_t)draws, 0, VF_STREAM_TEST);
    flight f = {m, from, target, r, surface, height, &rng};
    vf_upg_counts counts = {0};
    double sum = 0.0, sum2 = 0.0;
    for (int k = 0; k < GATHERINGS; k++) {
      double e = draws ? vf_upg_inverse_acceptance_draws(b, axis, ch, &rng, flight_lands, &f, &counts)
                       : vf_upg_inverse_acceptance(&src, axis, ch, omc, bound, &rng, flight_lands, &f, &counts);
      sum += e;
      sum2 += e * e;
    }
    double mean = sum / GATHERINGS, se = sqrt(fmax(0.0, sum2 / GATHERINGS - mean * mean) / (GATHERINGS - 1));
    double exact = 1.0 / p_acc, z = (mean - exact) / se;
    printf("  %-34s %-5s: mean 1/p_acc %.5g +- %.3g, quadrature %.5g (z %+.2f); %.2f trials, %.2f rays each\n", what,
           draws ? "draws" : "cone", mean, se, exact, z, (double)counts.trials / GATHERINGS,
           (double)counts.rays / GATHERINGS);
    CHECK(fabs(z) < K_Z);
    CHECK(fabs(1.05 * mean - exact) > K_Z * se || fabs(0.95 * mean - exact) > K_Z * se); /* teeth */
    CHECK_INT_EQ(counts.bound_exceeded, 0);
    CHECK_INT_EQ(counts.truncated, 0);
  }
}

static void test_inverse_acceptance_of_a_medium_vertex(void) {
  static const struct {
    const char *name;
    float g, fix_deg, dist, r;
    vf_vec3 sigma_a, sigma_s;
  } cases[] = {
      {"hg 0.6, ball ahead", 0.6f, 20.0f, 1.0f, 0.3f, {0.1f, 0.2f, 0.3f}, {0.8f, 0.5f, 1.1f}},
      {"hg 0.6, ball aside", 0.6f, 100.0f, 0.8f, 0.25f, {0.1f, 0.2f, 0.3f}, {0.8f, 0.5f, 1.1f}},
      {"hg -0.4, ball far", -0.4f, 60.0f, 3.0f, 0.4f, {0.05f, 0.05f, 0.05f}, {0.3f, 0.4f, 0.5f}},
      {"hg 0.9, narrow cone", 0.9f, 5.0f, 4.0f, 0.1f, {0.0f, 0.0f, 0.0f}, {0.4f, 0.4f, 0.4f}},
      {"hg 0.3, L inside the ball", 0.3f, 40.0f, 0.2f, 0.5f, {0.2f, 0.1f, 0.0f}, {1.0f, 1.5f, 2.0f}},
      {"hg 0.5, large ball near", 0.5f, 30.0f, 0.6f, 0.45f, {0.1f, 0.1f, 0.1f}, {1.0f, 1.5f, 2.0f}},
  };
  for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
    vf_medium med = {.sigma_a = cases[i].sigma_a, .sigma_s = cases[i].sigma_s, .g = cases[i].g};
    vf_medium_rt m;
    vf_medium_prepare(&m, &med);
    /* L at the origin, reached along -fix; the ball's centre on +z. */
    double a = cases[i].fix_deg * M_PI / 180.0;
    vf_vec3 fix = vf_vec3_make((float)sin(a), 0.0f, (float)cos(a));
    vf_bsdf b;
    vf_bsdf_setup_phase(&b, m.sigma_s, m.g, m.continuation, fix);
    vf_vec3 from = vf_vec3_splat(0.0f), target = vf_vec3_make(0.0f, 0.0f, cases[i].dist);
    double p = p_acc_medium(&b, &m, from, target, cases[i].r);
    check_inverse_acceptance(cases[i].name, &b, &m, from, target, cases[i].r, 0, 0.0f, p, 100 + i);
  }
}

/* Case 1 in a grid by quadrature: delta tracking against the majorant with spectral weights
 * (medium.h) scatters at distance t with density rho(t) mean_c sigma_s,c exp(-mean_c
 * sigma_t,c int_0^t rho), its real collisions being those of the mean extinction; that
 * density integrated over the chord, midpoints along the ray, for each direction of the cone. */
static double p_acc_grid(const vf_bsdf *b, const vf_medium_rt *m, vf_vec3 from, vf_vec3 target, double r) {
  enum { NT = 300, NP = 96, NS = 800 };
  vf_vec3 a = vf_sub(target, from);
  double dist = vf_length(a);
  vf_frame f = vf_frame_from_normal(vf_scale(a, (float)(1.0 / dist)));
  double theta_max = asin(r / dist), ms = vf_mean3(m->sigma_s), mt = vf_mean3(m->sigma_t);
  double sum = 0.0;
  for (int i = 0; i < NT; i++) {
    double theta = (i + 0.5) * theta_max / NT, st = sin(theta), ct = cos(theta);
    double h2 = r * r - dist * dist * st * st;
    if (!(h2 > 0.0)) continue;
    double t0 = dist * ct - sqrt(h2), t1 = dist * ct + sqrt(h2), ring = 0.0;
    for (int j = 0; j < NP; j++) {
      double phi = (j + 0.5) * 2.0 * M_PI / NP;
      vf_vec3 w = vf_normalize(vf_frame_to_world(&f, vf_vec3_make((float)(st * cos(phi)), (float)(st * sin(phi)), (float)ct)));
      float pdf;
      vf_bsdf_evaluate(b, w, NULL, &pdf, NULL);
      double tau = 0.0, chord = 0.0, h = t1 / NS;
      for (int k = 0; k < NS; k++) {
        double t = (k + 0.5) * h;
        double rho = vf_medium_density_at(m, vf_add(from, vf_scale(w, (float)t)));
        if (t > t0) chord += rho * ms * exp(-mt * (tau + 0.5 * rho * h)) * h;
        tau += rho * h;
      }
      ring += pdf * chord;
    }
    sum += ring * (2.0 * M_PI / NP) * st * (theta_max / NT);
  }
  return sum;
}

static void test_inverse_acceptance_of_a_medium_vertex_in_a_grid(void) {
  vf_medium med = {.sigma_a = vf_vec3_make(0.2f, 0.3f, 0.1f), .sigma_s = vf_vec3_make(0.5f, 0.7f, 0.9f), .g = 0.5f};
  med.grid = make_blob_grid();
  vf_medium_rt m;
  vf_medium_prepare(&m, &med);
  vf_vec3 from = vf_vec3_make(-0.6f, -0.3f, 0.1f), target = vf_vec3_make(0.3f, 0.2f, 0.0f);
  vf_bsdf b;
  vf_vec3 fix = vf_normalize(vf_vec3_make(-0.8f, 0.1f, 0.5f));
  vf_bsdf_setup_phase(&b, vf_scale(m.sigma_s, vf_medium_density_at(&m, from)), m.g, m.continuation, fix);
  double p = p_acc_grid(&b, &m, from, target, 0.3);
  check_inverse_acceptance("hg 0.5 in a grid, delta tracking", &b, &m, from, target, 0.3f, 0, 0.0f, p, 300);
  free(med.grid->density);
  free(med.grid);
}

static void test_inverse_acceptance_of_a_surface_vertex_through_a_medium(void) {
  static const struct {
    const char *name;
    float fix_deg, height, offset, r;
    vf_vec3 sigma_a, sigma_s;
  } cases[] = {
      {"lambert, fog, ceiling above", 30.0f, 1.0f, 0.2f, 0.15f, {0.1f, 0.2f, 0.3f}, {0.8f, 0.5f, 1.1f}},
      {"lambert, dense fog, ceiling aside", 60.0f, 0.7f, 1.0f, 0.2f, {0.5f, 0.5f, 0.5f}, {1.5f, 2.0f, 2.5f}},
      {"lambert, absorbing only", 45.0f, 2.0f, 0.5f, 0.3f, {0.4f, 0.8f, 1.2f}, {0.0f, 0.0f, 0.0f}},
  };
  for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
    vf_medium med = {.sigma_a = cases[i].sigma_a, .sigma_s = cases[i].sigma_s, .g = 0.0f};
    vf_medium_rt m;
    vf_medium_prepare(&m, &med);
    vf_material mat;
    memset(&mat, 0, sizeof mat);
    mat.diffuse = vf_vec3_make(0.8f, 0.6f, 0.4f);
    vf_bsdf_lobes lobes;
    vf_bsdf_lobes_of(&mat, &lobes);
    double a = cases[i].fix_deg * M_PI / 180.0;
    vf_bsdf b;
    CHECK(vf_bsdf_setup(&b, &mat, &lobes, vf_vec3_make(0.0f, 0.0f, 1.0f),
                        vf_vec3_make((float)sin(a), 0.0f, (float)cos(a))));
    vf_vec3 from = vf_vec3_splat(0.0f), x = vf_vec3_make(cases[i].offset, 0.1f, cases[i].height);
    double p = p_acc_surface(&b, &m, from, x, cases[i].r);
    check_inverse_acceptance(cases[i].name, &b, &m, from, x, cases[i].r, 1, cases[i].height, p, 200 + i);
  }
}

/* ---- whole renders ------------------------------------------------------------------------ */

/* Adds a homogeneous medium to the scene; returns its index (as test_medium.c). */
static int add_medium(vf_scene *scene, vf_vec3 sigma_a, vf_vec3 sigma_s, float g) {
  scene->media = realloc(scene->media, (size_t)(scene->num_media + 1) * sizeof *scene->media);
  vf_medium *m = &scene->media[scene->num_media];
  memset(m, 0, sizeof *m);
  m->sigma_a = sigma_a;
  m->sigma_s = sigma_s;
  m->g = g;
  return scene->num_media++;
}

/* Loads a JSON scene given as text (single quotes for double). */
static vf_scene *scene_from_text(const char *text) {
  char *t = strdup(text);
  for (char *p = t; *p; p++)
    if (*p == '\'') *p = '"';
  vf_scene *scene = NULL;
  int err = vf_scene_parse(t, strlen(t), "test_upg_medium", ".", NULL, 0, &scene);
  if (err != VF_OK) fprintf(stderr, "scene: %s\n", vf_error_detail(err));
  free(t);
  return scene;
}

typedef struct {
  int pixels;
  double sum[3], sum2[3];
} image_sums;

static void add_image_mean(void *ctx, int i, const float *cam, const float *light) {
  (void)i;
  image_sums *t = ctx;
  double m[3] = {0};
  for (int p = 0; p < t->pixels; p++)
    for (int c = 0; c < 3; c++) m[c] += cam[3 * p + c] + light[3 * p + c];
  for (int c = 0; c < 3; c++) {
    m[c] /= t->pixels;
    t->sum[c] += m[c];
    t->sum2[c] += m[c] * m[c];
  }
}

/* The furnace (an emitting sphere of radiance 1 around the camera, test_vcm's) filled with a
 * medium of albedo one: every path reads 1. upg's image mean, with a merge radius large
 * enough for its gatherings to matter, within 4 standard errors of it,
 * each error bar below 1%, no sample refused, and gatherings at medium vertices made. */
static void test_furnace_filled_with_a_medium_of_albedo_one(void) {
  vf_scene *scene = NULL;
  CHECK_INT_EQ(vf_scene_load("furnace", &scene), VF_OK);
  if (scene == NULL) return;
  scene->medium = add_medium(scene, vf_vec3_splat(0.0f), vf_vec3_make(0.6f, 0.8f, 1.0f), 0.4f);
  scene->settings.width = scene->settings.height = 32;
  vf_settings s = scene->settings;
  s.algorithm = VF_ALGO_UPG;
  s.sampler = VF_SAMPLER_INDEPENDENT;
  s.seed = 1000 + (uint64_t)s.algorithm;
  /* A radius of 0.05 of the scene's, so that gatherings carry much of the image. */
  s.radius_factor = 0.05;
#ifdef __SANITIZE_ADDRESS__
  enum { N = 32 };
#else
  enum { N = 128 };
#endif
  image_sums t = {s.width * s.height, {0}, {0}};
  vf_vcm_stats stats = {0};
  CHECK_INT_EQ(render_iterations(scene, &s, 2, 0, N, add_image_mean, &t, &stats), VF_OK);
  for (int c = 0; c < 3; c++) {
    double mean = t.sum[c] / N, se = sqrt(fmax(0.0, t.sum2[c] / N - mean * mean) / (N - 1));
    printf("  furnace in a medium upg, channel %d: %.5f +- %.5f (exact 1, z %+.2f)\n", c, mean, se, (mean - 1.0) / se);
    CHECK(fabs(mean - 1.0) < 4.0 * se + 1e-4);
    CHECK(se < 0.01);
  }
  printf("  gatherings %llu (%.2f tentative directions each), merged as vcm %llu, truncated %llu\n",
         (unsigned long long)stats.upg_gatherings, (double)stats.upg_trials / (double)stats.upg_gatherings,
         (unsigned long long)stats.upg_fallbacks, (unsigned long long)stats.upg_truncated);
  CHECK(stats.upg_gatherings > 0);
  CHECK_INT_EQ(stats.upg_bound_exceeded, 0);
  CHECK_INT_EQ(stats.nonfinite, 0);
  vf_scene_destroy(scene);
}

/* Per-block agreement of upg with pt, bpt and vcm on a built-in with media, with the sizes,
 * iterations and rule of test_medium.c's agree_on_builtin (8x8 blocks of a 64x64 image,
 * `iterations` of each algorithm (256 there), every block within 5 combined standard errors
 * and mean z^2 below 2; under the sanitizers a sixteenth of the work, printed, not
 * checked). */
static void agree_on_builtin(const char *name, vf_sampler_kind sampler, int iterations) {
  vf_scene *scene = NULL;
  CHECK_INT_EQ(vf_scene_load(name, &scene), VF_OK);
  if (scene == NULL) return;
  CHECK(scene->num_media > 0);
  scene->settings.max_path_length = 8;
#ifdef __SANITIZE_ADDRESS__
  scene->settings.width = scene->settings.height = 32;
  enum { BLOCKS = 8, NB = BLOCKS * BLOCKS, N = 64 };
#define MEDIA_AGREE(x) ((void)(x))
#else
  scene->settings.width = scene->settings.height = 64;
  enum { BLOCKS = 8, NB = BLOCKS * BLOCKS, N = 256 };
#define MEDIA_AGREE(x) CHECK(x)
#endif
  const vf_algorithm algorithms[] = {VF_ALGO_UPG, VF_ALGO_PT, VF_ALGO_BPT, VF_ALGO_VCM};
  enum { COUNT = sizeof algorithms / sizeof *algorithms };
  double mean[COUNT][NB], se[COUNT][NB];
  vf_vcm_stats upg = {0};
  for (int a = 0; a < COUNT; a++) {
    vf_settings s = scene->settings;
    s.algorithm = algorithms[a];
    s.sampler = sampler;
    s.seed = 77 + (uint64_t)algorithms[a];
    vf_vcm_stats stats = {0};
    CHECK_INT_EQ(render_block_estimates(scene, &s, 2, N * iterations / 256, BLOCKS, mean[a], se[a], &stats), VF_OK);
    CHECK_INT_EQ(stats.nonfinite, 0);
    if (a == 0) upg = stats;
  }
  char what[64];
  snprintf(what, sizeof what, "%s %s", name, vf_sampler_name(sampler));
  for (int b = 1; b < COUNT; b++)
    MEDIA_AGREE(blocks_agree(what, "upg", vf_algorithm_name(algorithms[b]), mean[0], se[0], mean[b], se[b], NB));
#undef MEDIA_AGREE
  printf("  %s upg: %llu gatherings, %.2f tentative directions and %.2f rays each, %llu merged as vcm (%.2g%%)\n", what,
         (unsigned long long)upg.upg_gatherings, (double)upg.upg_trials / (double)upg.upg_gatherings,
         (double)upg.upg_rays / (double)upg.upg_gatherings, (unsigned long long)upg.upg_fallbacks,
         100.0 * (double)upg.upg_fallbacks / (double)(upg.upg_gatherings + upg.upg_fallbacks));
  CHECK(upg.upg_gatherings > 0);
  CHECK_INT_EQ(upg.upg_bound_exceeded, 0);
  vf_scene_destroy(scene);
}

static void test_cornell_fog_agreement(void) { agree_on_builtin("cornell-fog", VF_SAMPLER_SOBOL, 256); }
/* The independent sampler with half the iterations: its iterations cost more (no
 * stratification to share, the same paths), and a minute a case is the budget. */
static void test_cornell_fog_agreement_independent(void) {
#ifndef __SANITIZE_ADDRESS__
  /* tests/sanitize.sh looks for memory errors, not statistics: one sampler there. */
  agree_on_builtin("cornell-fog", VF_SAMPLER_INDEPENDENT, 128);
#endif
}
static void test_cornell_smoke_agreement(void) { agree_on_builtin("cornell-smoke", VF_SAMPLER_SOBOL, 256); }
static void test_cornell_tinted_agreement(void) { agree_on_builtin("cornell-tinted", VF_SAMPLER_SOBOL, 256); }

/* A point light in fog that fills space, seen from inside it (test_medium.c's scene), with a
 * large fixed merge radius, 0.3 of the scene's radius: vcm's 3D kernel blurs the light's
 * glow by it and must disagree with bpt (so that the comparison has power), while upg, which
 * gathers with the same radius without bias, must agree, gathering from the light's side
 * where both sides can and (upg*) from the camera's. */
static void test_large_radius_in_fog_around_a_point_light(void) {
  vf_scene *scene = scene_from_text(
      "{'camera':{'position':[0,0,2],'forward':[0,0,-1],'up':[0,1,0],'fov':60,'resolution':[32,32]},"
      "'materials':{'black':{'diffuse':[0,0,0]}},'shapes':["
      "{'type':'sphere','center':[0,0,-30],'radius':1,'material':'black'}],"
      "'lights':[{'type':'point','position':[0,0.6,-0.5],'intensity':[4,4,4]}],"
      "'render':{'max_path_length':6}}");
  CHECK(scene != NULL);
  if (scene == NULL) return;
  scene->medium = add_medium(scene, vf_vec3_splat(0.1f), vf_vec3_make(0.4f, 0.5f, 0.6f), 0.3f);
  enum { BLOCKS = 4, NB = BLOCKS * BLOCKS, ALGORITHMS = 4 };
  /* upg twice: gathering from the light's side where both sides can, and from the camera's. */
  const vf_algorithm algorithms[ALGORITHMS] = {VF_ALGO_BPT, VF_ALGO_UPG, VF_ALGO_VCM, VF_ALGO_UPG};
#ifdef __SANITIZE_ADDRESS__
  const int iterations[ALGORITHMS] = {16, 16, 16, 16};
#else
  const int iterations[ALGORITHMS] = {128, 128, 128, 128};
#endif
  double mean[ALGORITHMS][NB], se[ALGORITHMS][NB];
  for (int a = 0; a < ALGORITHMS; a++) {
    vf_settings s = scene->settings;
    s.algorithm = algorithms[a];
    s.sampler = VF_SAMPLER_INDEPENDENT;
    s.seed = 600 + (uint64_t)a;
    s.radius_factor = 0.3;
    s.alpha = 1.0;
    s.gather = a == 3 ? VF_GATHER_CAMERA : VF_GATHER_LIGHT;
    vf_vcm_stats stats = {0};
    CHECK_INT_EQ(render_block_estimates(scene, &s, 2, iterations[a], BLOCKS, mean[a], se[a], &stats), VF_OK);
    CHECK_INT_EQ(stats.nonfinite, 0);
  }
  int upg_agrees = blocks_agree("large radius", "bpt", "upg", mean[0], se[0], mean[1], se[1], NB);
  int vcm_agrees = blocks_agree("large radius", "bpt", "vcm", mean[0], se[0], mean[2], se[2], NB);
  int camera_agrees = blocks_agree("large radius", "bpt", "upg*", mean[0], se[0], mean[3], se[3], NB);
#ifndef __SANITIZE_ADDRESS__
  CHECK(camera_agrees);
  CHECK(upg_agrees);
  CHECK(!vcm_agrees);
#else
  (void)upg_agrees;
  (void)vcm_agrees;
  (void)camera_agrees;
#endif
  vf_scene_destroy(scene);
}

/* ---- reproducibility ---------------------------------------------------------------------- */

/* upg in a scene with fog, a glass ball and a box of smoke (cornell-smoke's grid beside
 * cornell-fog's fog: the built-ins, one after the other): one thread and two give the same
 * film bit for bit, and [0, k) + [k, N) merged the film of [0, N), with both samplers. */
static void check_reproducible(const char *name) {
  vf_scene *scene = NULL;
  CHECK_INT_EQ(vf_scene_load(name, &scene), VF_OK);
  if (scene == NULL) return;
  scene->settings.width = scene->settings.height = 32;
  for (int k = 0; k < VF_SAMPLER_COUNT_; k++) {
    vf_settings s = scene->settings;
    s.algorithm = VF_ALGO_UPG;
    s.sampler = (vf_sampler_kind)k;
    vf_film *one = render_film(scene, &s, 1, 0, 4), *two = render_film(scene, &s, 2, 0, 4);
    vf_film *first = render_film(scene, &s, 2, 0, 1), *rest = render_film(scene, &s, 1, 1, 4);
    CHECK(one && two && first && rest);
    if (one && two && first && rest) {
      CHECK(films_bitwise_equal(one, two));
      CHECK_INT_EQ(vf_film_merge(first, rest), VF_OK);
      CHECK(films_bitwise_equal(one, first));
      printf("  %s upg %s: 1 and 2 threads %s, [0,1) + [1,4) against [0,4) %s\n", name, vf_sampler_name(s.sampler),
             films_bitwise_equal(one, two) ? "equal" : "DIFFER", films_bitwise_equal(one, first) ? "equal" : "DIFFER");
    }
    vf_film_destroy(one);
    vf_film_destroy(two);
    vf_film_destroy(first);
    vf_film_destroy(rest);
  }
  vf_scene_destroy(scene);
}

static void test_renders_in_media_are_reproducible(void) {
  check_reproducible("cornell-fog");
  check_reproducible("cornell-smoke");
}

int main(void) {
  setvbuf(stdout, NULL, _IOLBF, 0);
  RUN(test_inverse_acceptance_of_a_medium_vertex);
  RUN(test_inverse_acceptance_of_a_medium_vertex_in_a_grid);
  RUN(test_inverse_acceptance_of_a_surface_vertex_through_a_medium);
  RUN(test_furnace_filled_with_a_medium_of_albedo_one);
  RUN(test_renders_in_media_are_reproducible);
  RUN(test_large_radius_in_fog_around_a_point_light);
  RUN(test_cornell_fog_agreement);
  RUN(test_cornell_fog_agreement_independent);
  RUN(test_cornell_smoke_agreement);
  RUN(test_cornell_tinted_agreement);
  return check_finish();
}
