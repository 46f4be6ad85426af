/* How often workers ship (coordinator/ship.c), in process: a farm of a 1920x1080 job and
 * many busy workers. The interval grows with the busy workers and the measured merge work
 * per part, grows at once and shrinks slowly, stays within its bounds, is told in every
 * Lease and HeartbeatAck, and leases last at least as long; while a worker's rate is
 * unknown its lease is bounded by time, and its heartbeats tell the rate. */
#include "check.h"

#include <stdio.h>
#include "common/error.h"
#include "common/settings.h"
#include "coordinator/farm.h"
#include "coordinator/log.h"
#include "coordinator/ship.h"

#include <stdlib.h>
#include <unistd.h>

static char dir[64];
static const uint8_t scene_hash[32] = {5, 5, 5};

typedef struct {
  vf_farm farm;
  double now;
  uint64_t job;
} fixture;

static void request(fixture *f, Vcmfarm__Envelope *q, vf_farm_reply *r) { vf_farm_handle(&f->farm, q, f->now, r); }

static void setup(fixture *f, int width, int height) {
  vf_farm_config config = {dir, 1e9, 20.0, 0.0};
  vf_farm_init(&f->farm, &config);
  f->now = 1000.0;
  vf_settings s;
  vf_settings_default(&s);
  s.width = width;
  s.height = height;
  char settings[512];
  vf_settings_format(&s, settings, sizeof settings);
  Vcmfarm__Scene scene = VCMFARM__SCENE__INIT;
  scene.source_case = VCMFARM__SCENE__SOURCE_BUILTIN;
  scene.builtin = "cornell";
  Vcmfarm__SubmitJob sm = VCMFARM__SUBMIT_JOB__INIT;
  sm.name = "ship";
  sm.scene = &scene;
  sm.scene_hash.data = (uint8_t *)scene_hash;
  sm.scene_hash.len = 32;
  sm.settings = settings;
  sm.iterations = 1000000000;
  sm.priority = 1;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_SUBMIT;
  q.submit = &sm;
  vf_farm_reply r;
  request(f, &q, &r);
  CHECK_INT_EQ(r.env.body_case, VCMFARM__ENVELOPE__BODY_SUBMITTED);
  f->job = r.submitted.job_id;
  vf_farm_reply_release(&r);
}

static uint64_t register_worker(fixture *f) {
  Vcmfarm__Register reg = VCMFARM__REGISTER__INIT;
  static int registered; /* distinct names: a name registering again is that worker restarted */
  char name[16];
  snprintf(name, sizeof name, "%s%d", "w", registered++);
  reg.name = name;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_REGISTER;
  q.register_ = &reg;
  vf_farm_reply r;
  request(f, &q, &r);
  uint64_t id = r.registered.worker_id;
  vf_farm_reply_release(&r);
  return id;
}

/* A lease request's reply: its body case, and the lease when there is one. */
static int ask_lease(fixture *f, uint64_t worker, Vcmfarm__Lease *out) {
  Vcmfarm__LeaseRequest lr = VCMFARM__LEASE_REQUEST__INIT;
  lr.worker_id = worker;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_LEASE_REQUEST;
  q.lease_request = &lr;
  vf_farm_reply r;
  request(f, &q, &r);
  int body = r.env.body_case;
  if (body == VCMFARM__ENVELOPE__BODY_LEASE && out) *out = r.lease;
  vf_farm_reply_release(&r);
  return body;
}

static uint32_t heartbeat(fixture *f, uint64_t worker, uint64_t lease, uint64_t done, double seconds) {
  Vcmfarm__Heartbeat m = VCMFARM__HEARTBEAT__INIT;
  m.worker_id = worker;
  m.lease_id = lease;
  m.iterations_done = done;
  m.seconds = seconds;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_HEARTBEAT;
  q.heartbeat = &m;
  vf_farm_reply r;
  request(f, &q, &r);
  CHECK_INT_EQ(r.env.body_case, VCMFARM__ENVELOPE__BODY_HEARTBEAT_ACK);
  CHECK(r.heartbeat_ack.lease_valid);
  uint32_t ms = r.heartbeat_ack.ship_interval_ms;
  vf_farm_reply_release(&r);
  return ms;
}

/* `parts` parts of `seconds` each of merge work, over `dt` seconds of ticks. */
static void load(fixture *f, int parts, double seconds, double dt) {
  for (int i = 0; i < parts; i++) vf_ship_part_work(&f->farm, seconds, 1);
  for (double t = 0; t < dt; t += 0.2) {
    f->now += 0.2;
    vf_ship_tick(&f->farm, f->now);
  }
}

