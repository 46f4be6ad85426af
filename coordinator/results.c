#include "results.h"

#include "../common/clock.h"
#include "../common/error.h"
#include "../common/wire.h"
#include "jobs.h"
#include "checkpoint.h"
#include "leases.h"
#include "log.h"
#include "merger.h"
#include "partial.h"
#include "ship.h"
#include "workers.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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
  if (w && film->render_seconds > 0.0 && !film->pilot) { /* a pilot's iteration costs less */
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
  if (film->pilot)
    vf_log("merged job %llu pilot [%llu,%llu)%s: %llu/%d pilot iterations", (unsigned long long)job->id, b, e,
           late ? " (late result)" : "", (unsigned long long)vf_job_pilot_done(job), job->settings.pilot);
  else
    vf_log("merged job %llu [%llu,%llu)%s: %llu/%llu iterations", (unsigned long long)job->id, b, e,
           late ? " (late result)" : "", (unsigned long long)vf_job_done(job), (unsigned long long)job->iterations);
}

/* The checks every message of a result passes on the loop before its tiles are looked at:
 * the lease, the job, the size, the range. Returns the lease, or NULL when answered (a
 * refusal, or "already merged"). */
static vf_lease *admit(vf_farm *farm, const Vcmfarm__LeaseResult *m, vf_farm_reply *r) {
  unsigned long long lid = (unsigned long long)m->lease_id, jid = (unsigned long long)m->job_id;
  unsigned long long b = (unsigned long long)m->begin, e = (unsigned long long)m->end;
  vf_job *job = vf_farm_job(farm, m->job_id);
  vf_lease *l = vf_lease_find(&farm->leases, m->lease_id);
  vf_farm_worker *w = vf_workers_find_any(farm, m->worker_id);
  if (l == NULL) {
    refuse(w, job, r, "lease %016llx (job %llu [%llu,%llu)) is unknown: expired long ago, finished, or "
           "granted before a coordinator restart", lid, jid, b, e);
    return NULL;
  }
  if (l->job_id != m->job_id) {
    refuse(w, job, r, "lease %016llx is of job %llu, the result claims job %llu", lid, (unsigned long long)l->job_id,
           jid);
    return NULL;
  }
  /* A lease is one worker's: another's result for it would be merged in its holder's name
   * while the holder renders the same iterations. */
  if (l->worker_id != m->worker_id) {
    refuse(w, job, r, "lease %016llx is held by worker %llu, not by the sender %llu: nothing merged", lid,
           (unsigned long long)l->worker_id, (unsigned long long)m->worker_id);
    return NULL;
  }
  if (job == NULL) {
    refuse(w, NULL, r, "job %llu does not exist", jid);
    return NULL;
  }
  if (job->end != VF_JOB_ACTIVE) {
    refuse(w, job, r, "job %llu is %s", jid, vf_job_state(job, 0));
    return NULL;
  }
  size_t size = vcmfarm__lease_result__get_packed_size(m);
  if (size > VF_WIRE_MAX_RESULT) {
    refuse(w, job, r, "job %llu [%llu,%llu): a result message of %zu bytes, at most %zu", jid, b, e, size,
           VF_WIRE_MAX_RESULT);
    return NULL;
  }
  /* A pilot part chose the allocation; it is never a sample of the image, nor the other
   * way round (docs/PROTOCOL.md, "Pilots"). */
  if ((m->pilot != 0) != l->pilot) {
    refuse(w, job, r, l->pilot ? "lease %016llx is of job %llu's pilot, the result claims to be a part of its image: "
                                 "a pilot's iterations are never merged into the image; nothing merged"
                               : "lease %016llx is of job %llu's image, the result claims to be a pilot part: "
                                 "nothing merged", lid, jid);
    return NULL;
  }
  /* Sent again because the acknowledgement of its last tiles was lost: nothing to do. */
  if (m->begin >= l->first && m->begin < m->end && m->end <= l->begin) {
    vf_farm_reply_ack(r, 1, "already merged");
    return NULL;
  }
  if (m->begin != l->begin || m->end <= m->begin || m->end > l->end) {
    refuse(w, job, r, "lease %016llx holds job %llu [%llu,%llu) unmerged, the result claims [%llu,%llu)", lid, jid,
           (unsigned long long)l->begin, (unsigned long long)l->end, b, e);
    return NULL;
  }
  return l;
}

/* The whole part, validated (`film`, the caller's): checked against the job and merged,
 * its pixels added at once (`deferred` 0) or on the merge thread; answered. */
