#include "farm.h"

#include "../common/error.h"
#include "../common/wire.h"
#include "blobs.h"
#include "jobs.h"
#include "log.h"
#include "partial.h"
#include "schedule.h"
#include "state.h"

#include <sodium.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void vf_farm_init(vf_farm *farm, const vf_farm_config *config) {
  memset(farm, 0, sizeof *farm);
  farm->config = *config;
  farm->next_job_id = 1;
  vf_lease_table_init(&farm->leases);
}

void vf_farm_destroy(vf_farm *farm) {
  for (size_t i = 0; i < farm->num_jobs; i++) vf_job_destroy(farm->jobs[i]);
  free(farm->jobs);
  free(farm->workers);
  free(farm->checked);
  vf_lease_table_destroy(&farm->leases);
  memset(farm, 0, sizeof *farm);
}

vf_job *vf_farm_job(const vf_farm *farm, uint64_t id) {
  for (size_t i = 0; i < farm->num_jobs; i++)
    if (farm->jobs[i]->id == id) return farm->jobs[i];
  return NULL;
}

static vf_farm_worker *find_worker(vf_farm *farm, uint64_t id) {
  for (size_t i = 0; i < farm->num_workers; i++)
    if (farm->workers[i].id == id) return &farm->workers[i];
  return NULL;
}

static vf_farm_worker *worker_of_lease(vf_farm *farm, const vf_lease *lease) {
  vf_farm_worker *w = find_worker(farm, lease->worker_id);
  return w != NULL && w->lease_id == lease->id ? w : NULL;
}

/* The lease stops being active (expired: a late result may still be checked against it).
 * Its job is charged the worker time it really took, grant to now. */
static void end_lease(vf_farm *farm, vf_lease *lease, int keep, double now) {
  vf_farm_worker *w = worker_of_lease(farm, lease);
  if (w) w->lease_id = 0;
  vf_job *job = vf_farm_job(farm, lease->job_id);
  if (job && lease->state == VF_LEASE_ACTIVE) vf_schedule_charge(job, (now - lease->granted) - lease->charged);
  if (keep) vf_lease_expire(&farm->leases, lease->id);
  else vf_lease_remove(&farm->leases, lease->id);
}

/* The job takes no more results from its active leases' workers; the leases are kept as
 * expired, so results still on their way are checked against them and refused by the
 * job's state or by vf_film_merge, and logged as such. */
void vf_farm_end_job_leases(vf_farm *farm, uint64_t job_id, double now) {
  for (size_t i = 0; i < farm->leases.count;) {
    vf_lease *l = &farm->leases.leases[i];
    if (l->job_id == job_id && l->state == VF_LEASE_ACTIVE) {
      end_lease(farm, l, 1, now);
      i = 0;
    } else {
      i++;
    }
  }
}

/* ---- replies ---- */

static void reply_init(vf_farm_reply *r) {
  memset(r, 0, sizeof *r);
  vcmfarm__envelope__init(&r->env);
}

void vf_farm_reply_error(vf_farm_reply *r, Vcmfarm__ErrorCode code, const char *message) {
  char text[sizeof r->text];
  snprintf(text, sizeof text, "%s", message);
  reply_init(r);
  vcmfarm__error__init(&r->error);
  memcpy(r->text, text, sizeof text);
  r->error.code = code;
  r->error.message = r->text;
  r->env.body_case = VCMFARM__ENVELOPE__BODY_ERROR;
  r->env.error = &r->error;
}

void vf_farm_reply_errorf(vf_farm_reply *r, Vcmfarm__ErrorCode code, const char *fmt, ...) {
  char text[1024];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(text, sizeof text, fmt, ap);
  va_end(ap);
  vf_farm_reply_error(r, code, text);
}

void vf_farm_reply_ack(vf_farm_reply *r, int accepted, const char *message) {
  vcmfarm__result_ack__init(&r->result_ack);
  if (message != r->text) snprintf(r->text, sizeof r->text, "%s", message);
  r->result_ack.accepted = accepted;
  r->result_ack.message = r->text;
  r->env.body_case = VCMFARM__ENVELOPE__BODY_RESULT_ACK;
  r->env.result_ack = &r->result_ack;
}

