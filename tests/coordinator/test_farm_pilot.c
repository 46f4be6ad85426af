/* Farm jobs with a pilot (coordinator/job.h, leases.c, results.c, partial.c), in process: a
 * job of a 128x64 film with a pilot of 4 iterations and one registered worker. Checks that
 * its first leases are of the pilot, whose parts merge into the job's pilot film and never
 * into its image, that the allocation is computed once the pilot is complete, exactly as
 * from the whole pilot's film, kept as a blob and handed to the leases that follow, that a
 * part of the image rendered with another allocation (or none) is refused, and that a
 * pilot film written to the state directory and read back resumes the pilot. A job
 * submitted with its allocation (protocol 12) runs no pilot, has it in its film (durable
 * before the answer: a farm loaded from the state directory after it resumes with it) with
 * the seconds the client's pilots took in its times (protocol 13); one continuing a film
 * from iteration K (`submit --allocation-from --start-iteration K`) leases from K with it;
 * and an allocation of the
 * wrong size, of invalid counts, or on a job without a pilot or with auto choosing by
 * pilots is refused, as are pilot seconds out of range or without an allocation, and
 * merging turned off in a pixel only for vcm. */
#include "check.h"
#include "common/allocation.h"
#include "common/blob.h"
#include "common/error.h"
#include "common/film_wire.h"
#include "common/settings.h"
#include "coordinator/events.h"
#include "coordinator/farm.h"
#include "coordinator/jobs.h"
#include "coordinator/state.h"
#include "farm_calls.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define TIMEOUT 15.0
#define PILOT 4
#define W 128
#define H 64

static char dir[64];
static const uint8_t scene_hash[32] = {7, 7, 7};
static char settings[512];

typedef struct {
  vf_farm farm;
  uint64_t worker, lease, job, begin, end;
  int pilot;                  /* the lease is a pilot's */
  int has_allocation;         /* it names an allocation */
  uint8_t allocation_hash[32]; /* that allocation's hash */
  double now;
} fixture;

static void lease(fixture *f) {
  vf_farm_reply r;
  CHECK(farm_request_lease(&f->farm, f->now, f->worker, &r));
  f->lease = r.lease.lease_id;
  f->begin = r.lease.begin;
  f->end = r.lease.end;
  f->pilot = r.lease.pilot;
  f->has_allocation = r.lease.allocation != NULL && r.lease.allocation->hash.len == 32;
  if (f->has_allocation) {
    memcpy(f->allocation_hash, r.lease.allocation->hash.data, 32);
    CHECK_INT_EQ(r.lease.allocation->size, W * H);
  }
  vf_farm_reply_release(&r);
}

static void setup(fixture *f, uint64_t iterations) {
  memset(f, 0, sizeof *f);
  vf_farm_config config = {dir, TIMEOUT, 1000.0, 0.0};
  vf_farm_init(&f->farm, &config);
  f->now = 1000.0;
  f->job = farm_submit_builtin(&f->farm, f->now, "pilot", "cornell", scene_hash, settings, iterations, 0.0);
  f->worker = farm_register(&f->farm, f->now, "w");
  /* A fast worker, so that its lease covers the whole free range. */
  f->farm.workers[0].rate = 1e6;
  lease(f);
}

/* The film of iterations [begin, end) with made-up but valid sums: a pilot's (pilot set),
 * or one of the image with the allocation `samples`. */
static vf_film *part_film(uint64_t begin, uint64_t end, int pilot, const uint8_t *samples) {
  vf_film *film;
  if (vf_film_create(W, H, &film) != VF_OK) return NULL;
  memcpy(film->scene_hash, scene_hash, 32);
  snprintf(film->settings_text, sizeof film->settings_text, "%s", settings);
  film->pilot = pilot;
  if (samples) vf_film_set_samples(film, samples);
  float *rgb = malloc(3 * W * H * sizeof *rgb);
  for (uint64_t k = begin; k < end; k++) {
    /* a noisy left half and a quiet right half: the allocation differs between them */
    for (int i = 0; i < 3 * W * H; i++)
      rgb[i] = (i / 3) % W < W / 2 ? (float)((i * 7 + k * 13) % 17) / 17.0f : 0.5f + 0.01f * (float)(k % 2);
    vf_film_add_iteration(film, k, rgb, rgb, NULL);
  }
  free(rgb);
  film->render_seconds = 0.5;
  return film;
}

