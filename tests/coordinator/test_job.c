/* A farm job (coordinator/job.h): every field of a submission is checked as untrusted
 * input and a refused one is named; results are checked against the job and merged once;
 * the stop conditions (iterations, time, target RMSE against a reference, target estimated
 * error) end the job with the reason. */
#include "check.h"
#include "common/error.h"
#include "common/file.h"
#include "common/settings.h"
#include "coordinator/job.h"

#include <stdlib.h>
#include <string.h>

#define W 8
#define H 4

static char settings[512];
static char dir[4096];
static const uint8_t scene_hash[32] = {3, 1, 4};

/* A submission; each case of test_every_refused_field_is_named spoils one field. */
typedef struct {
  const char *name;
  int priority, builtin;
  const char *scene;
  size_t scene_len;
  size_t hash_len;
  const char *settings;
  uint64_t first, iterations;
} submission;

static submission valid(void) {
  return (submission){"cornell box", 1, 1, "cornell", 7, 32, settings, 0, 100};
}

static int create(const submission *s, vf_job **out) {
  return vf_job_create(1, s->name, s->priority, s->builtin, s->scene, s->scene_len, scene_hash, s->hash_len,
                       s->settings, s->first, s->iterations, out);
}

#define CHECK_STR_EQ(got, want)                                                                    \
  do {                                                                                             \
    const char *g_ = (got), *w_ = (want);                                                          \
    if (strcmp(g_, w_) != 0) CHECK_FAIL_("%s: \"%s\", expected \"%s\"", #got, g_, w_);             \
  } while (0)

static vf_job *make_job(uint64_t first, uint64_t iterations) {
  submission s = valid();
  s.first = first;
  s.iterations = iterations;
  vf_job *job = NULL;
  CHECK_INT_EQ(create(&s, &job), VF_OK);
  CHECK(job != NULL);
  return job;
}

/* A result of the job for [begin, end): the same image every iteration when `steady`
 * (no variance: estimated error 0), else a different one each time. */
static vf_film *result(const vf_job *job, uint64_t begin, uint64_t end, int steady) {
  vf_film *film = NULL;
  CHECK_INT_EQ(vf_film_create(job->film->width, job->film->height, &film), VF_OK);
  memcpy(film->scene_hash, job->scene_hash, 32);
  snprintf(film->settings_text, sizeof film->settings_text, "%s", job->settings_text);
  float rgb[3 * W * H];
  for (uint64_t k = begin; k < end; k++) {
    for (int i = 0; i < 3 * W * H; i++) rgb[i] = steady ? 0.25f : (float)((i * 5 + k * 3) % 7) / 7.0f;
    CHECK_INT_EQ(vf_film_add_iteration(film, k, rgb, rgb, NULL), VF_OK);
  }
  film->render_seconds = 0.1 * (double)(end - begin);
  return film;
}

static int merge(vf_job *job, uint64_t begin, uint64_t end, int steady) {
  vf_film *film = result(job, begin, end, steady);
  int err = vf_job_check_result(job, film, begin, end);
  if (err == VF_OK) err = vf_job_merge(job, film, 10.0);
  vf_film_destroy(film);
  return err;
}

static void test_a_valid_job_has_a_stamped_empty_film(void) {
  vf_job *job = make_job(40, 100);
  if (job == NULL) return;
  CHECK_INT_EQ(job->film->width, W);
  CHECK_INT_EQ(job->film->height, H);
  for (int i = 0; i < 32; i++) CHECK_INT_EQ(job->film->scene_hash[i], scene_hash[i]);
  CHECK_STR_CONTAINS(job->film->settings_text, settings);
  CHECK_STR_CONTAINS(job->film->scene_name, "cornell");
  CHECK_INT_EQ(vf_job_done(job), 0);
  CHECK_STR_CONTAINS(vf_job_state(job, 0), "queued");
  CHECK_STR_CONTAINS(vf_job_state(job, 5), "running");
  CHECK(vf_job_runnable(job));
  vf_job_destroy(job);
}

static void test_every_refused_field_is_named(void) {
  char long_name[VF_JOB_MAX_NAME + 2];
  memset(long_name, 'n', sizeof long_name - 1);
  long_name[sizeof long_name - 1] = '\0';
  char long_settings[600];
  memset(long_settings, 's', sizeof long_settings - 1);
  long_settings[sizeof long_settings - 1] = '\0';
  /* The canonical text with its first key moved to the end: parsed alike, not canonical. */
  char reordered[1100];
  const char *space = strchr(settings, ' ');
  snprintf(reordered, sizeof reordered, "%s %.*s", space + 1, (int)(space - settings), settings);
  char bad_alpha[600];
  snprintf(bad_alpha, sizeof bad_alpha, "%s", settings);
  char *alpha = strstr(bad_alpha, "alpha=");
  if (alpha) alpha[6] = '7'; /* alpha=7.75: beyond (0, 1] */
  size_t huge_len = VF_JOB_MAX_SCENE + 1;
  char *huge = malloc(huge_len);
  memset(huge, ' ', huge_len);
  const struct {
    const char *field; /* what the detail must name */
    submission s;
  } cases[] = {
      {"job name", {long_name, 1, 1, "cornell", 7, 32, settings, 0, 100}},
      {"job name: control character", {"a\tb", 1, 1, "cornell", 7, 32, settings, 0, 100}},
      {"job name: not valid UTF-8", {"caf\xe9", 1, 1, "cornell", 7, 32, settings, 0, 100}},
      {"job name: not valid UTF-8", {"cut \xc3", 1, 1, "cornell", 7, 32, settings, 0, 100}},
      {"scene: built-in name of 0 bytes", {"n", 1, 1, "", 0, 32, settings, 0, 100}},
      {"scene: built-in name of 64 bytes",
       {"n", 1, 1, "aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa", 64, 32, settings, 0, 100}},
      {"scene: built-in name with character", {"n", 1, 1, "Cornell", 7, 32, settings, 0, 100}},
      {"scene: built-in name with character", {"n", 1, 1, "../etc", 6, 32, settings, 0, 100}},
      {"scene: JSON text of 0 bytes", {"n", 1, 0, "", 0, 32, settings, 0, 100}},
      {"scene: JSON text of", {"n", 1, 0, huge, huge_len, 32, settings, 0, 100}},
      {"scene: text contains a NUL byte", {"n", 1, 0, "{\"a\":\0}", 7, 32, settings, 0, 100}},
      {"scene_hash: 31 bytes", {"n", 1, 1, "cornell", 7, 31, settings, 0, 100}},
      {"priority: 0", {"n", 0, 1, "cornell", 7, 32, settings, 0, 100}},
      {"priority: 1001", {"n", 1001, 1, "cornell", 7, 32, settings, 0, 100}},
      {"iterations: 0", {"n", 1, 1, "cornell", 7, 32, settings, 0, 0}},
      {"iterations: 1000000001", {"n", 1, 1, "cornell", 7, 32, settings, 0, VF_JOB_MAX_ITERATIONS + 1}},
      {"first_iteration", {"n", 1, 1, "cornell", 7, 32, settings, VF_JOB_MAX_FIRST + 1, 100}},
      {"settings: text longer than", {"n", 1, 1, "cornell", 7, 32, long_settings, 0, 100}},
      {"settings: malformed", {"n", 1, 1, "cornell", 7, 32, "algorithm=vcm", 0, 100}},
      {"settings:", {"n", 1, 1, "cornell", 7, 32, bad_alpha, 0, 100}},
      {"is not in canonical form", {"n", 1, 1, "cornell", 7, 32, reordered, 0, 100}},
  };
  for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
    static vf_job untouched; /* *out must keep it */
    vf_job *job = &untouched;
    int err = create(&cases[i].s, &job);
    if (err != VF_EINVAL) CHECK_FAIL_("case %zu (%s): %d, expected VF_EINVAL (%d)", i, cases[i].field, err, VF_EINVAL);
    if (job != &untouched) CHECK_FAIL_("case %zu (%s): *out written on failure", i, cases[i].field);
    if (err == VF_OK) vf_job_destroy(job);
    CHECK_STR_CONTAINS(vf_error_detail(err), cases[i].field);
  }
  free(huge);
  /* The limits themselves are accepted. */
  submission edge = valid();
  edge.name = long_name + 1; /* VF_JOB_MAX_NAME bytes */
  edge.priority = 1000;
  edge.first = VF_JOB_MAX_FIRST;
  edge.iterations = VF_JOB_MAX_ITERATIONS;
  vf_job *job = NULL;
  CHECK_INT_EQ(create(&edge, &job), VF_OK);
  vf_job_destroy(job);
}

