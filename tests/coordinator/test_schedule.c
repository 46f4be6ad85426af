/* Weighted sharing of workers between jobs (coordinator/schedule.h), in a simulated farm:
 * workers of given speeds take leases of the job the scheduler picks, each charged as the
 * coordinator charges it (an estimate at grant, corrected to the real duration at the
 * end), and the worker time every job received is compared with its weight's share. */
#include "check.h"
#include "coordinator/schedule.h"

#include <stdlib.h>

#define MAX_JOBS 4
#define MAX_WORKERS 8

typedef struct {
  vf_job jobs[MAX_JOBS];
  vf_job *ptrs[MAX_JOBS];
  int present[MAX_JOBS]; /* eligible */
  size_t num_jobs;
  double worker_seconds[MAX_JOBS];
  unsigned leases[MAX_JOBS];
} sim;

static int eligible(void *ctx, const vf_job *job) {
  sim *s = ctx;
  return s->present[job->id - 1];
}

static void add_job(sim *s, int priority) {
  vf_job *j = &s->jobs[s->num_jobs];
  j->id = s->num_jobs + 1;
  j->priority = priority;
  s->ptrs[s->num_jobs] = j;
  s->present[s->num_jobs] = 1;
  s->num_jobs++;
}

/* Runs workers (lease duration per worker, in seconds) until `until`, from `start`. A lease
 * is estimated at `estimate_factor` times its real duration (1: exact). Event-driven:
 * the worker that frees first takes the next lease. */
static void run(sim *s, const double *duration, int workers, double start, double until, double estimate_factor) {
  double free_at[MAX_WORKERS];
  vf_job *holding[MAX_WORKERS] = {0};
  double charged[MAX_WORKERS] = {0};
  for (int w = 0; w < workers; w++) free_at[w] = start + 0.001 * w;
  for (;;) {
    int w = 0;
    for (int k = 1; k < workers; k++)
      if (free_at[k] < free_at[w]) w = k;
    if (free_at[w] >= until) break;
    if (holding[w]) vf_schedule_charge(holding[w], duration[w] - charged[w]);
    vf_job *j = vf_schedule_pick(s->ptrs, s->num_jobs, eligible, s);
    holding[w] = j;
    if (j == NULL) {
      free_at[w] += 0.5;
      continue;
    }
    charged[w] = estimate_factor * duration[w];
    vf_schedule_charge(j, charged[w]);
    s->worker_seconds[j->id - 1] += duration[w];
    s->leases[j->id - 1]++;
    free_at[w] += duration[w];
  }
}

static void test_priority_two_gets_twice_the_leases(void) {
  sim s = {0};
  add_job(&s, 1);
  add_job(&s, 2);
  double d[3] = {1, 1, 1};
  run(&s, d, 3, 0, 300, 1.0);
  printf("     leases: priority 1 %u, priority 2 %u\n", s.leases[0], s.leases[1]);
  CHECK_NEAR((double)s.leases[1] / s.leases[0], 2.0, 0.05);
}

static void test_worker_time_is_shared_with_unequal_workers(void) {
  /* Workers of three speeds and estimates 50% off: the time shares still follow 1:3. */
  sim s = {0};
  add_job(&s, 3);
  add_job(&s, 1);
  double d[3] = {0.7, 1.9, 3.1};
  run(&s, d, 3, 0, 1000, 0.5);
  double share = s.worker_seconds[0] / (s.worker_seconds[0] + s.worker_seconds[1]);
  printf("     worker-seconds: priority 3 %.1f, priority 1 %.1f\n", s.worker_seconds[0], s.worker_seconds[1]);
  CHECK_NEAR(share, 0.75, 0.02);
}

static void test_three_jobs_share_by_weight(void) {
  sim s = {0};
  add_job(&s, 1);
  add_job(&s, 2);
  add_job(&s, 5);
  double d[4] = {1, 1.3, 0.8, 2};
  run(&s, d, 4, 0, 2000, 1.0);
  double total = s.worker_seconds[0] + s.worker_seconds[1] + s.worker_seconds[2];
  CHECK_NEAR(s.worker_seconds[0] / total, 1.0 / 8, 0.01);
  CHECK_NEAR(s.worker_seconds[1] / total, 2.0 / 8, 0.01);
  CHECK_NEAR(s.worker_seconds[2] / total, 5.0 / 8, 0.01);
}

static void test_a_newcomer_neither_starves_nor_waits(void) {
  /* Job 1 runs alone for a while; job 2 (same weight) then arrives. It must get about half
   * of the leases from then on, not all of them until it has caught up. */
  sim s = {0};
  add_job(&s, 1);
  add_job(&s, 1);
  s.present[1] = 0;
  double d[2] = {1, 1};
  run(&s, d, 2, 0, 100, 1.0);
  CHECK_INT_EQ(s.leases[1], 0);
  unsigned before = s.leases[0];
  s.present[1] = 1;
  run(&s, d, 2, 100, 140, 1.0);
  unsigned first = s.leases[0] - before, second = s.leases[1];
  printf("     after the newcomer: job 1 %u leases, job 2 %u\n", first, second);
  CHECK(first + second >= 70);
  CHECK_NEAR((double)second / (first + second), 0.5, 0.05);
}

static void test_ties_go_to_the_oldest_job(void) {
  sim s = {0};
  add_job(&s, 1);
  add_job(&s, 1);
  CHECK(vf_schedule_pick(s.ptrs, s.num_jobs, eligible, &s) == &s.jobs[0]);
  s.present[0] = 0;
  CHECK(vf_schedule_pick(s.ptrs, s.num_jobs, eligible, &s) == &s.jobs[1]);
  s.present[1] = 0;
  CHECK(vf_schedule_pick(s.ptrs, s.num_jobs, eligible, &s) == NULL);
}

static void test_estimates(void) {
  CHECK_NEAR(vf_schedule_estimate(10, 5.0, 1.0, 20.0), 2.0, 1e-12);  /* the worker's rate */
  CHECK_NEAR(vf_schedule_estimate(10, 0.0, 2.0, 20.0), 5.0, 1e-12);  /* else the job's */
  CHECK_NEAR(vf_schedule_estimate(1, 0.0, 0.0, 20.0), 20.0, 1e-12);  /* else the fallback */
  vf_job j = {0};
  j.priority = 4;
  vf_schedule_charge(&j, 8.0);
  CHECK_NEAR(vf_schedule_vtime(&j), 2.0, 1e-12);
  vf_schedule_charge(&j, -100.0);
  CHECK_NEAR(j.service, 0.0, 0.0);
}

int main(void) {
  RUN(test_priority_two_gets_twice_the_leases);
  RUN(test_worker_time_is_shared_with_unequal_workers);
  RUN(test_three_jobs_share_by_weight);
  RUN(test_a_newcomer_neither_starves_nor_waits);
  RUN(test_ties_go_to_the_oldest_job);
  RUN(test_estimates);
  return check_finish();
}
