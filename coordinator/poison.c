#include "poison.h"

#include "../common/clock.h"
#include "leases.h"
#include "log.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* One worker blocked from one job until `until` (vf_seconds_now()). */
typedef struct vf_poison_block {
  char worker[128];
  uint64_t job_id;
  double until;
} vf_poison_block;

static vf_poison_block *find_block(const vf_farm *farm, const char *worker, uint64_t job_id) {
  for (size_t i = 0; i < farm->num_blocks; i++)
    if (farm->blocks[i].job_id == job_id && strcmp(farm->blocks[i].worker, worker) == 0) return &farm->blocks[i];
  return NULL;
}

int vf_poison_blocked(const vf_farm *farm, const char *worker, uint64_t job_id, double now) {
  const vf_poison_block *b = find_block(farm, worker, job_id);
  return b != NULL && now < b->until;
}

/* Blocks the worker from the job until `until` (again, if it was). Out of memory, the
 * worker is not blocked: the job's failures still count. */
static void block(vf_farm *farm, const char *worker, uint64_t job_id, double until) {
  vf_poison_block *b = find_block(farm, worker, job_id);
  if (b == NULL) {
    if (farm->num_blocks == farm->blocks_capacity) {
      size_t cap = farm->blocks_capacity ? 2 * farm->blocks_capacity : 8;
      vf_poison_block *grown = realloc(farm->blocks, cap * sizeof *grown);
      if (grown == NULL) return;
      farm->blocks = grown;
      farm->blocks_capacity = cap;
    }
    b = &farm->blocks[farm->num_blocks++];
    snprintf(b->worker, sizeof b->worker, "%s", worker);
    b->job_id = job_id;
  }
  b->until = until;
}

const char *vf_poison_block_at(const vf_farm *farm, size_t i, uint64_t *job_id, double *until) {
  *job_id = farm->blocks[i].job_id;
  *until = farm->blocks[i].until;
  return farm->blocks[i].worker;
}

void vf_poison_restore(vf_farm *farm, const char *worker, uint64_t job_id, double until) {
  block(farm, worker, job_id, until);
}

static void fail_job(vf_farm *farm, vf_job *job, double now, const char *fmt, ...) __attribute__((format(printf, 4, 5)));
static void fail_job(vf_farm *farm, vf_job *job, double now, const char *fmt, ...) {
  char text[sizeof job->message];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(text, sizeof text, fmt, ap);
  va_end(ap);
  vf_job_finish(job, VF_STOP_FAILED, vf_unix_now(), text);
  vf_log("job %llu failed: %s", (unsigned long long)job->id, job->message);
  vf_events_add(&job->events, job->ended_at, "job_failed", job->id, "", "%s", job->message);
  vf_leases_end_job(farm, job->id, now);
  farm->state_dirty = 1;
}

/* Every registered worker is blocked from the job, and the coordinator has been up long
 * enough for the workers of a farm it restarted to have registered again. */
static int nobody_left(const vf_farm *farm, const vf_job *job, double now) {
  if (farm->num_workers == 0 || vf_unix_now() - farm->started_at < farm->config.worker_timeout) return 0;
  for (size_t i = 0; i < farm->num_workers; i++)
    if (!vf_poison_blocked(farm, farm->workers[i].name, job->id, now)) return 0;
  return 1;
}

void vf_poison_lease_failed(vf_farm *farm, uint64_t job_id, const char *worker, const char *why, double now) {
  vf_job *job = vf_farm_job(farm, job_id);
  if (job == NULL || job->end != VF_JOB_ACTIVE) return;
  block(farm, worker, job_id, now + farm->config.forgive_seconds);
  job->lease_failures++;
  farm->state_dirty = farm->state_urgent = 1; /* the count and the block are in state.json, within a tick */
  unsigned k = 0;
  while (k < job->failed_workers_count && strcmp(job->failed_workers[k], worker) != 0) k++;
  if (k == job->failed_workers_count && k < VF_POISON_WORKERS) {
    snprintf(job->failed_workers[k], sizeof job->failed_workers[k], "%s", worker);
    job->failed_workers_count++;
  }
  vf_log("job %llu: lease of worker %s failed (%u in a row, %u worker%s): %s; worker blocked from it for %.0f s",
         (unsigned long long)job_id, worker, job->lease_failures, job->failed_workers_count,
         job->failed_workers_count == 1 ? "" : "s", why, farm->config.forgive_seconds);
  vf_events_add(&job->events, vf_unix_now(), "lease_failed", job_id, worker,
                "lease of worker %s failed: %s; worker blocked from the job for %.0f s", worker, why,
                farm->config.forgive_seconds);
  if (job->failed_workers_count >= VF_POISON_WORKERS)
    fail_job(farm, job, now, "poison job: leases failed on %u workers in a row with no iteration merged; last: worker %s: %s",
             job->failed_workers_count, worker, why);
  else if (job->lease_failures >= VF_POISON_WORKERS && nobody_left(farm, job, now))
    fail_job(farm, job, now, "poison job: %u leases failed in a row with no iteration merged and every worker is "
             "blocked from it; last: worker %s: %s", job->lease_failures, worker, why);
}

void vf_poison_tick(vf_farm *farm, double now) {
  for (size_t i = 0; i < farm->num_blocks;) {
    vf_poison_block *b = &farm->blocks[i];
    if (now < b->until) {
      i++;
      continue;
    }
    vf_job *job = vf_farm_job(farm, b->job_id);
    if (job != NULL && job->end == VF_JOB_ACTIVE) {
      vf_log("job %llu: worker %s forgiven: it may lease the job again", (unsigned long long)b->job_id, b->worker);
      vf_events_add(&job->events, vf_unix_now(), "worker_forgiven", job->id, b->worker,
                    "worker %s forgiven: it may lease the job again", b->worker);
    }
    farm->blocks[i] = farm->blocks[--farm->num_blocks];
  }
  for (size_t i = 0; i < farm->num_jobs; i++) {
    vf_job *job = farm->jobs[i];
    if (job->lease_failures >= VF_POISON_WORKERS && vf_job_runnable(job) && nobody_left(farm, job, now))
      fail_job(farm, job, now, "poison job: %u leases failed in a row with no iteration merged and every worker is "
               "blocked from it", job->lease_failures);
  }
}

void vf_poison_forget_job(vf_farm *farm, uint64_t job_id) {
  for (size_t i = 0; i < farm->num_blocks;)
    if (farm->blocks[i].job_id == job_id) farm->blocks[i] = farm->blocks[--farm->num_blocks];
    else i++;
}
