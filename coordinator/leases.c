#include "leases.h"

#include "../common/clock.h"
#include "../common/error.h"
#include "blobs.h"
#include "deadline.h"
#include "log.h"
#include "poison.h"
#include "schedule.h"
#include "ship.h"

#include <math.h>
#include <stdio.h>

static vf_farm_worker *worker_of_lease(vf_farm *farm, const vf_lease *lease) {
  vf_farm_worker *w = vf_farm_find_worker(farm, lease->worker_id);
  return w != NULL && w->lease_id == lease->id ? w : NULL;
}

void vf_leases_end(vf_farm *farm, vf_lease *lease, int keep, double now) {
  vf_farm_worker *w = worker_of_lease(farm, lease);
  if (w) w->lease_id = 0;
  vf_job *job = vf_farm_job(farm, lease->job_id);
  if (job && lease->state == VF_LEASE_ACTIVE) vf_schedule_charge(job, (now - lease->granted) - lease->charged);
  if (keep) vf_lease_expire(&farm->leases, lease->id);
  else vf_lease_remove(&farm->leases, lease->id);
}

/* Ends, keeping them as expired, the job's active leases but `except` that overlap
 * [begin, end); logs each when `why` is set. Ending one changes the table, so the scan
 * starts again after each. */
static void end_active(vf_farm *farm, uint64_t job_id, uint64_t begin, uint64_t end, uint64_t except, const char *why,
                       double now) {
  for (size_t i = 0; i < farm->leases.count;) {
    vf_lease *l = &farm->leases.leases[i];
    if (l->id != except && l->job_id == job_id && l->state == VF_LEASE_ACTIVE && l->begin < end && begin < l->end) {
      if (why) {
        vf_log("lease %016llx revoked: %s", (unsigned long long)l->id, why);
        vf_job *job = vf_farm_job(farm, job_id);
        vf_farm_worker *w = worker_of_lease(farm, l);
        if (job)
          vf_events_add(&job->events, vf_unix_now(), "lease_revoked", job_id, w ? w->name : "",
                        "lease [%llu,%llu)%s%s revoked: %s", (unsigned long long)l->begin, (unsigned long long)l->end,
                        w ? " of worker " : "", w ? w->name : "", why);
      }
      vf_leases_end(farm, l, 1, now);
      i = 0;
    } else {
      i++;
    }
  }
}

void vf_leases_end_job(vf_farm *farm, uint64_t job_id, double now) {
  end_active(farm, job_id, 0, UINT64_MAX, 0, NULL, now);
}

void vf_leases_revoke(vf_farm *farm, uint64_t job_id, uint64_t begin, uint64_t end, uint64_t except, double now) {
  end_active(farm, job_id, begin, end, except, "a late result covered it", now);
}

void vf_leases_end_pilot(vf_farm *farm, uint64_t job_id, double now) {
  /* Granted before the allocation existed, every active lease of the job is a pilot's. */
  end_active(farm, job_id, 0, UINT64_MAX, 0, "the job's pilot is complete", now);
}

/* What a lease of the job is cut from now: in its pilot phase the pilot's iterations [0,
 * pilot) less those its pilot film holds, else its own (coordinator/job.h). */
typedef struct {
  const vf_iterset *done;
  uint64_t first, total;
  int pilot;
} phase;

static int phase_of(const vf_job *j, phase *p) {
  if (vf_job_in_pilot(j)) {
    if (j->pilot_film == NULL) return 0;
    *p = (phase){&j->pilot_film->iterations, 0, (uint64_t)j->settings.pilot, 1};
  } else {
    *p = (phase){&j->film->iterations, j->first, j->iterations, 0};
  }
  return 1;
}

typedef struct {
  vf_farm *farm;
  const vf_farm_worker *worker;
  double now;
} pick_ctx;

/* A job the worker may be handed: runnable, not paused and with a free range (else 0), the
 * worker satisfying its requirements and not blocked from it (else -1: vf_schedule_pick
 * leaves its place among the others alone, so a job only some workers may render keeps
 * its share of those). */
static int has_free_range(void *ctx, const vf_job *j) {
  pick_ctx *p = ctx;
  vf_farm *farm = p->farm;
  uint64_t b, e, free_count;
  phase ph = {0};
  if (!vf_job_runnable(j) || j->paused || vf_deadline_reached(j) || !phase_of(j, &ph) ||
      vf_lease_free_range(&farm->leases, j->id, ph.done, ph.first, ph.total, 1, &b, &e, &free_count) != 1)
    return 0;
  if (!vf_tags_satisfied(&j->requires, &p->worker->tags, p->worker->memory_bytes, NULL)) return -1;
  return vf_poison_blocked(farm, p->worker->name, j->id, p->now) ? -1 : 1;
}

