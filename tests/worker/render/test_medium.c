/* Participating media (worker/render/medium.h, segment.h) against physics: the phase
 * function's sampling by a chi-square test, distance sampling and tracking against their
 * integrals, and whole renders of analytic scenes with every technique that renders media:
 * an absorbing ball in front of an emitter, a furnace filled with a medium of albedo one,
 * single scattering in a thin slab. */
#include "blob_grid.h"
#include "check.h"
#include "render_util.h"
#include "worker/render/bsdf.h"
#include "worker/render/medium.h"
#include "worker/render/mis.h"
#include "worker/render/segment.h"
#include "worker/scene/json.h"
#include "worker/scene/load.h"

#include <stdlib.h>
#include <string.h>

static const vf_algorithm media_algorithms[] = {VF_ALGO_PT, VF_ALGO_LT, VF_ALGO_BPT, VF_ALGO_VCM};

/* ---- the phase function ------------------------------------------------------------------ */

/* The HG cdf in cos_theta from -1: F(c) = (1 - g^2) / (2 g) (1 / sqrt(1 + g^2 - 2 g c) - 1 / (1 + g)). */
static double hg_cdf(double c, double g) {
  if (fabs(g) < 1e-6) return 0.5 * (c + 1.0);
  return (1.0 - g * g) / (2.0 * g) * (1.0 / sqrt(1.0 + g * g - 2.0 * g * c) - 1.0 / (1.0 + g));
}

/* Sampled scattering angles follow HG (chi-square over 40 bins of cos theta); the density
 * sample() reports is evaluate()'s for the same direction, and evaluate integrates to one. */
static void test_phase_function_sampling_matches_its_density(void) {
  const float gs[] = {0.0f, 0.3f, -0.6f, 0.9f};
  vf_rng rng = vf_rng_for_path(7, 0, 0, 0);
  for (size_t k = 0; k < sizeof gs / sizeof *gs; k++) {
    float g = gs[k];
    vf_vec3 fix = vf_normalize(vf_vec3_make(0.3f, -0.5f, 0.8f));
    vf_bsdf b;
    vf_bsdf_setup_phase(&b, vf_vec3_make(0.5f, 1.0f, 2.0f), g, 1.0f, fix);
    enum { BINS = 40, N = 200000 };
    double count[BINS] = {0};
    int pdf_mismatch = 0;
    for (int i = 0; i < N; i++) {
      float rnd[3] = {vf_rng_float(&rng), vf_rng_float(&rng), vf_rng_float(&rng)};
      vf_vec3 gen;
      float pdf, rev, cos_gen;
      unsigned event;
      vf_vec3 f = vf_bsdf_sample(&b, rnd, &gen, &pdf, &rev, &cos_gen, &event);
      float c = -vf_dot(fix, gen); /* travel in is -fix */
      int bin = (int)((c + 1.0f) * 0.5f * BINS);
      bin = bin < 0 ? 0 : bin >= BINS ? BINS - 1 : bin;
      count[bin] += 1.0;
      float epdf, erev, ecos;
      vf_vec3 ef = vf_bsdf_evaluate(&b, gen, &ecos, &epdf, &erev);
      if (fabsf(epdf - pdf) > 1e-5f * pdf || fabsf(erev - rev) > 1e-5f * rev || ecos != 1.0f || cos_gen != 1.0f ||
          fabsf(ef.y - f.y) > 1e-5f * f.y || fabsf(f.y - 2.0f * f.x) > 1e-5f * f.y)
        pdf_mismatch++;
    }
    double chi2 = 0.0;
    for (int i = 0; i < BINS; i++) {
      double lo = -1.0 + 2.0 * i / BINS, hi = -1.0 + 2.0 * (i + 1) / BINS;
      double expected = N * (hg_cdf(hi, g) - hg_cdf(lo, g));
      chi2 += (count[i] - expected) * (count[i] - expected) / expected;
    }
    /* Integral of the density over the sphere, by quadrature in cos theta. */
    double integral = 0.0;
    enum { Q = 20000 };
    for (int i = 0; i < Q; i++) integral += 2.0 * VF_PI * vf_hg(-1.0f + 2.0f * ((float)i + 0.5f) / Q, g) * 2.0 / Q;
    printf("  HG g %+.1f: chi2 %.1f (39 dof), integral %.6f, %d density mismatches\n", g, chi2, integral, pdf_mismatch);
    CHECK(chi2 < 80.0); /* p ~ 1e-4 for 39 degrees of freedom */
    CHECK_NEAR(integral, 1.0, 2e-4);
    CHECK_INT_EQ(pdf_mismatch, 0);
  }
}

/* ---- distance sampling and tracking -------------------------------------------------------- */

/* Transmittance by quadrature along o + t dir, t in [0, d), for channel sigma_t. */
static double optical_depth(const vf_medium_rt *m, vf_vec3 o, vf_vec3 dir, float d, float sigma_t) {
  enum { Q = 20000 };
  double tau = 0.0;
  for (int i = 0; i < Q; i++) {
    float t = d * ((float)i + 0.5f) / Q;
    tau += sigma_t * vf_medium_density_at(m, vf_add(o, vf_scale(dir, t))) * d / Q;
  }
  return tau;
}

/* What distance sampling estimates: E[weight; passed] = T(d) and E[weight sigma_s(t);
 * scattered] = the probability of scattering, int_0^d T(t) sigma_s(t) dt, per channel, for
 * a homogeneous chromatic medium and a grid; ratio tracking's E[T] = T(d). */
static void test_distance_sampling_estimates_transmittance_and_scattering(void) {
  vf_density_grid *grid = make_blob_grid();
  for (int gridded = 0; gridded <= 1; gridded++) {
    vf_medium med = {.sigma_a = vf_vec3_make(0.1f, 0.4f, 0.2f), .sigma_s = vf_vec3_make(0.9f, 0.3f, 1.5f), .g = 0.2f,
                     .grid = gridded ? grid : NULL};
    vf_medium_rt m;
    vf_medium_prepare(&m, &med);
    vf_vec3 o = vf_vec3_make(-1.5f, 0.1f, -0.2f), dir = vf_normalize(vf_vec3_make(1.0f, 0.1f, 0.2f));
    float d = 3.0f;
    enum { N = 400000 };
    vf_rng rng = vf_rng_for_path(11, (uint64_t)gridded, 0, 0);
    double pass[3] = {0}, pass2[3] = {0}, scat[3] = {0}, scat2[3] = {0}, tr[3] = {0}, tr2[3] = {0};
    for (int i = 0; i < N; i++) {
      float t;
      vf_vec3 w;
      int e = vf_medium_sample_piece(&m, o, dir, d, vf_rng_float(&rng), &rng, &t, &w);
      double p[3] = {0}, s[3] = {0};
      if (e == VF_PIECE_PASSED) p[0] = w.x, p[1] = w.y, p[2] = w.z;
      if (e == VF_PIECE_SCATTERED) {
        float rho = vf_medium_density_at(&m, vf_add(o, vf_scale(dir, t)));
        s[0] = w.x * rho * m.sigma_s.x, s[1] = w.y * rho * m.sigma_s.y, s[2] = w.z * rho * m.sigma_s.z;
      }
      vf_vec3 T = vf_medium_transmittance_piece(&m, o, dir, d, &rng);
      double tt[3] = {T.x, T.y, T.z};
      for (int c = 0; c < 3; c++) {
        pass[c] += p[c], pass2[c] += p[c] * p[c];
        scat[c] += s[c], scat2[c] += s[c] * s[c];
        tr[c] += tt[c], tr2[c] += tt[c] * tt[c];
      }
    }
    const float st[3] = {m.sigma_t.x, m.sigma_t.y, m.sigma_t.z}, ss[3] = {m.sigma_s.x, m.sigma_s.y, m.sigma_s.z};
    for (int c = 0; c < 3; c++) {
      double exact_t = exp(-optical_depth(&m, o, dir, d, st[c]));
      /* int_0^d T(t) sigma_s(t) dt by quadrature. */
      enum { Q = 4000 };
      double exact_s = 0.0;
      for (int i = 0; i < Q; i++) {
        float t = d * ((float)i + 0.5f) / Q;
        vf_vec3 x = vf_add(o, vf_scale(dir, t));
        exact_s += exp(-optical_depth(&m, o, dir, t, st[c])) * ss[c] * vf_medium_density_at(&m, x) * d / Q;
      }
      double mp = pass[c] / N, sp = sqrt(fmax(0.0, pass2[c] / N - mp * mp) / N);
      double ms = scat[c] / N, sse = sqrt(fmax(0.0, scat2[c] / N - ms * ms) / N);
      double mt = tr[c] / N, st_e = sqrt(fmax(0.0, tr2[c] / N - mt * mt) / N);
      printf("  %s channel %d: passed %.5f +- %.5f (T %.5f), scattered %.5f +- %.5f (exact %.5f), tracked T %.5f +- %.5f\n",
             gridded ? "grid       " : "homogeneous", c, mp, sp, exact_t, ms, sse, exact_s, mt, st_e);
      CHECK_NEAR(mp, exact_t, 5.0 * sp + 1e-6);
      CHECK_NEAR(ms, exact_s, 5.0 * sse + 2e-4 * exact_s);
      CHECK_NEAR(mt, exact_t, 5.0 * st_e + 1e-6);
    }
  }
  free(grid->density);
  free(grid);
}