static void test_scene_path_is_checked(void) {
  submission s = valid();
  s.builtin = 0;
  s.scene = "{\"camera\":{}}";
  s.scene_len = strlen(s.scene);
  vf_job *job = NULL;
  CHECK_INT_EQ(create(&s, &job), VF_OK);
  if (job == NULL) return;
  char long_path[600];
  memset(long_path, 'p', sizeof long_path - 1);
  long_path[sizeof long_path - 1] = '\0';
  int err = vf_job_set_scene_path(job, long_path);
  CHECK_INT_EQ(err, VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(err), "scene_path: 599 bytes");
  err = vf_job_set_scene_path(job, "/scenes/a\nb.json");
  CHECK_INT_EQ(err, VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(err), "scene_path: control character at byte 9");
  err = vf_job_set_scene_path(job, "/scenes/caf\xe9.json"); /* Latin-1, not UTF-8 */
  CHECK_INT_EQ(err, VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(err), "scene_path: not valid UTF-8");
  CHECK_INT_EQ(vf_job_set_scene_path(job, "/scenes/box.json"), VF_OK);
  CHECK_STR_CONTAINS(job->film->scene_name, "/scenes/box.json");
  vf_job_destroy(job);
}

static void test_stop_conditions_are_checked(void) {
  vf_job *job = make_job(0, 100);
  if (job == NULL) return;
  const struct {
    double time_limit, target_rmse, target_error;
    const char *field;
  } bad[] = {
      {-1.0, 0, 0, "time_limit: -1"},
      {366.0 * 86400.0 + 1.0, 0, 0, "time_limit"},
      {NAN, 0, 0, "time_limit: nan"},
      {0, -0.5, 0, "target_rmse: -0.5"},
      {0, 0, INFINITY, "target_error: inf"},
      {0, 0.01, 0, "target_rmse: needs a reference image"},
  };
  for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
    int err = vf_job_set_stop(job, bad[i].time_limit, bad[i].target_rmse, bad[i].target_error);
    if (err != VF_EINVAL) CHECK_FAIL_("case %zu (%s): %d, expected VF_EINVAL (%d)", i, bad[i].field, err, VF_EINVAL);
    CHECK_STR_CONTAINS(vf_error_detail(err), bad[i].field);
  }
  CHECK_NEAR(job->time_limit, 0.0, 0.0); /* nothing of a refused call is kept */
  CHECK_INT_EQ(vf_job_set_stop(job, 3600.0, 0.0, 0.5), VF_OK);
  CHECK_NEAR(job->time_limit, 3600.0, 0.0);
  CHECK_NEAR(job->target_error, 0.5, 0.0);
  vf_job_destroy(job);
}