static void merge_part(vf_farm *farm, vf_job *job, vf_lease *l, vf_film *film, const Vcmfarm__LeaseResult *m,
                       double now, int deferred, vf_farm_reply *r);

void vf_results_receive(vf_farm *farm, const Vcmfarm__LeaseResult *m, double now, vf_farm_reply *r) {
  vf_lease *l = admit(farm, m, r);
  if (l == NULL) return;
  if (farm->merger != NULL) return vf_results_receive_later(farm, l, m, now, r);
  vf_job *job = vf_farm_job(farm, m->job_id);
  vf_farm_worker *w = vf_workers_find_any(farm, m->worker_id);
  if (stage(w, job, l, m, now, r) != 1) return;
  vf_film *film = NULL;
  int err = vf_partial_take(l->partial, &film);
  drop_part(l);
  if (err != VF_OK) {
    unsigned long long b = (unsigned long long)m->begin, e = (unsigned long long)m->end;
    return refuse(w, job, r, "job %llu [%llu,%llu): %s", (unsigned long long)m->job_id, b, e, vf_error_detail(err));
  }
  merge_part(farm, job, l, film, m, now, 0, r);
}

/* A whole part merged, or refused saying why. A pilot part (film->pilot) goes into the
 * job's pilot film as a part of the image goes into its film (deferred: its pixels added on
 * the merge thread), and once the pilot is complete the allocation follows
 * (vf_jobs_pilot_merged). */
static void merge_part(vf_farm *farm, vf_job *job, vf_lease *l, vf_film *film, const Vcmfarm__LeaseResult *m,
                       double now, int deferred, vf_farm_reply *r) {
  unsigned long long lid = (unsigned long long)m->lease_id, jid = (unsigned long long)m->job_id;
  unsigned long long b = (unsigned long long)m->begin, e = (unsigned long long)m->end;
  const char *pilot = film->pilot ? " pilot" : "";
  vf_farm_worker *w = vf_workers_find_any(farm, m->worker_id);
  int err = vf_job_check_result(job, film, m->begin, m->end);
  if (err == VF_OK)
    err = film->pilot ? (deferred ? vf_job_merge_pilot_deferred(job, film) : vf_job_merge_pilot(job, film))
          : deferred  ? vf_job_merge_deferred(job, film, now)
                      : vf_job_merge(job, film, now);
  if (err != VF_OK) {
    vf_film_destroy(film);
    if (err == VF_EOVERLAP)
      return refuse(w, job, r, "job %llu%s [%llu,%llu): %s lease %016llx: some of these iterations are already "
                    "counted, nothing merged", jid, pilot, b, e,
                    l->state == VF_LEASE_EXPIRED ? "late result of expired" : "duplicate result of", lid);
    return refuse(w, job, r, "job %llu%s [%llu,%llu): %s", jid, pilot, b, e, vf_error_detail(err));
  }
  merged(farm, job, l, film, m, now);
  if (film->pilot && deferred) {
    vf_results_add_pixels(farm, job, film); /* owns film now; the pilot is tested when it lands */
  } else if (film->pilot) {
    vf_film_destroy(film);
    vf_jobs_pilot_merged(farm, job, now);
  } else if (deferred) {
    vf_results_add_pixels(farm, job, film); /* owns film now; the targets are tested when it lands */
    if (vf_job_complete(job)) vf_jobs_finish(farm, job, now); /* its final film waits for the addition */
  } else {
    vf_film_destroy(film);
    if ((err = vf_job_check_stop(job)) < 0) vf_log("job %llu: measuring failed: %s", jid, vf_error_detail(err));
    if (vf_job_complete(job)) vf_jobs_finish(farm, job, now);
  }
  vf_farm_reply_ack(r, 1, "merged");
}

/* ---- off the loop (farm->merger) ----
 * A message's tiles are decoded and stored in its part on the merge thread (DECODE). The
 * messages of a part stream: each is answered "queued" as soon as it is handed to the
 * thread, except the one that brings the part's tiles to its total, which is answered
 * when it is decoded: with the part whole, it is validated there, and merged on the loop
 * except for the addition of its pixels, queued behind it (ADD). A message refused on the
 * thread marks the part failed; the part's next message (at the latest its last) is
 * refused with that reason and the part dropped, so nothing of it is merged. The part is
 * held by a reference of each message on the thread (coordinator/partial.h): the lease may
 * drop it meanwhile; the loop looks the lease up again by id when a message is back. */

typedef struct {
  vf_merge_item item;
  vf_farm *farm;
  uint64_t token;
  int answer;                 /* the message waits for this for its reply */
  Vcmfarm__Envelope *request; /* owned: request->result is the message */
  vf_partial *partial;        /* a reference */
  vf_film *film;              /* the whole part, validated, when it is */
  int err;
  char detail[1024];
} decode_item;

