/* The coordinator's state directory (coordinator/state.h): every job written (job list,
 * scene, file table, film, reference) is read back as it was, a stopped job whose final
 * film is not durable yet is read back active, a job's failed leases and blocked workers
 * outlive a restart (coordinator/poison.h), older formats are read, and a damaged
 * file is refused with an error naming the file and what is wrong with it, except a job's
 * film: a broken one fails that job alone. */
#include "check.h"
#include "common/clock.h"
#include "common/error.h"
#include "common/file.h"
#include "common/settings.h"
#include "coordinator/checkpoint.h"
#include "coordinator/farm.h"
#include "coordinator/log.h"
#include "coordinator/poison.h"
#include "coordinator/state.h"

#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define W 8
#define H 4

static char settings[512];
static char root[4096];
static const uint8_t scene_hash[32] = {0xab, 0xcd};

/* Two strings equal, both printed when not. */
#define CHECK_STR_EQ(got, want)                                                                    \
  do {                                                                                             \
    const char *g_ = (got), *w_ = (want);                                                          \
    if (strcmp(g_, w_) != 0) CHECK_FAIL_("%s: \"%s\", expected \"%s\"", #got, g_, w_);             \
  } while (0)

/* The hash's hex digits (one of two buffers, for two in one assertion). */
static const char *hex_of(const uint8_t hash[32]) {
  static char hex[2][65];
  static int next;
  next ^= 1;
  vf_blob_hex(hash, hex[next]);
  return hex[next];
}

/* The film's iteration set as text (one of two buffers). */
static const char *iterations_of(const vf_film *film) {
  static char text[2][256];
  static int next;
  next ^= 1;
  vf_iterset_format(&film->iterations, text[next], sizeof text[next]);
  return text[next];
}

/* A farm on the state directory dir, empty. */
static void open_farm(vf_farm *farm, const char *dir) {
  vf_farm_config config = {dir, 15.0, 20.0, 0.0};
  vf_farm_init(farm, &config);
}

/* The same, its state loaded: a failed load fails the case, its detail printed. */
static void open_loaded(vf_farm *farm, const char *dir) {
  open_farm(farm, dir);
  int err = vf_state_load(farm);
  CHECK_INT_EQ(err, VF_OK);
  if (err != VF_OK) fprintf(stderr, "  %s\n", vf_error_detail(err));
}

/* A fresh empty state directory under root. */
static void fresh_dir(char *dir, size_t n, const char *name) {
  snprintf(dir, n, "%s/%s", root, name);
  vf_file_remove_tree(dir);
  int fd = -1;
  CHECK_INT_EQ(vf_state_lock(dir, &fd), VF_OK); /* creates it */
  close(fd);
}

/* The same, and an empty farm on it. */
static void fresh_farm(vf_farm *farm, char *dir, size_t n, const char *name) {
  fresh_dir(dir, n, name);
  open_farm(farm, dir);
}

static void write_file(const char *dir, const char *name, const char *text) {
  char path[8192];
  snprintf(path, sizeof path, "%s/%s", dir, name);
  CHECK_INT_EQ(vf_file_write_atomic(path, text, strlen(text), 0600), VF_OK);
}

static vf_job *add_job(vf_farm *farm, int builtin, const char *scene, uint64_t first, uint64_t iterations) {
  vf_job *job = NULL;
  char name[32];
  snprintf(name, sizeof name, "job %llu", (unsigned long long)farm->next_job_id);
  CHECK_INT_EQ(vf_job_create(farm->next_job_id, name, (int)farm->next_job_id, builtin, scene, strlen(scene),
                             scene_hash, 32, settings, first, iterations, &job),
               VF_OK);
  CHECK(job != NULL);
  if (job == NULL) return NULL;
  CHECK_INT_EQ(vf_farm_add_job(farm, job), VF_OK);
  farm->next_job_id++;
  return job;
}

static void check_same_job(const vf_job *a, const vf_job *b) {
  CHECK_INT_EQ(b->id, a->id);
  CHECK_STR_EQ(b->name, a->name);
  CHECK_INT_EQ(b->priority, a->priority);
  CHECK_INT_EQ(b->scene_builtin, a->scene_builtin);
  CHECK_STR_EQ(b->scene_text, a->scene_text);
  CHECK_STR_EQ(hex_of(b->scene_hash), hex_of(a->scene_hash));
  CHECK_STR_EQ(b->settings_text, a->settings_text);
  CHECK_INT_EQ(b->first, a->first);
  CHECK_INT_EQ(b->iterations, a->iterations);
  CHECK_NEAR(b->time_limit, a->time_limit, 0.0);
  CHECK_NEAR(b->target_rmse, a->target_rmse, 0.0);
  CHECK_NEAR(b->target_error, a->target_error, 0.0);
  CHECK_NEAR(b->seconds, a->seconds, 0.0);
  CHECK_INT_EQ(b->end, a->end);
  CHECK_STR_EQ(b->message, a->message);
  CHECK_STR_EQ(vf_stop_reason_name(b->stop), vf_stop_reason_name(a->stop));
  CHECK_NEAR(b->submitted_at, a->submitted_at, 0.0);
  CHECK_NEAR(b->started_at, a->started_at, 0.0);
  CHECK_NEAR(b->ended_at, a->ended_at, 0.0);
  CHECK_STR_EQ(b->algorithm_resolved, a->algorithm_resolved);
  CHECK_INT_EQ(b->events.count, a->events.count);
  CHECK_INT_EQ(b->events.dropped, a->events.dropped);
  for (unsigned i = 0; i < a->events.count && i < b->events.count; i++) {
    const vf_event *x = vf_events_at(&a->events, i), *y = vf_events_at(&b->events, i);
    CHECK_NEAR(y->time, x->time, 0.0);
    CHECK_STR_EQ(y->kind, x->kind);
    CHECK_STR_EQ(y->worker, x->worker);
    CHECK_STR_EQ(y->message, x->message);
  }
  CHECK_STR_EQ(b->film->scene_name, a->film->scene_name);
  CHECK_STR_EQ(iterations_of(b->film), iterations_of(a->film));
  CHECK_INT_EQ(b->files.count, a->files.count);
  for (size_t i = 0; i < a->files.count && i < b->files.count; i++) {
    CHECK_STR_EQ(b->files.refs[i].name, a->files.refs[i].name);
    CHECK_STR_EQ(hex_of(b->files.refs[i].hash), hex_of(a->files.refs[i].hash));
    CHECK_INT_EQ(b->files.refs[i].size, a->files.refs[i].size);
  }
  CHECK_INT_EQ(b->reference.rgb != NULL, a->reference.rgb != NULL);
  for (int i = 0; a->reference.rgb && b->reference.rgb && i < 3 * W * H; i++)
    if (b->reference.rgb[i] != a->reference.rgb[i]) {
      CHECK_NEAR(b->reference.rgb[i], a->reference.rgb[i], 0.0);
      break;
    }
}

static void test_every_job_is_read_back_as_written(void) {
  char dir[4200];
  vf_farm a, b;
  fresh_farm(&a, dir, sizeof dir, "round_trip");
  /* 1: built-in, running, with merged iterations and stop conditions. */
  vf_job *j = add_job(&a, 1, "cornell", 0, 50);
  if (j == NULL) return;
  float rgb[3 * W * H] = {0};
  for (uint64_t k = 0; k < 7; k++) {
    rgb[k] = 1.0f + (float)k;
    CHECK_INT_EQ(vf_film_add_iteration(j->film, k, rgb, rgb, NULL), VF_OK);
  }
  CHECK_INT_EQ(vf_job_set_stop(j, 100.0, 0.0, 0.5), VF_OK);
  j->seconds = 12.5;
  j->submitted_at = 1714550000.25;
  j->started_at = 1714550001.5;
  snprintf(j->algorithm_resolved, sizeof j->algorithm_resolved, "pt");
  for (int k = 0; k < VF_JOB_EVENTS + 3; k++)
    vf_events_add(&j->events, 1714550002.0 + k, k % 2 ? "lease_expired" : "worker_lost", j->id, "w1",
                  "event %d: \"quoted\"", k);
  /* 2: a JSON scene with files, continuing from iteration 1000, cancelled. */
  j = add_job(&a, 0, "{\"shapes\":[{\"file\":\"../meshes/bunny.ply\"}]}", 1000, 10);
  const uint8_t h1[32] = {1}, h2[32] = {2};
  CHECK_INT_EQ(vf_blob_table_add(&j->files, "../meshes/bunny.ply", h1, 1234), VF_OK);
  CHECK_INT_EQ(vf_blob_table_add(&j->files, "sky.exr", h2, 99), VF_OK);
  CHECK_INT_EQ(vf_job_set_scene_path(j, "/home/u/scenes/bunny.json"), VF_OK);
  vf_job_finish(j, VF_STOP_CANCELLED, 1714550100.0, NULL);
  /* 3: failed; 4: stopped, its final film durable. */
  j = add_job(&a, 1, "veach-mis", 0, 10);
  vf_job_finish(j, VF_STOP_FAILED, 1714550200.0, "worker w: scene does not load");
  j = add_job(&a, 1, "cornell", 0, 10);
  vf_job_finish(j, VF_STOP_TIME, 1714550300.0, "time limit of 5 s reached");
  /* 5: with a reference and a target RMSE. */
  j = add_job(&a, 1, "cornell", 0, 10);
  char path[8192];
  snprintf(path, sizeof path, "%s/job-5.reference.exr", dir);
  vf_image ref = {0};
  CHECK_INT_EQ(vf_image_alloc(&ref, W, H), VF_OK);
  for (int i = 0; i < 3 * W * H; i++) ref.rgb[i] = 0.125f * (float)(i % 8);
  CHECK_INT_EQ(vf_image_write_exr(path, &ref), VF_OK);
  vf_image_destroy(&ref);
  CHECK_INT_EQ(vf_job_load_reference(j, path), VF_OK);
  CHECK_INT_EQ(vf_job_set_stop(j, 0.0, 0.02, 0.0), VF_OK);
  /* Job 2 has no film yet: nothing done, and its scene's path is the job list's. */
  for (size_t i = 0; i < a.num_jobs; i++) {
    CHECK_INT_EQ(vf_state_save_scene(dir, a.jobs[i]), VF_OK);
    if (a.jobs[i]->id != 2) CHECK_INT_EQ(vf_state_save_film(dir, a.jobs[i]), VF_OK);
  }
  a.state_dirty = 1;
  CHECK_INT_EQ(vf_state_save_index(&a), VF_OK);
  CHECK_INT_EQ(a.state_dirty, 0);
  CHECK_NEAR(a.jobs[0]->seconds_saved, 12.5, 0.0);

  open_loaded(&b, dir);
  CHECK_INT_EQ(b.num_jobs, a.num_jobs);
  CHECK_INT_EQ(b.next_job_id, 6);
  for (size_t i = 0; i < a.num_jobs && i < b.num_jobs; i++) check_same_job(a.jobs[i], b.jobs[i]);
  CHECK_INT_EQ(vf_job_done(b.jobs[0]), 7);
  vf_farm_destroy(&a);
  vf_farm_destroy(&b);
}

/* After a restart a finished job shows its errors again: the film's convergence log ends
 * with the measurement of its last iterations (issue 19: they came back null). */
static void test_a_finished_jobs_errors_come_back(void) {
  char dir[4200];
  vf_farm a, b;
  fresh_farm(&a, dir, sizeof dir, "errors_back");
  vf_job *j = add_job(&a, 1, "cornell", 0, 6);
  if (j == NULL) return;
  float rgb[3 * W * H];
  for (uint64_t k = 0; k < 6; k++) {
    for (int i = 0; i < 3 * W * H; i++) rgb[i] = (float)((i * 7 + (int)k * 13) % 11) * 0.1f;
    CHECK_INT_EQ(vf_film_add_iteration(j->film, k, rgb, rgb, NULL), VF_OK);
  }
  CHECK_INT_EQ(vf_job_log(j), VF_OK); /* the final checkpoint's entry */
  vf_job_finish(j, VF_STOP_ITERATIONS, 1714550400.0, NULL);
  double estimated = j->measured.estimated_rmse;
  if (!(estimated > 0.0)) CHECK_FAIL_("estimated RMSE %g, expected > 0", estimated);
  CHECK_INT_EQ(vf_state_save_scene(dir, j), VF_OK);
  CHECK_INT_EQ(vf_state_save_film(dir, j), VF_OK);
  CHECK_INT_EQ(vf_state_save_index(&a), VF_OK);
  open_farm(&b, dir);
  CHECK_INT_EQ(vf_state_load(&b), VF_OK);
  if (b.num_jobs == 1) {
    const vf_job *r = b.jobs[0];
    CHECK(vf_job_complete(r));
    CHECK_INT_EQ(r->measured_iterations, 6);
    CHECK_NEAR(r->measured.estimated_rmse, estimated, 1e-6 * estimated); /* the log's text holds 9 digits */
    CHECK_STR_EQ(vf_stop_reason_name(r->stop), "iterations");
    CHECK_NEAR(r->ended_at, 1714550400.0, 0.0);
  }
  vf_farm_destroy(&a);
  vf_farm_destroy(&b);
}

/* A restarted coordinator goes on counting a job's failed leases and keeps its workers
 * blocked until their forgive time: a third failure after the restart fails the poison
 * job, and a block already over is not brought back. */
static void test_failed_leases_and_blocks_outlive_a_restart(void) {
  char dir[4200];
  fresh_dir(dir, sizeof dir, "poison");
  vf_farm a, b;
  vf_farm_config config = {dir, 15.0, 20.0, 600.0}; /* forgive after 600 s */
  vf_farm_init(&a, &config);
  vf_job *j = add_job(&a, 1, "knot", 0, 4);
  if (j == NULL) return;
  double now = vf_seconds_now();
  vf_poison_lease_failed(&a, j->id, "w1", "it crashed", now);
  vf_poison_lease_failed(&a, j->id, "w2", "it crashed", now);
  vf_poison_restore(&a, "w9", j->id, now - 1.0); /* forgiven a second ago */
  CHECK_INT_EQ(a.state_dirty, 1);
  CHECK_INT_EQ(vf_state_save_scene(dir, j), VF_OK);
  CHECK_INT_EQ(vf_state_save_index(&a), VF_OK);
  vf_farm_init(&b, &config);
  CHECK_INT_EQ(vf_state_load(&b), VF_OK);
  CHECK_INT_EQ(b.num_jobs, 1);
  if (b.num_jobs == 1) {
    vf_job *r = b.jobs[0];
    now = vf_seconds_now();
    CHECK_INT_EQ(r->lease_failures, 2);
    CHECK_INT_EQ(r->failed_workers_count, 2);
    CHECK_STR_EQ(r->failed_workers[0], "w1");
    CHECK_STR_EQ(r->failed_workers[1], "w2");
    CHECK(vf_poison_blocked(&b, "w1", r->id, now));
    CHECK(vf_poison_blocked(&b, "w2", r->id, now));
    CHECK(!vf_poison_blocked(&b, "w1", r->id, now + 601.0)); /* still forgiven after 600 s */
    CHECK(!vf_poison_blocked(&b, "w9", r->id, now));
    CHECK(!vf_poison_blocked(&b, "w3", r->id, now));
    CHECK_INT_EQ(b.num_blocks, 2);
    vf_poison_lease_failed(&b, r->id, "w3", "it crashed", now);
    CHECK_INT_EQ(r->end, VF_JOB_FAILED);
    CHECK_STR_CONTAINS(r->message, "poison job: leases failed on 3 workers in a row");
  }
  vf_farm_destroy(&a);
  vf_farm_destroy(&b);
}

/* A failed lease is written with the job list at the farm's next tick, without waiting
 * for a checkpoint: a crash right after it (the farm dropped unsaved) still finds the
 * failure counted and the worker blocked. */
static void test_a_failed_lease_is_durable_within_a_tick(void) {
  char dir[4200];
  fresh_dir(dir, sizeof dir, "urgent");
  vf_farm a, b;
  vf_farm_config config = {dir, 15.0, 20.0, 600.0};
  vf_farm_init(&a, &config);
  vf_job *j = add_job(&a, 1, "knot", 0, 4);
  if (j == NULL) return;
  CHECK_INT_EQ(vf_state_save_scene(dir, j), VF_OK);
  CHECK_INT_EQ(vf_state_save_index(&a), VF_OK);
  double now = vf_seconds_now();
  vf_poison_lease_failed(&a, j->id, "w1", "it crashed", now);
  CHECK_INT_EQ(a.state_urgent, 1);
  vf_farm_tick(&a, now);
  CHECK_INT_EQ(a.state_urgent, 0);
  vf_farm_init(&b, &config); /* a's memory is gone: what a crash leaves */
  CHECK_INT_EQ(vf_state_load(&b), VF_OK);
  CHECK_INT_EQ(b.num_jobs, 1);
  if (b.num_jobs == 1) {
    CHECK_INT_EQ(b.jobs[0]->lease_failures, 1);
    CHECK(vf_poison_blocked(&b, "w1", b.jobs[0]->id, vf_seconds_now()));
  }
  vf_farm_destroy(&a);
  vf_farm_destroy(&b);
}

/* A paused job and the tags it requires come back paused and requiring them (format 5),
 * the other job neither; a bad requirement in the file is refused naming the job and the
 * tag. */
static void test_pause_and_requirements_outlive_a_restart(void) {
  char dir[4200];
  fresh_dir(dir, sizeof dir, "model");
  vf_farm a, b;
  open_farm(&a, dir);
  vf_job *j = add_job(&a, 1, "knot", 0, 4), *k = add_job(&a, 1, "cornell", 0, 4);
  if (j == NULL || k == NULL) return;
  char *requires[] = {"night", "mem>=64G"};
  CHECK_INT_EQ(vf_job_set_requires(j, requires, 2), VF_OK);
  j->paused = 1;
  CHECK_INT_EQ(vf_state_save_scene(dir, j), VF_OK);
  CHECK_INT_EQ(vf_state_save_scene(dir, k), VF_OK);
  CHECK_INT_EQ(vf_state_save_index(&a), VF_OK);
  open_loaded(&b, dir);
  CHECK_INT_EQ(b.num_jobs, 2);
  if (b.num_jobs == 2) {
    CHECK_INT_EQ(b.jobs[0]->paused, 1);
    CHECK_STR_EQ(vf_job_state(b.jobs[0], 0), "paused");
    CHECK_INT_EQ(b.jobs[0]->requires.count, 2);
    CHECK_STR_EQ(b.jobs[0]->requires.tag[0], "night");
    CHECK_STR_EQ(b.jobs[0]->requires.tag[1], "mem>=64G");
    CHECK_INT_EQ(b.jobs[1]->paused, 0);
    CHECK_INT_EQ(b.jobs[1]->requires.count, 0);
  }
  vf_farm_destroy(&b);
  /* A bad requirement written into the file by hand. */
  char path[4300];
  snprintf(path, sizeof path, "%s/state.json", dir);
  uint8_t *text;
  size_t len;
  CHECK_INT_EQ(vf_file_read_all(path, 1 << 20, &text, &len), VF_OK);
  char *night = strstr((char *)text, "\"night\"");
  CHECK(night != NULL);
  if (night) memcpy(night + 1, "ni ht", 5);
  CHECK_INT_EQ(vf_file_write_atomic(path, text, len, 0600), VF_OK);
  free(text);
  vf_farm c;
  open_farm(&c, dir);
  CHECK_INT_EQ(vf_state_load(&c), VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EINVAL), "job 1: requires: tag 'ni ht' holds a space");
  vf_farm_destroy(&c);
  vf_farm_destroy(&a);
}

