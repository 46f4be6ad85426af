/* Leases (coordinator/lease.h, the table; coordinator/leases.h, the farm's side): ranges
 * are cut from the free iterations only, so no iteration in the film or in an active lease
 * is leased again; an expired lease returns its range to the pool but stays findable for
 * late results, up to a limit; sizes are the worker's rate times the lease duration, at
 * most a fair share; a revoked lease is no longer valid to its worker's heartbeats and its
 * job is charged the time it really took. Failed leases (coordinator/poison.h): a worker
 * whose lease failed is blocked from the job until forgiven, failures on three workers in
 * a row fail the job, a merge clears them, and a worker registering again under its name
 * or lost without progress failed its lease. Tags (common/tags.h): a job is leased only to
 * workers satisfying its requirements, bad tags are refused naming them; a paused job gets
 * no new leases while those out stay valid. Fair share through the handlers: workers split
 * between jobs in the ratio of their priorities, a job only some may render getting those. */
#include "check.h"
#include "common/error.h"
#include "common/settings.h"
#include "coordinator/jobs.h"
#include "coordinator/leases.h"
#include "coordinator/state.h"
#include "coordinator/log.h"
#include "coordinator/poison.h"
#include "coordinator/workers.h"

#include <stdlib.h>
#include <unistd.h>

/* The free range of job 1 in [first, first + total) as "[b,e)", or "none". */
static const char *free_range(const vf_lease_table *t, const vf_iterset *done, uint64_t first, uint64_t total,
                              uint64_t max_size, uint64_t *free_count) {
  static char text[64];
  uint64_t b = 0, e = 0, n = 0;
  int rc = vf_lease_free_range(t, 1, done, first, total, max_size, &b, &e, &n);
  if (free_count) *free_count = n;
  if (rc < 0) return "error";
  if (rc == 0) return "none";
  snprintf(text, sizeof text, "[%llu,%llu)", (unsigned long long)b, (unsigned long long)e);
  return text;
}