/* Sends [begin, end) as a part of the fixture's lease, marked a pilot's or not, naming
 * `allocation` (32 bytes, or NULL for none); its pixels from `film`. */
static int send_part(fixture *f, const vf_film *film, uint64_t begin, int pilot, const uint8_t *allocation,
                     farm_sender *s) {
  Vcmfarm__LeaseResult m = VCMFARM__LEASE_RESULT__INIT;
  m.worker_id = f->worker;
  m.lease_id = f->lease;
  m.job_id = f->job;
  m.begin = begin;
  m.pilot = pilot;
  if (allocation) m.allocation = (ProtobufCBinaryData){32, (uint8_t *)allocation};
  s->farm = &f->farm;
  s->now = f->now;
  return vf_film_send_tiles(film, &m, VF_FILM_TILES_PER_MESSAGE, farm_send_one, s);
}

static vf_job *job_of(fixture *f) { return vf_farm_job(&f->farm, f->job); }

/* The allocation the whole pilot's film decides, computed here as the local render does. */
static void expected_allocation(uint8_t *samples) {
  vf_film *pilot = part_film(0, PILOT, 1, NULL);
  CHECK_INT_EQ(vf_allocation_compute(pilot, samples, NULL), VF_OK);
  vf_film_destroy(pilot);
}

static void test_pilot_parts_decide_the_allocation_once(void) {
  fixture f;
  setup(&f, 8);
  CHECK(f.pilot);
  CHECK(!f.has_allocation);
  CHECK_INT_EQ(f.begin, 0);
  CHECK_INT_EQ(f.end, PILOT); /* the pilot first, however fast the worker */
  vf_film *first = part_film(0, 2, 1, NULL), *second = part_film(2, PILOT, 1, NULL);
  farm_sender s = {0};
  CHECK_INT_EQ(send_part(&f, first, 0, 1, NULL, &s), 1);
  CHECK_STR_CONTAINS(s.message, "merged");
  CHECK_INT_EQ(vf_job_pilot_done(job_of(&f)), 2);
  CHECK_INT_EQ(vf_iterset_count(&job_of(&f)->film->iterations), 0); /* nothing of the image */
  CHECK(job_of(&f)->film->samples == NULL);
  CHECK_INT_EQ(send_part(&f, first, 0, 1, NULL, &s), 1); /* sent again: acknowledged, not counted */
  CHECK_STR_CONTAINS(s.message, "already merged");
  CHECK_INT_EQ(send_part(&f, second, 2, 1, NULL, &s), 1);
  CHECK_STR_CONTAINS(s.message, "merged");
  vf_job *job = job_of(&f);
  CHECK(job->film->samples != NULL);
  CHECK(job->pilot_film == NULL);
  CHECK_INT_EQ(vf_job_pilot_done(job), PILOT);
  CHECK_INT_EQ(vf_iterset_count(&job->film->iterations), 0);
  uint8_t expected[W * H];
  expected_allocation(expected);
  CHECK(memcmp(job->film->samples, expected, sizeof expected) == 0);
  size_t differ = 0;
  for (size_t i = 1; i < sizeof expected; i++) differ += expected[i] != expected[0];
  CHECK(differ > 0); /* not all one count: the test can tell allocations apart */
  uint8_t hash[32];
  vf_blob_hash(expected, sizeof expected, hash);
  CHECK(memcmp(job->allocation_hash, hash, 32) == 0);
  uint64_t size = 0;
  CHECK_INT_EQ(vf_blob_store_has(dir, hash, &size), 1); /* where workers fetch it */
  CHECK_INT_EQ(size, W * H);
  CHECK(job->allocation_summary[0] != '\0');
  /* The job's own iterations now, from 0, with the allocation. */
  lease(&f);
  CHECK(!f.pilot);
  CHECK(f.has_allocation);
  CHECK(memcmp(f.allocation_hash, hash, 32) == 0);
  CHECK_INT_EQ(f.begin, 0);
  CHECK_INT_EQ(f.end, 8);
  vf_film_destroy(first);
  vf_film_destroy(second);
  vf_farm_destroy(&f.farm);
}

/* The allocation computed, and the image's lease out: the fixture after the pilot. */
static void past_the_pilot(fixture *f, uint8_t *samples) {
  setup(f, 8);
  vf_film *pilot = part_film(0, PILOT, 1, NULL);
  farm_sender s = {0};
  CHECK_INT_EQ(send_part(f, pilot, 0, 1, NULL, &s), 1);
  vf_film_destroy(pilot);
  expected_allocation(samples);
  lease(f);
  CHECK(!f->pilot && f->has_allocation);
}