/* A film checkpoint that fails is an event of its job (and is tried again later). */
static void test_a_failed_checkpoint_is_an_event_of_its_job(void) {
  char dir[4200], blocked[4300];
  fresh_dir(dir, sizeof dir, "blocked");
  write_file(dir, "file", "not a directory");
  snprintf(blocked, sizeof blocked, "%s/file/state", dir);
  vf_farm farm;
  open_farm(&farm, blocked);
  vf_job *j = add_job(&farm, 1, "cornell", 0, 10);
  if (j == NULL) return;
  float rgb[3 * W * H] = {0};
  CHECK_INT_EQ(vf_film_add_iteration(j->film, 0, rgb, rgb, NULL), VF_OK);
  j->film_dirty = 1;
  int err = vf_checkpoint_write(&farm, 0);
  CHECK(err != VF_OK);
  /* The first error, the film's, not what the job list's write left behind. */
  CHECK_STR_CONTAINS(vf_error_detail(err), "job 1's film: ");
  CHECK_INT_EQ(j->events.count, 1);
  const vf_event *e = vf_events_at(&j->events, 0);
  if (e) {
    CHECK_STR_EQ(e->kind, "checkpoint_failed");
    CHECK_STR_CONTAINS(e->message, "film checkpoint failed: ");
    if (!(e->time > 1.6e9)) CHECK_FAIL_("event time %g, expected a Unix time", e->time);
  }
  CHECK(j->film_dirty); /* the next checkpoint tries again */
  CHECK_STR_CONTAINS(j->checkpoint_error, "film checkpoint failed (retrying): "); /* status's message */
  /* Complete, its final film not durable: not done. */
  for (uint64_t i = 1; i < 10; i++) CHECK_INT_EQ(vf_film_add_iteration(j->film, i, rgb, rgb, NULL), VF_OK);
  vf_checkpoint_final(&farm, j);
  CHECK(j->final_pending);
  CHECK_STR_EQ(vf_job_state(j, 0), "running");
  /* The directory usable again: the next checkpoint lands, the job is done, the message gone. */
  farm.config.state_dir = dir;
  CHECK_INT_EQ(vf_checkpoint_write(&farm, 0), VF_OK);
  CHECK(!j->final_pending);
  CHECK_STR_EQ(vf_job_state(j, 0), "done");
  CHECK_STR_EQ(j->checkpoint_error, "");
  vf_farm_destroy(&farm);
}

