#include "farm.h"

#include "../common/clock.h"
#include "../common/error.h"
#include "blobs.h"
#include "checkpoint.h"
#include "deadline.h"
#include "jobs.h"
#include "leases.h"
#include "log.h"
#include "partial.h"
#include "poison.h"
#include "results.h"
#include "ship.h"
#include "state.h"
#include "workers.h"

#include <stdint.h>

void vf_farm_handle(vf_farm *farm, const Vcmfarm__Envelope *q, double now, vf_farm_reply *r) {
  vf_farm_reply_init(r);
  uint64_t worker_id = 0;
  switch (q->body_case) {
  case VCMFARM__ENVELOPE__BODY_REGISTER: return vf_workers_register(farm, q->register_, now, r);
  case VCMFARM__ENVELOPE__BODY_RESULT: {
    vf_farm_worker *w = vf_farm_find_worker(farm, q->result->worker_id);
    if (w) w->last_seen = now;
    return vf_results_receive(farm, q->result, now, r);
  }
  case VCMFARM__ENVELOPE__BODY_LEASE_REQUEST: worker_id = q->lease_request->worker_id; break;
  case VCMFARM__ENVELOPE__BODY_HEARTBEAT: worker_id = q->heartbeat->worker_id; break;
  case VCMFARM__ENVELOPE__BODY_RELEASE: worker_id = q->release->worker_id; break;
  case VCMFARM__ENVELOPE__BODY_GOODBYE: worker_id = q->goodbye->worker_id; break;
  case VCMFARM__ENVELOPE__BODY_SUBMIT: return vf_jobs_submit(farm, q->submit, r);
  case VCMFARM__ENVELOPE__BODY_STATUS_REQUEST: return vf_jobs_status(farm, q->status_request, now, r);
  case VCMFARM__ENVELOPE__BODY_FETCH: return vf_jobs_fetch(farm, q->fetch, now, r);
  case VCMFARM__ENVELOPE__BODY_CANCEL: return vf_jobs_cancel(farm, q->cancel, now, r);
  case VCMFARM__ENVELOPE__BODY_REMOVE: return vf_jobs_remove(farm, q->remove, r);
  case VCMFARM__ENVELOPE__BODY_PAUSE: return vf_jobs_pause(farm, q->pause->job_id, 1, r);
  case VCMFARM__ENVELOPE__BODY_RESUME: return vf_jobs_pause(farm, q->resume->job_id, 0, r);
  case VCMFARM__ENVELOPE__BODY_BLOB_QUERY: return vf_blobs_query(farm, q->blob_query, r);
  case VCMFARM__ENVELOPE__BODY_BLOB_PUT: return vf_blobs_put(farm, q->blob_put, r);
  case VCMFARM__ENVELOPE__BODY_BLOB_REQUEST: worker_id = q->blob_request->worker_id; break;
  default:
    return vf_farm_reply_errorf(r, VCMFARM__ERROR_CODE__ERROR_BAD_REQUEST, "a coordinator does not accept a %s message",
                                vf_message_name(q));
  }
  vf_farm_worker *w = vf_farm_find_worker(farm, worker_id);
  if (w == NULL)
    return vf_farm_reply_errorf(r, VCMFARM__ERROR_CODE__ERROR_UNKNOWN_WORKER, "unknown worker %016llx: register again",
                                (unsigned long long)worker_id);
  w->last_seen = now;
  switch (q->body_case) {
  case VCMFARM__ENVELOPE__BODY_LEASE_REQUEST:
    w->state = VF_WORKER_ACTIVE; /* asking for work: not stopping after all */
    return vf_leases_grant(farm, w, now, r);
  case VCMFARM__ENVELOPE__BODY_GOODBYE: return vf_workers_goodbye(farm, w, q->goodbye, now, r);
  case VCMFARM__ENVELOPE__BODY_HEARTBEAT: return vf_leases_heartbeat(farm, w, q->heartbeat, r);
  case VCMFARM__ENVELOPE__BODY_BLOB_REQUEST: return vf_blobs_request(farm, w, q->blob_request, r);
  default: return vf_leases_release(farm, w, q->release, now, r);
  }
}

int vf_farm_expire(vf_farm *farm, double now) {
  vf_results_expire(farm, now);
  vf_checkpoint_snapshot_expire(farm, now);
  return vf_workers_expire(farm, now);
}

void vf_farm_stalled(vf_farm *farm, double gap, double now) {
  vf_log("the coordinator was stalled for %.1f s (paused, swapped out or blocked): the workers' silence meanwhile "
         "is excused, and their leases extended by it", gap);
  vf_events_add(&farm->events, vf_unix_now(), "coordinator_stalled", 0, "",
                "the coordinator was stalled for %.1f s; its workers' leases were extended by it", gap);
  vf_workers_excuse(farm, gap, now);
  for (size_t i = 0; i < farm->leases.count; i++) {
    vf_lease *l = &farm->leases.leases[i];
    if (l->partial == NULL) continue;
    double updated = vf_partial_updated(l->partial) + gap;
    vf_partial_touch(l->partial, updated < now ? updated : now);
  }
  /* A closing job's grace period too: its final parts may be among what was queued. */
  for (size_t i = 0; i < farm->num_jobs; i++) {
    vf_job *j = farm->jobs[i];
    if (j->closed_at > 0.0) j->closed_at = j->closed_at + gap < now ? j->closed_at + gap : now;
  }
}

void vf_farm_tick(vf_farm *farm, double now) {
  double dt = farm->last_tick > 0.0 ? now - farm->last_tick : 0.0;
  farm->last_tick = now;
  /* A failed lease or a block written within a tick rather than a checkpoint interval, so
   * that a crash right after cannot forget it; failing, the next tick tries again. */
  if (farm->state_urgent && vf_state_save_index(farm) == VF_OK) farm->state_urgent = 0;
  vf_ship_tick(farm, now);
  vf_poison_tick(farm, now);
  for (size_t i = 0; i < farm->num_jobs; i++) {
    vf_job *j = farm->jobs[i];
    if (!vf_job_runnable(j)) continue;
    /* Running from its first lease: a queued job's clock has not started, and a paused
     * one's stops once the leases it had out have ended. */
    uint64_t active = vf_lease_active_iterations(&farm->leases, j->id);
    if ((vf_job_done(j) > 0 && !j->paused) || active > 0) j->seconds += dt;
    if (j->time_limit > 0.0) vf_deadline_tick(farm, j, now);
  }
}

int vf_farm_checkpoint(vf_farm *farm, int all) { return vf_checkpoint_write(farm, all); }
