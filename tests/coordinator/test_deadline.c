/* Deadlines and stalls (coordinator/deadline.h, vf_farm_stalled in coordinator/farm.h,
 * the blame rule of coordinator/workers.h): a lease says how long its job has left; a job
 * at its time limit closes instead of stopping, merges the final parts that arrive within
 * the grace period and stops once its leases have ended or the grace is over; a stall of
 * the coordinator itself loses no worker; a worker's silence counts against it only when
 * others were heard meanwhile. The farm in process, its requests as the loop hands them. */
#include "check.h"
#include "common/error.h"
#include "common/film.h"
#include "common/film_wire.h"
#include "common/settings.h"
#include "coordinator/deadline.h"
#include "coordinator/farm.h"
#include "coordinator/log.h"
#include "farm_calls.h"

#include <stdlib.h>

#define TIMEOUT 15.0

static char dir[64];
static const uint8_t scene_hash[32] = {7, 7, 7};
static char settings[512];

typedef struct {
  vf_farm farm;
  uint64_t job;
  uint64_t worker[3];
  double now;
} fixture;

static void request(fixture *f, Vcmfarm__Envelope *q, vf_farm_reply *r) { vf_farm_handle(&f->farm, q, f->now, r); }

/* A farm with one job of `iterations` and a time limit of `time_limit` seconds (0: none),
 * and `workers` registered workers w0, w1, ... */
static void setup(fixture *f, uint64_t iterations, double time_limit, int workers) {
  vf_farm_config config = {dir, TIMEOUT, 1000.0, 60.0};
  vf_farm_init(&f->farm, &config);
  f->now = 1000.0;
  f->farm.last_tick = f->now;
  f->job = farm_submit_builtin(&f->farm, f->now, "deadline", "cornell", scene_hash, settings, iterations, time_limit);
  for (int i = 0; i < workers; i++) {
    char name[8];
    snprintf(name, sizeof name, "w%d", i);
    f->worker[i] = farm_register(&f->farm, f->now, name);
    f->farm.workers[i].rate = 10.0; /* known: leases sized by rate, not bounded by time */
  }
}

static vf_job *job_of(fixture *f) { return vf_farm_job(&f->farm, f->job); }

/* Worker i asks for work: 1 and the lease (*out) when granted, 0 when told to wait. */
static int lease_request(fixture *f, int i, Vcmfarm__Lease *out) {
  vf_farm_reply r;
  int leased = farm_request_lease(&f->farm, f->now, f->worker[i], &r);
  if (leased) {
    *out = r.lease;
    out->scene = NULL; /* the reply's, released below */
  }
  vf_farm_reply_release(&r);
  return leased;
}

/* Worker i's heartbeat for its lease: its HeartbeatAck (lease_valid false when not one). */
static Vcmfarm__HeartbeatAck heartbeat(fixture *f, int i, uint64_t lease_id) {
  Vcmfarm__Heartbeat m = VCMFARM__HEARTBEAT__INIT;
  m.worker_id = f->worker[i];
  m.lease_id = lease_id;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_HEARTBEAT;
  q.heartbeat = &m;
  vf_farm_reply r;
  request(f, &q, &r);
  Vcmfarm__HeartbeatAck ack = VCMFARM__HEARTBEAT_ACK__INIT;
  if (r.env.body_case == VCMFARM__ENVELOPE__BODY_HEARTBEAT_ACK) ack = r.heartbeat_ack;
  vf_farm_reply_release(&r);
  return ack;
}

static void release(fixture *f, int i, uint64_t lease_id) {
  Vcmfarm__LeaseRelease m = VCMFARM__LEASE_RELEASE__INIT;
  m.worker_id = f->worker[i];
  m.lease_id = lease_id;
  m.failure = "";
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_RELEASE;
  q.release = &m;
  vf_farm_reply r;
  request(f, &q, &r);
  CHECK(r.env.body_case == VCMFARM__ENVELOPE__BODY_RESULT_ACK && r.result_ack.accepted);
  vf_farm_reply_release(&r);
}

/* Worker i ships the part [begin, end) of its lease (made-up, valid sums); the last
 * answer's message in *s. 1 when every message was accepted. */
static int send_part(fixture *f, int i, uint64_t lease_id, uint64_t begin, uint64_t end, farm_sender *s) {
  vf_film *film;
  if (vf_film_create(64, 32, &film) != VF_OK) return 0;
  memcpy(film->scene_hash, scene_hash, 32);
  snprintf(film->settings_text, sizeof film->settings_text, "%s", settings);
  float rgb[3 * 64 * 32];
  for (uint64_t k = begin; k < end; k++) {
    for (int p = 0; p < 3 * 64 * 32; p++) rgb[p] = (float)((p * 7 + k * 13) % 17) / 17.0f;
    vf_film_add_iteration(film, k, rgb, rgb, NULL);
  }
  film->render_seconds = 0.5;
  Vcmfarm__LeaseResult m = VCMFARM__LEASE_RESULT__INIT;
  m.worker_id = f->worker[i];
  m.lease_id = lease_id;
  m.job_id = f->job;
  m.begin = begin;
  s->farm = &f->farm;
  s->now = f->now;
  int rc = vf_film_send_tiles(film, &m, VF_FILM_TILES_PER_MESSAGE, farm_send_one, s);
  vf_film_destroy(film);
  return rc == 1;
}