/* The stopping coordinator's checkpoint (all) writes what changed and the job list, never a
 * film already on disk as it is: the file of a finished job stays the one written. */
static void test_stopping_writes_only_changed_films(void) {
  char dir[4200], path[8192];
  vf_farm farm;
  fresh_farm(&farm, dir, sizeof dir, "stopping");
  vf_job *a = add_job(&farm, 1, "cornell", 0, 10), *b = add_job(&farm, 1, "cornell", 0, 10);
  if (a == NULL || b == NULL) return;
  CHECK_INT_EQ(vf_state_save_scene(dir, a), VF_OK); /* as at submission */
  CHECK_INT_EQ(vf_state_save_scene(dir, b), VF_OK);
  float rgb[3 * W * H] = {0};
  CHECK_INT_EQ(vf_film_add_iteration(a->film, 0, rgb, rgb, NULL), VF_OK);
  CHECK_INT_EQ(vf_film_add_iteration(b->film, 0, rgb, rgb, NULL), VF_OK);
  a->film_dirty = b->film_dirty = 1;
  CHECK_INT_EQ(vf_checkpoint_write(&farm, 0), VF_OK);
  CHECK(!a->film_dirty && !b->film_dirty);
  struct stat before[2], after[2];
  for (int k = 0; k < 2; k++) {
    snprintf(path, sizeof path, "%s/job-%d.exr", dir, k + 1);
    CHECK_INT_EQ(stat(path, &before[k]), 0);
  }
  /* b changes; a does not. */
  CHECK_INT_EQ(vf_film_add_iteration(b->film, 1, rgb, rgb, NULL), VF_OK);
  b->film_dirty = 1;
  CHECK_INT_EQ(vf_checkpoint_write(&farm, 1), VF_OK);
  for (int k = 0; k < 2; k++) {
    snprintf(path, sizeof path, "%s/job-%d.exr", dir, k + 1);
    CHECK_INT_EQ(stat(path, &after[k]), 0);
  }
  CHECK(after[0].st_ino == before[0].st_ino); /* not replaced (films are written by rename) */
  CHECK(after[1].st_ino != before[1].st_ino); /* replaced */
  vf_farm_destroy(&farm);
  /* And what is on disk is what the farm held: b's two iterations. */
  vf_farm back;
  open_loaded(&back, dir);
  CHECK_INT_EQ(back.num_jobs, 2);
  if (back.num_jobs == 2) {
    CHECK_INT_EQ(vf_job_done(back.jobs[0]), 1);
    CHECK_INT_EQ(vf_job_done(back.jobs[1]), 2);
  }
  vf_farm_destroy(&back);
}