/* ---- whole renders ---------------------------------------------------------------------------- */

/* Loads a JSON scene given as text (single quotes for double). */
static vf_scene *scene_from_text(const char *text) {
  char *t = strdup(text);
  for (char *p = t; *p; p++)
    if (*p == '\'') *p = '"';
  vf_scene *scene = NULL;
  int err = vf_scene_parse(t, strlen(t), "test_media", ".", NULL, 0, &scene);
  if (err != VF_OK) fprintf(stderr, "scene: %s\n", vf_error_detail(err));
  free(t);
  return scene;
}

/* Adds a homogeneous medium to the scene; returns its index. */
static int add_medium(vf_scene *scene, vf_vec3 sigma_a, vf_vec3 sigma_s, float g) {
  scene->media = realloc(scene->media, (size_t)(scene->num_media + 1) * sizeof *scene->media);
  vf_medium *m = &scene->media[scene->num_media];
  memset(m, 0, sizeof *m);
  m->sigma_a = sigma_a;
  m->sigma_s = sigma_s;
  m->g = g;
  return scene->num_media++;
}

/* Makes shape i the index-matched boundary of `interior` (no material), in the scene's medium. */
static void make_boundary(vf_scene *scene, int i, int interior) {
  vf_shape *sh = &scene->shapes[i];
  sh->material = -1;
  sh->interface = 1;
  sh->interior = interior;
  sh->exterior = scene->medium;
}

/* Per-channel mean over the whole image of each of n iterations of `algorithm`, and the
 * standard error of their mean (independent sampler: iterations independent). */
typedef struct {
  int pixels;
  double sum[3], sum2[3];
} image_sums;