static void test_results_are_checked_and_merged_once(void) {
  vf_job *job = make_job(10, 20);
  if (job == NULL) return;
  CHECK_INT_EQ(merge(job, 10, 15, 0), VF_OK);
  CHECK_INT_EQ(vf_job_done(job), 5);
  CHECK(job->film_dirty);
  CHECK_INT_EQ(merge(job, 12, 17, 0), VF_EOVERLAP); /* some already counted: nothing merged */
  CHECK_INT_EQ(vf_job_done(job), 5);
  /* A result claiming another range than it holds. */
  vf_film *film = result(job, 15, 18, 0);
  int err = vf_job_check_result(job, film, 15, 20);
  CHECK_INT_EQ(err, VF_EMISMATCH);
  vf_film_destroy(film);
  /* Iterations outside the job's [10, 30). */
  film = result(job, 29, 31, 0);
  err = vf_job_check_result(job, film, 29, 31);
  CHECK_INT_EQ(err, VF_EMISMATCH);
  CHECK_STR_CONTAINS(vf_error_detail(err), "outside job 1's [10,30)");
  vf_film_destroy(film);
  /* Another scene, other settings, another size. */
  film = result(job, 15, 16, 0);
  film->scene_hash[0] ^= 1;
  err = vf_job_check_film(job, film);
  CHECK_STR_CONTAINS(vf_error_detail(err), "scene hash differs");
  film->scene_hash[0] ^= 1;
  film->settings_text[0] = 'x';
  err = vf_job_check_film(job, film);
  CHECK_STR_CONTAINS(vf_error_detail(err), "settings");
  vf_film_destroy(film);
  vf_film_create(W + 1, H, &film);
  err = vf_job_check_film(job, film);
  CHECK_INT_EQ(err, VF_EMISMATCH);
  CHECK_STR_CONTAINS(vf_error_detail(err), "film is 9x4, job 1 is 8x4");
  vf_film_destroy(film);
  CHECK_INT_EQ(merge(job, 15, 30, 0), VF_OK);
  CHECK(vf_job_complete(job));
  CHECK(!vf_job_runnable(job));
  CHECK_STR_CONTAINS(vf_job_state(job, 0), "done");
  CHECK_INT_EQ(vf_job_check_stop(job), 0); /* complete needs no mark */
  CHECK_INT_EQ(job->end, VF_JOB_ACTIVE);
  vf_forecast f;
  vf_job_forecast(job, 1.0, &f);
  CHECK_NEAR(f.eta, 0.0, 0.0);
  CHECK_NEAR(f.progress, 1.0, 0.0);
  vf_job_destroy(job);
}