static void test_an_empty_directory_is_an_empty_farm(void) {
  char dir[4200];
  vf_farm farm;
  fresh_farm(&farm, dir, sizeof dir, "empty");
  CHECK_INT_EQ(vf_state_load(&farm), VF_OK);
  CHECK_INT_EQ(farm.num_jobs, 0);
  CHECK_INT_EQ(farm.next_job_id, 1);
  vf_farm_destroy(&farm);
}

/* Until a stopped job's final film is durable, the job list says it is still active, so a
 * crash in between resumes it from its last film (coordinator/checkpoint.h). */
static void test_a_stop_not_yet_durable_is_written_active(void) {
  char dir[4200];
  vf_farm a, b;
  fresh_farm(&a, dir, sizeof dir, "unsettled");
  vf_job *j = add_job(&a, 1, "cornell", 0, 10);
  if (j == NULL) return;
  CHECK_INT_EQ(vf_state_save_scene(dir, j), VF_OK);
  j->end = VF_JOB_STOPPED;
  snprintf(j->message, sizeof j->message, "target estimated error 0.1 reached");
  j->final_pending = 1;
  CHECK_INT_EQ(vf_state_save_index(&a), VF_OK);
  open_farm(&b, dir);
  CHECK_INT_EQ(vf_state_load(&b), VF_OK);
  CHECK_INT_EQ(b.num_jobs, 1);
  if (b.num_jobs == 1) {
    CHECK_INT_EQ(b.jobs[0]->end, VF_JOB_ACTIVE);
    CHECK_INT_EQ(strlen(b.jobs[0]->message), 0);
  }
  vf_farm_destroy(&b);
  /* Once it landed (vf_state_save_film clears final_pending), the stop is written. */
  CHECK_INT_EQ(vf_state_save_film(dir, j), VF_OK);
  CHECK_INT_EQ(j->final_pending, 0);
  CHECK_INT_EQ(vf_state_save_index(&a), VF_OK);
  open_farm(&b, dir);
  CHECK_INT_EQ(vf_state_load(&b), VF_OK);
  if (b.num_jobs == 1) {
    CHECK_INT_EQ(b.jobs[0]->end, VF_JOB_STOPPED);
    CHECK_STR_EQ(b.jobs[0]->message, "target estimated error 0.1 reached");
  }
  vf_farm_destroy(&a);
  vf_farm_destroy(&b);
}

