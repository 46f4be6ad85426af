/* bench_fair_share [WORKERS] [SECONDS] [PRIORITIES]
 *
 * The split of a farm's workers between running jobs by priority (docs/BENCHMARKS.md,
 * "Fair share of 1000 workers"), through the coordinator's own code: a vf_farm in this
 * process with WORKERS registered workers (default 1000) and one job per priority in
 * PRIORITIES (default 1,1,2), each with far more iterations than the run can render. Time
 * is simulated, so the run is deterministic and takes seconds: each worker asks for a
 * lease (vf_leases_grant, the handler a LeaseRequest reaches), renders it for its
 * iterations over its speed, hands it back (vf_leases_release, which charges the job the
 * lease's real duration) and asks again. Three farms: workers all of one speed; of four
 * speeds (0.5, 1, 1.5, 2 iterations per second, a worker's rate known to the coordinator
 * as measured); and of those speeds on jobs whose iterations cost 1, 2 and 0.5 times as
 * much (cycling), where the coordinator knows a worker's rate only as measured on the
 * last job it rendered, so that most leases last longer or shorter than estimated. Every simulated second after the first minute, the workers holding a
 * lease of each job are counted; printed per job: the mean of those counts, its share of
 * the busy workers, the share its weight asks for, and its share of the worker-seconds. */
#include "common/clock.h"
#include "common/error.h"
#include "common/settings.h"
#include "coordinator/leases.h"
#include "coordinator/log.h"
#include "coordinator/workers.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_JOBS 16
#define WARM_UP 60.0

typedef struct {
  uint64_t id;
  double speed;   /* iterations per second */
  double free_at; /* when it next asks: its lease ends, or its idle wait is over */
  uint64_t lease_id;
  size_t job;     /* index of the job it holds, MAX_JOBS none */
} sim_worker;

/* Relative cost of an iteration of job j in the third farm. */
static double job_cost(size_t j) { return j % 3 == 0 ? 1.0 : j % 3 == 1 ? 2.0 : 0.5; }