#define CHECK_STR_EQ(got, want)                                                                    \
  do {                                                                                             \
    const char *g_ = (got), *w_ = (want);                                                          \
    if (strcmp(g_, w_) != 0) CHECK_FAIL_("%s: \"%s\", expected \"%s\"", #got, g_, w_);             \
  } while (0)

static uint64_t add(vf_lease_table *t, uint64_t job, uint64_t begin, uint64_t end) {
  uint64_t id = 0;
  CHECK_INT_EQ(vf_lease_add(t, job, 99, begin, end, 0.0, &id), VF_OK);
  return id;
}

static void test_free_range_is_the_first_free_one(void) {
  vf_lease_table t;
  vf_lease_table_init(&t);
  vf_iterset done;
  vf_iterset_init(&done);
  uint64_t n;
  CHECK_STR_EQ(free_range(&t, &done, 0, 100, 10, &n), "[0,10)");
  CHECK_INT_EQ(n, 100);
  CHECK_STR_EQ(free_range(&t, &done, 0, 100, UINT64_MAX, &n), "[0,100)");
  /* A job of global iterations [1000, 1010) (continuing a film) starts at 1000. */
  CHECK_STR_EQ(free_range(&t, &done, 1000, 10, 4, &n), "[1000,1004)");
  CHECK_INT_EQ(n, 10);
  vf_iterset_destroy(&done);
  vf_lease_table_destroy(&t);
}

static void test_free_range_skips_the_film_and_active_leases(void) {
  vf_lease_table t;
  vf_lease_table_init(&t);
  vf_iterset done;
  vf_iterset_init(&done);
  vf_iterset_add(&done, 0, 5);
  vf_iterset_add(&done, 50, 60);
  add(&t, 1, 5, 15);
  add(&t, 2, 15, 40); /* another job's lease takes nothing of this one */
  uint64_t n;
  /* Stops before the film's [50,60): a range is contiguous and free throughout. */
  CHECK_STR_EQ(free_range(&t, &done, 0, 100, UINT64_MAX, &n), "[15,50)");
  CHECK_INT_EQ(n, 100 - 5 - 10 - 10);
  vf_iterset_add(&done, 15, 50);
  CHECK_STR_EQ(free_range(&t, &done, 0, 100, UINT64_MAX, &n), "[60,100)");
  CHECK_INT_EQ(n, 40);
  vf_iterset_add(&done, 60, 100);
  CHECK_STR_EQ(free_range(&t, &done, 0, 100, UINT64_MAX, &n), "none");
  CHECK_INT_EQ(n, 0);
  /* Iterations of the film outside the job's range do not count as its free ones. */
  CHECK_STR_EQ(free_range(&t, &done, 90, 20, UINT64_MAX, &n), "[100,110)");
  CHECK_INT_EQ(n, 10);
  vf_iterset_destroy(&done);
  vf_lease_table_destroy(&t);
}

/* A farm's life in miniature: leases of random sizes granted, some merged (into `done`, the
 * film), some expired (their range returns to the pool), until nothing is free. Every
 * iteration is merged exactly once and no range granted ever overlaps the film or an
 * active lease. */
static void test_ranges_in_the_film_are_never_leased_twice(void) {
  vf_lease_table t;
  vf_lease_table_init(&t);
  vf_iterset done;
  vf_iterset_init(&done);
  const uint64_t first = 7, total = 500;
  unsigned rng = 12345, grants = 0, overlaps = 0, bad_merges = 0;
  for (int step = 0; step < 10000; step++) {
    rng = rng * 1103515245u + 12345u;
    uint64_t b, e, n;
    int rc = vf_lease_free_range(&t, 1, &done, first, total, 1 + (rng >> 16) % 11, &b, &e, &n);
    if (rc == 0 && t.count == 0) break;
    if (rc == 1) {
      grants++;
      for (uint64_t k = b; k < e; k++) overlaps += vf_iterset_contains(&done, k);
      for (size_t i = 0; i < t.count; i++)
        if (t.leases[i].state == VF_LEASE_ACTIVE && t.leases[i].begin < e && b < t.leases[i].end) overlaps++;
      add(&t, 1, b, e);
    }
    /* The oldest lease ends: merged two times in three, else its worker is lost. */
    if (t.count > 0 && (rc != 1 || (rng >> 8) % 3 == 0)) {
      vf_lease *l = &t.leases[0];
      if (l->state == VF_LEASE_ACTIVE && (rng >> 4) % 3 != 0) {
        bad_merges += vf_iterset_add(&done, l->begin, l->end) != VF_OK;
        vf_lease_remove(&t, l->id);
      } else if (l->state == VF_LEASE_ACTIVE) {
        vf_lease_expire(&t, l->id);
      } else {
        vf_lease_remove(&t, l->id);
      }
    }
  }
  CHECK_INT_EQ(overlaps, 0);
  CHECK_INT_EQ(bad_merges, 0);
  if (grants < 50) CHECK_FAIL_("%u grants, expected at least 50", grants);
  CHECK_INT_EQ(vf_iterset_count(&done), total);
  CHECK_INT_EQ(vf_iterset_next_free(&done, first), first + total);
  vf_iterset_destroy(&done);
  vf_lease_table_destroy(&t);
}

static void test_an_expired_lease_returns_its_range_to_the_pool(void) {
  vf_lease_table t;
  vf_lease_table_init(&t);
  vf_iterset done;
  vf_iterset_init(&done);
  uint64_t id = add(&t, 1, 0, 10);
  CHECK_INT_EQ(vf_lease_active_iterations(&t, 1), 10);
  CHECK_STR_EQ(free_range(&t, &done, 0, 30, UINT64_MAX, NULL), "[10,30)");
  vf_lease_expire(&t, id);
  CHECK_INT_EQ(vf_lease_active_iterations(&t, 1), 0);
  CHECK_STR_EQ(free_range(&t, &done, 0, 30, UINT64_MAX, NULL), "[0,30)");
  /* Still there, for a late result to be checked against. */
  vf_lease *l = vf_lease_find(&t, id);
  CHECK(l != NULL);
  if (l) CHECK_INT_EQ(l->state, VF_LEASE_EXPIRED);
  vf_lease_remove(&t, id);
  CHECK(vf_lease_find(&t, id) == NULL);
  CHECK_INT_EQ(t.count, 0);
  vf_iterset_destroy(&done);
  vf_lease_table_destroy(&t);
}

static void test_expired_leases_are_kept_up_to_a_limit(void) {
  vf_lease_table t;
  vf_lease_table_init(&t);
  enum { N = VF_LEASE_KEEP_EXPIRED + 20 };
  uint64_t *ids = malloc(N * sizeof *ids);
  uint64_t active = add(&t, 1, 1000000, 1000001);
  for (uint64_t i = 0; i < N; i++) {
    ids[i] = add(&t, 1, i, i + 1);
    vf_lease_expire(&t, ids[i]);
  }
  CHECK_INT_EQ(t.count, VF_LEASE_KEEP_EXPIRED + 1);
  CHECK(vf_lease_find(&t, ids[0]) == NULL);  /* the oldest forgotten */
  CHECK(vf_lease_find(&t, ids[19]) == NULL);
  CHECK(vf_lease_find(&t, ids[20]) != NULL); /* the newest kept */
  CHECK(vf_lease_find(&t, ids[N - 1]) != NULL);
  CHECK(vf_lease_find(&t, active) != NULL);  /* an active lease is never forgotten */
  free(ids);
  vf_lease_table_destroy(&t);
}

static void test_lease_ids_are_unique_and_never_zero(void) {
  vf_lease_table t;
  vf_lease_table_init(&t);
  unsigned zero = 0, repeated = 0;
  for (uint64_t i = 0; i < 2000; i++) {
    uint64_t id = add(&t, 1, i, i + 1);
    zero += id == 0;
    for (size_t k = 0; k + 1 < t.count; k++) repeated += t.leases[k].id == id;
  }
  CHECK_INT_EQ(zero, 0);
  CHECK_INT_EQ(repeated, 0);
  vf_lease_table_destroy(&t);
}

static void test_rendering_iterations_follow_heartbeats(void) {
  vf_lease_table t;
  vf_lease_table_init(&t);
  vf_lease *l = vf_lease_find(&t, add(&t, 1, 100, 110));
  add(&t, 2, 0, 50);
  CHECK_INT_EQ(vf_lease_rendering_iterations(&t, 1), 0);
  l->reported = 4; /* [100,104) rendered, not shipped */
  CHECK_INT_EQ(vf_lease_rendering_iterations(&t, 1), 4);
  l->begin = 103; /* a part [100,103) merged */
  CHECK_INT_EQ(vf_lease_rendering_iterations(&t, 1), 1);
  CHECK_INT_EQ(vf_lease_active_iterations(&t, 1), 7);
  l->reported = 1000; /* a worker's word is clamped to its lease */
  CHECK_INT_EQ(vf_lease_rendering_iterations(&t, 1), 7);
  vf_lease_expire(&t, l->id);
  CHECK_INT_EQ(vf_lease_rendering_iterations(&t, 1), 0);
  vf_lease_table_destroy(&t);
}

static void test_lease_size_is_a_fair_share(void) {
  CHECK_INT_EQ(vf_lease_size(0.0, 20.0, 1000, 1), 1);   /* rate unknown: one, to measure it */
  CHECK_INT_EQ(vf_lease_size(2.5, 20.0, 1000, 1), 50);  /* 20 s at 2.5 per second */
  CHECK_INT_EQ(vf_lease_size(100.0, 20.0, 1000, 4), 250); /* a fair share of what is left */
  CHECK_INT_EQ(vf_lease_size(100.0, 20.0, 1001, 4), 251); /* rounded up */
  CHECK_INT_EQ(vf_lease_size(100.0, 20.0, 3, 8), 1);    /* at least one */
  CHECK_INT_EQ(vf_lease_size(100.0, 20.0, 0, 0), 1);
  CHECK_INT_EQ(vf_lease_size(0.01, 20.0, 1000, 1), 1);
  CHECK_INT_EQ(vf_lease_size(1e12, 1e3, UINT64_MAX, 1), 1000000000);
}

/* ---- the farm's side: grants, heartbeats, revocation ---- */

typedef struct {
  vf_farm farm;
  vf_job *job;
  uint64_t worker[4];
  double now;
} farm_fixture;

static void farm_setup(farm_fixture *f, uint64_t iterations, int workers) {
  vf_farm_config config = {"/nonexistent/vf_test_lease", 15.0, 20.0, 60.0};
  vf_farm_init(&f->farm, &config);
  f->now = 100.0;
  vf_settings s;
  vf_settings_default(&s);
  s.width = s.height = 8;
  char settings[512];
  vf_settings_format(&s, settings, sizeof settings);
  const uint8_t hash[32] = {1};
  CHECK_INT_EQ(vf_job_create(1, "j", 1, 1, "cornell", 7, hash, 32, settings, 0, iterations, &f->job), VF_OK);
  CHECK_INT_EQ(vf_farm_add_job(&f->farm, f->job), VF_OK);
  for (int i = 0; i < workers; i++) {
    Vcmfarm__Register m = VCMFARM__REGISTER__INIT;
    char name[8]; /* distinct: a name registering again is that worker restarted */
    snprintf(name, sizeof name, "w%d", i);
    m.name = name;
    vf_farm_reply r;
    vf_farm_reply_init(&r);
    vf_workers_register(&f->farm, &m, f->now, &r);
    CHECK_INT_EQ(r.env.body_case, VCMFARM__ENVELOPE__BODY_REGISTERED);
    f->worker[i] = r.registered.worker_id;
    vf_farm_reply_release(&r);
  }
}

/* Worker i asks for work: its new lease, or NULL when it was told to wait. */
static vf_lease *grant(farm_fixture *f, int i) {
  vf_farm_reply r;
  vf_farm_reply_init(&r);
  vf_farm_worker *w = vf_farm_find_worker(&f->farm, f->worker[i]);
  vf_leases_grant(&f->farm, w, f->now, &r);
  uint64_t id = r.env.body_case == VCMFARM__ENVELOPE__BODY_LEASE ? r.lease.lease_id : 0;
  vf_farm_reply_release(&r);
  return vf_lease_find(&f->farm.leases, id);
}

static int heartbeat_valid(farm_fixture *f, int i, uint64_t lease_id) {
  Vcmfarm__Heartbeat m = VCMFARM__HEARTBEAT__INIT;
  m.worker_id = f->worker[i];
  m.lease_id = lease_id;
  vf_farm_reply r;
  vf_farm_reply_init(&r);
  vf_leases_heartbeat(&f->farm, vf_farm_find_worker(&f->farm, f->worker[i]), &m, &r);
  int valid = r.env.body_case == VCMFARM__ENVELOPE__BODY_HEARTBEAT_ACK && r.heartbeat_ack.lease_valid;
  vf_farm_reply_release(&r);
  return valid;
}

static void test_grants_are_sized_by_rate_and_fair_share(void) {
  farm_fixture f;
  farm_setup(&f, 100, 4);
  vf_lease *l = grant(&f, 0);
  CHECK(l != NULL);
  if (l) CHECK_INT_EQ(l->end - l->begin, 25); /* rate unknown: a fair share, bounded by time */
  for (int i = 0; i < 4; i++) vf_farm_find_worker(&f.farm, f.worker[i])->rate = 1000.0;
  l = grant(&f, 1); /* 20 s at 1000/s, but at most ceil(100 / 4) */
  CHECK(l != NULL);
  if (l) {
    CHECK_INT_EQ(l->begin, 25);
    CHECK_INT_EQ(l->end, 44); /* ceil(75 free / 4) */
  }
  /* Asking again while holding a lease gives it up: the same range is granted again. */
  l = grant(&f, 1);
  CHECK(l != NULL);
  if (l) CHECK_INT_EQ(l->begin, 25);
  vf_farm_destroy(&f.farm);
}

static void test_no_free_range_means_idle(void) {
  farm_fixture f;
  farm_setup(&f, 2, 3);
  CHECK(grant(&f, 0) != NULL);
  CHECK(grant(&f, 1) != NULL);
  vf_farm_reply r;
  vf_farm_reply_init(&r);
  vf_leases_grant(&f.farm, vf_farm_find_worker(&f.farm, f.worker[2]), f.now, &r);
  CHECK_INT_EQ(r.env.body_case, VCMFARM__ENVELOPE__BODY_IDLE);
  if (r.idle.retry_ms < 1 || r.idle.retry_ms > 500)
    CHECK_FAIL_("retry after %u ms, expected 1 to 500", r.idle.retry_ms);
  vf_farm_reply_release(&r);
  vf_farm_destroy(&f.farm);
}

static void test_a_revoked_lease_is_invalid_and_charged(void) {
  farm_fixture f;
  farm_setup(&f, 100, 3);
  for (int i = 0; i < 3; i++) vf_farm_find_worker(&f.farm, f.worker[i])->rate = 1.0;
  vf_lease *a = grant(&f, 0), *b = grant(&f, 1), *c = grant(&f, 2);
  CHECK(a != NULL && b != NULL && c != NULL);
  if (a == NULL || b == NULL || c == NULL) {
    vf_farm_destroy(&f.farm);
    return;
  }
  uint64_t ida = a->id, idb = b->id, idc = c->id;
  CHECK_INT_EQ(b->begin, 20); /* [0,20), [20,40), [40,60): 20 s at 1 per second each */
  CHECK_INT_EQ(c->begin, 40);
  CHECK(heartbeat_valid(&f, 0, ida));
  CHECK(!heartbeat_valid(&f, 1, ida)); /* not worker 1's */
  double charged = f.job->service;
  CHECK_NEAR(charged, 60.0, 1e-9);
  /* A late result of a's covering [10, 25) makes b moot, not c. */
  f.now += 5.0;
  vf_leases_revoke(&f.farm, f.job->id, 10, 25, ida, f.now);
  CHECK(heartbeat_valid(&f, 0, ida));
  CHECK(!heartbeat_valid(&f, 1, idb));
  CHECK(heartbeat_valid(&f, 2, idc));
  CHECK_INT_EQ(vf_farm_find_worker(&f.farm, f.worker[1])->lease_id, 0);
  b = vf_lease_find(&f.farm.leases, idb);
  CHECK(b != NULL); /* kept, expired, for its late results */
  if (b) CHECK_INT_EQ(b->state, VF_LEASE_EXPIRED);
  /* b was charged 20 s at its grant and took 5: its job gets 15 back. */
  CHECK_NEAR(f.job->service, charged - 15.0, 1e-9);
  CHECK_INT_EQ(vf_lease_active_iterations(&f.farm.leases, f.job->id), 40);
  vf_leases_end_job(&f.farm, f.job->id, f.now);
  CHECK(!heartbeat_valid(&f, 0, ida));
  CHECK(!heartbeat_valid(&f, 2, idc));
  CHECK_INT_EQ(vf_lease_active_iterations(&f.farm.leases, f.job->id), 0);
  vf_farm_destroy(&f.farm);
}

static void release(farm_fixture *f, int i, uint64_t lease_id, const char *failure, int want_accepted) {
  Vcmfarm__LeaseRelease m = VCMFARM__LEASE_RELEASE__INIT;
  m.worker_id = f->worker[i];
  m.lease_id = lease_id;
  m.failure = (char *)failure;
  vf_farm_reply r;
  vf_farm_reply_init(&r);
  vf_leases_release(&f->farm, vf_farm_find_worker(&f->farm, f->worker[i]), &m, f->now, &r);
  CHECK_INT_EQ(r.result_ack.accepted, want_accepted);
  vf_farm_reply_release(&r);
}

static void test_a_release_returns_the_lease_to_the_pool(void) {
  farm_fixture f;
  farm_setup(&f, 100, 2);
  vf_lease *a = grant(&f, 0);
  CHECK(a != NULL);
  uint64_t id = a ? a->id : 0;
  release(&f, 1, id, "", 0); /* not worker 1's to give back */
  release(&f, 0, id, "", 1);
  CHECK(vf_lease_find(&f.farm.leases, id) == NULL);
  CHECK_INT_EQ(f.job->end, VF_JOB_ACTIVE);
  CHECK_INT_EQ(f.job->lease_failures, 0);
  CHECK(grant(&f, 0) != NULL); /* handing back is no failure: not blocked */
  vf_farm_destroy(&f.farm);
}

static void test_a_reported_failure_blocks_the_worker_until_forgiven(void) {
  farm_fixture f;
  farm_setup(&f, 100, 2);
  vf_lease *a = grant(&f, 0);
  CHECK(a != NULL);
  release(&f, 0, a ? a->id : 0, "scene does not load:\nbad", 1);
  /* One worker failing is no reason to fail the job: the others may render it. */
  CHECK_INT_EQ(f.job->end, VF_JOB_ACTIVE);
  CHECK_INT_EQ(f.job->lease_failures, 1);
  const vf_event *e = vf_events_at(&f.job->events, f.job->events.count - 1);
  CHECK(e != NULL);
  if (e) {
    CHECK_STR_EQ(e->kind, "lease_failed");
    CHECK_STR_CONTAINS(e->message, "scene does not load:?bad"); /* no control characters */
  }
  CHECK(grant(&f, 0) == NULL); /* blocked from its only job: idle */
  CHECK_INT_EQ(f.job->schedule_idle, 0); /* the job is not idle for the others: it keeps its place */
  CHECK(grant(&f, 1) != NULL);
  f.now += 59.0;
  vf_poison_tick(&f.farm, f.now);
  CHECK(vf_poison_blocked(&f.farm, "w0", f.job->id, f.now));
  f.now += 2.0; /* the forgive time of 60 s is over */
  vf_poison_tick(&f.farm, f.now);
  CHECK(!vf_poison_blocked(&f.farm, "w0", f.job->id, f.now));
  CHECK(grant(&f, 0) != NULL);
  e = vf_events_at(&f.job->events, f.job->events.count - 1);
  if (e) CHECK_STR_EQ(e->kind, "worker_forgiven");
  vf_farm_destroy(&f.farm);
}

static void test_failures_on_three_workers_in_a_row_fail_the_job(void) {
  farm_fixture f;
  farm_setup(&f, 100, 4);
  for (int i = 0; i < 2; i++) {
    vf_lease *l = grant(&f, i);
    CHECK(l != NULL);
    release(&f, i, l ? l->id : 0, "renderer: out of memory", 1);
  }
  vf_lease *held = grant(&f, 3);
  CHECK(held != NULL);
  uint64_t held_id = held ? held->id : 0;
  CHECK_INT_EQ(f.job->end, VF_JOB_ACTIVE);
  vf_lease *l = grant(&f, 2);
  CHECK(l != NULL);
  release(&f, 2, l ? l->id : 0, "renderer: out of memory", 1);
  CHECK_INT_EQ(f.job->end, VF_JOB_FAILED);
  CHECK_INT_EQ(f.job->stop, VF_STOP_FAILED);
  CHECK_STR_CONTAINS(f.job->message, "3 workers in a row");
  CHECK_STR_CONTAINS(f.job->message, "w2: renderer: out of memory");
  CHECK(f.farm.state_dirty);
  CHECK(!heartbeat_valid(&f, 3, held_id)); /* every lease of the job ended */
  CHECK(grant(&f, 3) == NULL);
  vf_farm_destroy(&f.farm);
}

static void test_a_merge_clears_the_failures_in_a_row(void) {
  farm_fixture f;
  farm_setup(&f, 100, 4);
  for (int i = 0; i < 2; i++) {
    vf_lease *l = grant(&f, i);
    release(&f, i, l ? l->id : 0, "renderer: out of memory", 1);
  }
  CHECK_INT_EQ(f.job->failed_workers_count, 2);
  vf_film *part = NULL;
  CHECK_INT_EQ(vf_film_clone(f.job->film, &part), VF_OK);
  if (part) {
    CHECK_INT_EQ(vf_iterset_add(&part->iterations, 50, 51), VF_OK);
    CHECK_INT_EQ(vf_job_merge(f.job, part, f.now), VF_OK);
    vf_film_destroy(part);
  }
  CHECK_INT_EQ(f.job->lease_failures, 0);
  CHECK_INT_EQ(f.job->failed_workers_count, 0);
  vf_lease *l = grant(&f, 2);
  release(&f, 2, l ? l->id : 0, "renderer: out of memory", 1);
  CHECK_INT_EQ(f.job->end, VF_JOB_ACTIVE); /* 1 in a row, not 3 */
  vf_farm_destroy(&f.farm);
}

static void test_a_job_every_worker_is_blocked_from_fails(void) {
  farm_fixture f;
  farm_setup(&f, 100, 1);
  for (int round = 0; round < 3; round++) {
    vf_lease *l = grant(&f, 0);
    CHECK(l != NULL);
    release(&f, 0, l ? l->id : 0, "cannot fetch tri.ply: damaged", 1);
    CHECK(grant(&f, 0) == NULL); /* blocked */
    if (round < 2) {
      /* Fewer than 3 failures in a row: the worker is forgiven and tries again. */
      f.farm.started_at -= 16.0;
      vf_poison_tick(&f.farm, f.now);
      CHECK_INT_EQ(f.job->end, VF_JOB_ACTIVE);
      f.farm.started_at += 16.0;
      f.now += 61.0;
      vf_poison_tick(&f.farm, f.now);
    }
  }
  /* 3 in a row, and the only worker blocked; but just started: the other workers of a
   * restarted farm may not have registered yet. */
  CHECK_INT_EQ(f.job->end, VF_JOB_ACTIVE);
  vf_poison_tick(&f.farm, f.now);
  CHECK_INT_EQ(f.job->end, VF_JOB_ACTIVE);
  f.farm.started_at -= 16.0; /* up for longer than the worker timeout of 15 s */
  vf_poison_tick(&f.farm, f.now);
  CHECK_INT_EQ(f.job->end, VF_JOB_FAILED);
  CHECK_STR_CONTAINS(f.job->message, "3 leases failed in a row with no iteration merged and every worker is blocked");
  vf_farm_destroy(&f.farm);
}

static void test_a_worker_registering_again_crashed_on_its_lease(void) {
  farm_fixture f;
  farm_setup(&f, 100, 2);
  vf_lease *l = grant(&f, 0);
  CHECK(l != NULL);
  uint64_t id = l ? l->id : 0;
  Vcmfarm__Register m = VCMFARM__REGISTER__INIT;
  m.name = "w0";
  vf_farm_reply r;
  vf_farm_reply_init(&r);
  vf_workers_register(&f.farm, &m, f.now, &r);
  uint64_t again = r.registered.worker_id;
  vf_farm_reply_release(&r);
  CHECK(vf_farm_find_worker(&f.farm, f.worker[0]) == NULL); /* the old one is lost */
  CHECK(vf_farm_find_worker(&f.farm, again) != NULL);
  CHECK_INT_EQ(f.farm.num_workers, 2);
  l = vf_lease_find(&f.farm.leases, id);
  CHECK(l == NULL || l->state == VF_LEASE_EXPIRED);
  CHECK_INT_EQ(f.job->lease_failures, 1);
  f.worker[0] = again;
  CHECK(grant(&f, 0) == NULL); /* known by name: still blocked */
  vf_farm_destroy(&f.farm);
}

static void test_a_worker_lost_without_progress_failed_its_lease(void) {
  farm_fixture f;
  farm_setup(&f, 100, 2);
  vf_lease *l0 = grant(&f, 0), *l1 = grant(&f, 1);
  CHECK(l0 != NULL && l1 != NULL);
  if (l1) l1->begin++; /* worker 1 had a part merged */
  /* Others were heard during w0's silence (here w1, until it fell silent too): the
   * silence is w0's own, not the coordinator cut off from all (coordinator/workers.h). */
  vf_farm_find_worker(&f.farm, f.worker[1])->last_seen = f.now + 10.0;
  f.now += 16.0;
  CHECK_INT_EQ(vf_workers_expire(&f.farm, f.now), 1);
  f.now += 10.0;
  CHECK_INT_EQ(vf_workers_expire(&f.farm, f.now), 1);
  CHECK_INT_EQ(f.job->lease_failures, 1);
  CHECK_STR_EQ(f.job->failed_workers[0], "w0");
  CHECK(vf_poison_blocked(&f.farm, "w0", f.job->id, f.now));
  CHECK(!vf_poison_blocked(&f.farm, "w1", f.job->id, f.now));
  vf_farm_destroy(&f.farm);
}

/* ---- tags and requirements (common/tags.h), pause and resume ---- */

/* Registers a worker named `name` with these tags and memory: its id, or 0 when refused
 * (the error's message then in *why, when given). */
static uint64_t register_tagged(farm_fixture *f, const char *name, char **tags, size_t n, uint64_t memory,
                                char *why, size_t why_size) {
  Vcmfarm__Register m = VCMFARM__REGISTER__INIT;
  m.name = (char *)name;
  m.tags = tags;
  m.n_tags = n;
  m.memory_bytes = memory;
  vf_farm_reply r;
  vf_farm_reply_init(&r);
  vf_workers_register(&f->farm, &m, f->now, &r);
  uint64_t id = r.env.body_case == VCMFARM__ENVELOPE__BODY_REGISTERED ? r.registered.worker_id : 0;
  if (why && r.env.body_case == VCMFARM__ENVELOPE__BODY_ERROR) {
    CHECK_INT_EQ(r.error.code, VCMFARM__ERROR_CODE__ERROR_BAD_REQUEST);
    snprintf(why, why_size, "%s", r.error.message);
  }
  vf_farm_reply_release(&r);
  return id;
}

/* A second job of `iterations` in the fixture's farm, requiring `requires` (a list). */
static vf_job *add_job(farm_fixture *f, uint64_t id, uint64_t iterations, const char *requires) {
  vf_job *j = NULL;
  CHECK_INT_EQ(vf_job_create(id, "k", 1, 1, "cornell", 7, f->job->scene_hash, 32, f->job->settings_text, 0, iterations,
                             &j),
               VF_OK);
  if (j == NULL) return NULL;
  vf_tags t;
  vf_tags_init(&t);
  if (requires) CHECK_INT_EQ(vf_tags_parse("requires", requires, &t, 1), VF_OK);
  char *ptrs[VF_TAGS_MAX];
  for (unsigned i = 0; i < t.count; i++) ptrs[i] = t.tag[i];
  CHECK_INT_EQ(vf_job_set_requires(j, ptrs, t.count), VF_OK);
  CHECK_INT_EQ(vf_farm_add_job(&f->farm, j), VF_OK);
  return j;
}

static void test_a_job_is_leased_only_to_workers_satisfying_its_requirements(void) {
  farm_fixture f;
  farm_setup(&f, 1000, 0);
  /* Job 1 needs the night pool with 64 GiB; job 2 anything. */
  char *night[] = {"night", "avx512"}, *day[] = {"avx512"};
  CHECK_INT_EQ(vf_tags_parse("requires", "night,mem>=64G", &f.job->requires, 1), VF_OK);
  vf_job *other = add_job(&f, 2, 1000, NULL);
  f.worker[0] = register_tagged(&f, "big-night", night, 2, UINT64_C(64) << 30, NULL, 0);
  f.worker[1] = register_tagged(&f, "small-night", night, 2, UINT64_C(32) << 30, NULL, 0);
  f.worker[2] = register_tagged(&f, "big-day", day, 1, UINT64_C(128) << 30, NULL, 0);
  CHECK(f.worker[0] && f.worker[1] && f.worker[2]);
  for (int round = 0; round < 3; round++) { /* the same answer however often they ask */
    vf_lease *l1 = grant(&f, 1), *l2 = grant(&f, 2), *l0 = grant(&f, 0);
    CHECK(l0 != NULL && l1 != NULL && l2 != NULL);
    if (l0) CHECK_INT_EQ(l0->job_id, f.job->id);
    if (l1) CHECK_INT_EQ(l1->job_id, other->id); /* lacks the memory */
    if (l2) CHECK_INT_EQ(l2->job_id, other->id); /* lacks the tag */
  }
  /* Job 2 gone: the workers that cannot render job 1 are told to wait. */
  other->end = VF_JOB_CANCELLED;
  vf_leases_end_job(&f.farm, other->id, f.now);
  CHECK(grant(&f, 1) == NULL);
  CHECK(grant(&f, 2) == NULL);
  CHECK(grant(&f, 0) != NULL);
  vf_farm_destroy(&f.farm);
}

static void test_bad_tags_in_a_registration_are_refused_naming_them(void) {
  farm_fixture f;
  farm_setup(&f, 100, 0);
  char why[256] = "";
  char *spaced[] = {"ok", "has space"};
  CHECK(register_tagged(&f, "a", spaced, 2, 0, why, sizeof why) == 0);
  CHECK_STR_CONTAINS(why, "Register.tags: tag 'has space' holds a space");
  char *not_utf8[] = {"caf\xe9"};
  CHECK(register_tagged(&f, "a", not_utf8, 1, 0, why, sizeof why) == 0);
  CHECK_STR_CONTAINS(why, "Register.tags: tag 'caf\\xe9' is not UTF-8");
  char *memory[] = {"mem>=1T"};
  CHECK(register_tagged(&f, "a", memory, 1, 0, why, sizeof why) == 0);
  CHECK_STR_CONTAINS(why, "measured, not given");
  char long_tag[40];
  memset(long_tag, 'x', sizeof long_tag - 1);
  long_tag[sizeof long_tag - 1] = '\0';
  char *too_long[] = {long_tag};
  CHECK(register_tagged(&f, "a", too_long, 1, 0, why, sizeof why) == 0);
  CHECK_STR_CONTAINS(why, "39 bytes long, at most 32");
  char *many[VF_TAGS_MAX + 1];
  for (int i = 0; i <= VF_TAGS_MAX; i++) many[i] = "t";
  CHECK(register_tagged(&f, "a", many, VF_TAGS_MAX + 1, 0, why, sizeof why) == 0);
  CHECK_STR_CONTAINS(why, "Register.tags: 17 tags, at most 16");
  CHECK_INT_EQ(f.farm.num_workers, 0); /* none of them registered */
  /* A worker refused for its tags does not replace the one of its name. */
  char *fine[] = {"night"};
  f.worker[0] = register_tagged(&f, "a", fine, 1, 0, NULL, 0);
  CHECK(register_tagged(&f, "a", spaced, 2, 0, why, sizeof why) == 0);
  CHECK(vf_farm_find_worker(&f.farm, f.worker[0]) != NULL);
  vf_farm_destroy(&f.farm);
}

static void test_bad_requirements_of_a_job_are_refused_naming_them(void) {
  farm_fixture f;
  farm_setup(&f, 100, 0);
  char *bad[] = {"night", "mem>=64"};
  CHECK_INT_EQ(vf_job_set_requires(f.job, bad, 2), VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EINVAL), "requires: requirement 'mem>=64': memory is mem>=N");
  CHECK_INT_EQ(f.job->requires.count, 0);
  char *many[VF_TAGS_MAX + 1];
  for (int i = 0; i <= VF_TAGS_MAX; i++) many[i] = "t";
  CHECK_INT_EQ(vf_job_set_requires(f.job, many, VF_TAGS_MAX + 1), VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EINVAL), "requires: 17 tags, at most 16");
  vf_farm_destroy(&f.farm);
}

