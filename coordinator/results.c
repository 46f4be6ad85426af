#include "results.h"

#include "../common/clock.h"
#include "../common/error.h"
#include "../common/wire.h"
#include "jobs.h"
#include "leases.h"
#include "log.h"
#include "partial.h"
#include "workers.h"

#include <stdarg.h>
#include <stdio.h>

/* Refuses a result message of worker `w` (NULL: not registered) for job (NULL: none):
 * counted for both, an event of the job, logged and answered. */
static void refuse(vf_farm_worker *w, vf_job *job, vf_farm_reply *r, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
static void refuse(vf_farm_worker *w, vf_job *job, vf_farm_reply *r, const char *fmt, ...) {
  char text[1024];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(text, sizeof text, fmt, ap);
  va_end(ap);
  if (w) w->results_refused++;
  if (job) {
    job->results_refused++;
    vf_events_add(&job->events, vf_unix_now(), "result_refused", job->id, w ? w->name : "", "%s", text);
  }
  vf_log("refused result: %s", text);
  vf_farm_reply_ack(r, 0, text);
}

static void drop_part(vf_lease *l) {
  vf_partial_destroy(l->partial);
  l->partial = NULL;
}

/* Stores the message's tiles in the lease's part (a new one when the message starts
 * another). Returns 1 when the part is whole, 0 when tiles are missing (acknowledged), -1
 * when refused (answered and the part dropped). */
static int stage(vf_farm_worker *w, vf_job *job, vf_lease *l, const Vcmfarm__LeaseResult *m, double now,
                 vf_farm_reply *r) {
  unsigned long long jid = (unsigned long long)m->job_id, b = (unsigned long long)m->begin;
  unsigned long long e = (unsigned long long)m->end;
  int err;
  if (l->partial != NULL && !vf_partial_same(l->partial, m)) {
    vf_log("lease %016llx: a new part [%llu,%llu) replaces the one being received", (unsigned long long)l->id, b, e);
    drop_part(l);
  }
  if (l->partial == NULL && (err = vf_partial_create(job, m, &l->partial)) != VF_OK) {
    refuse(w, job, r, "job %llu [%llu,%llu): %s", jid, b, e, vf_error_detail(err));
    return -1;
  }
  vf_partial_touch(l->partial, now);
  if ((err = vf_partial_add(l->partial, m)) != VF_OK) {
    drop_part(l);
    refuse(w, job, r, "job %llu [%llu,%llu): %s; the part is dropped", jid, b, e, vf_error_detail(err));
    return -1;
  }
  if (vf_partial_received(l->partial) == vf_partial_total(l->partial)) return 1;
  snprintf(r->text, sizeof r->text, "tiles %u/%u of [%llu,%llu) received", vf_partial_received(l->partial),
           vf_partial_total(l->partial), b, e);
  vf_farm_reply_ack(r, 1, r->text);
  return 0;
}

/* The whole part merged into the job's film: the worker's rate, the lease's start and the
 * leases a late result covered follow. */
static void merged(vf_farm *farm, vf_job *job, vf_lease *l, const vf_film *film, const Vcmfarm__LeaseResult *m,
                   double now) {
  unsigned long long lid = (unsigned long long)m->lease_id, b = (unsigned long long)m->begin;
  unsigned long long e = (unsigned long long)m->end;
  int late = l->state == VF_LEASE_EXPIRED;
  vf_farm_worker *w = vf_workers_find_any(farm, l->worker_id);
  if (w) {
    w->iterations_merged += m->end - m->begin;
    w->parts_merged++;
  }
  if (w && film->render_seconds > 0.0) {
    double rate = (double)(m->end - m->begin) / film->render_seconds;
    w->rate = w->rate > 0.0 ? 0.5 * w->rate + 0.5 * rate : rate;
  }
  l->begin = m->end;
  if (l->begin == l->end)
    vf_leases_end(farm, l, 0, now);
  else
    vf_log("lease %016llx: part [%llu,%llu) merged, [%llu,%llu) to go", lid, b, e, (unsigned long long)l->begin,
           (unsigned long long)l->end);
  /* A late result may cover iterations reassigned since: those leases are moot now. */
  vf_leases_revoke(farm, m->job_id, m->begin, m->end, m->lease_id, now);
  vf_log("merged job %llu [%llu,%llu)%s: %llu/%llu iterations", (unsigned long long)job->id, b, e,
         late ? " (late result)" : "", (unsigned long long)vf_job_done(job), (unsigned long long)job->iterations);
}

void vf_results_receive(vf_farm *farm, const Vcmfarm__LeaseResult *m, double now, vf_farm_reply *r) {
  unsigned long long lid = (unsigned long long)m->lease_id, jid = (unsigned long long)m->job_id;
  unsigned long long b = (unsigned long long)m->begin, e = (unsigned long long)m->end;
  vf_job *job = vf_farm_job(farm, m->job_id);
  vf_lease *l = vf_lease_find(&farm->leases, m->lease_id);
  vf_farm_worker *w = vf_workers_find_any(farm, m->worker_id);
  if (l == NULL)
    return refuse(w, job, r, "lease %016llx (job %llu [%llu,%llu)) is unknown: expired long ago, finished, or "
                  "granted before a coordinator restart", lid, jid, b, e);
  if (l->job_id != m->job_id)
    return refuse(w, job, r, "lease %016llx is of job %llu, the result claims job %llu", lid,
                  (unsigned long long)l->job_id, jid);
  if (job == NULL) return refuse(w, NULL, r, "job %llu does not exist", jid);
  if (job->end != VF_JOB_ACTIVE) return refuse(w, job, r, "job %llu is %s", jid, vf_job_state(job, 0));
  size_t size = vcmfarm__lease_result__get_packed_size(m);
  if (size > VF_WIRE_MAX_RESULT)
    return refuse(w, job, r, "job %llu [%llu,%llu): a result message of %zu bytes, at most %zu", jid, b, e, size,
                  VF_WIRE_MAX_RESULT);
  /* Sent again because the acknowledgement of its last tiles was lost: nothing to do. */
  if (m->begin >= l->first && m->begin < m->end && m->end <= l->begin) return vf_farm_reply_ack(r, 1, "already merged");
  if (m->begin != l->begin || m->end <= m->begin || m->end > l->end)
    return refuse(w, job, r, "lease %016llx holds job %llu [%llu,%llu) unmerged, the result claims [%llu,%llu)", lid,
                  jid, (unsigned long long)l->begin, (unsigned long long)l->end, b, e);
  if (stage(w, job, l, m, now, r) != 1) return;
  vf_film *film = NULL;
  int err = vf_partial_take(l->partial, &film);
  drop_part(l);
  if (err == VF_OK) err = vf_job_check_result(job, film, m->begin, m->end);
  if (err == VF_OK) err = vf_job_merge(job, film, now);
  if (err != VF_OK) {
    vf_film_destroy(film);
    if (err == VF_EOVERLAP)
      return refuse(w, job, r, "job %llu [%llu,%llu): %s lease %016llx: some of these iterations are already counted, "
                    "nothing merged", jid, b, e,
                    l->state == VF_LEASE_EXPIRED ? "late result of expired" : "duplicate result of", lid);
    return refuse(w, job, r, "job %llu [%llu,%llu): %s", jid, b, e, vf_error_detail(err));
  }
  merged(farm, job, l, film, m, now);
  vf_film_destroy(film);
  if ((err = vf_job_check_stop(job)) < 0) vf_log("job %llu: measuring failed: %s", jid, vf_error_detail(err));
  if (vf_job_complete(job)) vf_jobs_finish(farm, job, now);
  vf_farm_reply_ack(r, 1, "merged");
}

void vf_results_expire(vf_farm *farm, double now) {
  for (size_t i = 0; i < farm->leases.count; i++) {
    vf_lease *l = &farm->leases.leases[i];
    if (l->partial == NULL || now - vf_partial_updated(l->partial) <= farm->config.worker_timeout) continue;
    vf_log("lease %016llx: part [%llu,...) incomplete (%u/%u tiles) and silent for %.1f s; dropped",
           (unsigned long long)l->id, (unsigned long long)l->begin, vf_partial_received(l->partial),
           vf_partial_total(l->partial), now - vf_partial_updated(l->partial));
    drop_part(l);
  }
}