/* The text of state.json with one job, whose key `key` has the value `value` instead of
 * the valid one (NULL: the key is left out). */
static void job_list(char *out, size_t n, int format, const char *key, const char *value) {
  char hex[65];
  vf_blob_hex(scene_hash, hex);
  char quoted_hex[80], quoted_settings[600];
  snprintf(quoted_hex, sizeof quoted_hex, "\"%s\"", hex);
  snprintf(quoted_settings, sizeof quoted_settings, "\"%s\"", settings);
  const char *fields[][2] = {
      {"id", "1"},           {"name", "\"j\""},         {"priority", "2"},        {"scene_builtin", "true"},
      {"scene_hash", quoted_hex}, {"settings", quoted_settings}, {"first_iteration", "0"}, {"iterations", "10"},
      {"time_limit", "0"},   {"target_rmse", "0"},      {"target_error", "0"},    {"reference", "false"},
      {"seconds", "1.5"},    {"end", "\"active\""},     {"message", "\"\""},
      /* format 4 */
      {"stop_reason", "\"\""}, {"submitted_at", "1714550000"}, {"started_at", "0"}, {"ended_at", "0"},
      {"algorithm_resolved", "\"\""}, {"events", "[]"}, {"events_dropped", "0"},
      {"lease_failures", "0"}, {"failed_workers", "[]"}, {"blocked", "[]"}, /* optional in format 4 */
  };
  size_t num_fields = format >= 4 ? sizeof fields / sizeof *fields : 15;
  size_t len = (size_t)snprintf(out, n, "{\"format\": %d, \"next_job_id\": 2, \"jobs\": [{", format);
  const char *sep = "";
  for (size_t i = 0; i < num_fields; i++) {
    int replaced = key != NULL && strcmp(fields[i][0], key) == 0;
    if (replaced && value == NULL) continue;
    len += (size_t)snprintf(out + len, n - len, "%s\"%s\": %s", sep, fields[i][0], replaced ? value : fields[i][1]);
    sep = ", ";
  }
  snprintf(out + len, n - len, "}]}");
}

/* Loads dir into a fresh farm; returns the error and its detail in detail. */
static int load(const char *dir, char *detail, size_t n) {
  vf_farm farm;
  open_farm(&farm, dir);
  int err = vf_state_load(&farm);
  snprintf(detail, n, "%s", err != VF_OK ? vf_error_detail(err) : "");
  vf_farm_destroy(&farm);
  return err;
}

/* Loads dir: 1 when it loads with job 1 failed (its message into detail), 0 when job 1
 * is not failed, -1 when the load fails (its detail into detail). */
static int load_failed(const char *dir, char *detail, size_t n) {
  vf_farm farm;
  open_farm(&farm, dir);
  int err = vf_state_load(&farm), rc = -1;
  snprintf(detail, n, "%s", err != VF_OK ? vf_error_detail(err) : "");
  vf_job *j = err == VF_OK ? vf_farm_job(&farm, 1) : NULL;
  if (j) {
    rc = j->end == VF_JOB_FAILED;
    snprintf(detail, n, "%s", j->message);
  }
  vf_farm_destroy(&farm);
  return rc;
}

static long file_size(const char *dir, const char *name) {
  char path[8192];
  snprintf(path, sizeof path, "%s/%s", dir, name);
  FILE *f = fopen(path, "rb");
  if (f == NULL) return -1;
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fclose(f);
  return n;
}

/* A film truncated on disk, or extended beyond its job's range (a user's `continue` while
 * the coordinator was down), fails its job alone: the farm loads, the other job runs, the
 * failed job says why in its message and events, and its file is never written over. */
