#include "schedule.h"

double vf_schedule_vtime(const vf_job *job) {
  int w = job->priority < VF_PRIORITY_MIN ? VF_PRIORITY_MIN : job->priority;
  return job->service / (double)w;
}

vf_job *vf_schedule_pick(vf_job *const *jobs, size_t count, int (*eligible)(void *ctx, const vf_job *job), void *ctx) {
  vf_job *best = NULL;
  double floor = 0.0;
  int have_floor = 0;
  /* The least virtual time among jobs already being served: where a newcomer enters. */
  for (size_t i = 0; i < count; i++) {
    vf_job *j = jobs[i];
    int e = eligible(ctx, j);
    if (e == 0) {
      j->schedule_idle = 1;
      continue;
    }
    if (j->schedule_idle) continue;
    double v = vf_schedule_vtime(j);
    if (!have_floor || v < floor) floor = v, have_floor = 1;
  }
  for (size_t i = 0; i < count; i++) {
    vf_job *j = jobs[i];
    if (eligible(ctx, j) <= 0) continue;
    if (j->schedule_idle) {
      /* Entering (again): no credit for the time it was absent, no debt either. */
      double w = (double)(j->priority < VF_PRIORITY_MIN ? VF_PRIORITY_MIN : j->priority);
      if (have_floor && vf_schedule_vtime(j) < floor) j->service = floor * w;
      j->schedule_idle = 0;
    }
    if (best == NULL || vf_schedule_vtime(j) < vf_schedule_vtime(best) ||
        (vf_schedule_vtime(j) == vf_schedule_vtime(best) && j->id < best->id))
      best = j;
  }
  return best;
}

double vf_schedule_estimate(uint64_t size, double worker_rate, double job_rate, double fallback) {
  if (worker_rate > 0.0) return (double)size / worker_rate;
  if (job_rate > 0.0) return (double)size / job_rate;
  return fallback;
}

void vf_schedule_charge(vf_job *job, double seconds) {
  job->service += seconds;
  if (job->service < 0.0) job->service = 0.0;
}