static void decode_work(vf_merge_item *item) {
  decode_item *d = (decode_item *)item;
  vf_error_clear();
  d->err = vf_partial_add(d->partial, d->request->result);
  if (d->err == VF_OK && vf_partial_received(d->partial) == vf_partial_total(d->partial))
    d->err = vf_partial_take(d->partial, &d->film);
  if (d->err != VF_OK) snprintf(d->detail, sizeof d->detail, "%s", vf_error_detail(d->err));
}

static void decode_done(vf_merge_item *item) {
  decode_item *d = (decode_item *)item;
  vf_farm *farm = d->farm;
  const Vcmfarm__LeaseResult *m = d->request->result;
  unsigned long long jid = (unsigned long long)m->job_id, b = (unsigned long long)m->begin;
  unsigned long long e = (unsigned long long)m->end;
  double now = vf_seconds_now();
  vf_ship_part_work(farm, item->seconds, 0);
  vf_job *job = vf_farm_job(farm, m->job_id);
  vf_lease *l = vf_lease_find(&farm->leases, m->lease_id);
  vf_farm_worker *w = vf_workers_find_any(farm, m->worker_id);
  int current = l != NULL && job != NULL && l->job_id == m->job_id && l->begin == m->begin && l->partial == d->partial;
  if (d->err != VF_OK) vf_partial_fail(d->partial, d->detail);
  if (!d->answer) {
    if (d->err != VF_OK && current) vf_log("job %llu [%llu,%llu): %s; the part is dropped", jid, b, e, d->detail);
    vf_film_destroy(d->film);
  } else {
    vf_farm_reply r;
    vf_farm_reply_init(&r);
    const char *failure = vf_partial_failure(d->partial);
    if (!current) {
      vf_film_destroy(d->film);
      refuse(w, job, &r, "job %llu [%llu,%llu): its lease ended or the part was dropped while it was being received",
             jid, b, e);
    } else if (job->end != VF_JOB_ACTIVE) {
      vf_film_destroy(d->film);
      drop_part(l);
      refuse(w, job, &r, "job %llu is %s", jid, vf_job_state(job, 0));
    } else if (failure != NULL) {
      vf_film_destroy(d->film);
      refuse(w, job, &r, "job %llu [%llu,%llu): %s; the part is dropped", jid, b, e, failure);
      drop_part(l);
    } else if (d->film == NULL) { /* tiles sent twice counted among the total: more to come */
      vf_partial_touch(l->partial, now);
      snprintf(r.text, sizeof r.text, "tiles of [%llu,%llu) received, some twice: %u tiles, more to come", b, e,
               vf_partial_total(l->partial));
      vf_farm_reply_ack(&r, 1, r.text);
    } else {
      drop_part(l); /* spent: its film is d->film */
      merge_part(farm, job, l, d->film, m, now, 1, &r);
    }
    if (farm->reply_later) farm->reply_later(farm->reply_ctx, d->token, &r);
    vf_farm_reply_release(&r);
  }
  vf_partial_destroy(d->partial);
  vf_message_free(d->request);
  free(d);
}

/* Not now: the merge thread has enough to do. The sender keeps its message and sends it
 * again after retry_ms, nothing refused (docs/PROTOCOL.md, "Merging off the loop"). */
static void busy(vf_farm *farm, vf_farm_reply *r, const char *why) {
  snprintf(r->text, sizeof r->text, "busy: %s; send it again later", why);
  vf_farm_reply_ack(r, 0, r->text);
  r->result_ack.retry_ms = vf_ship_retry_ms(farm);
}