/* mode 0: one speed; 1: four speeds; 2: four speeds and jobs of three costs. */
static int run(int workers, double seconds, const int *priorities, int num_jobs, int mode) {
  int mixed = mode >= 1;
  vf_farm farm;
  vf_farm_config config = {"/nonexistent/bench_fair_share", 15.0, 20.0, 60.0};
  vf_farm_init(&farm, &config);
  vf_settings s;
  vf_settings_default(&s);
  s.width = s.height = 8;
  char settings[512];
  vf_settings_format(&s, settings, sizeof settings);
  const uint8_t hash[32] = {1};
  for (int j = 0; j < num_jobs; j++) {
    vf_job *job;
    char name[32];
    snprintf(name, sizeof name, "job-%d", j + 1);
    if (vf_job_create((uint64_t)j + 1, name, priorities[j], 1, "cornell", 7, hash, 32, settings, 0,
                      VF_JOB_MAX_ITERATIONS, &job) != VF_OK ||
        vf_farm_add_job(&farm, job) != VF_OK) {
      fprintf(stderr, "bench_fair_share: %s\n", vf_error_detail(VF_EINVAL));
      return 1;
    }
  }
  sim_worker *w = calloc((size_t)workers, sizeof *w);
  if (w == NULL) return 1;
  for (int i = 0; i < workers; i++) {
    Vcmfarm__Register m = VCMFARM__REGISTER__INIT;
    char name[32];
    snprintf(name, sizeof name, "sim-%04d", i);
    m.name = name;
    vf_farm_reply r;
    vf_farm_reply_init(&r);
    vf_workers_register(&farm, &m, 0.0, &r);
    w[i].id = r.registered.worker_id;
    vf_farm_reply_release(&r);
    w[i].speed = mixed ? 0.5 * (double)(1 + i % 4) : 1.0;
    w[i].free_at = 0.001 * i; /* they arrive within a second */
    w[i].job = MAX_JOBS;
    vf_farm_find_worker(&farm, w[i].id)->rate = w[i].speed;
  }
  double held_sum[MAX_JOBS] = {0}, worker_seconds[MAX_JOBS] = {0}, next_sample = WARM_UP;
  unsigned samples = 0, leases = 0;
  for (;;) {
    int k = 0;
    for (int i = 1; i < workers; i++)
      if (w[i].free_at < w[k].free_at) k = i;
    double now = w[k].free_at;
    /* Samples due before this event see the farm as it is until it. */
    while (next_sample <= now && next_sample < seconds) {
      for (int i = 0; i < workers; i++)
        if (w[i].job < MAX_JOBS) held_sum[w[i].job] += 1.0;
      samples++;
      next_sample += 1.0;
    }
    if (now >= seconds) break;
    vf_farm_worker *fw = vf_farm_find_worker(&farm, w[k].id);
    vf_farm_reply r;
    if (w[k].lease_id != 0) { /* rendered: handed back, charged its real duration */
      Vcmfarm__LeaseRelease m = VCMFARM__LEASE_RELEASE__INIT;
      m.worker_id = w[k].id;
      m.lease_id = w[k].lease_id;
      m.failure = "";
      vf_farm_reply_init(&r);
      vf_leases_release(&farm, fw, &m, now, &r);
      vf_farm_reply_release(&r);
      if (mode == 2) fw->rate = w[k].speed / job_cost(w[k].job); /* as measured on that job */
      w[k].lease_id = 0;
      w[k].job = MAX_JOBS;
    }
    vf_farm_reply_init(&r);
    vf_leases_grant(&farm, fw, now, &r);
    if (r.env.body_case == VCMFARM__ENVELOPE__BODY_LEASE) {
      double cost = mode == 2 ? job_cost((size_t)(r.lease.job_id - 1)) : 1.0;
      double duration = (double)(r.lease.end - r.lease.begin) * cost / w[k].speed;
      w[k].lease_id = r.lease.lease_id;
      w[k].job = (size_t)(r.lease.job_id - 1);
      w[k].free_at = now + duration;
      double counted_until = w[k].free_at < seconds ? w[k].free_at : seconds;
      if (counted_until > WARM_UP) worker_seconds[w[k].job] += counted_until - (now > WARM_UP ? now : WARM_UP);
      leases++;
    } else {
      w[k].free_at = now + (r.env.body_case == VCMFARM__ENVELOPE__BODY_IDLE ? r.idle.retry_ms / 1000.0 : 1.0);
    }
    vf_farm_reply_release(&r);
  }
  int weight_sum = 0;
  double held_total = 0.0, seconds_total = 0.0;
  for (int j = 0; j < num_jobs; j++) {
    weight_sum += priorities[j];
    held_total += held_sum[j];
    seconds_total += worker_seconds[j];
  }
  printf("%d workers, %s%s; %.0f simulated s, counted from %.0f s (%u samples), %u leases of %.0f s at each worker's "
         "rate\n", workers, mixed ? "speeds 0.5, 1, 1.5 and 2 iterations/s" : "all of one speed",
         mode == 2 ? ", jobs' iterations costing 1, 2, 0.5 (cycling), rates as measured on the last job" : "", seconds,
         WARM_UP, samples, leases, farm.config.lease_seconds);
  printf("| job | priority | workers holding a lease of it (mean) | share of busy workers | share its weight asks | share of worker-seconds |\n");
  printf("|---|---|---|---|---|---|\n");
  for (int j = 0; j < num_jobs; j++)
    printf("| %d | %d | %.1f | %.2f%% | %.2f%% | %.2f%% |\n", j + 1, priorities[j], held_sum[j] / (samples ? samples : 1),
           100.0 * held_sum[j] / (held_total > 0 ? held_total : 1), 100.0 * priorities[j] / weight_sum,
           100.0 * worker_seconds[j] / (seconds_total > 0 ? seconds_total : 1));
  free(w);
  vf_farm_destroy(&farm);
  return 0;
}

int main(int argc, char **argv) {
  int workers = argc > 1 ? atoi(argv[1]) : 1000;
  double seconds = argc > 2 ? atof(argv[2]) : 600.0;
  int priorities[MAX_JOBS], num_jobs = 0;
  const char *list = argc > 3 ? argv[3] : "1,1,2";
  for (const char *p = list; *p && num_jobs < MAX_JOBS;) {
    priorities[num_jobs++] = atoi(p);
    p = strchr(p, ',');
    if (p == NULL) break;
    p++;
  }
  if (workers < 1 || workers > 100000 || !(seconds > WARM_UP) || num_jobs == 0) {
    fprintf(stderr, "usage: bench_fair_share [WORKERS 1..100000] [SECONDS > %.0f] [PRIORITIES, e.g. 1,1,2]\n", WARM_UP);
    return 2;
  }
  for (int j = 0; j < num_jobs; j++)
    if (priorities[j] < 1 || priorities[j] > 1000) {
      fprintf(stderr, "bench_fair_share: priority %d: a weight from 1 to 1000\n", priorities[j]);
      return 2;
    }
  vf_log_set_quiet(1);
  double t0 = vf_seconds_now();
  int err = 0;
  for (int mode = 0; mode < 3 && err == 0; mode++) {
    if (mode) printf("\n");
    err = run(workers, seconds, priorities, num_jobs, mode);
  }
  printf("\n(%.1f s of this machine's time)\n", vf_seconds_now() - t0);
  return err;
}