static void test_unknown_rates_get_leases_bounded_by_time_then_sized_by_heartbeats(void) {
  fixture f;
  setup(&f, 1920, 1080);
  uint64_t w[4];
  Vcmfarm__Lease l[4];
  for (int i = 0; i < 4; i++) w[i] = register_worker(&f);
  /* No rate known: every worker gets a lease at once, a share of the range for a time. */
  for (int i = 0; i < 3; i++) {
    CHECK_INT_EQ(ask_lease(&f, w[i], &l[i]), VCMFARM__ENVELOPE__BODY_LEASE);
    CHECK_INT_EQ(l[i].seconds_ms, (uint32_t)(1000.0 * vf_ship_lease_seconds(&f.farm)));
    CHECK(l[i].end - l[i].begin >= 1000);
    CHECK(l[i].end - l[i].begin <= (uint64_t)VF_LEASE_UNKNOWN_RATE);
    CHECK(l[i].ship_interval_ms >= (uint32_t)(1000 * VF_SHIP_MIN_SECONDS));
  }
  /* A heartbeat tells the rate (1 iteration in 2 s): the next lease is sized by it. */
  heartbeat(&f, w[0], l[0].lease_id, 1, 2.0);
  CHECK_INT_EQ(ask_lease(&f, w[3], &l[3]), VCMFARM__ENVELOPE__BODY_LEASE);
  CHECK_INT_EQ(l[3].seconds_ms, 0);
  double lease_seconds = (double)(l[3].end - l[3].begin) * 2.0;
  CHECK_NEAR(lease_seconds, vf_ship_lease_seconds(&f.farm), 2.0);
  vf_farm_destroy(&f.farm);
}

static void test_interval_grows_with_merge_load_within_bounds(void) {
  fixture f;
  setup(&f, 1920, 1080);
  enum { N = 200 };
  uint64_t w[N];
  Vcmfarm__Lease l;
  for (int i = 0; i < N; i++) w[i] = register_worker(&f);
  CHECK_INT_EQ(ask_lease(&f, w[0], &l), VCMFARM__ENVELOPE__BODY_LEASE);
  heartbeat(&f, w[0], l.lease_id, 1, 2.0);
  for (int i = 1; i < N; i++) CHECK_INT_EQ(ask_lease(&f, w[i], NULL), VCMFARM__ENVELOPE__BODY_LEASE);
  load(&f, 0, 0.0, 1.0);
  double prior = f.farm.ship_seconds;
  /* The prior: N busy workers, parts of 1920x1080 pixels at the prior cost, load 1/2. */
  CHECK_NEAR(prior, N * 1920.0 * 1080.0 * VF_SHIP_PRIOR_SECONDS_PER_PIXEL / VF_SHIP_TARGET_LOAD, 1.0);
  /* Parts measured at four times the prior's cost: four times as long, at once. */
  double part = 4.0 * 1920.0 * 1080.0 * VF_SHIP_PRIOR_SECONDS_PER_PIXEL;
  load(&f, 4, part, 6.0);
  double grown = f.farm.ship_seconds;
  CHECK(grown > 2.0 * prior);
  CHECK_NEAR(grown, N * part / VF_SHIP_TARGET_LOAD, 0.05 * grown);
  CHECK_INT_EQ(heartbeat(&f, w[0], l.lease_id, 1, 2.0), vf_ship_interval_ms(&f.farm));
  /* Cheap parts again: it shrinks, but by at most a tenth per second. */
  load(&f, 4, part / 100.0, 6.0);
  CHECK(f.farm.ship_seconds >= 0.5 * grown);
  CHECK(f.farm.ship_seconds < grown);
  /* A huge cost: bounded above. */
  load(&f, 40, 1e6, 6.0);
  CHECK_NEAR(f.farm.ship_seconds, VF_SHIP_MAX_SECONDS, 1e-9);
  vf_farm_destroy(&f.farm);
}

static void test_one_worker_small_film_ships_at_the_minimum(void) {
  fixture f;
  setup(&f, 64, 64);
  uint64_t w = register_worker(&f);
  Vcmfarm__Lease l;
  CHECK_INT_EQ(ask_lease(&f, w, &l), VCMFARM__ENVELOPE__BODY_LEASE);
  load(&f, 4, 1e-3, 6.0);
  CHECK_NEAR(f.farm.ship_seconds, VF_SHIP_MIN_SECONDS, 1e-9);
  CHECK_INT_EQ(heartbeat(&f, w, l.lease_id, 1, 0.01), (uint32_t)(1000 * VF_SHIP_MIN_SECONDS));
  /* Leases last --lease-seconds when that is longer than the interval. */
  CHECK_NEAR(vf_ship_lease_seconds(&f.farm), 20.0, 1e-9);
  vf_farm_destroy(&f.farm);
}

int main(void) {
  snprintf(dir, sizeof dir, "/tmp/vf-test-ship-XXXXXX");
  if (mkdtemp(dir) == NULL) return 1;
  vf_log_set_quiet(1);
  RUN(test_unknown_rates_get_leases_bounded_by_time_then_sized_by_heartbeats);
  RUN(test_interval_grows_with_merge_load_within_bounds);
  RUN(test_one_worker_small_film_ships_at_the_minimum);
  char cmd[128];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
  if (system(cmd) != 0) return 1;
  return check_finish();
}