static void test_a_broken_film_fails_its_job_alone(void) {
  char dir[4200], path[8192];
  vf_farm farm;
  fresh_farm(&farm, dir, sizeof dir, "broken_film");
  vf_job *a = add_job(&farm, 1, "cornell", 0, 10), *b = add_job(&farm, 1, "cornell", 0, 10);
  if (a == NULL || b == NULL) return vf_farm_destroy(&farm);
  CHECK_INT_EQ(vf_state_save_scene(dir, a), VF_OK);
  CHECK_INT_EQ(vf_state_save_scene(dir, b), VF_OK);
  float rgb[3 * W * H] = {0};
  for (uint64_t i = 0; i < 3; i++) {
    CHECK_INT_EQ(vf_film_add_iteration(a->film, i, rgb, rgb, NULL), VF_OK);
    CHECK_INT_EQ(vf_film_add_iteration(b->film, i, rgb, rgb, NULL), VF_OK);
  }
  CHECK_INT_EQ(vf_checkpoint_write(&farm, 1), VF_OK);
  vf_farm_destroy(&farm);
  /* Job 1's film truncated to half its bytes. */
  long full = file_size(dir, "job-1.exr");
  CHECK(full > 0);
  snprintf(path, sizeof path, "%s/job-1.exr", dir);
  CHECK_INT_EQ(truncate(path, full / 2), 0);
  /* Job 2's film extended past [0, 10) by iterations [10, 12). */
  vf_film *film = NULL;
  snprintf(path, sizeof path, "%s/job-2.exr", dir);
  CHECK_INT_EQ(vf_film_read(path, &film), VF_OK);
  if (film) {
    CHECK_INT_EQ(vf_film_add_iteration(film, 10, rgb, rgb, NULL), VF_OK);
    CHECK_INT_EQ(vf_film_add_iteration(film, 11, rgb, rgb, NULL), VF_OK);
    CHECK_INT_EQ(vf_film_write(film, path), VF_OK);
    vf_film_destroy(film);
  }
  long extended = file_size(dir, "job-2.exr");
  vf_job *c = NULL;
  for (int round = 0; round < 2; round++) { /* and again after the failures were written */
    open_loaded(&farm, dir);
    if (round == 0) { /* a third job, intact, that the farm goes on with */
      c = add_job(&farm, 1, "cornell", 0, 10);
      if (c) CHECK_INT_EQ(vf_film_add_iteration(c->film, 0, rgb, rgb, NULL), VF_OK);
      if (c) c->film_dirty = 1;
      if (c) CHECK_INT_EQ(vf_state_save_scene(dir, c), VF_OK);
      farm.state_dirty = 1;
    }
    a = vf_farm_job(&farm, 1);
    b = vf_farm_job(&farm, 2);
    c = vf_farm_job(&farm, 3);
    CHECK(a != NULL && b != NULL && c != NULL);
    if (a && b && c) {
      CHECK_INT_EQ(a->end, VF_JOB_FAILED);
      CHECK_STR_EQ(vf_stop_reason_name(a->stop), "failed");
      CHECK_STR_EQ(vf_job_state(a, 0), "failed");
      CHECK_STR_CONTAINS(a->message, "its film cannot be read back: ");
      CHECK_STR_CONTAINS(a->message, "job-1.exr");
      CHECK_INT_EQ(b->end, VF_JOB_FAILED);
      CHECK_STR_CONTAINS(b->message, "job-2.exr: does not belong to job 2: film holds iterations outside job 2's [0,10)");
      const vf_event *e = vf_events_at(&b->events, b->events.count - 1);
      if (e) CHECK_STR_EQ(e->kind, "job_failed");
      CHECK_INT_EQ(c->end, VF_JOB_ACTIVE);
      CHECK(vf_job_runnable(c));
      CHECK_INT_EQ(vf_job_done(c), 1);
    }
    CHECK_INT_EQ(vf_checkpoint_write(&farm, 1), VF_OK);
    vf_farm_destroy(&farm);
    CHECK_INT_EQ(file_size(dir, "job-1.exr"), full / 2); /* left as they were, for the user */
    CHECK_INT_EQ(file_size(dir, "job-2.exr"), extended);
  }
}

/* A job list of format 3 (no times, reasons or events) with settings in 17 digits: read,
 * the settings in today's form, the stop reason derived from the end. */
static void test_format_3_is_read_with_old_settings_text(void) {
  char dir[4200], text[4096], detail[2048], old_settings[600];
  fresh_dir(dir, sizeof dir, "format3");
  write_file(dir, "job-1.scene", "cornell");
  snprintf(old_settings, sizeof old_settings, "\"%s\"",
           "algorithm=vcm max_path_length=10 radius_factor=0.0030000000000000001 alpha=0.75 seed=1 resolution=8x4");
  job_list(text, sizeof text, 3, "end", "\"failed\"");
  char *at = strstr(text, settings), rest[4096];
  CHECK(at != NULL);
  if (at) { /* the settings as an older coordinator wrote them */
    snprintf(rest, sizeof rest, "%s", at + strlen(settings) + 1);
    snprintf(at - 1, sizeof text - (size_t)(at - 1 - text), "%s%s", old_settings, rest);
  }
  write_file(dir, "state.json", text);
  vf_farm farm;
  open_farm(&farm, dir);
  int err = vf_state_load(&farm);
  snprintf(detail, sizeof detail, "%s", err != VF_OK ? vf_error_detail(err) : "");
  CHECK_INT_EQ(err, VF_OK);
  if (err != VF_OK) fprintf(stderr, "  %s\n", detail);
  if (farm.num_jobs == 1) {
    CHECK_STR_EQ(farm.jobs[0]->settings_text, settings);
    CHECK_STR_EQ(vf_stop_reason_name(farm.jobs[0]->stop), "failed");
    CHECK_NEAR(farm.jobs[0]->submitted_at, 0.0, 0.0);
    CHECK_INT_EQ(farm.jobs[0]->events.count, 0);
  }
  vf_farm_destroy(&farm);
}