/* The lease's body: the job's scene (and its file table), hash, settings and range; for a
 * job with a pilot, whether it is a pilot lease, or the allocation it renders with. */
static void fill_lease(const vf_farm *farm, vf_job *job, uint64_t lease_id, uint64_t b, uint64_t e, int pilot,
                       vf_farm_reply *r) {
  vcmfarm__lease__init(&r->lease);
  vcmfarm__scene__init(&r->scene);
  if (job->scene_builtin) {
    r->scene.source_case = VCMFARM__SCENE__SOURCE_BUILTIN;
    r->scene.builtin = job->scene_text;
  } else {
    r->scene.source_case = VCMFARM__SCENE__SOURCE_JSON;
    r->scene.json = job->scene_text;
  }
  if (vf_blobs_lease(job, r) != VF_OK)
    return vf_farm_reply_fail(r, vf_error_set(VF_ENOMEM, "out of memory for the lease's file table"));
  r->lease.lease_id = lease_id;
  r->lease.job_id = job->id;
  r->lease.scene = &r->scene;
  r->lease.scene_hash.data = job->scene_hash;
  r->lease.scene_hash.len = 32;
  r->lease.settings = job->settings_text;
  r->lease.begin = b;
  r->lease.end = e;
  r->lease.ship_interval_ms = vf_ship_interval_ms(farm);
  r->lease.deadline_ms = vf_deadline_lease_ms(job);
  r->lease.pilot = pilot;
  if (!pilot && job->film->samples != NULL) {
    vcmfarm__blob_ref__init(&r->allocation);
    r->allocation.name = "allocation";
    r->allocation.hash.data = job->allocation_hash;
    r->allocation.hash.len = 32;
    r->allocation.size = (uint64_t)job->film->width * (uint64_t)job->film->height;
    r->lease.allocation = &r->allocation;
  }
  r->env.body_case = VCMFARM__ENVELOPE__BODY_LEASE;
  r->env.lease = &r->lease;
}

void vf_leases_grant(vf_farm *farm, vf_farm_worker *w, double now, vf_farm_reply *r) {
  vf_lease *old = vf_lease_find(&farm->leases, w->lease_id);
  if (old != NULL) {
    vf_log("worker %s asks for work while holding lease %016llx; that lease returns to the pool", w->name,
           (unsigned long long)old->id);
    vf_job *old_job = vf_farm_job(farm, old->job_id);
    if (old_job)
      vf_events_add(&old_job->events, vf_unix_now(), "lease_expired", old_job->id, w->name,
                    "worker %s asked for work while holding lease [%llu,%llu), which returns to the pool", w->name,
                    (unsigned long long)old->begin, (unsigned long long)old->end);
    vf_leases_end(farm, old, 1, now);
  }
  w->lease_id = 0;
  pick_ctx pick = {farm, w, now};
  vf_job *job = vf_schedule_pick(farm->jobs, farm->num_jobs, has_free_range, &pick);
  if (job == NULL) {
    vcmfarm__idle__init(&r->idle);
    /* Often enough that a new job starts within half a second; cheap for the coordinator. */
    double retry = farm->config.worker_timeout / 4.0;
    r->idle.retry_ms = (uint32_t)(retry > 0.5 ? 500.0 : retry * 1000.0);
    r->env.body_case = VCMFARM__ENVELOPE__BODY_IDLE;
    r->env.idle = &r->idle;
    return;
  }
  double rate = w->rate > 0.0 ? w->rate : job->rate;
  vf_ship_workers_changed(farm); /* the interval for this many workers, before the lease says it */
  uint64_t b, e, free_count;
  phase ph = {0};
  if (!phase_of(job, &ph)) /* has_free_range found one: cannot happen */
    return vf_farm_reply_fail(r, vf_error_set(VF_EINVAL, "job %llu has no pilot film", (unsigned long long)job->id));
  vf_lease_free_range(&farm->leases, job->id, ph.done, ph.first, ph.total, UINT64_MAX, &b, &e, &free_count);
  /* Rate unknown: a fair share of the range, for the lease's time (the worker stops then:
   * Lease.seconds_ms), so that a thousand workers starting a job neither wait nor all ship
   * one iteration at once. */
  uint64_t size = rate > 0.0 ? vf_lease_size(rate, vf_ship_lease_seconds(farm), free_count, farm->num_workers)
                             : vf_lease_size(VF_LEASE_UNKNOWN_RATE, 1.0, free_count, farm->num_workers);
  if (vf_lease_free_range(&farm->leases, job->id, ph.done, ph.first, ph.total, size, &b, &e, &free_count) != 1 ||
      vf_lease_add(&farm->leases, job->id, w->id, b, e, now, &w->lease_id) != VF_OK)
    return vf_farm_reply_fail(r, vf_error_set(VF_ENOMEM, "out of memory for leases"));
  vf_lease *granted = vf_lease_find(&farm->leases, w->lease_id);
  granted->pilot = ph.pilot;
  granted->charged = vf_schedule_estimate(e - b, w->rate, job->rate, vf_ship_lease_seconds(farm));
  vf_schedule_charge(job, granted->charged);
  w->leases++;
  if (job->started_at == 0.0) {
    job->started_at = vf_unix_now();
    farm->state_dirty = 1;
  }
  vf_log("lease %016llx: job %llu %siterations [%llu,%llu) to worker %s", (unsigned long long)w->lease_id,
         (unsigned long long)job->id, ph.pilot ? "pilot " : "", (unsigned long long)b, (unsigned long long)e, w->name);
  fill_lease(farm, job, w->lease_id, b, e, ph.pilot, r);
  if (rate <= 0.0) r->lease.seconds_ms = (uint32_t)(1000.0 * vf_ship_lease_seconds(farm));
}