/* The tick, with the time since the last one given to the job's clock. */
static void tick(fixture *f, double seconds) {
  f->now += seconds;
  vf_farm_tick(&f->farm, f->now);
}

static void test_a_lease_says_how_long_its_job_has_left(void) {
  fixture f;
  setup(&f, 1000, 60.0, 2);
  Vcmfarm__Lease l;
  CHECK(lease_request(&f, 0, &l));
  CHECK_INT_EQ(l.deadline_ms, 60000);
  job_of(&f)->seconds = 45.25;
  CHECK(lease_request(&f, 1, &l));
  CHECK_INT_EQ(l.deadline_ms, 14750);
  vf_farm_destroy(&f.farm);
  setup(&f, 1000, 0.0, 1);
  CHECK(lease_request(&f, 0, &l));
  CHECK_INT_EQ(l.deadline_ms, 0); /* no time limit */
  vf_farm_destroy(&f.farm);
}

static void test_the_final_part_after_the_time_limit_is_merged(void) {
  fixture f;
  setup(&f, 1000, 60.0, 2);
  Vcmfarm__Lease l;
  CHECK(lease_request(&f, 0, &l));
  vf_job *job = job_of(&f);
  job->seconds = 59.9;
  tick(&f, 0.2); /* the limit is reached: the job closes, and does not stop */
  CHECK(job->seconds >= 60.0);
  CHECK_INT_EQ(job->end, VF_JOB_ACTIVE);
  CHECK(job->closed_at > 0.0);
  Vcmfarm__HeartbeatAck ack = heartbeat(&f, 0, l.lease_id);
  CHECK(ack.lease_valid);
  CHECK(ack.deliver_now);
  Vcmfarm__Lease other;
  CHECK(!lease_request(&f, 1, &other)); /* a closing job is handed to no one */
  tick(&f, 2.0);
  farm_sender s;
  CHECK(send_part(&f, 0, l.lease_id, l.begin, l.begin + 7, &s));
  CHECK_STR_CONTAINS(s.message, "merged");
  CHECK_INT_EQ(job->end, VF_JOB_ACTIVE); /* its worker still holds the rest */
  release(&f, 0, l.lease_id);
  tick(&f, 0.2);
  CHECK_INT_EQ(job->end, VF_JOB_STOPPED);
  CHECK_INT_EQ(job->stop, VF_STOP_TIME);
  CHECK_STR_CONTAINS(job->message, "time limit of 60 s reached");
  CHECK_INT_EQ(vf_job_done(job), 7); /* every iteration the worker rendered */
  vf_farm_destroy(&f.farm);
}

static void test_the_grace_period_bounds_the_wait(void) {
  fixture f;
  setup(&f, 1000, 60.0, 1);
  Vcmfarm__Lease l;
  CHECK(lease_request(&f, 0, &l));
  vf_job *job = job_of(&f);
  job->seconds = 60.0;
  tick(&f, 0.2);
  double closed = f.now, grace = vf_deadline_grace(&f.farm);
  CHECK_NEAR(grace, TIMEOUT, 1e-9);
  while (f.now + 0.2 < closed + grace) {
    heartbeat(&f, 0, l.lease_id); /* alive, delivering nothing */
    tick(&f, 0.2);
  }
  CHECK_INT_EQ(job->end, VF_JOB_ACTIVE);
  tick(&f, 0.4);
  CHECK_INT_EQ(job->end, VF_JOB_STOPPED);
  CHECK_INT_EQ(job->stop, VF_STOP_TIME);
  CHECK(!heartbeat(&f, 0, l.lease_id).lease_valid); /* revoked */
  CHECK_INT_EQ(job->lease_failures, 0);
  vf_farm_destroy(&f.farm);
}

/* The coordinator paused through the whole grace period of a closing job: the final part
 * that waited in its socket is read at the first tick, and must still be merged. */
static void test_a_stall_extends_the_grace_period(void) {
  fixture f;
  setup(&f, 1000, 60.0, 1);
  Vcmfarm__Lease l;
  CHECK(lease_request(&f, 0, &l));
  vf_job *job = job_of(&f);
  job->seconds = 60.0;
  tick(&f, 0.2);
  CHECK(job->closed_at > 0.0);
  f.now += 20.0; /* > the grace period of 15 s */
  vf_farm_stalled(&f.farm, 19.8, f.now);
  farm_sender s;
  CHECK(send_part(&f, 0, l.lease_id, l.begin, l.begin + 4, &s));
  CHECK_STR_CONTAINS(s.message, "merged");
  vf_farm_tick(&f.farm, f.now);
  CHECK_INT_EQ(job->end, VF_JOB_ACTIVE);
  release(&f, 0, l.lease_id);
  tick(&f, 0.2);
  CHECK_INT_EQ(job->end, VF_JOB_STOPPED);
  CHECK_INT_EQ(vf_job_done(job), 4);
  vf_farm_destroy(&f.farm);
}

