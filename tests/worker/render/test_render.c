/* The render loop's promises: an iteration's result depends only on (seed, global index),
 * not on thread count or on how iterations are split between runs. */
#include "check.h"
#include "render_util.h"
#include "common/error.h"
#include "common/film.h"
#include "common/film_accum.h"
#include "worker/render/render.h"
#include "worker/scene/load.h"

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* The merge radius the renders take (render_with): the range promises are checked with a
 * radius per pixel too. */
static vf_radius_mode radius_under_test = VF_RADIUS_GLOBAL;

static vf_film *render_with(const char *scene_name, vf_sampler_kind sampler, vf_algorithm algorithm, uint64_t seed,
                            int threads, uint64_t begin, uint64_t end) {
  vf_scene *scene = NULL;
  CHECK_INT_EQ(vf_scene_load(scene_name, &scene), VF_OK);
  if (scene == NULL) return NULL;
  vf_settings s = scene->settings;
  s.algorithm = algorithm;
  s.sampler = sampler;
  s.radius = radius_under_test;
  s.seed = seed;
  s.width = 96;
  s.height = 64;
  vf_film *film = render_film(scene, &s, threads, begin, end);
  vf_scene_destroy(scene);
  return film;
}

/* The promises hold for every sampler (common/sampler.h): each test runs with each. */
static vf_sampler_kind sampler_under_test = VF_SAMPLER_INDEPENDENT;

static vf_film *render(const char *scene_name, vf_algorithm algorithm, uint64_t seed, int threads, uint64_t begin,
                       uint64_t end) {
  return render_with(scene_name, sampler_under_test, algorithm, seed, threads, begin, end);
}

static int same_sums(const vf_fixed *a, const vf_fixed *b, size_t n) { return memcmp(a, b, n * sizeof *a) == 0; }

static double mean_of(const vf_film *f) {
  size_t n = (size_t)f->width * f->height;
  float *rgb = malloc(3 * n * sizeof *rgb);
  vf_film_mean(f, rgb);
  double s = 0.0;
  for (size_t i = 0; i < 3 * n; i++) s += rgb[i];
  free(rgb);
  return s / (3.0 * n);
}

/* The cases the range promises are checked on: the perspective camera's and the
 * orthographic camera's (its rays start on the view plane, its light vertices link to their
 * feet there), and a radius per pixel (for the algorithms that merge). */
static const struct {
  const char *scene;
  vf_radius_mode radius;
} range_cases[] = {{"cornell", VF_RADIUS_GLOBAL}, {"cornell-ortho", VF_RADIUS_GLOBAL}, {"cornell", VF_RADIUS_PER_PIXEL}};
enum { NUM_RANGE_CASES = sizeof range_cases / sizeof *range_cases };

/* Selects range case k for algorithm a; 0 when the case does not apply to a. */
static int range_case(int k, vf_algorithm a) {
  radius_under_test = range_cases[k].radius;
  return radius_under_test == VF_RADIUS_GLOBAL || vf_algorithm_merges(a);
}

static void test_one_and_two_threads_give_bitwise_identical_films(void) {
  for (int k = 0; k < NUM_RANGE_CASES; k++)
    for (int a = 0; a < VF_ALGO_COUNT_; a++) {
      if (!range_case(k, (vf_algorithm)a)) continue;
      vf_film *one = render(range_cases[k].scene, (vf_algorithm)a, 7, 1, 0, 3);
      vf_film *two = render(range_cases[k].scene, (vf_algorithm)a, 7, 2, 0, 3);
      if (!one || !two) return;
      if (!films_bitwise_equal(one, two))
        printf("  %s radius %s %s (%s) differs between 1 and 2 threads\n", range_cases[k].scene,
               vf_radius_mode_name(range_cases[k].radius), vf_algorithm_name(a), vf_sampler_name(sampler_under_test));
      CHECK(films_bitwise_equal(one, two));
      vf_film_destroy(one);
      vf_film_destroy(two);
    }
  radius_under_test = VF_RADIUS_GLOBAL;
}

static long file_bytes(const char *path, char **out) {
  FILE *f = fopen(path, "rb");
  if (!f) return -1;
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fseek(f, 0, SEEK_SET);
  *out = malloc((size_t)n);
  if (fread(*out, 1, (size_t)n, f) != (size_t)n) n = -1;
  fclose(f);
  return n;
}