void vf_leases_heartbeat(vf_farm *farm, vf_farm_worker *w, const Vcmfarm__Heartbeat *m, vf_farm_reply *r) {
  vf_lease *l = vf_lease_find(&farm->leases, m->lease_id);
  vf_job *job = l ? vf_farm_job(farm, l->job_id) : NULL;
  vcmfarm__heartbeat_ack__init(&r->heartbeat_ack);
  r->heartbeat_ack.lease_valid = l != NULL && l->state == VF_LEASE_ACTIVE && l->worker_id == w->id &&
                                 w->lease_id == l->id && job != NULL && vf_job_runnable(job);
  if (r->heartbeat_ack.lease_valid) {
    l->reported = m->iterations_done; /* clamped where it is used */
    /* A first rate before any part is merged: leases of the ship interval's length at once.
     * Not from a pilot's iterations, which trace one camera sub-path a pixel. */
    if (!l->pilot && m->iterations_done > 0 && m->seconds > 0.0 && isfinite(m->seconds) &&
        m->iterations_done <= l->end - l->first) {
      double rate = (double)m->iterations_done / m->seconds;
      if (w->rate <= 0.0) w->rate = rate;
      if (job->rate <= 0.0) job->rate = rate;
    }
  }
  /* The job's time limit is reached: its final part now (coordinator/deadline.h). */
  r->heartbeat_ack.deliver_now = r->heartbeat_ack.lease_valid && vf_deadline_reached(job);
  r->heartbeat_ack.ship_interval_ms = vf_ship_interval_ms(farm);
  r->env.body_case = VCMFARM__ENVELOPE__BODY_HEARTBEAT_ACK;
  r->env.heartbeat_ack = &r->heartbeat_ack;
}

void vf_leases_release(vf_farm *farm, const vf_farm_worker *w, const Vcmfarm__LeaseRelease *m, double now,
                       vf_farm_reply *r) {
  vf_lease *l = vf_lease_find(&farm->leases, m->lease_id);
  if (l == NULL || l->worker_id != w->id || l->state != VF_LEASE_ACTIVE) {
    vf_farm_reply_ack(r, 0, "no such active lease of this worker");
    return;
  }
  if (m->failure[0] != '\0') {
    /* The worker survived a failure of the renderer on this job: the lease failed
     * (coordinator/poison.h); the job fails only when others fail on it too. */
    char why[256];
    snprintf(why, sizeof why, "%s", m->failure);
    for (char *c = why; *c; c++)
      if ((unsigned char)*c < 0x20 || *c == 0x7f) *c = '?';
    uint64_t job_id = l->job_id;
    vf_job *job = vf_farm_job(farm, job_id);
    vf_log("worker %s failed lease %016llx of job %llu: %s", w->name, (unsigned long long)l->id,
           (unsigned long long)job_id, why);
    vf_leases_end(farm, l, 0, now);
    if (job != NULL) vf_poison_lease_failed(farm, job_id, w->name, why, now);
  } else {
    vf_log("worker %s handed back lease %016llx", w->name, (unsigned long long)l->id);
    vf_leases_end(farm, l, 0, now);
  }
  vf_farm_reply_ack(r, 1, "released");
}