/* Workers split between jobs by priority through the handlers themselves: 40 workers of one
 * speed, each asking for work, rendering its lease for its duration, handing it back and
 * asking again, for 400 simulated seconds; then the workers holding a lease of each job are
 * counted. Priorities 1, 1 and 2: 10, 10 and 20 (within one worker). With the priority-2
 * job requiring a tag only 8 workers carry, it gets those 8 (it cannot use more) and the
 * others split the remaining 32 evenly. */
static void split_by_priority(const char *night_requires, int night_workers, int want[3]) {
  enum { WORKERS = 40 };
  farm_fixture f;
  farm_setup(&f, 1000000, 0);
  add_job(&f, 2, 1000000, NULL);
  vf_job *third = add_job(&f, 3, 1000000, night_requires);
  if (third) third->priority = 2;
  uint64_t ids[WORKERS], lease[WORKERS] = {0};
  double free_at[WORKERS];
  uint64_t held_job[WORKERS] = {0};
  for (int i = 0; i < WORKERS; i++) {
    char name[16], *night[] = {"night"};
    snprintf(name, sizeof name, "s%d", i);
    ids[i] = register_tagged(&f, name, night, i < night_workers ? 1 : 0, 0, NULL, 0);
    vf_farm_find_worker(&f.farm, ids[i])->rate = 1.0;
    free_at[i] = 0.01 * i;
  }
  for (int events = 0; events < 100000; events++) {
    int k = 0;
    for (int i = 1; i < WORKERS; i++)
      if (free_at[i] < free_at[k]) k = i;
    if (free_at[k] >= 400.0) break;
    f.now = free_at[k];
    vf_farm_worker *w = vf_farm_find_worker(&f.farm, ids[k]);
    vf_farm_reply r;
    if (lease[k]) {
      Vcmfarm__LeaseRelease m = VCMFARM__LEASE_RELEASE__INIT;
      m.worker_id = ids[k];
      m.lease_id = lease[k];
      m.failure = "";
      vf_farm_reply_init(&r);
      vf_leases_release(&f.farm, w, &m, f.now, &r);
      vf_farm_reply_release(&r);
      lease[k] = held_job[k] = 0;
    }
    vf_farm_reply_init(&r);
    vf_leases_grant(&f.farm, w, f.now, &r);
    if (r.env.body_case == VCMFARM__ENVELOPE__BODY_LEASE) {
      lease[k] = r.lease.lease_id;
      held_job[k] = r.lease.job_id;
      free_at[k] = f.now + (double)(r.lease.end - r.lease.begin) / 1.0;
    } else {
      free_at[k] = f.now + 0.5;
    }
    vf_farm_reply_release(&r);
  }
  int held[3] = {0, 0, 0};
  for (int i = 0; i < WORKERS; i++)
    if (held_job[i] >= 1 && held_job[i] <= 3) held[held_job[i] - 1]++;
  printf("     workers per job: %d, %d, %d (expected about %d, %d, %d)\n", held[0], held[1], held[2], want[0], want[1],
         want[2]);
  for (int j = 0; j < 3; j++) CHECK_NEAR(held[j], want[j], 1.0);
  CHECK_INT_EQ(held[0] + held[1] + held[2], WORKERS);
  vf_farm_destroy(&f.farm);
}

