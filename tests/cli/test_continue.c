/* `vcmfarm continue` and the checkpoint options of `render`, run in-process through their
 * command functions: continuing in steps equals rendering at once, gaps are filled first,
 * the wrong scene and damaged inputs are refused with nothing written, targets stop the
 * render, checkpoints log entries. */
#include "check.h"
#include "film_fixtures.h"
#include "common/error.h"
#include "common/film.h"
#include "common/image.h"
#include "cli/continue_cmd.h"
#include "cli/options.h"
#include "cli/render_cmd.h"

#include <stdlib.h>

static vf_film *read_film(const char *path) {
  vf_film *f = NULL;
  CHECK_INT_EQ(vf_film_read(path, &f), VF_OK);
  return f;
}

static double image_mean(const vf_film *f) {
  size_t n = 3 * (size_t)f->width * (size_t)f->height;
  float *rgb = malloc(n * sizeof *rgb);
  vf_film_mean(f, rgb);
  double s = 0;
  for (size_t i = 0; i < n; i++) s += rgb[i];
  free(rgb);
  return s / (double)n;
}

static double max_sum_difference(const vf_film *a, const vf_film *b) {
  size_t n = 3 * (size_t)a->width * (size_t)a->height;
  double d = 0;
  for (size_t i = 0; i < n; i++) {
    d = fmax(d, fabs(vf_film_sum_at(a, i) - vf_film_sum_at(b, i)));
    d = fmax(d, fabs(vf_film_square_at(a, i) - vf_film_square_at(b, i)) /
                    fmax(1.0, (double)vf_iterset_count(&a->iterations)));
  }
  return d;
}

/* Continuing in steps equals rendering at once, with each sampler (common/sampler.h):
 * continue renders the film's own settings, its sampler included. */
static void test_continue_in_three_steps_equals_one_render(void) {
  static const char *const algorithms[] = {"vcm", "bpt", "ppm"};
  static const char *const samplers[] = {"independent", "sobol"};
  for (size_t k = 0; k < 2 * sizeof algorithms / sizeof *algorithms; k++) {
    size_t a = k % 3;
    const char *sampler = samplers[k / 3];
    const char *whole = fixture_path("whole.exr"), *steps = fixture_path("steps.exr");
    const char *out = fixture_path("steps2.exr");
    CHECK_INT_EQ(fixture_run(vf_cmd_render, "render", "cornell", "-a", algorithms[a], "--sampler", sampler, "-n", "9",
                             "-R", "40x32", "-s", "5", "-q", "-o", whole, NULL), 0);
    CHECK_INT_EQ(fixture_run(vf_cmd_render, "render", "cornell", "-a", algorithms[a], "--sampler", sampler, "-n", "2",
                             "-R", "40x32", "-s", "5", "-q", "-o", steps, NULL), 0);
    CHECK_INT_EQ(fixture_run(vf_cmd_continue, "continue", steps, "-n", "3", "-q", NULL), 0);          /* in place */
    CHECK_INT_EQ(fixture_run(vf_cmd_continue, "continue", steps, "-n", "4", "-q", "-o", out, NULL), 0); /* elsewhere */
    vf_film *w = read_film(whole), *s = read_film(out), *mid = read_film(steps);
    if (!w || !s || !mid) return;
    CHECK_INT_EQ(vf_iterset_count(&mid->iterations), 5);
    CHECK(vf_iterset_equal(&w->iterations, &s->iterations));
    CHECK(strcmp(w->settings_text, s->settings_text) == 0);
    double diff = max_sum_difference(w, s), mean = image_mean(w);
    printf("  %s %s: continued 2+3+4 vs 9 at once: max |difference| %.3g, image mean %.3g\n", algorithms[a], sampler,
           diff, mean);
    CHECK((strstr(s->settings_text, "sampler=sobol") != NULL) == (k / 3 == 1));
    /* fixed-point sums: continued and whole are the same film, bit for bit */
    CHECK(diff == 0.0);
    CHECK(memcmp(s->sum, w->sum, 3 * sizeof *s->sum * (size_t)s->width * (size_t)s->height) == 0);
    CHECK(memcmp(s->square_sum, w->square_sum, 3 * sizeof *s->sum * (size_t)s->width * (size_t)s->height) == 0);
    CHECK(vf_film_estimate_rmse(s) == vf_film_estimate_rmse(w));
    /* one log entry per session, all in run 0: the film never changed between sessions */
    CHECK_INT_EQ(s->convergence.count, 3);
    for (size_t i = 0; i < s->convergence.count; i++) CHECK_INT_EQ(s->convergence.entries[i].run, 0);
    if (s->convergence.count == 3) CHECK_INT_EQ(s->convergence.entries[2].iterations, 9);
    vf_film_destroy(w);
    vf_film_destroy(s);
    vf_film_destroy(mid);
  }
}