static void test_a_part_of_another_allocation_is_refused(void) {
  fixture f;
  uint8_t samples[W * H], other[W * H];
  past_the_pilot(&f, samples);
  memcpy(other, samples, sizeof other);
  other[0] = other[0] == 1 ? 2 : 1;
  uint8_t other_hash[32];
  vf_blob_hash(other, sizeof other, other_hash);
  vf_film *wrong = part_film(0, 3, 0, other), *right = part_film(0, 3, 0, samples);
  farm_sender s = {0};
  CHECK_INT_EQ(send_part(&f, wrong, 0, 0, other_hash, &s), 0);
  CHECK_STR_CONTAINS(s.message, "rendered with allocation");
  CHECK_INT_EQ(send_part(&f, right, 0, 0, NULL, &s), 0); /* naming none */
  CHECK_STR_CONTAINS(s.message, "allocation");
  CHECK_INT_EQ(vf_iterset_count(&job_of(&f)->film->iterations), 0);
  CHECK_INT_EQ(job_of(&f)->results_refused, 2);
  CHECK_INT_EQ(send_part(&f, right, 0, 0, f.allocation_hash, &s), 1);
  CHECK_STR_CONTAINS(s.message, "merged");
  CHECK_INT_EQ(vf_iterset_count(&job_of(&f)->film->iterations), 3);
  CHECK(memcmp(job_of(&f)->film->samples, samples, sizeof samples) == 0);
  vf_film_destroy(wrong);
  vf_film_destroy(right);
  vf_farm_destroy(&f.farm);
}

static void test_a_pilot_part_is_never_merged_into_the_image(void) {
  fixture f;
  setup(&f, 8);
  /* A part of the pilot's lease that claims to be of the image: refused. */
  uint8_t samples[W * H];
  expected_allocation(samples);
  uint8_t hash[32];
  vf_blob_hash(samples, sizeof samples, hash);
  vf_film *image = part_film(0, 2, 0, samples), *pilot = part_film(0, 2, 1, NULL);
  farm_sender s = {0};
  CHECK_INT_EQ(send_part(&f, image, 0, 0, hash, &s), 0);
  CHECK_STR_CONTAINS(s.message, "never merged into the image");
  CHECK_INT_EQ(vf_iterset_count(&job_of(&f)->film->iterations), 0);
  CHECK_INT_EQ(vf_job_pilot_done(job_of(&f)), 0);
  /* Films themselves: a pilot's never merges into one of the image, nor the other way. */
  vf_film *image_film = part_film(4, 6, 0, samples);
  CHECK_INT_EQ(vf_film_merge(image_film, pilot), VF_EMISMATCH);
  CHECK_INT_EQ(vf_film_merge(pilot, image_film), VF_EMISMATCH);
  vf_film_destroy(image_film);
  /* After the pilot, a pilot part sent for the image's lease: refused too. */
  vf_film *whole = part_film(0, PILOT, 1, NULL);
  CHECK_INT_EQ(send_part(&f, whole, 0, 1, NULL, &s), 1);
  vf_film_destroy(whole);
  lease(&f);
  CHECK(!f.pilot);
  CHECK_INT_EQ(send_part(&f, pilot, 0, 1, NULL, &s), 0);
  CHECK_STR_CONTAINS(s.message, "claims to be a pilot part");
  CHECK_INT_EQ(vf_iterset_count(&job_of(&f)->film->iterations), 0);
  vf_film_destroy(image);
  vf_film_destroy(pilot);
  vf_farm_destroy(&f.farm);
}