static void test_workers_are_split_by_priority(void) {
  int want[3] = {10, 10, 20};
  split_by_priority(NULL, 0, want);
}

static void test_a_job_only_some_workers_may_render_gets_those(void) {
  int want[3] = {16, 16, 8};
  split_by_priority("night", 8, want);
}

/* Pause or resume job 1 through the farm's handler: whether it was accepted. */
static int pause_job(farm_fixture *f, int pause, char *message, size_t n) {
  vf_farm_reply r;
  vf_farm_reply_init(&r);
  vf_jobs_pause(&f->farm, f->job->id, pause, &r);
  int accepted = r.env.body_case == VCMFARM__ENVELOPE__BODY_RESULT_ACK && r.result_ack.accepted;
  if (message) snprintf(message, n, "%s", r.env.body_case == VCMFARM__ENVELOPE__BODY_RESULT_ACK ? r.result_ack.message : "");
  vf_farm_reply_release(&r);
  return accepted;
}

static void test_a_paused_job_gets_no_new_leases_and_keeps_those_out(void) {
  char dir[] = "/tmp/vf_test_lease_pause-XXXXXX";
  CHECK(mkdtemp(dir) != NULL);
  farm_fixture f;
  farm_setup(&f, 100, 3);
  f.farm.config.state_dir = dir; /* pausing is saved before it is answered */
  for (int i = 0; i < 3; i++) vf_farm_find_worker(&f.farm, f.worker[i])->rate = 1.0;
  vf_lease *held = grant(&f, 0);
  CHECK(held != NULL);
  uint64_t held_id = held ? held->id : 0;
  char message[256];
  CHECK(pause_job(&f, 1, message, sizeof message));
  CHECK_STR_CONTAINS(message, "paused job 1: no new leases; 1 worker finishes what it leased (20 iterations)");
  CHECK_STR_CONTAINS(vf_job_state(f.job, 20), "paused");
  CHECK(!pause_job(&f, 1, message, sizeof message));
  CHECK_STR_CONTAINS(message, "job 1 is paused already");
  CHECK(grant(&f, 1) == NULL);                 /* no new lease */
  CHECK(heartbeat_valid(&f, 0, held_id));      /* the one out stays valid: it finishes and ships */
  CHECK_INT_EQ(vf_lease_active_iterations(&f.farm.leases, f.job->id), 20);
  const vf_event *last = vf_events_at(&f.job->events, f.job->events.count - 1);
  CHECK(last != NULL);
  if (last) CHECK_STR_EQ(last->kind, "job_paused");
  CHECK(pause_job(&f, 0, message, sizeof message));
  CHECK_STR_CONTAINS(message, "resumed job 1");
  vf_lease *after = grant(&f, 1);
  CHECK(after != NULL);
  if (after) CHECK_INT_EQ(after->begin, 20); /* beside the lease that was out, not over it */
  CHECK(!pause_job(&f, 0, message, sizeof message));
  CHECK_STR_CONTAINS(message, "not paused already");
  f.job->end = VF_JOB_CANCELLED;
  CHECK(!pause_job(&f, 1, message, sizeof message));
  CHECK_STR_CONTAINS(message, "job 1 is cancelled already");
  vf_farm_destroy(&f.farm);
  vf_state_remove_job_files(dir, 1);
  char path[256];
  snprintf(path, sizeof path, "%s/state.json", dir);
  unlink(path);
  rmdir(dir);
}