void vf_results_receive_later(vf_farm *farm, vf_lease *l, const Vcmfarm__LeaseResult *m, double now,
                              vf_farm_reply *r) {
  vf_job *job = vf_farm_job(farm, m->job_id);
  vf_farm_worker *w = vf_workers_find_any(farm, m->worker_id);
  unsigned long long jid = (unsigned long long)m->job_id, b = (unsigned long long)m->begin;
  unsigned long long e = (unsigned long long)m->end;
  if (vf_merger_full(farm->merger)) return busy(farm, r, "the merge queue is full");
  if (l->partial != NULL && !vf_partial_same(l->partial, m)) {
    vf_log("lease %016llx: a new part [%llu,%llu) replaces the one being received", (unsigned long long)l->id, b, e);
    drop_part(l);
  }
  if (l->partial == NULL) {
    size_t staged = 0;
    for (size_t i = 0; i < farm->leases.count; i++) staged += farm->leases.leases[i].partial != NULL;
    if (staged >= VF_PARTS_STAGED_MAX) return busy(farm, r, "as many parts as it holds are being received");
    int err = vf_partial_create(job, m, &l->partial);
    if (err != VF_OK) return refuse(w, job, r, "job %llu [%llu,%llu): %s", jid, b, e, vf_error_detail(err));
  }
  const char *failure = vf_partial_failure(l->partial);
  if (failure != NULL) {
    refuse(w, job, r, "job %llu [%llu,%llu): %s; the part is dropped", jid, b, e, failure);
    return drop_part(l);
  }
  decode_item *d = calloc(1, sizeof *d);
  if (d == NULL) return busy(farm, r, "out of memory");
  d->item.work = decode_work;
  d->item.done = decode_done;
  d->farm = farm;
  d->token = farm->request_token;
  d->request = farm->request;
  farm->request = NULL; /* ours now */
  d->partial = l->partial;
  vf_partial_retain(d->partial);
  uint32_t queued = vf_partial_queue(d->partial, (uint32_t)m->n_tiles), total = vf_partial_total(d->partial);
  d->answer = queued >= total;
  vf_partial_touch(d->partial, now);
  vf_merger_queue(farm->merger, &d->item);
  if (d->answer) {
    r->deferred = 1;
    return;
  }
  snprintf(r->text, sizeof r->text, "tiles %u/%u of [%llu,%llu) queued", queued, total, b, e);
  vf_farm_reply_ack(r, 1, r->text);
}

/* ADD: the pixels of a merged part into its job's film, or of a pilot part into its
 * pilot film. */
typedef struct {
  vf_merge_item item;
  vf_farm *farm;
  uint64_t job_id;
  vf_film *dst;  /* the job's (pilot) film: its pixels are the thread's while job->(pilot_)merging */
  vf_film *film; /* owned */
} add_item;

/* A pilot part's pixels landed: the last of the pilot's may complete it. */
static void pilot_added(vf_farm *farm, vf_job *job) {
  if (job->pilot_merging > 0) job->pilot_merging--;
  if (job->pilot_merging == 0) vf_jobs_pilot_merged(farm, job, vf_seconds_now());
}

static void add_work(vf_merge_item *item) {
  add_item *a = (add_item *)item;
  vf_film_add_pixels(a->dst, a->film);
}

static void add_done(vf_merge_item *item) {
  add_item *a = (add_item *)item;
  vf_farm *farm = a->farm;
  vf_ship_part_work(farm, item->seconds, 1);
  vf_job *job = vf_farm_job(farm, a->job_id);
  int pilot = a->film->pilot;
  vf_film_destroy(a->film);
  free(a);
  if (job == NULL) return;
  if (pilot) return pilot_added(farm, job);
  if (job->merging > 0) job->merging--;
  if (job->merging > 0) return;
  int err = vf_job_check_stop(job);
  if (err < 0) vf_log("job %llu: measuring failed: %s", (unsigned long long)job->id, vf_error_detail(err));
  if (err == 1) vf_jobs_finish(farm, job, vf_seconds_now());
  else vf_checkpoint_resume(farm, job); /* a final film or a fetch waiting for the pixels */
}

void vf_results_add_pixels(vf_farm *farm, vf_job *job, vf_film *film) {
  vf_film *dst = film->pilot ? job->pilot_film : job->film;
  add_item *a = calloc(1, sizeof *a);
  if (a == NULL) { /* the addition cannot be refused now: do it here */
    int pilot = film->pilot;
    vf_film_add_pixels(dst, film);
    vf_film_destroy(film);
    if (pilot) return pilot_added(farm, job);
    job->merging--;
    return;
  }
  *a = (add_item){.item = {.work = add_work, .done = add_done}, .farm = farm, .job_id = job->id, .dst = dst,
                  .film = film};
  vf_merger_queue(farm->merger, &a->item);
}

void vf_results_expire(vf_farm *farm, double now) {
  for (size_t i = 0; i < farm->leases.count; i++) {
    vf_lease *l = &farm->leases.leases[i];
    if (l->partial == NULL || now - vf_partial_updated(l->partial) <= farm->config.worker_timeout) continue;
    vf_log("lease %016llx: part [%llu,...) incomplete (%u tiles) and silent for %.1f s; dropped",
           (unsigned long long)l->id, (unsigned long long)l->begin, vf_partial_total(l->partial),
           now - vf_partial_updated(l->partial));
    drop_part(l);
  }
}