void vf_farm_reply_release(vf_farm_reply *r) {
  free(r->job_status);
  free(r->job_status_ptrs);
  free(r->worker_status);
  free(r->worker_status_ptrs);
  free(r->film_bytes);
  free(r->log);
  free(r->log_ptrs);
  free(r->missing);
  free(r->blob_bytes);
  free(r->file_refs);
  free(r->file_ref_ptrs);
  reply_init(r);
}

/* ---- workers ---- */

static void handle_register(vf_farm *farm, const Vcmfarm__Register *m, double now, vf_farm_reply *r) {
  if (farm->num_workers == farm->workers_capacity) {
    size_t cap = farm->workers_capacity ? 2 * farm->workers_capacity : 8;
    vf_farm_worker *grown = realloc(farm->workers, cap * sizeof *grown);
    if (grown == NULL) return vf_farm_reply_error(r, VCMFARM__ERROR_CODE__ERROR_INTERNAL, "out of memory");
    farm->workers = grown;
    farm->workers_capacity = cap;
  }
  vf_farm_worker *w = &farm->workers[farm->num_workers++];
  memset(w, 0, sizeof *w);
  do {
    randombytes_buf(&w->id, sizeof w->id);
  } while (w->id == 0 || find_worker(farm, w->id) != w);
  snprintf(w->name, sizeof w->name, "%s", m->name);
  for (char *c = w->name; *c; c++)
    if ((unsigned char)*c < 0x20) *c = '?';
  w->cores = m->cores;
  w->threads = m->threads;
  w->last_seen = now;
  vf_log("worker %s registered (%u cores, %u threads, vcmfarm %.32s) as %016llx", w->name, w->cores, w->threads,
         m->software_version, (unsigned long long)w->id);
  vcmfarm__registered__init(&r->registered);
  r->registered.worker_id = w->id;
  double hb = farm->config.worker_timeout / 5.0;
  r->registered.heartbeat_ms = (uint32_t)(hb * 1000.0 < 50.0 ? 50.0 : hb * 1000.0);
  r->registered.timeout_ms = (uint32_t)(farm->config.worker_timeout * 1000.0);
  r->env.body_case = VCMFARM__ENVELOPE__BODY_REGISTERED;
  r->env.registered = &r->registered;
}

static int has_free_range(void *ctx, const vf_job *j) {
  vf_farm *farm = ctx;
  uint64_t b, e, free_count;
  return vf_job_runnable(j) &&
         vf_lease_free_range(&farm->leases, j->id, &j->film->iterations, j->first, j->iterations, 1, &b, &e, &free_count) == 1;
}