static void test_a_pilot_film_written_and_read_back_resumes_the_pilot(void) {
  fixture f;
  setup(&f, 8);
  vf_film *first = part_film(0, 3, 1, NULL);
  farm_sender s = {0};
  CHECK_INT_EQ(send_part(&f, first, 0, 1, NULL, &s), 1);
  vf_film_destroy(first);
  vf_job *job = job_of(&f);
  CHECK(job->pilot_dirty);
  CHECK_INT_EQ(vf_state_save_pilot(dir, job), VF_OK);
  CHECK(!job->pilot_dirty);
  char path[256];
  snprintf(path, sizeof path, "%s/job-%llu.pilot.exr", dir, (unsigned long long)f.job);
  vf_film *back = NULL;
  CHECK_INT_EQ(vf_film_read(path, &back), VF_OK);
  CHECK(back != NULL && back->pilot);
  CHECK_INT_EQ(back ? vf_iterset_count(&back->iterations) : 0, 3);
  /* A second job of the same pilot, as a restarted coordinator makes it: it takes the film
   * and leases only what is missing of the pilot. */
  vf_film *second = part_film(3, PILOT, 1, NULL);
  CHECK_INT_EQ(vf_film_merge(back, second), VF_OK);
  uint8_t samples[W * H], expected[W * H];
  CHECK_INT_EQ(vf_allocation_compute(back, samples, NULL), VF_OK);
  expected_allocation(expected);
  CHECK(memcmp(samples, expected, sizeof samples) == 0); /* parts in any grouping: one allocation */
  vf_film_destroy(back);
  vf_film_destroy(second);
  vf_farm_destroy(&f.farm);
}

/* Submits the job of the fixture's settings (or `settings_text`) from global iteration
 * `first` with the allocation `samples` of n bytes (NULL: none), put in the state
 * directory's blob store first as a client sends it, and the seconds the client's pilots
 * took (version 13). The reply's kind
 * and, for an error, its message into message. Its id, 0 if refused. */
static uint64_t submit_given(vf_farm *farm, const char *settings_text, uint64_t first, const uint8_t *samples,
                             size_t n, double pilot_render_seconds, double pilot_cpu_seconds, char *message,
                             size_t size) {
  uint8_t hash[32];
  if (samples) {
    vf_blob_hash(samples, n, hash);
    CHECK_INT_EQ(vf_blob_store_put(farm->config.state_dir, hash, samples, n), VF_OK);
  }
  Vcmfarm__Scene scene = VCMFARM__SCENE__INIT;
  scene.source_case = VCMFARM__SCENE__SOURCE_BUILTIN;
  scene.builtin = "cornell";
  Vcmfarm__BlobRef ref = VCMFARM__BLOB_REF__INIT;
  ref.name = "allocation";
  ref.hash = (ProtobufCBinaryData){32, hash};
  ref.size = n;
  Vcmfarm__SubmitJob sm = VCMFARM__SUBMIT_JOB__INIT;
  sm.name = "given";
  sm.scene = &scene;
  sm.scene_hash = (ProtobufCBinaryData){32, (uint8_t *)scene_hash};
  sm.settings = (char *)settings_text;
  sm.iterations = 8;
  sm.first_iteration = first;
  sm.priority = 1;
  sm.allocation = samples ? &ref : NULL;
  sm.pilot_render_seconds = pilot_render_seconds;
  sm.pilot_cpu_seconds = pilot_cpu_seconds;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_SUBMIT;
  q.submit = &sm;
  vf_farm_reply r;
  vf_farm_handle(farm, &q, 1000.0, &r);
  uint64_t id = r.env.body_case == VCMFARM__ENVELOPE__BODY_SUBMITTED ? r.submitted.job_id : 0;
  snprintf(message, size, "%s", r.env.body_case == VCMFARM__ENVELOPE__BODY_ERROR ? r.env.error->message : "");
  vf_farm_reply_release(&r);
  return id;
}

static uint64_t submit_with_allocation(vf_farm *farm, const char *settings_text, const uint8_t *samples, size_t n,
                                       char *message, size_t size) {
  return submit_given(farm, settings_text, 0, samples, n, 0.0, 0.0, message, size);
}

/* A farm on the state directory `name` (in config) with the fixture's job submitted from
 * iteration `first` with the expected allocation (samples, its hash into hash) and the
 * client's pilot seconds: it runs no pilot, and its first lease, to a registered worker,
 * is [first, first + 8) naming the allocation. The job, or NULL (the case failed). */