static void test_a_job_at_its_limit_with_no_lease_stops_at_once(void) {
  fixture f;
  setup(&f, 1000, 60.0, 1);
  Vcmfarm__Lease l;
  CHECK(lease_request(&f, 0, &l));
  farm_sender s;
  CHECK(send_part(&f, 0, l.lease_id, l.begin, l.begin + 3, &s));
  release(&f, 0, l.lease_id);
  job_of(&f)->seconds = 60.5;
  tick(&f, 0.2);
  CHECK_INT_EQ(job_of(&f)->end, VF_JOB_STOPPED);
  CHECK_INT_EQ(vf_job_done(job_of(&f)), 3);
  vf_farm_destroy(&f.farm);
}

/* SIGSTOP of the coordinator for 16 s with the default worker timeout of 15 s: the loop's
 * first tick after it finds every worker silent for 16 s. */
static void test_a_stalled_coordinator_loses_nobody(void) {
  fixture f;
  setup(&f, 1000, 0.0, 3);
  Vcmfarm__Lease l[3];
  for (int i = 0; i < 3; i++) CHECK(lease_request(&f, i, &l[i]));
  f.now += 16.2;
  vf_farm_stalled(&f.farm, 16.0, f.now);
  CHECK_INT_EQ(vf_farm_expire(&f.farm, f.now), 0);
  CHECK_INT_EQ(f.farm.num_workers, 3);
  for (int i = 0; i < 3; i++) CHECK(heartbeat(&f, i, l[i].lease_id).lease_valid);
  CHECK_INT_EQ(job_of(&f)->lease_failures, 0);
  CHECK_INT_EQ(job_of(&f)->end, VF_JOB_ACTIVE);
  /* Excused once: a worker silent for a whole timeout after it is lost as ever. */
  f.now += 10.0;
  heartbeat(&f, 0, l[0].lease_id);
  heartbeat(&f, 1, l[1].lease_id);
  f.now += 5.5;
  CHECK_INT_EQ(vf_farm_expire(&f.farm, f.now), 1);
  CHECK(vf_farm_find_worker(&f.farm, f.worker[2]) == NULL);
  vf_farm_destroy(&f.farm);
}

static void test_a_silence_counts_against_a_worker_only_when_others_were_heard(void) {
  fixture f;
  setup(&f, 1000, 0.0, 2);
  Vcmfarm__Lease l[2];
  for (int i = 0; i < 2; i++) CHECK(lease_request(&f, i, &l[i]));
  /* Both silent together (the coordinator cut off): lost, and no one's failure. */
  f.now += 16.0;
  CHECK_INT_EQ(vf_farm_expire(&f.farm, f.now), 2);
  CHECK_INT_EQ(job_of(&f)->lease_failures, 0);
  vf_farm_destroy(&f.farm);
  /* w0 silent while w1 is heard: w0's lease failed. */
  setup(&f, 1000, 0.0, 2);
  for (int i = 0; i < 2; i++) CHECK(lease_request(&f, i, &l[i]));
  f.now += 10.0;
  heartbeat(&f, 1, l[1].lease_id);
  f.now += 6.0;
  CHECK_INT_EQ(vf_farm_expire(&f.farm, f.now), 1);
  CHECK_INT_EQ(job_of(&f)->lease_failures, 1);
  CHECK(vf_farm_find_worker(&f.farm, f.worker[1]) != NULL);
  vf_farm_destroy(&f.farm);
}

int main(void) {
  vf_log_set_quiet(1);
  snprintf(dir, sizeof dir, "/tmp/vf_test_deadline_XXXXXX");
  if (mkdtemp(dir) == NULL) return 1;
  vf_settings s;
  vf_settings_default(&s);
  s.width = 64;
  s.height = 32;
  vf_settings_format(&s, settings, sizeof settings);
  RUN(test_a_lease_says_how_long_its_job_has_left);
  RUN(test_the_final_part_after_the_time_limit_is_merged);
  RUN(test_the_grace_period_bounds_the_wait);
  RUN(test_a_stall_extends_the_grace_period);
  RUN(test_a_job_at_its_limit_with_no_lease_stops_at_once);
  RUN(test_a_stalled_coordinator_loses_nobody);
  RUN(test_a_silence_counts_against_a_worker_only_when_others_were_heard);
  char cmd[128];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
  if (system(cmd) != 0) return 1;
  return check_finish();
}