static void handle_lease_request(vf_farm *farm, vf_farm_worker *w, double now, vf_farm_reply *r) {
  vf_lease *old = vf_lease_find(&farm->leases, w->lease_id);
  if (old != NULL) {
    vf_log("worker %s asks for work while holding lease %016llx; that lease returns to the pool", w->name,
           (unsigned long long)old->id);
    end_lease(farm, old, 1, now);
  }
  w->lease_id = 0;
  vf_job *job = vf_schedule_pick(farm->jobs, farm->num_jobs, has_free_range, farm);
  if (job == NULL) {
    vcmfarm__idle__init(&r->idle);
    /* Often enough that a new job starts within half a second; cheap for the coordinator. */
    double retry = farm->config.worker_timeout / 4.0;
    r->idle.retry_ms = (uint32_t)(retry > 0.5 ? 500.0 : retry * 1000.0);
    r->env.body_case = VCMFARM__ENVELOPE__BODY_IDLE;
    r->env.idle = &r->idle;
    return;
  }
  uint64_t b, e, free_count;
  vf_lease_free_range(&farm->leases, job->id, &job->film->iterations, job->first, job->iterations, UINT64_MAX, &b, &e, &free_count);
  uint64_t size = vf_lease_size(w->rate, farm->config.lease_seconds, free_count, farm->num_workers);
  if (vf_lease_free_range(&farm->leases, job->id, &job->film->iterations, job->first, job->iterations, size, &b, &e,
                          &free_count) != 1 ||
      vf_lease_add(&farm->leases, job->id, w->id, b, e, now, &w->lease_id) != VF_OK)
    return vf_farm_reply_error(r, VCMFARM__ERROR_CODE__ERROR_INTERNAL, "out of memory for leases");
  vf_lease *granted = vf_lease_find(&farm->leases, w->lease_id);
  granted->charged = vf_schedule_estimate(e - b, w->rate, job->rate, farm->config.lease_seconds);
  vf_schedule_charge(job, granted->charged);
  vf_log("lease %016llx: job %llu iterations [%llu,%llu) to worker %s", (unsigned long long)w->lease_id,
         (unsigned long long)job->id, (unsigned long long)b, (unsigned long long)e, w->name);
  vcmfarm__lease__init(&r->lease);
  vcmfarm__scene__init(&r->scene);
  if (job->scene_builtin) {
    r->scene.source_case = VCMFARM__SCENE__SOURCE_BUILTIN;
    r->scene.builtin = job->scene_text;
  } else {
    r->scene.source_case = VCMFARM__SCENE__SOURCE_JSON;
    r->scene.json = job->scene_text;
  }
  if (vf_farm_blobs_lease(job, r) != VF_OK)
    return vf_farm_reply_error(r, VCMFARM__ERROR_CODE__ERROR_INTERNAL, "out of memory for the lease's file table");
  r->lease.lease_id = w->lease_id;
  r->lease.job_id = job->id;
  r->lease.scene = &r->scene;
  r->lease.scene_hash.data = job->scene_hash;
  r->lease.scene_hash.len = 32;
  r->lease.settings = job->settings_text;
  r->lease.begin = b;
  r->lease.end = e;
  r->env.body_case = VCMFARM__ENVELOPE__BODY_LEASE;
  r->env.lease = &r->lease;
}

static void handle_heartbeat(vf_farm *farm, vf_farm_worker *w, const Vcmfarm__Heartbeat *m, vf_farm_reply *r) {
  vf_lease *l = vf_lease_find(&farm->leases, m->lease_id);
  vf_job *job = l ? vf_farm_job(farm, l->job_id) : NULL;
  vcmfarm__heartbeat_ack__init(&r->heartbeat_ack);
  r->heartbeat_ack.lease_valid = l != NULL && l->state == VF_LEASE_ACTIVE && l->worker_id == w->id &&
                                 w->lease_id == l->id && job != NULL && vf_job_runnable(job);
  if (r->heartbeat_ack.lease_valid) l->reported = m->iterations_done; /* clamped where it is used */
  r->env.body_case = VCMFARM__ENVELOPE__BODY_HEARTBEAT_ACK;
  r->env.heartbeat_ack = &r->heartbeat_ack;
}