static void test_a_time_limit_stops_the_job(void) {
  vf_job *job = make_job(0, 100);
  if (job == NULL) return;
  CHECK_INT_EQ(vf_job_set_stop(job, 5.0, 0.0, 0.0), VF_OK);
  job->seconds = 4.9;
  CHECK_INT_EQ(vf_job_check_stop(job), 0);
  vf_forecast f;
  vf_job_forecast(job, 0.0, &f);
  CHECK_NEAR(f.eta, 0.1, 1e-9);
  CHECK_INT_EQ(f.by, VF_STOP_TIME);
  CHECK_NEAR(f.progress, 0.98, 1e-9);
  CHECK_INT_EQ(job->stop, VF_STOP_NONE);
  CHECK_NEAR(job->ended_at, 0.0, 0.0);
  job->seconds = 5.0;
  /* Reached, but the final parts of its leases are not in (coordinator/deadline.h). */
  CHECK_INT_EQ(vf_job_check_stop(job), 0);
  CHECK_INT_EQ(job->end, VF_JOB_ACTIVE);
  job->time_up = 1;
  CHECK_INT_EQ(vf_job_check_stop(job), 1);
  CHECK_INT_EQ(job->end, VF_JOB_STOPPED);
  CHECK_INT_EQ(job->stop, VF_STOP_TIME);
  CHECK_STR_EQ(vf_stop_reason_name(job->stop), "time");
  if (!(job->ended_at > 1.6e9)) CHECK_FAIL_("ended_at %g, expected a Unix time", job->ended_at);
  CHECK_STR_CONTAINS(job->message, "time limit of 5 s reached");
  CHECK_STR_CONTAINS(vf_job_state(job, 0), "done");
  CHECK(vf_job_complete(job));
  CHECK_INT_EQ(vf_job_check_stop(job), 0); /* once */
  vf_job_destroy(job);
}