static vf_job *given_job(fixture *f, vf_farm_config *config, char *state, size_t size, const char *name,
                         uint64_t first, double render_seconds, double cpu_seconds, uint8_t samples[W * H],
                         uint8_t hash[32]) {
  char message[512];
  snprintf(state, size, "%s/%s", dir, name);
  CHECK(mkdir(state, 0700) == 0);
  memset(f, 0, sizeof *f);
  *config = (vf_farm_config){state, TIMEOUT, 1000.0, 0.0};
  vf_farm_init(&f->farm, config);
  f->now = 1000.0;
  expected_allocation(samples);
  vf_blob_hash(samples, W * H, hash);
  f->job = submit_given(&f->farm, settings, first, samples, W * H, render_seconds, cpu_seconds, message,
                        sizeof message);
  CHECK(f->job != 0);
  vf_job *job = job_of(f);
  CHECK(job != NULL && job->film->samples != NULL && !vf_job_in_pilot(job));
  if (job == NULL || job->film->samples == NULL) return NULL;
  CHECK_INT_EQ(job->first, first);
  CHECK(job->film->render_seconds == render_seconds && job->film->cpu_seconds == cpu_seconds);
  CHECK(memcmp(job->film->samples, samples, W * H) == 0);
  CHECK(memcmp(job->allocation_hash, hash, 32) == 0);
  CHECK_INT_EQ(vf_job_pilot_done(job), PILOT);
  CHECK(job->allocation_summary[0] != '\0');
  f->worker = farm_register(&f->farm, f->now, "w");
  f->farm.workers[0].rate = 1e6;
  lease(f);
  CHECK(!f->pilot);
  CHECK(f->has_allocation);
  CHECK(memcmp(f->allocation_hash, hash, 32) == 0);
  CHECK_INT_EQ(f->begin, first);
  CHECK_INT_EQ(f->end, first + 8);
  return job;
}

/* A coordinator started on the state directory of config now (no checkpoint since the
 * submission) resumes job `id` from `first` with its allocation and seconds. */
static void check_given_job_resumes(const vf_farm_config *config, uint64_t id, uint64_t first,
                                    const uint8_t samples[W * H], const uint8_t hash[32], double render_seconds,
                                    double cpu_seconds) {
  vf_farm after;
  vf_farm_init(&after, config);
  CHECK_INT_EQ(vf_state_load(&after), VF_OK);
  const vf_job *back = vf_farm_job(&after, id);
  CHECK(back != NULL && back->film->samples != NULL && !vf_job_in_pilot(back));
  if (back != NULL && back->film->samples != NULL) {
    CHECK_INT_EQ(back->first, first);
    CHECK(memcmp(back->film->samples, samples, W * H) == 0);
    CHECK(memcmp(back->allocation_hash, hash, 32) == 0);
    CHECK(back->film->render_seconds == render_seconds && back->film->cpu_seconds == cpu_seconds);
  }
  vf_farm_destroy(&after);
}

/* The client's pilots took 2.5 s of wall time and 4 of CPU: the film counts them. */
static void test_a_job_submitted_with_its_allocation_runs_no_pilot(void) {
  char state[128];
  fixture f;
  vf_farm_config config;
  uint8_t samples[W * H], hash[32];
  vf_job *job = given_job(&f, &config, state, sizeof state, "given", 0, 2.5, 4.0, samples, hash);
  if (job == NULL) return;
  /* One pilot_done event, the submission's: pausing and resuming the job adds none. */
  for (int pause = 1; pause >= 0; pause--) {
    vf_farm_reply r;
    vf_farm_reply_init(&r);
    vf_jobs_pause(&f.farm, f.job, pause, &r);
    vf_farm_reply_release(&r);
  }
  int pilot_events = 0;
  for (unsigned i = 0; i < job->events.count; i++)
    pilot_events += strcmp(vf_events_at(&job->events, i)->kind, "pilot_done") == 0;
  CHECK_INT_EQ(pilot_events, 1);
  /* Its film was written before the answer. */
  vf_farm_destroy(&f.farm);
  check_given_job_resumes(&config, f.job, 0, samples, hash, 2.5, 4.0);
}

/* `submit --allocation-from FILM --start-iteration K`, continuing a film elsewhere: the job
 * from iteration 1000 with the film's allocation leases from 1000 with it, across a
 * restart too. */
static void test_a_job_continued_with_its_allocation_starts_where_asked(void) {
  char state[128];
  fixture f;
  vf_farm_config config;
  uint8_t samples[W * H], hash[32];
  if (given_job(&f, &config, state, sizeof state, "continued", 1000, 0.0, 0.0, samples, hash) == NULL) return;
  vf_farm_destroy(&f.farm);
  check_given_job_resumes(&config, f.job, 1000, samples, hash, 0.0, 0.0);
}