static void test_a_damaged_job_list_is_refused_naming_the_problem(void) {
  char dir[4200], text[4096], detail[2048];
  fresh_dir(dir, sizeof dir, "damaged");
  write_file(dir, "job-1.scene", "cornell");
  job_list(text, sizeof text, 3, NULL, NULL);
  write_file(dir, "state.json", text);
  CHECK_INT_EQ(load(dir, detail, sizeof detail), VF_OK); /* the valid one, for reference */
  const struct {
    const char *text; /* a whole state.json, or NULL for the job list with key = value */
    const char *key, *value, *detail;
  } cases[] = {
      {"", NULL, NULL, "state.json: not valid JSON"},
      {"{\"format\": 3, \"next_job_id\": 2, \"jobs\": [{\"id\": 1, \"na", NULL, NULL, "state.json: not valid JSON"},
      {"{\"format\": 9, \"next_job_id\": 1, \"jobs\": []}", NULL, NULL,
       "state format 9, this coordinator reads 1 to 5"},
      {"{\"next_job_id\": 1, \"jobs\": []}", NULL, NULL,
       "\"format\" missing or not a whole number"},
      {"{\"format\": 3, \"next_job_id\": -1, \"jobs\": []}", NULL, NULL,
       "\"next_job_id\" missing or not a whole number"},
      {"{\"format\": 3, \"next_job_id\": 1, \"jobs\": {}}", NULL, NULL, "\"jobs\" is not an array"},
      {NULL, "id", "1.5", "\"id\" missing or not a whole number"},
      {NULL, "iterations", "-1", "\"iterations\" missing or not a whole number in [0, 1000000000]"},
      {NULL, "iterations", "0", "job 1: iterations: 0, must be 1 to"},
      {NULL, "first_iteration", NULL, "\"first_iteration\" missing"},
      {NULL, "priority", "\"high\"", "job 1: bad \"priority\""},
      {NULL, "priority", "0", "job 1: priority: 0, must be 1 to 1000"},
      {NULL, "settings", NULL, "job 1: a field is missing or malformed"},
      {NULL, "scene_hash", "\"abcd\"", "job 1: a field is missing or malformed"},
      {NULL, "scene_builtin", "1", "job 1: a field is missing or malformed"},
      {NULL, "settings", "\"algorithm=vcm\"", "job 1: settings: settings: malformed"},
      {NULL, "time_limit", "-5", "job 1: a stop condition is malformed"},
      {NULL, "reference", "\"yes\"", "job 1: a stop condition is malformed"},
      {NULL, "target_rmse", "0.1", "job 1: target_rmse: needs a reference image"},
      {NULL, "name", "\"a\\u0001b\"", "job 1: job name: control character at byte 1"},
      {NULL, "stop_reason", "\"finished\"", "job 1: a time, the stop reason or the resolved algorithm is malformed"},
      {NULL, "started_at", "-1", "job 1: a time, the stop reason or the resolved algorithm is malformed"},
      {NULL, "events", "[{\"time\": 1}]", "job 1: an event is malformed"},
      {NULL, "events", "{}", "job 1: an event is malformed"},
      {NULL, "lease_failures", "-1", "job 1: its failed leases or blocked workers are malformed"},
      {NULL, "failed_workers", "[\"w1\", 2]", "job 1: its failed leases or blocked workers are malformed"},
      {NULL, "failed_workers", "[\"a\", \"b\", \"c\", \"d\"]",
       "job 1: its failed leases or blocked workers are malformed"},
      {NULL, "blocked", "[{\"worker\": \"w1\"}]", "job 1: its failed leases or blocked workers are malformed"},
      {NULL, "blocked", "{}", "job 1: its failed leases or blocked workers are malformed"},
  };
  for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
    if (cases[i].text) snprintf(text, sizeof text, "%s", cases[i].text);
    else job_list(text, sizeof text, 4, cases[i].key, cases[i].value);
    write_file(dir, "state.json", text);
    int err = load(dir, detail, sizeof detail);
    if (err == VF_OK) CHECK_FAIL_("case %zu (%s) was accepted", i, cases[i].detail);
    CHECK_STR_CONTAINS(detail, cases[i].detail);
    CHECK_STR_CONTAINS(detail, "state.json");
  }
}

/* A job name that an older build saved with bytes that are not UTF-8 loads with '?' in
 * their place: refused, it would keep the coordinator from starting; kept, it would make
 * status --json invalid. */
static void test_a_saved_name_that_is_not_utf8_loads_sanitized(void) {
  char dir[4200], text[4096];
  fresh_dir(dir, sizeof dir, "latin1_name");
  job_list(text, sizeof text, 4, "name", "\"caf\xe9 \xc3\"");
  write_file(dir, "state.json", text);
  write_file(dir, "job-1.scene", "cornell");
  vf_farm farm;
  open_farm(&farm, dir);
  CHECK_INT_EQ(vf_state_load(&farm), VF_OK);
  vf_job *j = vf_farm_job(&farm, 1);
  CHECK(j != NULL);
  if (j) CHECK_STR_CONTAINS(j->name, "caf? ?");
  vf_farm_destroy(&farm);
}

static void test_damaged_job_files_are_refused_naming_the_file(void) {
  char dir[4200], text[4096], detail[2048], path[8192];
  int err;
  fresh_dir(dir, sizeof dir, "damaged_files");
  job_list(text, sizeof text, 3, NULL, NULL);
  write_file(dir, "state.json", text);
  /* No scene file. */
  err = load(dir, detail, sizeof detail);
  CHECK_INT_EQ(err, VF_ENOENT);
  CHECK_STR_CONTAINS(detail, "job-1.scene");
  write_file(dir, "job-1.scene", "cornell");
  /* A film that is not an EXR, or of another job (another size): the job comes up failed,
   * naming the file (test_a_broken_film_fails_its_job_alone). */
  write_file(dir, "job-1.exr", "this is no film");
  CHECK_INT_EQ(load_failed(dir, detail, sizeof detail), 1);
  CHECK_STR_CONTAINS(detail, "job-1.exr");
  vf_film *film = NULL;
  CHECK_INT_EQ(vf_film_create(W * 2, H, &film), VF_OK);
  memcpy(film->scene_hash, scene_hash, 32);
  snprintf(film->settings_text, sizeof film->settings_text, "%s", settings);
  snprintf(path, sizeof path, "%s/job-1.exr", dir);
  CHECK_INT_EQ(vf_film_write(film, path), VF_OK);
  vf_film_destroy(film);
  CHECK_INT_EQ(load_failed(dir, detail, sizeof detail), 1);
  CHECK_STR_CONTAINS(detail, "job-1.exr: does not belong to job 1: film is 16x4, job 1 is 8x4");
  unlink(path);
  /* A damaged file table. */
  write_file(dir, "job-1.files", "[{\"name\": \"a.ply\"}]");
  err = load(dir, detail, sizeof detail);
  CHECK_INT_EQ(err, VF_EINVAL);
  CHECK_STR_CONTAINS(detail, "job-1.files: entry 0");
  /* A job list that says there is a reference, which is not there. */
  snprintf(path, sizeof path, "%s/job-1.files", dir);
  unlink(path);
  job_list(text, sizeof text, 3, "reference", "true");
  write_file(dir, "state.json", text);
  err = load(dir, detail, sizeof detail);
  CHECK_INT_EQ(err, VF_ENOENT);
  CHECK_STR_CONTAINS(detail, "job-1.reference.exr");
}

static void test_format_1_is_read(void) {
  char dir[4200], text[4096];
  fresh_dir(dir, sizeof dir, "format1");
  write_file(dir, "job-1.scene", "cornell");
  /* Format 1 had no first iteration, and any integer priority ("higher first"). */
  const char *change[][2] = {{"first_iteration", NULL}, {"priority", "-3"}};
  for (int i = 0; i < 2; i++) {
    job_list(text, sizeof text, 1, change[i][0], change[i][1]);
    write_file(dir, "state.json", text);
    vf_farm farm;
    open_loaded(&farm, dir);
    CHECK_INT_EQ(farm.num_jobs, 1);
    if (farm.num_jobs == 1) {
      CHECK_INT_EQ(farm.jobs[0]->priority, i == 0 ? 2 : 1);
      CHECK_INT_EQ(farm.jobs[0]->first, 0);
      CHECK_NEAR(farm.jobs[0]->seconds, 1.5, 0.0);
    }
    CHECK_INT_EQ(farm.next_job_id, 2);
    vf_farm_destroy(&farm);
  }
}