static void test_a_target_error_stops_the_job(void) {
  vf_job *job = make_job(0, 100);
  if (job == NULL) return;
  CHECK_INT_EQ(vf_job_set_stop(job, 0.0, 0.0, 0.01), VF_OK);
  CHECK_INT_EQ(merge(job, 0, 4, 0), VF_OK); /* noisy: an error well above 0.01 */
  CHECK_INT_EQ(vf_job_check_stop(job), 0);
  if (!(job->measured.estimated_rmse > 0.01))
    CHECK_FAIL_("estimated RMSE %g, expected above 0.01", job->measured.estimated_rmse);
  /* The 96 iterations left at 2 per second come first: the target needs thousands. */
  vf_forecast f;
  vf_job_forecast(job, 2.0, &f);
  CHECK_NEAR(f.eta, 48.0, 1e-9);
  CHECK_INT_EQ(f.by, VF_STOP_ITERATIONS);
  CHECK_NEAR(f.progress, 0.04, 1e-9);
  vf_job_destroy(job);
  /* Open-ended (the cap of 10^9 iterations with a target): the target alone counts, its
   * iterations extrapolated with the default slope 1/2 from one measurement. */
  job = make_job(0, VF_JOB_MAX_ITERATIONS);
  if (job == NULL) return;
  CHECK_INT_EQ(vf_job_set_stop(job, 0.0, 0.0, 0.01), VF_OK);
  CHECK_INT_EQ(merge(job, 0, 4, 0), VF_OK);
  CHECK_INT_EQ(vf_job_check_stop(job), 0);
  vf_job_forecast(job, 2.0, &f);
  CHECK_INT_EQ(f.by, VF_STOP_TARGET_ERROR);
  double r = job->measured.estimated_rmse / 0.01, needed = 4.0 * r * r;
  CHECK_NEAR(f.progress, 4.0 / needed, 1e-9);
  CHECK_NEAR(f.eta, (needed - 4.0) / 2.0, 1e-6 * needed);
  CHECK_NEAR(f.slope, 0.5, 0.0);
  vf_job_destroy(job);
  job = make_job(0, 100);
  if (job == NULL) return;
  CHECK_INT_EQ(vf_job_set_stop(job, 0.0, 0.0, 0.01), VF_OK);
  CHECK_INT_EQ(merge(job, 0, 1, 1), VF_OK);
  CHECK_INT_EQ(vf_job_check_stop(job), 0); /* one iteration estimates nothing */
  CHECK_INT_EQ(merge(job, 1, 3, 1), VF_OK); /* steady: no variance */
  CHECK_INT_EQ(vf_job_check_stop(job), 1);
  CHECK_STR_CONTAINS(job->message, "target estimated error 0.01 reached: 0 at 3 iterations");
  CHECK_STR_EQ(vf_stop_reason_name(job->stop), "target_error");
  vf_job_destroy(job);
}

static void test_a_target_rmse_stops_the_job(void) {
  vf_job *job = make_job(0, 100);
  if (job == NULL) return;
  char path[4200];
  snprintf(path, sizeof path, "%s/reference.exr", dir);
  vf_image ref = {0};
  CHECK_INT_EQ(vf_image_alloc(&ref, W, H + 1), VF_OK);
  CHECK_INT_EQ(vf_image_write_exr(path, &ref), VF_OK);
  int err = vf_job_load_reference(job, path);
  CHECK_INT_EQ(err, VF_EMISMATCH);
  CHECK_STR_CONTAINS(vf_error_detail(err), "reference is 8x5, job 1 renders 8x4");
  CHECK(job->reference.rgb == NULL);
  vf_image_destroy(&ref);
  /* The reference is the steady image's mean: the RMSE falls to 0 at once. */
  CHECK_INT_EQ(merge(job, 0, 2, 1), VF_OK);
  CHECK_INT_EQ(vf_image_alloc(&ref, W, H), VF_OK);
  vf_film_mean(job->film, ref.rgb);
  CHECK_INT_EQ(vf_image_write_exr(path, &ref), VF_OK);
  vf_image_destroy(&ref);
  CHECK_INT_EQ(vf_job_load_reference(job, path), VF_OK);
  CHECK_INT_EQ(vf_job_set_stop(job, 0.0, 1e-6, 0.0), VF_OK);
  CHECK_INT_EQ(vf_job_check_stop(job), 1);
  CHECK_STR_CONTAINS(job->message, "target RMSE 1e-06 reached: 0 at 2 iterations");
  CHECK_STR_EQ(vf_stop_reason_name(job->stop), "target_rmse");
  CHECK_NEAR(job->measured.rmse, 0.0, 0.0);
  vf_job_destroy(job);
}

static void test_the_convergence_log_gains_one_entry_per_change(void) {
  vf_job *job = make_job(0, 100);
  if (job == NULL) return;
  CHECK_INT_EQ(vf_job_log(job), VF_OK); /* nothing done: no entry */
  CHECK_INT_EQ(job->film->convergence.count, 0);
  CHECK_INT_EQ(merge(job, 0, 3, 0), VF_OK);
  job->film_dirty = 0;
  CHECK_INT_EQ(vf_job_log(job), VF_OK);
  CHECK_INT_EQ(vf_job_log(job), VF_OK);
  CHECK_INT_EQ(job->film->convergence.count, 1);
  CHECK_INT_EQ(job->film->convergence.entries[0].iterations, 3);
  CHECK(job->film_dirty); /* the entry is part of the film */
  CHECK_INT_EQ(merge(job, 3, 5, 0), VF_OK);
  CHECK_INT_EQ(vf_job_log(job), VF_OK);
  CHECK_INT_EQ(job->film->convergence.count, 2);
  vf_job_destroy(job);
}