static void add_image_mean(void *ctx, int i, const float *cam, const float *light) {
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

static int render_image_mean(const vf_scene *scene, vf_algorithm algorithm, int n, double mean[3], double se[3],
                             uint64_t *nonfinite) {
  vf_settings s = scene->settings;
  s.algorithm = algorithm;
  s.sampler = VF_SAMPLER_INDEPENDENT;
  s.seed = 1000 + (uint64_t)algorithm;
  image_sums t = {s.width * s.height, {0}, {0}};
  vf_vcm_stats stats = {0};
  int err = render_iterations(scene, &s, 2, 0, n, add_image_mean, &t, &stats);
  for (int c = 0; c < 3; c++) {
    mean[c] = t.sum[c] / n;
    se[c] = sqrt(fmax(0.0, t.sum2[c] / n - mean[c] * mean[c]) / (n - 1));
  }
  *nonfinite = stats.nonfinite;
  return err;
}

/* Every algorithm of media_algorithms (lt with n_lt iterations, the others n) reads the
 * image mean `exact` per channel, within 5 standard errors and the float's and
 * quadrature's 1e-4; each error bar below `teeth` of the value, so that the check has
 * teeth. */
static void check_image_mean(const vf_scene *scene, const char *what, const double exact[3], int n, int n_lt,
                             double teeth) {
  for (size_t a = 0; a < sizeof media_algorithms / sizeof *media_algorithms; a++) {
    double mean[3] = {0}, se[3] = {0};
    uint64_t nonfinite = 0;
    vf_algorithm algorithm = media_algorithms[a];
    CHECK_INT_EQ(render_image_mean(scene, algorithm, algorithm == VF_ALGO_LT ? n_lt : n, mean, se, &nonfinite), VF_OK);
    printf("  %s %-3s: %.5f %.5f %.5f +- %.5f %.5f %.5f (exact %.5f %.5f %.5f)\n", what, vf_algorithm_name(algorithm),
           mean[0], mean[1], mean[2], se[0], se[1], se[2], exact[0], exact[1], exact[2]);
    for (int c = 0; c < 3; c++) {
      CHECK_NEAR(mean[c], exact[c], 5.0 * se[c] + 1e-4 * exact[c]);
      CHECK(se[c] < teeth * exact[c]);
    }
    CHECK_INT_EQ(nonfinite, 0);
  }
}

/* An emitter of radiance 1 seen through an index-matched ball of radius 1 filled with an
 * absorbing medium: each ray reads exp(-sigma_a chord) per channel, chord the ball's along
 * it (the diameter at the image's centre). The image's mean, by quadrature over the image
 * plane, is the exact value. */
static double ball_image_mean(double sigma_a, double camera_distance, double tan_half_fov) {
  enum { Q = 400 };
  double sum = 0.0;
  for (int j = 0; j < Q; j++)
    for (int i = 0; i < Q; i++) {
      double u = (2.0 * (i + 0.5) / Q - 1.0) * tan_half_fov, v = (2.0 * (j + 0.5) / Q - 1.0) * tan_half_fov;
      double b2 = camera_distance * camera_distance * (u * u + v * v) / (1.0 + u * u + v * v);
      sum += exp(-sigma_a * 2.0 * sqrt(fmax(0.0, 1.0 - b2)));
    }
  return sum / ((double)Q * Q);
}

static void test_absorbing_ball_in_front_of_an_emitter(void) {
  /* The emitter, 9 away and 0.1 wide, covers the image (0.079 wide there) and little more,
   * so that light tracing finds the camera as often as it can. */
  vf_scene *scene = scene_from_text(
      "{'camera':{'position':[0,0,6],'forward':[0,0,-1],'up':[0,1,0],'fov':0.5,'resolution':[15,15]},"
      "'materials':{'black':{'diffuse':[0,0,0]}},'shapes':["
      "{'type':'sphere','center':[0,0,0],'radius':1,'material':'black'},"
      "{'type':'mesh','material':'black','emission':[1,1,1],"
      "'positions':[-0.05,-0.05,-3, 0.05,-0.05,-3, 0.05,0.05,-3, -0.05,0.05,-3],'indices':[0,1,2, 0,2,3]}],"
      "'render':{'max_path_length':4}}");
  CHECK(scene != NULL);
  if (scene == NULL) return;
  vf_vec3 sigma_a = vf_vec3_make(0.2f, 0.5f, 1.0f);
  make_boundary(scene, 0, add_medium(scene, sigma_a, vf_vec3_splat(0.0f), 0.0f));
  double t = tan(0.25 * VF_PI / 180.0);
  const double exact[3] = {ball_image_mean(0.2, 6.0, t), ball_image_mean(0.5, 6.0, t), ball_image_mean(1.0, 6.0, t)};
  /* The techniques that see the emitter through the ball read it exactly per ray (only the
   * pixels' jitter varies); lt's own noise is checked to be below 2%. */
  check_image_mean(scene, "absorbing ball", exact, 32, 256, 0.02);
  vf_scene_destroy(scene);
}

/* The furnace (every wall emits 0.5 with albedo 0.5) filled with a medium that scatters
 * and does not absorb: radiance 1 everywhere stays the equilibrium, so every path still
 * sees 1 - 0.5^(surface bounces), which the path-length limit of 64 leaves at 1 to a few
 * parts in a million. */
static void test_furnace_filled_with_a_medium_of_albedo_one(void) {
  vf_scene *scene = NULL;
  CHECK_INT_EQ(vf_scene_load("furnace", &scene), VF_OK);
  if (scene == NULL) return;
  scene->medium = add_medium(scene, vf_vec3_splat(0.0f), vf_vec3_make(0.6f, 0.8f, 1.0f), 0.4f);
  scene->settings.width = scene->settings.height = 32;
  /* Not light tracing alone: its connections of medium vertices to a pinhole carry
   * sigma_s p / d^2, whose square integrates over the volume around the camera as the
   * integral of 1 / d^2 in d, which diverges. Its estimate has the right mean but no
   * variance, and a 5-sigma rule means nothing for it (it reads 2 sigma low here with 1024
   * iterations). Its connections through media are checked in the slab. */
  const vf_algorithm algorithms[] = {VF_ALGO_PT, VF_ALGO_BPT, VF_ALGO_VCM};
  for (size_t a = 0; a < sizeof algorithms / sizeof *algorithms; a++) {
    double mean[3] = {0}, se[3] = {0};
    uint64_t nonfinite = 0;
    CHECK_INT_EQ(render_image_mean(scene, algorithms[a], 32, mean, se, &nonfinite), VF_OK);
    printf("  furnace in a medium %-3s: %.5f %.5f %.5f +- %.5f %.5f %.5f (exact 1)\n", vf_algorithm_name(algorithms[a]), mean[0], mean[1], mean[2], se[0], se[1], se[2]);
    for (int c = 0; c < 3; c++) {
      CHECK_NEAR(mean[c], 1.0, 5.0 * se[c] + 1e-4);
      CHECK(se[c] < 0.01); /* the check above must have teeth */
    }
    CHECK_INT_EQ(nonfinite, 0);
  }
  vf_scene_destroy(scene);
}

/* Single scattering in a slab: an orthographic camera looks straight down into a slab of
 * thickness h (index-matched, nothing below it) lit straight down by a sun of irradiance
 * E. With paths of two segments (camera, one scattering, light) the radiance is
 *   L = sigma_s p(-1) E int_0^h exp(-2 sigma_t u) du = sigma_s p(-1) E (1 - exp(-2 sigma_t h)) / (2 sigma_t)
 * per channel, p(-1) the HG density of turning straight back. */
static void test_single_scattering_in_a_thin_slab(void) {
  vf_scene *scene = scene_from_text(
      "{'camera':{'type':'orthographic','position':[0,5,0],'forward':[0,-1,0],'up':[0,0,-1],'width':2,"
      "'resolution':[8,8]},"
      "'materials':{'black':{'diffuse':[0,0,0]}},'shapes':["
      "{'type':'mesh','material':'black','positions':["
      "-2,0,-2, 2,0,-2, 2,0.5,-2, -2,0.5,-2, -2,0,2, 2,0,2, 2,0.5,2, -2,0.5,2],"
      "'indices':[0,2,1, 0,3,2, 4,5,6, 4,6,7, 0,1,5, 0,5,4, 3,7,6, 3,6,2, 0,4,7, 0,7,3, 1,2,6, 1,6,5]}],"
      "'lights':[{'type':'directional','direction':[0,-1,0],'irradiance':[1,2,3]}],"
      "'render':{'max_path_length':2}}");
  CHECK(scene != NULL);
  if (scene == NULL) return;
  vf_vec3 sa = vf_vec3_make(0.3f, 0.1f, 0.5f), ss = vf_vec3_make(0.4f, 0.8f, 0.6f);
  float g = 0.3f, h = 0.5f;
  make_boundary(scene, 0, add_medium(scene, sa, ss, g));
  const double E[3] = {1, 2, 3}, s_s[3] = {ss.x, ss.y, ss.z}, s_t[3] = {sa.x + ss.x, sa.y + ss.y, sa.z + ss.z};
  double exact[3];
  for (int c = 0; c < 3; c++)
    exact[c] = s_s[c] * vf_hg(-1.0f, g) * E[c] * (1.0 - exp(-2.0 * s_t[c] * h)) / (2.0 * s_t[c]);
  check_image_mean(scene, "slab single scattering", exact, 256, 4096, 0.05);
  vf_scene_destroy(scene);
}

/* A scene's shape by name, or -1. */
static int shape_named(const vf_scene *scene, const char *name) {
  for (int i = 0; i < scene->num_shapes; i++)
    if (strcmp(scene->shapes[i].name, name) == 0) return i;
  return -1;
}

/* Per-block agreement of pt, bpt and vcm on a built-in with media, and of lt where its
 * variance is finite (not with the camera inside a scattering medium: its connections of
 * medium vertices to the pinhole carry 1 / d^2, see the furnace above). */
static void agree_on_builtin(const char *name, vf_sampler_kind sampler, int with_lt) {
  vf_scene *scene = NULL;
  CHECK_INT_EQ(vf_scene_load(name, &scene), VF_OK);
  if (scene == NULL) return;
  CHECK(scene->num_media > 0);
  scene->settings.max_path_length = 8;
#ifdef __SANITIZE_ADDRESS__
  /* tests/sanitize.sh looks for memory errors and non-finite samples: a sixteenth of the
   * work, whose agreement is printed, not checked (its few batches estimate heavy-tailed
   * blocks' spread too unsteadily for a 5-sigma rule). The release run checks it. */
  scene->settings.width = scene->settings.height = 32;
  enum { BLOCKS = 8, NB = BLOCKS * BLOCKS, N = 64 };
#define MEDIA_AGREE(x) ((void)(x))
#else
  scene->settings.width = scene->settings.height = 64;
  enum { BLOCKS = 8, NB = BLOCKS * BLOCKS, N = 256 };
#define MEDIA_AGREE(x) CHECK(x)
#endif
  const vf_algorithm algorithms[] = {VF_ALGO_PT, VF_ALGO_BPT, VF_ALGO_VCM, VF_ALGO_LT};
  int count = with_lt ? 4 : 3;
  double mean[4][NB], se[4][NB];
  for (int a = 0; a < count; a++) {
    vf_settings s = scene->settings;
    s.algorithm = algorithms[a];
    s.sampler = sampler;
    s.seed = 77 + (uint64_t)a;
    vf_vcm_stats stats = {0};
    CHECK_INT_EQ(render_block_estimates(scene, &s, 2, algorithms[a] == VF_ALGO_LT ? 4 * N : N, BLOCKS, mean[a], se[a],
                                        &stats),
                 VF_OK);
    CHECK_INT_EQ(stats.nonfinite, 0);
  }
  char what[64];
  snprintf(what, sizeof what, "%s %s", name, vf_sampler_name(sampler));
  for (int a = 0; a < count; a++)
    for (int b = a + 1; b < count; b++)
      MEDIA_AGREE(blocks_agree(what, vf_algorithm_name(algorithms[a]), vf_algorithm_name(algorithms[b]), mean[a],
                               se[a], mean[b], se[b], NB));
#undef MEDIA_AGREE
  vf_scene_destroy(scene);
}

/* The three built-ins with media: fog with a glass ball raised above the floor, which
 * focuses the ceiling light into a cone in the fog (a volumetric caustic), with both
 * samplers; smoke, a density grid read through OpenVDB and tracked, in an index-matched
 * box, where lt applies too (no specular surface in view, the camera outside the smoke);
 * a glass ball with an absorbing interior (lt cannot see the balls: the camera sees them
 * only along specular paths). */
static void test_media_builtins_agreement_of_the_techniques(void) {
  agree_on_builtin("cornell-fog", VF_SAMPLER_SOBOL, 0);
#ifndef __SANITIZE_ADDRESS__
  /* tests/sanitize.sh looks for memory errors, not statistics: one sampler there. */
  agree_on_builtin("cornell-fog", VF_SAMPLER_INDEPENDENT, 0);
#endif
  agree_on_builtin("cornell-smoke", VF_SAMPLER_SOBOL, 1);
  agree_on_builtin("cornell-tinted", VF_SAMPLER_SOBOL, 0);
}

/* ---- the MIS identity with medium vertices ------------------------------------------------- */

/* The distance densities of a piece of length d in m (medium.h): scattering at its end or
 * passing it. */
static float piece_scatter(const vf_medium_rt *m, float d) {
  float pass, scatter;
  vf_medium_piece_pdf(m, d, 1.0f, &pass, &scatter);
  return scatter;
}
static float piece_pass(const vf_medium_rt *m, float d) {
  float pass, scatter;
  vf_medium_piece_pdf(m, d, 1.0f, &pass, &scatter);
  return pass;
}

/* The phase "BSDF" at x for a path arriving from `from`: its density of going to `to`
 * and the reverse. */
static void phase_pdfs(const vf_medium_rt *m, vf_vec3 from, vf_vec3 x, vf_vec3 to, float *pdf, float *rev) {
  vf_bsdf b;
  vf_bsdf_setup_phase(&b, m->sigma_s, m->g, m->continuation, vf_normalize(vf_sub(from, x)));
  float c;
  vf_bsdf_evaluate(&b, vf_normalize(vf_sub(to, x)), &c, pdf, rev);
}

/* A path x0 (a point light) - x1 - x2 (both in a homogeneous medium that fills space) -
 * x3 (a pinhole): its MIS quantities driven as the renderer's passes drive them (light
 * start, hits through the medium with the segments' distance densities, scattering by
 * the phase function, with merges in media counted by vf_vcm.medium_merge), and the weights
 * of every technique that samples it: light sampling at x1, the connection of x1 and x2,
 * x2 projected onto the camera, and (vcm) merging at x1 and at x2; bpm has the merges
 * alone. They must sum to one,
 * and each equal its direct evaluation (media_path_weights_direct). */
static double media_path_weight_sum(vf_vec3 x[4], const vf_medium_rt *m, vf_algorithm a, float beta, float eta_s,
                                    float radius, double *w_out) {
  const float n_light = 1e5f, pick = 1.0f, camera_pdf_w = 3.7f;
  vf_mis_config c = {0};
  c.beta = beta;
  c.light_paths = n_light;
  int vm = a == VF_ALGO_VCM || a == VF_ALGO_BPM || a == VF_ALGO_UPG, vc = a != VF_ALGO_BPM;
  c.vm_weight = vm ? vf_mis_h(&c, eta_s) : 0.0f;
  c.vc_weight = vc ? vf_mis_h(&c, 1.0f / eta_s) : 0.0f;
  float ratio = vm ? vf_mis_h(&c, 4.0f * radius / 3.0f) : 0.0f;
  float d01 = vf_length(vf_sub(x[1], x[0])), d12 = vf_length(vf_sub(x[2], x[1])), d23 = vf_length(vf_sub(x[3], x[2]));
  /* The light sub-path: x0, x1, x2. */
  vf_mis l1, l2;
  vf_mis_light_start(&l1, &c, pick, pick / (4.0f * VF_PI), 1.0f, 1, 1);
  vf_mis_hit_media(&l1, &c, d01, 1.0f, 1, piece_scatter(m, d01), piece_pass(m, d01));
  l2 = l1;
  float p, r;
  phase_pdfs(m, x[0], x[1], x[2], &p, &r);
  vf_mis_scatter_at(&l2, &c, 1.0f, p, r, 0, ratio);
  vf_mis_hit_media(&l2, &c, d12, 1.0f, 1, piece_scatter(m, d12), piece_scatter(m, d12));
  /* The camera sub-path: x3, x2, x1. */
  vf_mis z1, z2;
  vf_mis_camera_start(&z1, &c, camera_pdf_w);
  vf_mis_hit_media(&z1, &c, d23, 1.0f, 1, piece_scatter(m, d23), piece_pass(m, d23));
  z2 = z1;
  phase_pdfs(m, x[3], x[2], x[1], &p, &r);
  vf_mis_scatter_at(&z2, &c, 1.0f, p, r, 0, ratio);
  vf_mis_hit_media(&z2, &c, d12, 1.0f, 1, piece_scatter(m, d12), piece_scatter(m, d12));
  float vm_medium = c.vm_weight * ratio;
  /* s = 1: light sampling at x1 (camera_pass.c, light_sample): a point light. */
  float rev_pdf;
  phase_pdfs(m, x[2], x[1], x[0], &p, &rev_pdf);
  w_out[0] = vf_mis_weight_light_sample_at(&z2, &c, 0.0f, rev_pdf, d01 * d01 * pick, pick / (4.0f * VF_PI),
                                           1.0f * piece_scatter(m, d01), 1.0f, vm_medium);
  /* s = 2: the connection of x1 (light) and x2 (camera). */
  float camera_pdf, camera_rev, light_pdf, light_rev;
  phase_pdfs(m, x[3], x[2], x[1], &camera_pdf, &camera_rev);
  phase_pdfs(m, x[0], x[1], x[2], &light_pdf, &light_rev);
  w_out[1] = vf_mis_weight_connection_at(&l1, &z1, &c, camera_pdf / (d12 * d12) * piece_scatter(m, d12),
                                         light_pdf / (d12 * d12) * piece_scatter(m, d12), light_rev, camera_rev,
                                         vm_medium, vm_medium);
  /* s = 3: x2 projected onto the camera (light_pass.c, connect_to_camera). */
  phase_pdfs(m, x[1], x[2], x[3], &p, &rev_pdf);
  w_out[2] = vf_mis_weight_camera_connection_at(&l2, &c, camera_pdf_w / (d23 * d23) * piece_scatter(m, d23), rev_pdf,
                                                vm_medium);
  w_out[3] = w_out[4] = w_out[5] = 0.0;
  if (!vc) w_out[0] = w_out[1] = w_out[2] = 0.0; /* bpm: merging alone */
  if (a == VF_ALGO_UPG) {
    /* upg's gatherings in place of the merges (gathering_pass.c), each weighted as the
     * renderer weighs it: at x1 from the light's side (x0, the point light's own point,
     * joined to the camera vertex x1) and from the camera's (x2, the camera vertex before,
     * joined to the light vertex x1: w_out[5], the same path again); at x2 from the light's
     * side only (the camera vertex before x2 is the lens). */
    vf_mis start;
    vf_mis_light_start(&start, &c, pick, pick / (4.0f * VF_PI), 1.0f, 1, 1);
    phase_pdfs(m, x[2], x[1], x[0], &p, &r);
    w_out[3] = vf_mis_weight_gather_media(start, &z2, &c, 0, 1.0f, 1.0f, 0.0f, 0.0f, d01, 1.0f, piece_scatter(m, d01),
                                          piece_pass(m, d01), ratio, p, r);
    float cp, cr, lp, lr;
    phase_pdfs(m, x[3], x[2], x[1], &cp, &cr);
    phase_pdfs(m, x[0], x[1], x[2], &lp, &lr);
    w_out[5] = vf_mis_weight_gather_camera_media(&l1, z1, &c, ratio, 1.0f, cp, cr, d12, 1.0f, piece_scatter(m, d12),
                                                 piece_scatter(m, d12), ratio, lp, lr);
    float light_pdf1, light_rev1;
    phase_pdfs(m, x[0], x[1], x[2], &light_pdf1, &light_rev1);
    phase_pdfs(m, x[3], x[2], x[1], &p, &r);
    w_out[4] = vf_mis_weight_gather_media(l1, &z1, &c, 1, ratio, 1.0f, light_pdf1, light_rev1, d12, 1.0f,
                                          piece_scatter(m, d12), piece_scatter(m, d12), ratio, p, r);
  } else if (vm) {
    /* Merging at x1: the light vertex that arrived there, the camera vertex z2. */
    phase_pdfs(m, x[2], x[1], x[0], &p, &r);
    w_out[3] = vf_mis_weight_merge_medium(&l1, &z2, &c, ratio, p, r);
    /* Merging at x2: the light vertex y2, the camera vertex z1. */
    phase_pdfs(m, x[3], x[2], x[1], &p, &r);
    w_out[4] = vf_mis_weight_merge_medium(&l2, &z1, &c, ratio, p, r);
  }
  return w_out[0] + w_out[1] + w_out[2] + w_out[3] + w_out[4];
}

/* The same weights by direct evaluation (tech. rep. eq. 12, any beta), in double, from
 * the path's vertex densities one by one: from the light pL(x0) = pick (a point), pL(x1) =
 * emission pdf * scatter(d01) / d01^2, pL(x2) = phase pdf at x1 * scatter(d12) / d12^2;
 * from the camera pE(x2) = camera pdf * scatter(d23) / d23^2, pE(x1) = phase pdf at x2 *
 * scatter(d12) / d12^2. Techniques: light sampling at x1 pL0 pE1 pE2; the connection
 * pL0 pL1 pE2; the projection onto the camera n_light pL0 pL1 pL2; merging at x1
 * eta_m pL0 pL1 pE1 pE2 and at x2 eta_m pL0 pL1 pL2 pE2, eta_m = (4/3) pi r^3 n_light. */
static void media_path_weights_direct(vf_vec3 x[4], const vf_medium_rt *m, vf_algorithm a, double beta, double radius,
                                      double *w) {
  const double n_light = 1e5, pick = 1.0, camera_pdf_w = 3.7;
  double d01 = vf_length(vf_sub(x[1], x[0])), d12 = vf_length(vf_sub(x[2], x[1])), d23 = vf_length(vf_sub(x[3], x[2]));
  float p, r;
  double pL0 = pick, pL1 = pick / (4.0 * VF_PI) * piece_scatter(m, (float)d01) / (d01 * d01);
  phase_pdfs(m, x[0], x[1], x[2], &p, &r);
  double pL2 = p * piece_scatter(m, (float)d12) / (d12 * d12);
  double pE2 = camera_pdf_w * piece_scatter(m, (float)d23) / (d23 * d23);
  phase_pdfs(m, x[3], x[2], x[1], &p, &r);
  double pE1 = p * piece_scatter(m, (float)d12) / (d12 * d12);
  int vc = a != VF_ALGO_BPM;
  double eta = a == VF_ALGO_VCM || a == VF_ALGO_BPM || a == VF_ALGO_UPG ? 4.0 / 3.0 * M_PI * radius * radius * radius * n_light : 0.0;
  double t[5] = {vc * pL0 * pE1 * pE2, vc * pL0 * pL1 * pE2, vc * n_light * pL0 * pL1 * pL2, eta * pL0 * pL1 * pE1 * pE2,
                 eta * pL0 * pL1 * pL2 * pE2};
  double sum = 0.0;
  for (int k = 0; k < 5; k++) sum += pow(t[k], beta);
  for (int k = 0; k < 5; k++) w[k] = pow(t[k], beta) / sum;
}

static void test_mis_identity_on_paths_in_a_medium(void) {
  vf_medium med = {.sigma_a = vf_vec3_make(0.1f, 0.3f, 0.2f), .sigma_s = vf_vec3_make(0.8f, 0.5f, 1.1f), .g = 0.4f};
  vf_medium_rt m;
  vf_medium_prepare(&m, &med);
  vf_rng rng = vf_rng_for_path(3, 0, 0, 0);
  double worst = 0.0, worst_direct = 0.0, min_vm = 1.0, max_vm = 0.0, upg_share = 0.0;
  const float betas[] = {1.0f, 2.0f, 3.0f};
  for (int trial = 0; trial < 300; trial++) {
    vf_vec3 x[4];
    for (int i = 0; i < 4; i++)
      x[i] = vf_vec3_make(4.0f * vf_rng_float(&rng) - 2.0f, 4.0f * vf_rng_float(&rng) - 2.0f,
                          4.0f * vf_rng_float(&rng) - 2.0f);
    float radius = 0.01f + 0.5f * vf_rng_float(&rng);
    float eta_s = VF_PI * radius * radius * 1e5f;
    for (size_t b = 0; b < 3; b++)
      for (int kind = 0; kind < 4; kind++) {
        double w[6], direct[5];
        const vf_algorithm algorithms[] = {VF_ALGO_BPT, VF_ALGO_VCM, VF_ALGO_BPM, VF_ALGO_UPG};
        vf_algorithm a = algorithms[kind];
        int vcm = a == VF_ALGO_VCM;
        double sum = media_path_weight_sum(x, &m, a, betas[b], eta_s, radius, w);
        media_path_weights_direct(x, &m, a, betas[b], radius, direct);
        worst = fmax(worst, fabs(sum - 1.0));
        if (a == VF_ALGO_UPG) { /* either side's gathering at x1 has the one weight of that path */
          worst = fmax(worst, fabs(sum - w[3] + w[5] - 1.0));
          if (direct[3] > 1e-6) worst_direct = fmax(worst_direct, fabs(w[5] - direct[3]) / direct[3]);
          upg_share = fmax(upg_share, w[3] + w[4]);
        }
        for (int k = 0; k < 5; k++)
          if (direct[k] > 1e-6) worst_direct = fmax(worst_direct, fabs(w[k] - direct[k]) / direct[k]);
        if (vcm) {
          min_vm = fmin(min_vm, w[3] + w[4]);
          max_vm = fmax(max_vm, w[3] + w[4]);
        }
        for (int k = 0; k < 5; k++) CHECK(w[k] >= 0.0 && w[k] <= 1.0);
      }
  }
  printf("  paths with two medium vertices (bpt, vcm, bpm, upg from both sides): worst |sum of weights - 1| %.2g, "
         "worst relative difference from the direct evaluation %.2g; merges' share %.3g to %.3g, upg's gatherings' up "
         "to %.3g\n",
         worst, worst_direct, min_vm, max_vm, upg_share);
  CHECK(upg_share > 0.5);
  CHECK(worst < 1e-4);
  CHECK(worst_direct < 1e-3); /* the float recursion against double, as tests/worker/render/test_mis.c */
  CHECK(max_vm > 0.5); /* merging takes part, heavily on some paths */
}

/* The diffuse "BSDF" at surface point x (unit normal n) for a path arriving from `from`:
 * its density of going to `to`, the reverse, and |cos| at x towards `to`. */
static void surface_pdfs(vf_vec3 n, vf_vec3 from, vf_vec3 x, vf_vec3 to, float *pdf, float *rev, float *cos_to) {
  vf_material mat;
  memset(&mat, 0, sizeof mat);
  mat.diffuse = vf_vec3_make(0.7f, 0.5f, 0.3f);
  vf_bsdf_lobes lobes;
  vf_bsdf_lobes_of(&mat, &lobes);
  vf_bsdf b;
  vf_bsdf_setup(&b, &mat, &lobes, n, vf_normalize(vf_sub(from, x)));
  vf_bsdf_evaluate(&b, vf_normalize(vf_sub(to, x)), cos_to, pdf, rev);
}

/* A path x0 (a point light) - x1 (a diffuse surface, normal n1) - x2 (in a homogeneous
 * medium that fills space) - x3 (a pinhole), its quantities driven as the passes drive
 * them: vcm's weights (light sampling at x1, the connection of x1 and x2, x2 projected
 * onto the camera, merging at x1 on the surface and at x2 in the medium) sum to one, and
 * upg's gatherings, each as gathering_pass.c weighs it, have merging's weights: at x1 from
 * the light's side (x0 joined to x1) and from the camera's (the medium vertex x2 joined to
 * the light vertex x1), at x2 from the light's side (the surface vertex x1 joined to x2).
 * *worst_sum and *worst_gather: the largest |sum - 1| and relative |gather - merge|. */
static void surface_and_medium_path(vf_vec3 x[4], vf_vec3 n1, const vf_medium_rt *m, float beta, float radius,
                                    double *worst_sum, double *worst_gather, double *gather_share) {
  const float n_light = 1e5f, pick = 1.0f, camera_pdf_w = 3.7f;
  vf_mis_config c = {0};
  c.beta = beta;
  c.light_paths = n_light;
  float eta_s = VF_PI * radius * radius * n_light;
  c.vm_weight = vf_mis_h(&c, eta_s);
  c.vc_weight = vf_mis_h(&c, 1.0f / eta_s);
  float ratio = vf_mis_h(&c, 4.0f * radius / 3.0f), vm = c.vm_weight;
  float d01 = vf_length(vf_sub(x[1], x[0])), d12 = vf_length(vf_sub(x[2], x[1])), d23 = vf_length(vf_sub(x[3], x[2]));
  float cos10 = fabsf(vf_dot(n1, vf_normalize(vf_sub(x[0], x[1])))), cos12 = fabsf(vf_dot(n1, vf_normalize(vf_sub(x[2], x[1]))));
  float p, r, cosv;
  /* The light sub-path x0, x1, x2. */
  vf_mis start, l1, l2;
  vf_mis_light_start(&start, &c, pick, pick / (4.0f * VF_PI), 1.0f, 1, 1);
  l1 = start;
  vf_mis_hit_media(&l1, &c, d01, cos10, 1, piece_pass(m, d01), piece_pass(m, d01));
  l2 = l1;
  float lp1, lr1; /* x1's light BSDF towards x2 */
  surface_pdfs(n1, x[0], x[1], x[2], &lp1, &lr1, &cosv);
  vf_mis_scatter_at(&l2, &c, cos12, lp1, lr1, 0, 1.0f);
  vf_mis_hit_media(&l2, &c, d12, 1.0f, 1, piece_scatter(m, d12), piece_pass(m, d12));
  /* The camera sub-path x3, x2, x1. */
  vf_mis z1, z2;
  vf_mis_camera_start(&z1, &c, camera_pdf_w);
  vf_mis_hit_media(&z1, &c, d23, 1.0f, 1, piece_scatter(m, d23), piece_pass(m, d23));
  z2 = z1;
  float cp2, cr2; /* x2's camera phase function towards x1 */
  phase_pdfs(m, x[3], x[2], x[1], &cp2, &cr2);
  vf_mis_scatter_at(&z2, &c, 1.0f, cp2, cr2, 0, ratio);
  vf_mis_hit_media(&z2, &c, d12, cos12, 1, piece_pass(m, d12), piece_scatter(m, d12));
  double w[5];
  /* s = 1: light sampling at x1 (a point light: no BSDF sample reaches it). */
  float bp, brev;
  surface_pdfs(n1, x[2], x[1], x[0], &bp, &brev, &cosv);
  w[0] = vf_mis_weight_light_sample_at(&z2, &c, 0.0f, brev, d01 * d01 * pick, pick / (4.0f * VF_PI),
                                       cos10 * piece_pass(m, d01), 1.0f, vm);
  /* s = 2: the connection of x1 (light) and x2 (camera). */
  w[1] = vf_mis_weight_connection_at(&l1, &z1, &c, cp2 * cos12 / (d12 * d12) * piece_pass(m, d12),
                                     lp1 / (d12 * d12) * piece_scatter(m, d12), lr1, cr2, vm, vm * ratio);
  /* s = 3: x2 projected onto the camera. */
  phase_pdfs(m, x[1], x[2], x[3], &p, &r);
  w[2] = vf_mis_weight_camera_connection_at(&l2, &c, camera_pdf_w / (d23 * d23) * piece_scatter(m, d23), r, vm * ratio);
  /* Merging at x1 (the surface) and at x2 (the medium). */
  float mp1, mr1; /* x1's camera BSDF (from x2) towards x0 */
  surface_pdfs(n1, x[2], x[1], x[0], &mp1, &mr1, &cosv);
  w[3] = vf_mis_weight_merge(&l1, &z2, &c, mp1, mr1);
  w[4] = vf_mis_weight_merge_medium(&l2, &z1, &c, ratio, cp2, cr2);
  double sum = w[0] + w[1] + w[2] + w[3] + w[4];
  *worst_sum = fmax(*worst_sum, fabs(sum - 1.0));
  /* upg's gatherings. */
  double g[3];
  g[0] = vf_mis_weight_gather_media(start, &z2, &c, 0, 1.0f, 1.0f, 0.0f, 0.0f, d01, cos10, piece_pass(m, d01),
                                    piece_pass(m, d01), 0.0f, mp1, mr1);
  g[1] = vf_mis_weight_gather_camera_media(&l1, z1, &c, ratio, 1.0f, cp2, cr2, d12, cos12, piece_pass(m, d12),
                                           piece_scatter(m, d12), 0.0f, lr1, lp1);
  g[2] = vf_mis_weight_gather_media(l1, &z1, &c, 1, 1.0f, cos12, lp1, lr1, d12, 1.0f, piece_scatter(m, d12),
                                    piece_pass(m, d12), ratio, cp2, cr2);
  const double merge[3] = {w[3], w[3], w[4]};
  for (int k = 0; k < 3; k++)
    if (merge[k] > 1e-6) *worst_gather = fmax(*worst_gather, fabs(g[k] - merge[k]) / merge[k]);
  *gather_share = fmax(*gather_share, g[0] + g[2]);
}

static void test_mis_identity_on_paths_with_a_surface_in_a_medium(void) {
  vf_medium med = {.sigma_a = vf_vec3_make(0.1f, 0.3f, 0.2f), .sigma_s = vf_vec3_make(0.8f, 0.5f, 1.1f), .g = -0.3f};
  vf_medium_rt m;
  vf_medium_prepare(&m, &med);
  vf_rng rng = vf_rng_for_path(4, 0, 0, 0);
  double worst_sum = 0.0, worst_gather = 0.0, share = 0.0;
  const float betas[] = {1.0f, 2.0f};
  for (int trial = 0; trial < 300; trial++) {
    vf_vec3 x[4];
    for (int i = 0; i < 4; i++)
      x[i] = vf_vec3_make(4.0f * vf_rng_float(&rng) - 2.0f, 4.0f * vf_rng_float(&rng) - 2.0f,
                          4.0f * vf_rng_float(&rng) - 2.0f);
    /* A normal at x1 that sees both x0 and x2, tilted at random within that. */
    vf_vec3 a = vf_normalize(vf_sub(x[0], x[1])), b = vf_normalize(vf_sub(x[2], x[1]));
    float t = 0.2f + 0.6f * vf_rng_float(&rng);
    vf_vec3 n1 = vf_normalize(vf_add(vf_scale(a, t), vf_scale(b, 1.0f - t)));
    if (!(vf_dot(n1, a) > 0.05f && vf_dot(n1, b) > 0.05f)) continue;
    float radius = 0.01f + 0.5f * vf_rng_float(&rng);
    for (size_t k = 0; k < sizeof betas / sizeof *betas; k++)
      surface_and_medium_path(x, n1, &m, betas[k], radius, &worst_sum, &worst_gather, &share);
  }
  printf("  paths light - surface - medium - camera (vcm, upg from both sides): worst |sum of weights - 1| %.2g, "
         "worst relative difference of a gathering's weight from merging's %.2g; gatherings' share up to %.3g\n",
         worst_sum, worst_gather, share);
  CHECK(worst_sum < 1e-4);
  CHECK(worst_gather < 1e-4);
  CHECK(share > 0.5);
}

/* --algorithm auto with media: a scattering medium beside specular surfaces (volumetric
 * caustics) is vcm's; the unbiased choice is made from the surfaces alone, as without media. */
static void test_auto_chooses_for_media(void) {
  vf_scene *fog = NULL, *rough = NULL;
  CHECK_INT_EQ(vf_scene_load("cornell-diffuse", &fog), VF_OK);
  CHECK_INT_EQ(vf_scene_load("cornell-rough", &rough), VF_OK);
  if (fog == NULL || rough == NULL) return;
  const char *why = NULL;
  /* No specular surface: the materials decide, as without media. */
  fog->medium = add_medium(fog, vf_vec3_splat(0.01f), vf_vec3_splat(0.2f), 0.0f);
  CHECK_INT_EQ(vf_vcm_auto_algorithm(fog, VF_ALGO_AUTO, &why), VF_ALGO_PT);
  vf_scene_destroy(fog);
  CHECK_INT_EQ(vf_scene_load("cornell", &fog), VF_OK);
  if (fog == NULL) return;
  CHECK_INT_EQ(vf_vcm_auto_algorithm(fog, VF_ALGO_AUTO, &why), VF_ALGO_VCM);
  fog->medium = add_medium(fog, vf_vec3_splat(0.01f), vf_vec3_splat(0.2f), 0.0f);
  CHECK_INT_EQ(vf_vcm_auto_algorithm(fog, VF_ALGO_AUTO, &why), VF_ALGO_VCM);
  printf("  cornell in fog: %s\n", why);
  CHECK(strstr(why, "medium") != NULL);
  CHECK_INT_EQ(vf_vcm_auto_algorithm(rough, VF_ALGO_AUTO_UNBIASED, &why), VF_ALGO_UPG);
  /* upg gathers in media without bias too (tests/worker/render/test_upg_medium.c): the
   * medium changes nothing of the unbiased choice. */
  rough->medium = add_medium(rough, vf_vec3_splat(0.01f), vf_vec3_splat(0.2f), 0.0f);
  CHECK_INT_EQ(vf_vcm_auto_algorithm(rough, VF_ALGO_AUTO_UNBIASED, &why), VF_ALGO_UPG);
  printf("  cornell-rough in fog, unbiased: %s\n", why);
  vf_scene_destroy(fog);
  vf_scene_destroy(rough);
}

/* Every algorithm renders media (upg since it gathers in them: test_upg_medium.c), but a
 * radius per pixel and merging in media need different radii: refused. */
static void test_a_radius_per_pixel_refuses_media(void) {
  vf_scene *scene = NULL;
  CHECK_INT_EQ(vf_scene_load("cornell", &scene), VF_OK);
  if (scene == NULL) return;
  scene->medium = add_medium(scene, vf_vec3_splat(0.01f), vf_vec3_splat(0.2f), 0.0f);
  vf_accel *accel = NULL;
  vf_pool *pool = NULL;
  CHECK_INT_EQ(vf_accel_create(scene, &accel), VF_OK);
  CHECK_INT_EQ(vf_pool_create(1, &pool), VF_OK);
  /* A radius per pixel and merging in media need different radii: refused too. */
  vf_settings s = scene->settings;
  s.algorithm = VF_ALGO_VCM;
  s.radius = VF_RADIUS_PER_PIXEL;
  vf_vcm *vcm = NULL;
  CHECK(vf_vcm_create(scene, accel, &s, pool, &vcm) != VF_OK);
  vf_vcm_destroy(vcm);
  vf_pool_destroy(pool);
  vf_accel_destroy(accel);
  vf_scene_destroy(scene);
}

/* One iteration's camera and light images with `threads` threads. */
static float *render_once(const vf_scene *scene, const vf_settings *s, int threads, uint64_t iteration) {
  size_t pixels = (size_t)s->width * s->height;
  float *out = calloc(6 * pixels, sizeof(float));
  vf_accel *accel = NULL;
  vf_pool *pool = NULL;
  vf_vcm *vcm = NULL;
  vf_vcm_stats stats = {0};
  int err = vf_accel_create(scene, &accel);
  if (err == VF_OK) err = vf_pool_create(threads, &pool);
  if (err == VF_OK) err = vf_vcm_create(scene, accel, s, pool, &vcm);
  if (err == VF_OK) err = vf_vcm_iteration(vcm, iteration, out, out + 3 * pixels, &stats);
  vf_vcm_destroy(vcm);
  vf_pool_destroy(pool);
  vf_accel_destroy(accel);
  if (err != VF_OK) {
    free(out);
    return NULL;
  }
  return out;
}

/* An iteration is a pure function of (seed, iteration, path): the same bits on one thread
 * and on two, for every technique, both samplers, in a scene with fog, a glass ball and a
 * box of smoke (a grid, tracked with numbers from the paths' streams). */
static void test_renders_in_media_are_reproducible(void) {
  vf_scene *scene = NULL;
  CHECK_INT_EQ(vf_scene_load("cornell", &scene), VF_OK);
  if (scene == NULL) return;
  scene->medium = add_medium(scene, vf_vec3_splat(0.05f), vf_vec3_splat(0.3f), 0.2f);
  int ball = shape_named(scene, "glass ball");
  CHECK(ball >= 0);
  if (ball < 0) return;
  scene->shapes[ball].interface = 1;
  scene->shapes[ball].interior = -1;
  scene->shapes[ball].exterior = scene->medium;
  /* The mirror ball becomes the bounding sphere of a smoke grid. */
  int mirror = shape_named(scene, "mirror ball");
  CHECK(mirror >= 0);
  if (mirror < 0) return;
  int smoke = add_medium(scene, vf_vec3_splat(0.5f), vf_vec3_make(2.0f, 3.0f, 4.0f), -0.3f);
  vf_density_grid *grid = make_blob_grid();
  grid->box_min = vf_sub(scene->shapes[mirror].center, vf_vec3_splat(scene->shapes[mirror].radius));
  grid->box_max = vf_add(scene->shapes[mirror].center, vf_vec3_splat(scene->shapes[mirror].radius));
  scene->media[smoke].grid = grid;
  make_boundary(scene, mirror, smoke);
  scene->settings.width = scene->settings.height = 48;
  const vf_algorithm algorithms[] = {VF_ALGO_PT, VF_ALGO_LT, VF_ALGO_BPT, VF_ALGO_VCM, VF_ALGO_UPG};
  for (int k = 0; k < VF_SAMPLER_COUNT_; k++)
    for (size_t a = 0; a < sizeof algorithms / sizeof *algorithms; a++) {
      vf_settings s = scene->settings;
      s.algorithm = algorithms[a];
      s.sampler = (vf_sampler_kind)k;
      float *one = render_once(scene, &s, 1, 5), *two = render_once(scene, &s, 2, 5);
      CHECK(one != NULL && two != NULL);
      size_t n = 6 * (size_t)s.width * s.height, differ = 0;
      double sum = 0.0;
      for (size_t i = 0; one && two && i < n; i++) {
        differ += memcmp(&one[i], &two[i], sizeof(float)) != 0;
        sum += one[i];
      }
      printf("  %-3s %-11s: 1 and 2 threads differ in %zu of %zu values (image sum %.3f)\n",
             vf_algorithm_name(s.algorithm), vf_sampler_name(s.sampler), differ, n, sum);
      CHECK_INT_EQ(differ, 0);
      CHECK(sum > 0.0);
      free(one);
      free(two);
    }
  vf_scene_destroy(scene);
}

/* A point light in fog that fills space, seen from inside it (the light above the view):
 * the techniques that merge in media (vcm, and ppm and bpm, which only merge) against bpt
 * block by block. The merge radius is 0.02 (radius factor 0.02 of the scene's radius 1,
 * fixed over the iterations) where the radiance in view varies over distances of order 1,
 * so the kernel's bias is far below the error bars. Tests the merges' 3D kernel and
 * normalisation, their MIS weights in vcm and bpm, and ppm's unweighted first merge.
 * Not pt and lt: pt's light samples from vertices near the point light carry 1 / d^2,
 * whose square integrates over the volume around the light as 1 / d^2 in d, which
 * diverges (lt the same around the pinhole): their means are right (both agree with bpt
 * to 1-3 image-wide standard errors with 8 times the iterations) but their error bars
 * are not, so a 5-sigma rule per block would be wrong for them; bpt's light sub-paths
 * sample those vertices from the light, with the 1 / d^2 in their density. */
static void test_merging_in_fog_around_a_point_light(void) {
  vf_scene *scene = scene_from_text(
      "{'camera':{'position':[0,0,2],'forward':[0,0,-1],'up':[0,1,0],'fov':60,'resolution':[32,32]},"
      "'materials':{'black':{'diffuse':[0,0,0]}},'shapes':["
      "{'type':'sphere','center':[0,0,-30],'radius':1,'material':'black'}],"
      "'lights':[{'type':'point','position':[0,2.5,-0.5],'intensity':[4,4,4]}],"
      "'render':{'max_path_length':6}}");
  CHECK(scene != NULL);
  if (scene == NULL) return;
  scene->medium = add_medium(scene, vf_vec3_splat(0.1f), vf_vec3_make(0.4f, 0.5f, 0.6f), 0.3f);
  enum { BLOCKS = 4, NB = BLOCKS * BLOCKS, ALGORITHMS = 4 };
  const vf_algorithm algorithms[ALGORITHMS] = {VF_ALGO_BPT, VF_ALGO_VCM, VF_ALGO_PPM, VF_ALGO_BPM};
  const int iterations[ALGORITHMS] = {128, 128, 1024, 512};
  double mean[ALGORITHMS][NB], se[ALGORITHMS][NB];
  for (int a = 0; a < ALGORITHMS; a++) {
    vf_settings s = scene->settings;
    s.algorithm = algorithms[a];
    s.sampler = VF_SAMPLER_INDEPENDENT;
    s.seed = 500 + (uint64_t)a;
    s.radius_factor = 0.02;
    s.alpha = 1.0; /* a fixed radius: the bias stays what the comment above says */
    vf_vcm_stats stats = {0};
    CHECK_INT_EQ(render_block_estimates(scene, &s, 2, iterations[a], BLOCKS, mean[a], se[a], &stats), VF_OK);
    CHECK_INT_EQ(stats.nonfinite, 0);
  }
  for (int a = 1; a < ALGORITHMS; a++)
    CHECK(blocks_agree("point in fog", "bpt", vf_algorithm_name(algorithms[a]), mean[0], se[0], mean[a], se[a], NB));
  vf_scene_destroy(scene);
}

/* ---- connections through index-matched boundaries ------------------------------------------ */

/* The length of segment p-q inside the axis-aligned box [lo, hi] (slab clipping). */
static double chord_in_box(vf_vec3 p, vf_vec3 q, vf_vec3 lo, vf_vec3 hi) {
  double t0 = 0.0, t1 = 1.0;
  const double pp[3] = {p.x, p.y, p.z}, d[3] = {q.x - p.x, q.y - p.y, q.z - p.z};
  const double l[3] = {lo.x, lo.y, lo.z}, h[3] = {hi.x, hi.y, hi.z};
  for (int a = 0; a < 3; a++) {
    if (d[a] == 0.0) {
      if (pp[a] < l[a] || pp[a] > h[a]) return 0.0;
      continue;
    }
    double ta = (l[a] - pp[a]) / d[a], tb = (h[a] - pp[a]) / d[a];
    if (ta > tb) {
      double x = ta;
      ta = tb;
      tb = x;
    }
    t0 = fmax(t0, ta);
    t1 = fmin(t1, tb);
  }
  double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  return t1 > t0 ? (t1 - t0) * len : 0.0;
}

/* cornell-smoke's box made an absorbing medium (sigma_a 1): the transmittance of a
 * connection between two points of the room's walls, floor and ceiling, either way, is
 * exp(-chord), the chord its length inside the box, through the box's index-matched faces;
 * with the room's other surfaces in the way, zero. Checked against slab clipping for pairs
 * whose segment no surface blocks (the room is convex; the box has no material). */
static void test_connections_through_boundaries_have_the_exact_transmittance(void) {
  vf_scene *scene = NULL;
  CHECK_INT_EQ(vf_scene_load("cornell-smoke", &scene), VF_OK);
  if (scene == NULL) return;
  int box = shape_named(scene, "smoke box");
  CHECK(box >= 0 && scene->shapes[box].material < 0);
  if (box < 0) return;
  vf_medium_release(&scene->media[scene->shapes[box].interior]);
  scene->media[scene->shapes[box].interior].sigma_a = vf_vec3_splat(1.0f);
  scene->media[scene->shapes[box].interior].sigma_s = vf_vec3_splat(0.0f);
  vf_vec3 lo = vf_vec3_splat(INFINITY), hi = vf_vec3_splat(-INFINITY);
  const vf_shape *sh = &scene->shapes[box];
  for (uint32_t i = 0; i < sh->num_vertices; i++) {
    vf_vec3 x = vf_vec3_make(sh->positions[3 * i], sh->positions[3 * i + 1], sh->positions[3 * i + 2]);
    lo = vf_vec3_make(fminf(lo.x, x.x), fminf(lo.y, x.y), fminf(lo.z, x.z));
    hi = vf_vec3_make(fmaxf(hi.x, x.x), fmaxf(hi.y, x.y), fmaxf(hi.z, x.z));
  }
  vf_settings s = scene->settings;
  s.width = s.height = 8;
  s.algorithm = VF_ALGO_BPT;
  vf_accel *accel = NULL;
  vf_pool *pool = NULL;
  vf_vcm *v = NULL;
  CHECK_INT_EQ(vf_accel_create(scene, &accel), VF_OK);
  CHECK_INT_EQ(vf_pool_create(1, &pool), VF_OK);
  CHECK_INT_EQ(vf_vcm_create(scene, accel, &s, pool, &v), VF_OK);
  if (v == NULL) return;
  vf_sampler sampler;
  vf_sampler_start(&sampler, VF_SAMPLER_INDEPENDENT, 1, 0, 0, 0);
  vf_rng rng = vf_rng_for_path(5, 0, 0, 0);
  int checked = 0, through = 0;
  double worst = 0.0;
  for (int k = 0; k < 20000; k++) {
    /* Points on the room's surfaces: the first hits of rays from random points inside. */
    vf_hit h[2];
    vf_vec3 start = vf_vec3_make(1.9f * vf_rng_float(&rng) - 0.95f, 1.9f * vf_rng_float(&rng) - 0.95f,
                                 1.9f * vf_rng_float(&rng) - 0.95f);
    int ok = 1;
    for (int e = 0; e < 2 && ok; e++) {
      vf_vec3 dir = vf_sample_uniform_sphere(vf_rng_float(&rng), vf_rng_float(&rng));
      vf_vec3 o = start;
      ok = 0;
      for (int step = 0; step < 8; step++) {
        if (!vf_accel_intersect(accel, o, dir, INFINITY, &h[e])) break;
        if (scene->shapes[h[e].shape].material >= 0) {
          ok = 1;
          break;
        }
        o = vf_add(h[e].position, vf_scale(dir, 1e-4f));
      }
    }
    if (!ok || (vf_length(vf_sub(h[0].position, h[1].position)) < 1e-3f)) continue;
    /* Each end's medium is the medium around it: outside the box, vacuum. */
    float fwd, rev;
    vf_vec3 ta = vf_segment_transmittance(v, 0, -1, h[0].position, h[0].normal, 1.0f, h[1].position, h[1].normal, 1.0f,
                                          0, &sampler, &fwd, &rev);
    vf_vec3 tb = vf_segment_transmittance(v, 0, -1, h[1].position, h[1].normal, 1.0f, h[0].position, h[0].normal, 1.0f,
                                          0, &sampler, &fwd, &rev);
    /* Unblocked when both ends are seen from each other in the convex room: the same
     * faces, no ball (the room's shapes other than the box are its walls, floor, ceiling
     * and light). */
    double chord = chord_in_box(h[0].position, h[1].position, lo, hi);
    if (ta.x == 0.0f && tb.x == 0.0f) continue; /* on one plane, or behind the light */
    double exact = exp(-chord);
    worst = fmax(worst, fmax(fabs(ta.x - exact), fabs(tb.x - exact)) / exact);
    checked++;
    through += chord > 0.0;
  }
  printf("  %d connections (%d through the box): worst relative error of the transmittance %.2g\n", checked, through,
         worst);
  CHECK(checked > 1000 && through > 100);
  /* Each crossing moves the ray off the face by 256 units in the last place along its
   * normal (vf_offset_ray_origin), 3e-5 here, which a grazing ray lengthens: 1e-3 of a
   * chord's transmittance is that at a cosine of 0.03. */
  CHECK(worst < 1e-3);
  vf_vcm_destroy(v);
  vf_pool_destroy(pool);
  vf_accel_destroy(accel);
  vf_scene_destroy(scene);
}

int main(void) {
  RUN(test_phase_function_sampling_matches_its_density);
  RUN(test_distance_sampling_estimates_transmittance_and_scattering);
  RUN(test_mis_identity_on_paths_in_a_medium);
  RUN(test_mis_identity_on_paths_with_a_surface_in_a_medium);
  RUN(test_absorbing_ball_in_front_of_an_emitter);
  RUN(test_furnace_filled_with_a_medium_of_albedo_one);
  RUN(test_single_scattering_in_a_thin_slab);
  RUN(test_media_builtins_agreement_of_the_techniques);
  RUN(test_merging_in_fog_around_a_point_light);
  RUN(test_connections_through_boundaries_have_the_exact_transmittance);
  RUN(test_auto_chooses_for_media);
  RUN(test_renders_in_media_are_reproducible);
  RUN(test_a_radius_per_pixel_refuses_media);
  return check_finish();
}