static void test_one_coordinator_per_directory(void) {
  char dir[4200];
  snprintf(dir, sizeof dir, "%s/locked", root);
  int fd = -1, fd2 = -1;
  CHECK_INT_EQ(vf_state_lock(dir, &fd), VF_OK);
  int err = vf_state_lock(dir, &fd2);
  CHECK_INT_EQ(err, VF_EIO);
  CHECK_STR_CONTAINS(vf_error_detail(err), "another coordinator uses this state directory");
  CHECK_INT_EQ(fd2, -1);
  close(fd);
  CHECK_INT_EQ(vf_state_lock(dir, &fd2), VF_OK); /* free again */
  close(fd2);
}

static void test_a_refused_jobs_files_are_removed(void) {
  char dir[4200], path[8192];
  vf_farm farm;
  fresh_farm(&farm, dir, sizeof dir, "remove");
  vf_job *j = add_job(&farm, 0, "{}", 0, 10);
  if (j == NULL) return;
  const uint8_t h[32] = {9};
  CHECK_INT_EQ(vf_blob_table_add(&j->files, "a.ply", h, 1), VF_OK);
  CHECK_INT_EQ(vf_state_save_scene(dir, j), VF_OK);
  CHECK_INT_EQ(vf_state_save_film(dir, j), VF_OK);
  vf_state_remove_job_files(dir, j->id);
  const char *ext[] = {".scene", ".files", ".exr"};
  for (int i = 0; i < 3; i++) {
    snprintf(path, sizeof path, "%s/job-1%s", dir, ext[i]);
    if (access(path, F_OK) == 0) CHECK_FAIL_("%s is still there", path);
  }
  vf_farm_destroy(&farm);
}

/* A state directory deleted under a running coordinator, or emptied with the directory left
 * (a deletion that lost a race with a file being written), is made again and filled: scene
 * and job list at once or at the next checkpoint, the film by it; neither when nothing is
 * wrong. */
static void test_a_deleted_or_emptied_directory_is_made_again(void) {
  char dir[4200], path[8192];
  const char *files[] = {"state.json", "job-1.scene", "job-1.exr", "lock"};
  for (int emptied = 0; emptied < 2; emptied++) {
    vf_farm farm;
    snprintf(dir, sizeof dir, "%s/recreate", root);
    vf_file_remove_tree(dir);
    open_farm(&farm, dir);
    CHECK_INT_EQ(vf_state_lock(dir, &farm.state_lock_fd), VF_OK);
    vf_job *j = add_job(&farm, 1, "cornell", 0, 10);
    if (j == NULL) return;
    float rgb[3 * W * H] = {0};
    CHECK_INT_EQ(vf_film_add_iteration(j->film, 0, rgb, rgb, NULL), VF_OK);
    CHECK_INT_EQ(vf_state_save_scene(dir, j), VF_OK);
    j->film_dirty = farm.state_dirty = 1;
    CHECK_INT_EQ(vf_checkpoint_write(&farm, 0), VF_OK);
    CHECK_INT_EQ(vf_state_recreate(&farm), 0); /* all there */
    if (emptied) {
      for (int i = 0; i < 4; i++) {
        snprintf(path, sizeof path, "%s/%s", dir, files[i]);
        CHECK_INT_EQ(unlink(path), 0);
      }
    } else {
      vf_file_remove_tree(dir);
      CHECK(access(dir, F_OK) != 0);
    }
    CHECK_INT_EQ(vf_checkpoint_write(&farm, 0), VF_OK); /* makes it again, then writes */
    struct stat st;
    CHECK_INT_EQ(fstat(farm.state_lock_fd, &st), 0);
    CHECK_INT_EQ(st.st_nlink, 1); /* the new lock has its name */
    for (int i = 0; i < 4; i++) {
      snprintf(path, sizeof path, "%s/%s", dir, files[i]);
      if (access(path, F_OK) != 0) CHECK_FAIL_("%s (%s) was not made again", path, emptied ? "emptied" : "deleted");
    }
    int other = -1; /* and it is locked */
    CHECK_INT_EQ(vf_state_lock(dir, &other), VF_EIO);
    close(farm.state_lock_fd);
    vf_farm_destroy(&farm);
    vf_farm back;
    open_loaded(&back, dir);
    CHECK_INT_EQ(back.num_jobs, 1);
    if (back.num_jobs == 1) CHECK_INT_EQ(vf_job_done(back.jobs[0]), 1);
    vf_farm_destroy(&back);
  }
}

int main(void) {
  vf_log_set_quiet(1);
  /* Any order parses; the job's text is the canonical one (W x H). */
  vf_settings s;
  if (vf_settings_parse(&s, "resolution=8x4 seed=1 alpha=0.75 radius_factor=0.003 max_path_length=10 algorithm=vcm") !=
          VF_OK ||
      vf_settings_format(&s, settings, sizeof settings) != VF_OK ||
      vf_file_temp_dir("vf_test_state", root, sizeof root) != VF_OK)
    return 1;
  RUN(test_every_job_is_read_back_as_written);
  RUN(test_a_finished_jobs_errors_come_back);
  RUN(test_format_3_is_read_with_old_settings_text);
  RUN(test_a_failed_checkpoint_is_an_event_of_its_job);
  RUN(test_failed_leases_and_blocks_outlive_a_restart);
  RUN(test_pause_and_requirements_outlive_a_restart);
  RUN(test_a_failed_lease_is_durable_within_a_tick);
  RUN(test_stopping_writes_only_changed_films);
  RUN(test_an_empty_directory_is_an_empty_farm);
  RUN(test_a_stop_not_yet_durable_is_written_active);
  RUN(test_a_damaged_job_list_is_refused_naming_the_problem);
  RUN(test_damaged_job_files_are_refused_naming_the_file);
  RUN(test_a_broken_film_fails_its_job_alone);
  RUN(test_format_1_is_read);
  RUN(test_one_coordinator_per_directory);
  RUN(test_a_deleted_or_emptied_directory_is_made_again);
  RUN(test_a_refused_jobs_files_are_removed);
  RUN(test_a_saved_name_that_is_not_utf8_loads_sanitized);
  vf_file_remove_tree(root);
  return check_finish();
}