static void test_an_end_is_recorded_once_with_its_reason(void) {
  vf_job *job = make_job(0, 100);
  if (job == NULL) return;
  vf_job_finish(job, VF_STOP_CANCELLED, 1000.0, NULL);
  CHECK_INT_EQ(job->end, VF_JOB_CANCELLED);
  vf_job_finish(job, VF_STOP_FAILED, 2000.0, "late");
  CHECK_INT_EQ(job->end, VF_JOB_CANCELLED);
  CHECK_NEAR(job->ended_at, 1000.0, 0.0);
  CHECK_STR_EQ(vf_stop_reason_name(job->stop), "cancelled");
  vf_forecast f;
  vf_job_forecast(job, 1.0, &f);
  CHECK_INT_EQ(f.by, VF_STOP_CANCELLED);
  vf_job_destroy(job);
  job = make_job(0, 100);
  if (job == NULL) return;
  vf_job_finish(job, VF_STOP_FAILED, 5.0, "worker w: bad\nscene");
  CHECK_INT_EQ(job->end, VF_JOB_FAILED);
  CHECK_STR_EQ(job->message, "worker w: bad?scene");
  vf_job_destroy(job);
}

static void test_a_job_keeps_its_latest_events(void) {
  vf_job *job = make_job(0, 100);
  if (job == NULL) return;
  for (int i = 0; i < VF_JOB_EVENTS + 8; i++)
    vf_events_add(&job->events, 100.0 + i, "result_refused", job->id, "w\x01", "refused %d\n", i);
  CHECK_INT_EQ(job->events.count, VF_JOB_EVENTS);
  CHECK_INT_EQ(job->events.dropped, 8);
  const vf_event *oldest = vf_events_at(&job->events, 0), *latest = vf_events_at(&job->events, VF_JOB_EVENTS - 1);
  CHECK_STR_EQ(oldest->message, "refused 8?");
  CHECK_NEAR(oldest->time, 108.0, 0.0);
  CHECK_STR_EQ(latest->message, "refused 39?");
  CHECK_STR_EQ(latest->worker, "w?");
  CHECK(vf_events_at(&job->events, VF_JOB_EVENTS) == NULL);
  vf_job_destroy(job);
}

static void test_a_measure_comes_back_from_the_log(void) {
  vf_job *job = make_job(0, 100);
  if (job == NULL) return;
  CHECK_INT_EQ(merge(job, 0, 4, 0), VF_OK);
  CHECK_INT_EQ(vf_job_log(job), VF_OK);
  double logged = job->measured.estimated_rmse;
  job->measured_iterations = UINT64_MAX; /* as read back by a restarted coordinator */
  vf_job_restore_measure(job);
  CHECK_INT_EQ(job->measured_iterations, 4);
  CHECK_NEAR(job->measured.estimated_rmse, logged, 0.0);
  CHECK_INT_EQ(merge(job, 4, 6, 0), VF_OK); /* the log's last entry is older: nothing restored */
  job->measured_iterations = UINT64_MAX;
  vf_job_restore_measure(job);
  CHECK_INT_EQ(job->measured_iterations, UINT64_MAX);
  vf_job_destroy(job);
}

int main(void) {
  vf_settings s;
  vf_settings_default(&s);
  s.width = W;
  s.height = H;
  vf_settings_format(&s, settings, sizeof settings);
  if (vf_file_temp_dir("vf_test_job", dir, sizeof dir) != VF_OK) return 1;
  RUN(test_a_valid_job_has_a_stamped_empty_film);
  RUN(test_every_refused_field_is_named);
  RUN(test_scene_path_is_checked);
  RUN(test_stop_conditions_are_checked);
  RUN(test_results_are_checked_and_merged_once);
  RUN(test_a_time_limit_stops_the_job);
  RUN(test_a_target_error_stops_the_job);
  RUN(test_a_target_rmse_stops_the_job);
  RUN(test_the_convergence_log_gains_one_entry_per_change);
  RUN(test_an_end_is_recorded_once_with_its_reason);
  RUN(test_a_job_keeps_its_latest_events);
  RUN(test_a_measure_comes_back_from_the_log);
  vf_file_remove_tree(dir);
  return check_finish();
}