/* The film records the wall-clock and CPU render times, which no two runs share; with those
 * two attributes set equal, two renders of the same seed are the same file byte for byte. */
static void test_same_seed_twice_gives_identical_files(void) {
  char a_path[] = "/tmp/vf_test_render_a_XXXXXX.exr", b_path[] = "/tmp/vf_test_render_b_XXXXXX.exr";
  close(mkstemps(a_path, 4));
  close(mkstemps(b_path, 4));
  vf_film *a = render("cornell", VF_ALGO_VCM, 11, 2, 0, 2);
  vf_film *b = render("cornell", VF_ALGO_VCM, 11, 2, 0, 2);
  if (!a || !b) return;
  a->render_seconds = b->render_seconds = 0.0;
  a->cpu_seconds = b->cpu_seconds = 0.0;
  CHECK_INT_EQ(vf_film_write(a, a_path), VF_OK);
  CHECK_INT_EQ(vf_film_write(b, b_path), VF_OK);
  char *da = NULL, *db = NULL;
  long na = file_bytes(a_path, &da), nb = file_bytes(b_path, &db);
  CHECK(na > 0);
  CHECK_INT_EQ(na, nb);
  CHECK(na == nb && na > 0 && memcmp(da, db, (size_t)na) == 0);
  vf_film *c = render("cornell", VF_ALGO_VCM, 12, 2, 0, 2);
  CHECK(c && !films_bitwise_equal(a, c)); /* another seed is another film */
  free(da);
  free(db);
  unlink(a_path);
  unlink(b_path);
  vf_film_destroy(a);
  vf_film_destroy(b);
  vf_film_destroy(c);
}

/* Iterations [0,2) and [2,5) rendered apart, in the opposite order, merge into [0,5). */
static void test_split_ranges_merge_into_the_whole(void) {
  for (int k = 0; k < NUM_RANGE_CASES * VF_ALGO_COUNT_; k++) {
    const char *scene = range_cases[k / VF_ALGO_COUNT_].scene;
    int a = k % VF_ALGO_COUNT_;
    if (!range_case(k / VF_ALGO_COUNT_, (vf_algorithm)a)) continue;
    vf_film *whole = render(scene, (vf_algorithm)a, 3, 2, 0, 5);
    vf_film *late = render(scene, (vf_algorithm)a, 3, 2, 2, 5);
    vf_film *early = render(scene, (vf_algorithm)a, 3, 2, 0, 2);
    if (!whole || !late || !early) return;
    CHECK_INT_EQ(vf_film_merge(late, early), VF_OK);
    CHECK(vf_iterset_equal(&late->iterations, &whole->iterations));
    size_t n = 3 * (size_t)whole->width * whole->height;
    double max_diff = 0.0, scale = mean_of(whole);
    for (size_t i = 0; i < n; i++) {
      max_diff = fmax(max_diff, fabs(vf_film_sum_at(late, i) - vf_film_sum_at(whole, i)));
    }
    printf("  %-13s %-9s %-3s %-11s split vs whole: max |difference| %.3g (image mean %.3g)\n", scene,
           vf_radius_mode_name(radius_under_test), vf_algorithm_name(a), vf_sampler_name(sampler_under_test), max_diff,
           scale);
    for (size_t i = 0; i < n; i++)
      max_diff = fmax(max_diff, fabs(vf_film_square_at(late, i) - vf_film_square_at(whole, i)));
    /* fixed-point sums: the split film is the whole one, bit for bit */
    CHECK(films_bitwise_equal(late, whole));
    CHECK(max_diff == 0.0);
    vf_film_destroy(whole);
    vf_film_destroy(late);
    vf_film_destroy(early);
  }
  radius_under_test = VF_RADIUS_GLOBAL;
}

/* A worker's way (render.h, vf_render_control.accum): the pixels go to a compact
 * accumulator and the rest of each iteration to the film, whose own sums stay zero; the
 * accumulator carried into it gives the film of the plain loop bit for bit, also with the
 * accumulator's slots held to a small limit so that values leave them for its side table
 * (common/film_accum.h), and with the film delivered in between. */