static void test_continue_fills_gaps_first(void) {
  const char *a = fixture_path("gap_a.exr"), *b = fixture_path("gap_b.exr"), *whole = fixture_path("gap_whole.exr");
  CHECK_INT_EQ(fixture_run(vf_cmd_render, "render", "cornell", "-n", "2", "-R", "24x16", "-q", "-o", a, NULL), 0);
  CHECK_INT_EQ(fixture_run(vf_cmd_render, "render", "cornell", "-k", "5", "-n", "2", "-R", "24x16", "-q", "-o", b,
                           NULL), 0);
  CHECK_INT_EQ(fixture_run(vf_cmd_render, "render", "cornell", "-n", "8", "-R", "24x16", "-q", "-o", whole, NULL), 0);
  vf_film *fa = read_film(a), *fb = read_film(b);
  if (!fa || !fb) return;
  CHECK_INT_EQ(vf_film_merge(fa, fb), VF_OK);
  CHECK_INT_EQ(vf_film_write_version(fa, a, 1), VF_OK); /* a film of format version 1 continues too */
  CHECK_INT_EQ(fixture_run(vf_cmd_continue, "continue", a, "-n", "4", "-q", NULL), 0); /* [2,5) then [7,8) */
  vf_film *c = read_film(a), *w = read_film(whole);
  if (c && w) {
    char text[64] = "";
    vf_iterset_format(&c->iterations, text, sizeof text);
    printf("  [0,2) [5,7) continued by 4: %s\n", text);
    CHECK(strcmp(text, "[0,8)") == 0);
    CHECK(max_sum_difference(c, w) <= 1e-5 * image_mean(w));
    /* runs: a's 0, b's renumbered 1, then the merged film's new run 2 */
    CHECK(c->convergence.count >= 3);
    if (c->convergence.count >= 3) CHECK_INT_EQ(c->convergence.entries[c->convergence.count - 1].run, 2);
  }
  vf_film_destroy(fa);
  vf_film_destroy(fb);
  vf_film_destroy(c);
  vf_film_destroy(w);
}

static void test_bad_inputs_are_refused_and_nothing_is_written(void) {
  const char *film = fixture_path("bad_base.exr"), *out = fixture_path("bad_out.exr"), *junk = fixture_path("junk.exr");
  const char *small = fixture_path("small_ref.exr");
  CHECK_INT_EQ(fixture_run(vf_cmd_render, "render", "cornell", "-n", "2", "-R", "24x16", "-q", "-o", film, NULL), 0);
  size_t size = 0;
  unsigned char *bytes = fixture_slurp(film, &size);
  if (!bytes) return;
  fixture_spill(junk, bytes, size / 2); /* truncated */
  vf_image img = {0};
  vf_image_alloc(&img, 8, 8);
  CHECK_INT_EQ(vf_image_write_exr(small, &img), VF_OK);
  vf_image_destroy(&img);

  /* another scene: exit 2, the film untouched */
  CHECK_INT_EQ(fixture_run(vf_cmd_continue, "continue", film, "--scene", "furnace", "-n", "1", "-q", NULL), 2);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EMISMATCH), "content hash");
  CHECK(fixture_file_holds(film, bytes, size));
  /* damaged or absent film */
  CHECK_INT_EQ(fixture_run(vf_cmd_continue, "continue", junk, "-n", "1", "-q", "-o", out, NULL), 2);
  CHECK_STR_CONTAINS(vf_error_detail(vf_error_code()), junk);
  CHECK_INT_EQ(fixture_run(vf_cmd_continue, "continue", fixture_path("absent.exr"), "-n", "1", "-q", "-o", out,
                           NULL), 2);
  /* damaged, absent or wrong-size reference */
  CHECK_INT_EQ(fixture_run(vf_cmd_continue, "continue", film, "--reference", junk, "-n", "1", "-q", "-o", out,
                           NULL), 2);
  CHECK_INT_EQ(fixture_run(vf_cmd_continue, "continue", film, "--reference", small, "-n", "1", "-q", "-o", out,
                           NULL), 2);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EMISMATCH), small);
  CHECK_INT_EQ(fixture_run(vf_cmd_render, "render", "cornell", "-R", "24x16", "--reference", fixture_path("absent.exr"),
                           "-q", "-o", out, NULL), 2);
  CHECK_INT_EQ(fixture_run(vf_cmd_render, "render", "cornell", "-R", "24x16", "--reference", small, "-q", "-o", out,
                           NULL), 2);
  /* --target-rmse needs a reference */
  CHECK_INT_EQ(fixture_run(vf_cmd_continue, "continue", film, "--target-rmse", "0.1", "-q", "-o", out, NULL), 2);
  CHECK_INT_EQ(fixture_run(vf_cmd_render, "render", "cornell", "--target-rmse", "0.1", "-q", "-o", out, NULL), 2);
  CHECK(!fixture_exists(out));
  CHECK(fixture_file_holds(film, bytes, size));
  free(bytes);
}