static void refuse_result(vf_job *job, vf_farm_reply *r, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void refuse_result(vf_job *job, vf_farm_reply *r, const char *fmt, ...) {
  char text[1024];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(text, sizeof text, fmt, ap);
  va_end(ap);
  if (job) job->results_refused++;
  vf_log("refused result: %s", text);
  vf_farm_reply_ack(r, 0, text);
}

/* Starts the checkpoint of one film: written here without a film writer, else a snapshot
 * handed to it (the job's film keeps changing meanwhile). A job whose write is in flight is
 * left dirty: vf_farm_film_written or the next checkpoint takes it. */
static int save_film(vf_farm *farm, vf_job *job) {
  if (job->film_writing) return VF_OK;
  if (farm->write_film == NULL) return vf_state_save_film(farm->config.state_dir, job);
  char path[4096];
  int err = vf_state_film_path(farm->config.state_dir, job->id, path, sizeof path);
  vf_film *snapshot;
  if (err != VF_OK || (err = vf_film_clone(job->film, &snapshot)) != VF_OK) return err;
  if ((err = farm->write_film(farm->write_ctx, job->id, snapshot, path)) != VF_OK) {
    vf_film_destroy(snapshot);
    return err;
  }
  job->film_writing = 1;
  job->writing_generation = job->film_generation;
  farm->writes_pending++;
  return VF_OK;
}

void vf_farm_film_written(vf_farm *farm, uint64_t job_id, int err, double seconds) {
  if (farm->writes_pending > 0) farm->writes_pending--;
  vf_job *job = vf_farm_job(farm, job_id);
  if (job == NULL) return;
  unsigned long long jid = (unsigned long long)job_id;
  job->film_writing = 0;
  if (err != VF_OK) {
    vf_log("checkpoint of job %llu failed: %s", jid, vf_error_detail(err));
    return; /* still dirty: the next checkpoint tries again */
  }
  if (seconds >= 1.0) vf_log("job %llu: film checkpoint written in %.2f s (off the event loop)", jid, seconds);
  if (job->writing_generation != job->film_generation) {
    /* Changed while being written; a final film is written again at once. */
    if (job->final_pending && (err = save_film(farm, job)) != VF_OK)
      vf_log("checkpoint of job %llu failed: %s", jid, vf_error_detail(err));
    return;
  }
  job->film_dirty = 0;
  if (job->final_pending) {
    job->final_pending = 0;
    farm->state_dirty = 1;
    if ((err = vf_state_save_index(farm)) != VF_OK) vf_log("writing the job list failed: %s", vf_error_detail(err));
  }
}

size_t vf_farm_writes_pending(const vf_farm *farm) { return farm->writes_pending; }

/* A job that just completed or stopped: no more leases, a last convergence entry, and its
 * film and the job list written at once. Until the final film is durable, state.json
 * records a stopped job as still active (coordinator/state.c): a crash in between resumes
 * it from its last film and it stops again, rather than staying stopped short of the
 * iterations it had merged. */
static void finish_job(vf_farm *farm, vf_job *job, double now) {
  unsigned long long jid = (unsigned long long)job->id;
  if (job->end == VF_JOB_STOPPED) {
    vf_log("job %llu done: %s", jid, job->message);
    farm->state_dirty = 1;
  } else {
    vf_log("job %llu done", jid);
  }
  vf_farm_end_job_leases(farm, job->id, now);
  job->final_pending = 1;
  int err = vf_job_log(job);
  if (err == VF_OK) err = save_film(farm, job);
  if (err == VF_OK && farm->state_dirty) err = vf_state_save_index(farm);
  if (err != VF_OK) vf_log("job %llu: checkpoint failed: %s", jid, vf_error_detail(err));
}

/* One message of a lease's result (coordinator/partial.h): tiles of the part
 * [m->begin, m->end) that starts where the lease's unmerged iterations do. The part is
 * merged when its last tile arrives; the lease then starts at m->end, and ends when
 * nothing of it is left. */
static void handle_result(vf_farm *farm, const Vcmfarm__LeaseResult *m, double now, vf_farm_reply *r) {
  unsigned long long lid = (unsigned long long)m->lease_id, jid = (unsigned long long)m->job_id;
  unsigned long long b = (unsigned long long)m->begin, e = (unsigned long long)m->end;
  vf_job *job = vf_farm_job(farm, m->job_id);
  vf_lease *l = vf_lease_find(&farm->leases, m->lease_id);
  if (l == NULL)
    return refuse_result(job, r, "lease %016llx (job %llu [%llu,%llu)) is unknown: expired long ago, finished, or "
                         "granted before a coordinator restart", lid, jid, b, e);
  if (l->job_id != m->job_id)
    return refuse_result(job, r, "lease %016llx is of job %llu, the result claims job %llu", lid,
                         (unsigned long long)l->job_id, jid);
  if (job == NULL) return refuse_result(NULL, r, "job %llu does not exist", jid);
  if (job->end != VF_JOB_ACTIVE)
    return refuse_result(job, r, "job %llu is %s", jid, vf_job_state(job, 0));
  size_t size = vcmfarm__lease_result__get_packed_size(m);
  if (size > VF_WIRE_MAX_RESULT)
    return refuse_result(job, r, "job %llu [%llu,%llu): a result message of %zu bytes, at most %zu", jid, b, e, size,
                         VF_WIRE_MAX_RESULT);
  /* Sent again because the acknowledgement of its last tiles was lost: nothing to do. */
  if (m->begin >= l->first && m->begin < m->end && m->end <= l->begin) {
    vf_farm_reply_ack(r, 1, "already merged");
    return;
  }
  if (m->begin != l->begin || m->end <= m->begin || m->end > l->end)
    return refuse_result(job, r, "lease %016llx holds job %llu [%llu,%llu) unmerged, the result claims [%llu,%llu)",
                         lid, jid, (unsigned long long)l->begin, (unsigned long long)l->end, b, e);
  int err;
  if (l->partial != NULL && !vf_partial_same(l->partial, m)) {
    vf_log("lease %016llx: a new part [%llu,%llu) replaces the one being received", lid, b, e);
    vf_partial_destroy(l->partial);
    l->partial = NULL;
  }
  if (l->partial == NULL && (err = vf_partial_create(job, m, &l->partial)) != VF_OK)
    return refuse_result(job, r, "job %llu [%llu,%llu): %s", jid, b, e, vf_error_detail(err));
  vf_partial_touch(l->partial, now);
  if ((err = vf_partial_add(l->partial, m)) != VF_OK) {
    vf_partial_destroy(l->partial);
    l->partial = NULL;
    return refuse_result(job, r, "job %llu [%llu,%llu): %s; the part is dropped", jid, b, e, vf_error_detail(err));
  }
  if (vf_partial_received(l->partial) < vf_partial_total(l->partial)) {
    snprintf(r->text, sizeof r->text, "tiles %u/%u of [%llu,%llu) received", vf_partial_received(l->partial),
             vf_partial_total(l->partial), b, e);
    return vf_farm_reply_ack(r, 1, r->text);
  }
  vf_film *film = NULL;
  err = vf_partial_take(l->partial, &film);
  vf_partial_destroy(l->partial);
  l->partial = NULL;
  if (err == VF_OK) err = vf_job_check_result(job, film, m->begin, m->end);
  if (err != VF_OK) {
    vf_film_destroy(film);
    return refuse_result(job, r, "job %llu [%llu,%llu): %s", jid, b, e, vf_error_detail(err));
  }
  int late = l->state == VF_LEASE_EXPIRED;
  err = vf_job_merge(job, film, now);
  if (err != VF_OK) {
    vf_film_destroy(film);
    if (err == VF_EOVERLAP)
      return refuse_result(job, r, "job %llu [%llu,%llu): %s lease %016llx: some of these iterations are already "
                           "counted, nothing merged", jid, b, e, late ? "late result of expired" : "duplicate result of",
                           lid);
    return refuse_result(job, r, "job %llu [%llu,%llu): %s", jid, b, e, vf_error_detail(err));
  }
  vf_farm_worker *w = find_worker(farm, l->worker_id);
  if (w && film->render_seconds > 0.0) {
    double rate = (double)(m->end - m->begin) / film->render_seconds;
    w->rate = w->rate > 0.0 ? 0.5 * w->rate + 0.5 * rate : rate;
  }
  vf_film_destroy(film);
  l->begin = m->end;
  if (l->begin == l->end)
    end_lease(farm, l, 0, now);
  else
    vf_log("lease %016llx: part [%llu,%llu) merged, [%llu,%llu) to go", lid, b, e, (unsigned long long)l->begin,
           (unsigned long long)l->end);
  /* A late result may cover iterations reassigned since: those leases are moot now. */
  for (size_t i = 0; i < farm->leases.count;) {
    vf_lease *o = &farm->leases.leases[i];
    if (o->id != m->lease_id && o->job_id == m->job_id && o->state == VF_LEASE_ACTIVE && o->begin < m->end &&
        m->begin < o->end) {
      vf_log("lease %016llx revoked: a late result covered it", (unsigned long long)o->id);
      end_lease(farm, o, 1, now);
      i = 0;
    } else {
      i++;
    }
  }
  uint64_t done = vf_job_done(job);
  vf_log("merged job %llu [%llu,%llu)%s: %llu/%llu iterations", jid, b, e, late ? " (late result)" : "",
         (unsigned long long)done, (unsigned long long)job->iterations);
  if ((err = vf_job_check_stop(job)) < 0) vf_log("job %llu: measuring failed: %s", jid, vf_error_detail(err));
  if (vf_job_complete(job)) finish_job(farm, job, now);
  vf_farm_reply_ack(r, 1, "merged");
}

static void handle_release(vf_farm *farm, vf_farm_worker *w, const Vcmfarm__LeaseRelease *m, double now,
                           vf_farm_reply *r) {
  vf_lease *l = vf_lease_find(&farm->leases, m->lease_id);
  if (l == NULL || l->worker_id != w->id || l->state != VF_LEASE_ACTIVE) {
    vf_farm_reply_ack(r, 0, "no such active lease of this worker");
    return;
  }
  vf_job *job = vf_farm_job(farm, l->job_id);
  if (m->failure[0] != '\0' && job != NULL && job->end == VF_JOB_ACTIVE) {
    job->end = VF_JOB_FAILED;
    snprintf(job->message, sizeof job->message, "worker %s: %s", w->name, m->failure);
    for (char *c = job->message; *c; c++)
      if ((unsigned char)*c < 0x20) *c = '?';
    vf_log("job %llu failed: %s", (unsigned long long)job->id, job->message);
    vf_farm_end_job_leases(farm, job->id, now);
    farm->state_dirty = 1;
  } else {
    vf_log("worker %s handed back lease %016llx", w->name, (unsigned long long)l->id);
    end_lease(farm, l, 0, now);
  }
  vf_farm_reply_ack(r, 1, "released");
}

void vf_farm_handle(vf_farm *farm, const Vcmfarm__Envelope *q, double now, vf_farm_reply *r) {
  reply_init(r);
  uint64_t worker_id = 0;
  switch (q->body_case) {
  case VCMFARM__ENVELOPE__BODY_REGISTER: return handle_register(farm, q->register_, now, r);
  case VCMFARM__ENVELOPE__BODY_RESULT: {
    vf_farm_worker *w = find_worker(farm, q->result->worker_id);
    if (w) w->last_seen = now;
    return handle_result(farm, q->result, now, r);
  }
  case VCMFARM__ENVELOPE__BODY_LEASE_REQUEST: worker_id = q->lease_request->worker_id; break;
  case VCMFARM__ENVELOPE__BODY_HEARTBEAT: worker_id = q->heartbeat->worker_id; break;
  case VCMFARM__ENVELOPE__BODY_RELEASE: worker_id = q->release->worker_id; break;
  case VCMFARM__ENVELOPE__BODY_SUBMIT: return vf_farm_submit(farm, q->submit, r);
  case VCMFARM__ENVELOPE__BODY_STATUS_REQUEST: return vf_farm_status(farm, q->status_request, now, r);
  case VCMFARM__ENVELOPE__BODY_FETCH: return vf_farm_fetch(farm, q->fetch, r);
  case VCMFARM__ENVELOPE__BODY_CANCEL: return vf_farm_cancel(farm, q->cancel, now, r);
  case VCMFARM__ENVELOPE__BODY_REMOVE: return vf_farm_remove(farm, q->remove, r);
  case VCMFARM__ENVELOPE__BODY_BLOB_QUERY: return vf_farm_blob_query(farm, q->blob_query, r);
  case VCMFARM__ENVELOPE__BODY_BLOB_PUT: return vf_farm_blob_put(farm, q->blob_put, r);
  case VCMFARM__ENVELOPE__BODY_BLOB_REQUEST: worker_id = q->blob_request->worker_id; break;
  default:
    return vf_farm_reply_errorf(r, VCMFARM__ERROR_CODE__ERROR_BAD_REQUEST, "a coordinator does not accept a %s message",
                        vf_message_name(q));
  }
  vf_farm_worker *w = find_worker(farm, worker_id);
  if (w == NULL)
    return vf_farm_reply_errorf(r, VCMFARM__ERROR_CODE__ERROR_UNKNOWN_WORKER, "unknown worker %016llx: register again",
                        (unsigned long long)worker_id);
  w->last_seen = now;
  switch (q->body_case) {
  case VCMFARM__ENVELOPE__BODY_LEASE_REQUEST: return handle_lease_request(farm, w, now, r);
  case VCMFARM__ENVELOPE__BODY_HEARTBEAT: return handle_heartbeat(farm, w, q->heartbeat, r);
  case VCMFARM__ENVELOPE__BODY_BLOB_REQUEST: return vf_farm_blob_request(farm, w, q->blob_request, r);
  default: return handle_release(farm, w, q->release, now, r);
  }
}

int vf_farm_expire(vf_farm *farm, double now) {
  int lost = 0;
  /* A part whose sender went silent will not be completed: its staged film (as large as
   * the job's) is dropped rather than kept as long as its lease is remembered. */
  for (size_t i = 0; i < farm->leases.count; i++) {
    vf_lease *l = &farm->leases.leases[i];
    if (l->partial != NULL && now - vf_partial_updated(l->partial) > farm->config.worker_timeout) {
      vf_log("lease %016llx: part [%llu,...) incomplete (%u/%u tiles) and silent for %.1f s; dropped",
             (unsigned long long)l->id, (unsigned long long)l->begin, vf_partial_received(l->partial),
             vf_partial_total(l->partial), now - vf_partial_updated(l->partial));
      vf_partial_destroy(l->partial);
      l->partial = NULL;
    }
  }
  for (size_t i = 0; i < farm->num_workers;) {
    vf_farm_worker *w = &farm->workers[i];
    if (now - w->last_seen <= farm->config.worker_timeout) {
      i++;
      continue;
    }
    vf_lease *l = vf_lease_find(&farm->leases, w->lease_id);
    if (l) {
      vf_log("worker %s lost (silent for %.1f s); lease %016llx of job %llu [%llu,%llu) returns to the pool", w->name,
             now - w->last_seen, (unsigned long long)l->id, (unsigned long long)l->job_id,
             (unsigned long long)l->begin, (unsigned long long)l->end);
      end_lease(farm, l, 1, now);
    } else {
      vf_log("worker %s lost (silent for %.1f s)", w->name, now - w->last_seen);
    }
    farm->workers[i] = farm->workers[--farm->num_workers];
    lost++;
  }
  return lost;
}

void vf_farm_tick(vf_farm *farm, double now) {
  double dt = farm->last_tick > 0.0 ? now - farm->last_tick : 0.0;
  farm->last_tick = now;
  for (size_t i = 0; i < farm->num_jobs; i++) {
    vf_job *j = farm->jobs[i];
    if (!vf_job_runnable(j)) continue;
    /* Running from its first lease: a queued job's clock has not started. */
    if (vf_job_done(j) > 0 || vf_lease_active_iterations(&farm->leases, j->id) > 0) j->seconds += dt;
    if (j->time_limit > 0.0 && vf_job_check_stop(j) == 1) finish_job(farm, j, now);
  }
}

int vf_farm_checkpoint(vf_farm *farm, int all) {
  int first = VF_OK;
  for (size_t i = 0; i < farm->num_jobs; i++) {
    vf_job *j = farm->jobs[i];
    int err = vf_job_log(j);
    if (err != VF_OK) vf_log("job %llu: convergence entry: %s", (unsigned long long)j->id, vf_error_detail(err));
    if (j->seconds != j->seconds_saved) farm->state_dirty = 1;
    if (!j->film_dirty && !all) continue;
    err = save_film(farm, j);
    if (err != VF_OK) {
      vf_log("checkpoint of job %llu failed: %s", (unsigned long long)j->id, vf_error_detail(err));
      if (first == VF_OK) first = err;
    }
  }
  if (farm->state_dirty || all) {
    int err = vf_state_save_index(farm);
    if (err != VF_OK) {
      vf_log("writing the job list failed: %s", vf_error_detail(err));
      if (first == VF_OK) first = err;
    }
  }
  return first;
}