static int count_deliveries(void *ctx, vf_film *film, const vf_render_status *st) {
  (void)film;
  (void)st;
  ++*(int *)ctx;
  return VF_OK;
}

static void test_the_accumulator_gives_the_film_bit_for_bit(void) {
  vf_scene *scene = NULL;
  CHECK_INT_EQ(vf_scene_load("cornell", &scene), VF_OK);
  if (scene == NULL) return;
  vf_settings s = scene->settings;
  s.sampler = sampler_under_test;
  s.width = 96;
  s.height = 64;
  const int64_t limits[] = {0, (int64_t)1 << 34};
  for (int l = 0; l < 2; l++) {
    vf_film *plain = render_film(scene, &s, 2, 3, 8);
    vf_renderer *r = NULL;
    vf_film *film = NULL;
    vf_film_accum *a = NULL;
    CHECK_INT_EQ(vf_renderer_create(scene, &s, 2, &r), VF_OK);
    CHECK_INT_EQ(vf_film_create(s.width, s.height, &film), VF_OK);
    CHECK_INT_EQ(vf_film_accum_create(s.width, s.height, &a), VF_OK);
    if (!plain || !r || !film || !a) return;
    if (limits[l] > 0) vf_film_accum_set_limit(a, limits[l]);
    CHECK_INT_EQ(vf_renderer_stamp(r, film), VF_OK);
    int deliveries = 0;
    vf_render_control control = {.ctx = &deliveries, .deliver = count_deliveries, .accum = a};
    CHECK_INT_EQ(vf_render_range(r, film, 3, 8, &control, NULL), VF_OK);
    CHECK_INT_EQ(deliveries, 6);
    size_t n = 3 * (size_t)s.width * s.height, nonzero = 0;
    for (size_t i = 0; i < n; i++) nonzero += film->sum[i] != 0 || film->square_sum[i] != 0;
    CHECK_INT_EQ(nonzero, 0);
    size_t spilled = vf_film_accum_spilled(a);
    if (limits[l] > 0) CHECK(spilled > 0);
    vf_film_accum_carry(a, film);
    int equal = films_bitwise_equal(film, plain);
    printf("  %-11s limit %s: %zu values in the side table; carried film vs the loop's own: %s\n",
           vf_sampler_name(sampler_under_test), limits[l] ? "2^34" : "int64", spilled, equal ? "equal" : "DIFFER");
    CHECK(equal);
    vf_film_accum_destroy(a);
    vf_film_destroy(film);
    vf_film_destroy(plain);
    vf_renderer_destroy(r);
  }
  vf_scene_destroy(scene);
}

/* `auto` renders exactly what it chose (same random streams, same techniques), and its
 * films say "auto": the choice is made again from the scene wherever the film goes. */
static void test_auto_renders_exactly_its_choice(void) {
  static const struct {
    const char *scene;
    vf_algorithm requested, chosen;
    const char *text;
  } cases[] = {{"cornell", VF_ALGO_AUTO, VF_ALGO_VCM, "algorithm=auto "},
               {"cornell-diffuse", VF_ALGO_AUTO, VF_ALGO_PT, "algorithm=auto "},
               {"cornell-rough", VF_ALGO_AUTO_UNBIASED, VF_ALGO_UPG, "algorithm=auto-unbiased "}};
  for (size_t c = 0; c < sizeof cases / sizeof *cases; c++) {
    vf_film *chosen = render(cases[c].scene, cases[c].chosen, 5, 2, 0, 2);
    vf_film *automatic = render(cases[c].scene, cases[c].requested, 5, 2, 0, 2);
    if (!chosen || !automatic) return;
    CHECK_STR_CONTAINS(automatic->settings_text, cases[c].text);
    size_t n = 3 * (size_t)chosen->width * chosen->height;
    CHECK(same_sums(chosen->sum, automatic->sum, n));
    CHECK(same_sums(chosen->square_sum, automatic->square_sum, n));
    vf_film_destroy(chosen);
    vf_film_destroy(automatic);
  }
}

/* The sampler is part of the settings: films of the two samplers differ, say which they
 * used (independent by saying nothing, as every film before samplers), and refuse to merge
 * even over disjoint iterations. */