static void test_targets_stop_and_checkpoints_log(void) {
  const char *ref = fixture_path("t_ref.exr"), *film = fixture_path("t_film.exr");
  CHECK_INT_EQ(fixture_run(vf_cmd_render, "render", "cornell", "-a", "bpt", "-s", "99", "-n", "64", "-R", "32x24", "-q",
                           "-o", ref, NULL), 0);
  /* --target-error: open-ended, stops right after the iteration whose estimate is low
   * enough (a farm job: after the merged part, test_farm.sh stop_conditions) */
  CHECK_INT_EQ(fixture_run(vf_cmd_render, "render", "cornell", "-R", "32x24", "--target-error", "0.12",
                           "-q", "-o", film, NULL), 0);
  vf_film *f = read_film(film);
  if (f) {
    uint64_t n = vf_iterset_count(&f->iterations);
    double est = vf_film_estimate_rmse(f);
    printf("  --target-error 0.12 stopped after %llu iterations at %.4f\n", (unsigned long long)n, est);
    CHECK(est <= 0.12);
    CHECK(n >= 2 && n < 1000);
    CHECK_INT_EQ(f->convergence.count, 1); /* default interval 10 s: only the final entry */
    if (f->convergence.count) CHECK(isnan(f->convergence.entries[0].rmse));
  }
  vf_film_destroy(f);
  /* --target-rmse with --reference, checkpoints every iteration (interval ~0) */
  CHECK_INT_EQ(fixture_run(vf_cmd_continue, "continue", film, "--reference", ref, "--target-rmse", "0.09",
                           "--checkpoint-interval", "1e-9", "-q", NULL), 0);
  f = read_film(film);
  if (f) {
    const vf_convergence_log *log = &f->convergence;
    CHECK(log->count >= 2);
    const vf_convergence_entry *last = &log->entries[log->count - 1];
    printf("  --target-rmse 0.09: %zu log entries, last at %llu iterations: RMSE %.4f, estimate %.4f\n", log->count,
           (unsigned long long)last->iterations, last->rmse, last->estimated_rmse);
    CHECK(last->rmse <= 0.09);
    CHECK(log->count < 2 || log->entries[log->count - 2].rmse > 0.09 || log->entries[log->count - 2].iterations ==
                                                                       last->iterations);
    CHECK_INT_EQ(last->iterations, vf_iterset_count(&f->iterations));
    CHECK_INT_EQ(last->run, 0);
  }
  vf_film_destroy(f);
  /* already met: nothing rendered, nothing written */
  const char *out = fixture_path("t_out.exr");
  CHECK_INT_EQ(fixture_run(vf_cmd_continue, "continue", film, "--target-error", "1e9", "-q", "-o", out, NULL), 0);
  CHECK(!fixture_exists(out));
}

/* The default interval is 10 s or 100 times the last checkpoint's cost, whichever is
 * longer, up to 300 s; a given interval is kept whatever checkpoints cost. */
static void test_checkpoint_intervals(void) {
  vf_cli_checkpoint automatic = VF_CLI_CHECKPOINT_DEFAULT, given = VF_CLI_CHECKPOINT_DEFAULT;
  CHECK(vf_cli_checkpoint_next(&automatic, 0.0) == 10.0);
  CHECK(vf_cli_checkpoint_next(&automatic, 0.05) == 10.0); /* a small film: its cost is below 1% */
  CHECK(fabs(vf_cli_checkpoint_next(&automatic, 0.6) - 60.0) < 1e-9);
  CHECK(vf_cli_checkpoint_next(&automatic, 4.6) == 300.0); /* a crash loses at most 5 minutes */
  CHECK_INT_EQ(vf_cli_checkpoint_option(&given, "2.5"), VF_OK);
  CHECK(vf_cli_checkpoint_next(&given, 0.6) == 2.5);
  CHECK_INT_EQ(vf_cli_checkpoint_option(&given, "0"), VF_OK);
  CHECK(vf_cli_checkpoint_next(&given, 0.6) == 0.0); /* only at the end */
  CHECK(vf_cli_checkpoint_option(&given, "-1") != VF_OK);
}

int main(void) {
  if (fixture_scratch_open("test_continue") != 0) return 1;
  RUN(test_continue_in_three_steps_equals_one_render);
  RUN(test_continue_fills_gaps_first);
  RUN(test_bad_inputs_are_refused_and_nothing_is_written);
  RUN(test_targets_stop_and_checkpoints_log);
  RUN(test_checkpoint_intervals);
  if (fixture_scratch_close() != 0) return 1;
  return check_finish();
}
