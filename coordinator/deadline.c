#include "deadline.h"

#include "../common/clock.h"
#include "jobs.h"
#include "log.h"

#include <math.h>

double vf_deadline_grace(const vf_farm *farm) {
  return farm->config.worker_timeout > VF_DEADLINE_GRACE_MIN ? farm->config.worker_timeout : VF_DEADLINE_GRACE_MIN;
}

int vf_deadline_reached(const vf_job *job) { return job->time_limit > 0.0 && job->seconds >= job->time_limit; }

uint32_t vf_deadline_lease_ms(const vf_job *job) {
  if (job->time_limit <= 0.0) return 0;
  double ms = ceil((job->time_limit - job->seconds) * 1000.0);
  if (!(ms >= 1.0)) return 1; /* reached (or NaN, which validation excludes): deliver at once */
  return ms >= (double)UINT32_MAX ? UINT32_MAX : (uint32_t)ms;
}

/* The job's active leases: those whose final part may still come. */
static unsigned active_leases(const vf_farm *farm, uint64_t job_id) {
  unsigned n = 0;
  for (size_t i = 0; i < farm->leases.count; i++)
    n += farm->leases.leases[i].job_id == job_id && farm->leases.leases[i].state == VF_LEASE_ACTIVE;
  return n;
}

int vf_deadline_tick(vf_farm *farm, vf_job *job, double now) {
  if (!vf_job_runnable(job) || !vf_deadline_reached(job)) return 0;
  unsigned active = active_leases(farm, job->id);
  unsigned long long jid = (unsigned long long)job->id;
  if (job->closed_at == 0.0) {
    job->closed_at = now;
    if (active > 0) {
      vf_log("job %llu: time limit of %g s reached; closing: waiting up to %.0f s for the final parts of its %u "
             "lease%s", jid, job->time_limit, vf_deadline_grace(farm), active, active == 1 ? "" : "s");
      vf_events_add(&job->events, vf_unix_now(), "closing", job->id, "",
                    "time limit of %g s reached: no new leases; waiting up to %.0f s for the final parts of %u lease%s",
                    job->time_limit, vf_deadline_grace(farm), active, active == 1 ? "" : "s");
    }
  }
  if (active > 0 && now - job->closed_at < vf_deadline_grace(farm)) return 0;
  if (active > 0) {
    vf_log("job %llu: %u lease%s delivered nothing within the grace period of %.0f s; revoked", jid, active,
           active == 1 ? "" : "s", vf_deadline_grace(farm));
    vf_events_add(&job->events, vf_unix_now(), "grace_over", job->id, "",
                  "%u lease%s delivered nothing more within the grace period of %.0f s after the time limit", active,
                  active == 1 ? "" : "s", vf_deadline_grace(farm));
  }
  job->time_up = 1;
  if (vf_job_check_stop(job) != 1) return 0;
  vf_jobs_finish(farm, job, now);
  return 1;
}