static void test_films_of_different_samplers_refuse_to_merge(void) {
  vf_film *independent = render_with("cornell", VF_SAMPLER_INDEPENDENT, VF_ALGO_VCM, 5, 2, 0, 2);
  vf_film *sobol = render_with("cornell", VF_SAMPLER_SOBOL, VF_ALGO_VCM, 5, 2, 2, 4);
  if (!independent || !sobol) return;
  CHECK_STR_CONTAINS(sobol->settings_text, " sampler=sobol");
  CHECK(strstr(independent->settings_text, "sampler=") == NULL);
  CHECK_INT_EQ(vf_film_merge(independent, sobol), VF_EMISMATCH);
  CHECK_INT_EQ(vf_iterset_count(&independent->iterations), 2);
  vf_film_destroy(independent);
  vf_film_destroy(sobol);
}

typedef struct {
  int calls, due, final, due_with_iterations[8];
  uint64_t iterations_at_final;
} delivery_log;

static int log_delivery(void *ctx, vf_film *film, const vf_render_status *st) {
  delivery_log *log = ctx;
  log->calls++;
  if (st->final) {
    log->final++;
    log->iterations_at_final = vf_iterset_count(&film->iterations);
  } else if (st->delivery_due && log->due < 8) {
    log->due_with_iterations[log->due++] = (int)vf_iterset_count(&film->iterations);
  }
  return VF_OK;
}

/* The delivery contract (worker/render/render.h): a call after every iteration; due ones at the
 * interval, but never after the range's last iteration, which the one final call
 * delivers, so that the write at the end of a range is not counted in its seconds. */
static void test_the_end_of_a_range_is_delivered_once_as_final(void) {
  vf_scene *scene = NULL;
  vf_renderer *r = NULL;
  vf_film *film = NULL;
  CHECK_INT_EQ(vf_scene_load("cornell", &scene), VF_OK);
  if (scene == NULL) return;
  vf_settings s = scene->settings;
  s.width = 16;
  s.height = 12;
  CHECK_INT_EQ(vf_renderer_create(scene, &s, 1, &r), VF_OK);
  CHECK_INT_EQ(vf_film_create(s.width, s.height, &film), VF_OK);
  if (r && film && vf_renderer_stamp(r, film) == VF_OK) {
    delivery_log log = {0};
    vf_render_control control = {.ctx = &log, .delivery_interval = 1e-9, .deliver = log_delivery};
    vf_render_status st;
    CHECK_INT_EQ(vf_render_range(r, film, 0, 4, &control, &st), VF_OK);
    CHECK_INT_EQ(log.calls, 5); /* one after each of the 4 iterations, then the final one */
    CHECK_INT_EQ(log.due, 3);   /* after iterations 1, 2 and 3, not 4 */
    for (int i = 0; i < log.due; i++) CHECK_INT_EQ(log.due_with_iterations[i], i + 1);
    CHECK_INT_EQ(log.final, 1);
    CHECK_INT_EQ(log.iterations_at_final, 4);
    CHECK_INT_EQ(st.iterations_done, 4);
    /* No interval: nothing due before the final call. */
    delivery_log quiet = {0};
    control = (vf_render_control){.ctx = &quiet, .deliver = log_delivery};
    CHECK_INT_EQ(vf_render_range(r, film, 4, 6, &control, &st), VF_OK);
    CHECK_INT_EQ(quiet.calls, 3);
    CHECK_INT_EQ(quiet.due, 0);
    CHECK_INT_EQ(quiet.final, 1);
    CHECK_INT_EQ(quiet.iterations_at_final, 6);
  }
  vf_film_destroy(film);
  vf_renderer_destroy(r);
  vf_scene_destroy(scene);
}

int main(void) {
  RUN(test_films_of_different_samplers_refuse_to_merge);
  RUN(test_the_end_of_a_range_is_delivered_once_as_final);
  for (int k = 0; k < VF_SAMPLER_COUNT_; k++) {
    sampler_under_test = (vf_sampler_kind)k;
    printf("sampler %s\n", vf_sampler_name(sampler_under_test));
    RUN(test_auto_renders_exactly_its_choice);
    RUN(test_one_and_two_threads_give_bitwise_identical_films);
    RUN(test_same_seed_twice_gives_identical_files);
    RUN(test_split_ranges_merge_into_the_whole);
    RUN(test_the_accumulator_gives_the_film_bit_for_bit);
  }
  return check_finish();
}