static void test_allocations_that_are_refused(void) {
  fixture f;
  setup(&f, 8);
  char message[512];
  uint8_t samples[W * H];
  expected_allocation(samples);
  /* One count short of the film's pixels. */
  CHECK_INT_EQ(submit_with_allocation(&f.farm, settings, samples, sizeof samples - 1, message, sizeof message), 0);
  CHECK_STR_CONTAINS(message, "allocation: 8191 counts, the job's film has 8192 pixels");
  /* A count that is no allocation's. */
  uint8_t bad[W * H];
  memcpy(bad, samples, sizeof bad);
  bad[W * 3 + 5] = 3;
  CHECK_INT_EQ(submit_with_allocation(&f.farm, settings, bad, sizeof bad, message, sizeof message), 0);
  CHECK_STR_CONTAINS(message, "allocation");
  CHECK_STR_CONTAINS(message, "pixel 389");
  /* Pilot seconds out of range, or without an allocation. */
  CHECK_INT_EQ(submit_given(&f.farm, settings, 0, samples, sizeof samples, -1.0, 1.0, message, sizeof message), 0);
  CHECK_STR_CONTAINS(message, "pilot_render_seconds -1, pilot_cpu_seconds 1: seconds from 0 to 1e9");
  CHECK_INT_EQ(submit_given(&f.farm, settings, 0, samples, sizeof samples, 1.0, NAN, message, sizeof message), 0);
  CHECK_STR_CONTAINS(message, "seconds from 0 to 1e9");
  CHECK_INT_EQ(submit_given(&f.farm, settings, 0, samples, sizeof samples, 1.0, 2e9, message, sizeof message), 0);
  CHECK_STR_CONTAINS(message, "seconds from 0 to 1e9");
  CHECK_INT_EQ(submit_given(&f.farm, settings, 0, NULL, 0, 1.0, 1.0, message, sizeof message), 0);
  CHECK_STR_CONTAINS(message, "pilot seconds without an allocation");
  /* A job without a pilot, and auto choosing by pilots. */
  vf_settings s;
  vf_settings_default(&s);
  s.width = W;
  s.height = H;
  char text[512];
  vf_settings_format(&s, text, sizeof text);
  CHECK_INT_EQ(submit_with_allocation(&f.farm, text, samples, sizeof samples, message, sizeof message), 0);
  CHECK_STR_CONTAINS(message, "the job's settings have no pilot");
  s.pilot = PILOT;
  s.algorithm = VF_ALGO_AUTO;
  vf_settings_format(&s, text, sizeof text);
  CHECK_INT_EQ(submit_with_allocation(&f.farm, text, samples, sizeof samples, message, sizeof message), 0);
  CHECK_STR_CONTAINS(message, "auto with a pilot");
  /* Merging turned off in a pixel (allocation.h): a vcm job's, not a bpt job's. */
  memcpy(bad, samples, sizeof bad);
  bad[W * 2 + 1] |= VF_ALLOCATION_NO_MERGING;
  s.algorithm = VF_ALGO_BPT;
  vf_settings_format(&s, text, sizeof text);
  CHECK_INT_EQ(submit_with_allocation(&f.farm, text, bad, sizeof bad, message, sizeof message), 0);
  CHECK_STR_CONTAINS(message, "pixel 257 turns vertex merging off, which only a vcm render does");
  CHECK_INT_EQ(f.farm.num_jobs, 1); /* the fixture's own */
  s.algorithm = VF_ALGO_VCM;
  vf_settings_format(&s, text, sizeof text);
  CHECK(submit_with_allocation(&f.farm, text, bad, sizeof bad, message, sizeof message) != 0);
  CHECK_INT_EQ(f.farm.num_jobs, 2);
  vf_farm_destroy(&f.farm);
}

int main(void) {
  snprintf(dir, sizeof dir, "/tmp/vf_test_farm_pilot_XXXXXX");
  if (mkdtemp(dir) == NULL) return 1;
  vf_settings s;
  vf_settings_default(&s);
  s.width = W;
  s.height = H;
  s.pilot = PILOT;
  vf_settings_format(&s, settings, sizeof settings);
  RUN(test_pilot_parts_decide_the_allocation_once);
  RUN(test_a_part_of_another_allocation_is_refused);
  RUN(test_a_pilot_part_is_never_merged_into_the_image);
  RUN(test_a_pilot_film_written_and_read_back_resumes_the_pilot);
  RUN(test_a_job_submitted_with_its_allocation_runs_no_pilot);
  RUN(test_a_job_continued_with_its_allocation_starts_where_asked);
  RUN(test_allocations_that_are_refused);
  char cmd[128];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
  if (system(cmd) != 0) return 1;
  return check_finish();
}