int main(void) {
  vf_log_set_quiet(1);
  RUN(test_free_range_is_the_first_free_one);
  RUN(test_free_range_skips_the_film_and_active_leases);
  RUN(test_ranges_in_the_film_are_never_leased_twice);
  RUN(test_an_expired_lease_returns_its_range_to_the_pool);
  RUN(test_expired_leases_are_kept_up_to_a_limit);
  RUN(test_lease_ids_are_unique_and_never_zero);
  RUN(test_rendering_iterations_follow_heartbeats);
  RUN(test_lease_size_is_a_fair_share);
  RUN(test_grants_are_sized_by_rate_and_fair_share);
  RUN(test_no_free_range_means_idle);
  RUN(test_a_revoked_lease_is_invalid_and_charged);
  RUN(test_a_release_returns_the_lease_to_the_pool);
  RUN(test_a_reported_failure_blocks_the_worker_until_forgiven);
  RUN(test_failures_on_three_workers_in_a_row_fail_the_job);
  RUN(test_a_merge_clears_the_failures_in_a_row);
  RUN(test_a_job_every_worker_is_blocked_from_fails);
  RUN(test_a_worker_registering_again_crashed_on_its_lease);
  RUN(test_a_worker_lost_without_progress_failed_its_lease);
  RUN(test_a_job_is_leased_only_to_workers_satisfying_its_requirements);
  RUN(test_bad_tags_in_a_registration_are_refused_naming_them);
  RUN(test_bad_requirements_of_a_job_are_refused_naming_them);
  RUN(test_a_paused_job_gets_no_new_leases_and_keeps_those_out);
  RUN(test_workers_are_split_by_priority);
  RUN(test_a_job_only_some_workers_may_render_gets_those);
  return check_finish();
}
