#include "jobs.h"

#include "../common/allocation.h"
#include "../common/clock.h"
#include "../common/error.h"
#include "../common/wire.h"
#include "blobs.h"
#include "checkpoint.h"
#include "leases.h"
#include "log.h"
#include "merger.h"
#include "poison.h"
#include "state.h"
#include "workers.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

void vf_jobs_submit(vf_farm *farm, const Vcmfarm__SubmitJob *m, vf_farm_reply *r) {
  if (m->scene == NULL || m->scene->source_case == VCMFARM__SCENE__SOURCE__NOT_SET)
    return vf_farm_reply_error(r, VCMFARM__ERROR_CODE__ERROR_BAD_REQUEST, "submit without a scene");
  int builtin = m->scene->source_case == VCMFARM__SCENE__SOURCE_BUILTIN, err;
  const char *text = builtin ? m->scene->builtin : m->scene->json;
  char *sent_text = NULL; /* owned: a text that came as a blob */
  size_t text_len;
  if (m->scene->source_case == VCMFARM__SCENE__SOURCE_JSON_BLOB) {
    if ((err = vf_blobs_scene_text(farm, m->scene->json_blob, &sent_text, &text_len)) != VF_OK)
      return vf_farm_reply_fail(r, err);
    text = sent_text;
  } else {
    text_len = strlen(text);
  }
  vf_job *job;
  err = vf_job_create(farm->next_job_id, m->name, m->priority, builtin, text, text_len, m->scene_hash.data,
                      m->scene_hash.len, m->settings, m->first_iteration, m->iterations, &job);
  free(sent_text);
  if (err == VF_OK && ((err = vf_job_set_scene_path(job, m->scene_path)) != VF_OK ||
                       (err = vf_job_set_requires(job, m->requires, m->n_requires)) != VF_OK ||
                       (err = vf_blobs_attach(farm, job, m->scene)) != VF_OK))
    vf_job_destroy(job);
  if (err != VF_OK) return vf_farm_reply_fail(r, err);
  /* Files of this id can only be a submission's that a crash cut short before the job list
   * named it: a film left by one would be taken for this job's at the next start. */
  vf_state_remove_job_files(farm->config.state_dir, job->id);
  /* The reference is a blob sent first, checked against its hash, then read as an image. */
  if (m->reference && (err = vf_blobs_reference(farm, m->reference)) == VF_OK)
    err = vf_state_save_reference(farm->config.state_dir, job, m->reference->hash.data);
  if (err != VF_OK) {
    vf_job_destroy(job);
    return vf_farm_reply_fail(r, err);
  }
  /* Submitted with its allocation (version 12), the job runs no pilot: the counts, a blob
   * sent first, are opaque bytes here, checked only by allocation.h, and given to its film,
   * which is written below before the job is acknowledged, so that a restart finds them
   * where it finds a farm pilot's. */
  if (m->allocation && (err = vf_job_allocation_allowed(job)) == VF_OK) {
    uint8_t *samples = NULL;
    size_t pixels = (size_t)job->film->width * (size_t)job->film->height;
    if ((err = vf_blobs_allocation(farm, m->allocation, pixels, &samples)) == VF_OK) {
      err = vf_job_submit_allocation(job, samples);
      free(samples);
    }
  }
  /* The client's pilots (version 13) count in the film's times as a farm pilot's do. */
  if (err == VF_OK && (m->pilot_render_seconds != 0.0 || m->pilot_cpu_seconds != 0.0)) {
    if (!m->allocation)
      err = vf_error_set(VF_EINVAL, "pilot_render_seconds, pilot_cpu_seconds: pilot seconds without an allocation");
    else if (!(m->pilot_render_seconds >= 0.0 && m->pilot_render_seconds <= 1e9) ||
             !(m->pilot_cpu_seconds >= 0.0 && m->pilot_cpu_seconds <= 1e9))
      err = vf_error_set(VF_EINVAL, "pilot_render_seconds %g, pilot_cpu_seconds %g: seconds from 0 to 1e9",
                         m->pilot_render_seconds, m->pilot_cpu_seconds);
    else {
      job->film->render_seconds += m->pilot_render_seconds;
      job->film->cpu_seconds += m->pilot_cpu_seconds;
    }
  }
  if (err != VF_OK) {
    vf_state_remove_job_files(farm->config.state_dir, job->id);
    vf_job_destroy(job);
    return vf_farm_reply_fail(r, err);
  }
  vf_algorithm resolved;
  if (m->algorithm_resolved[0] != '\0' &&
      (vf_algorithm_parse(m->algorithm_resolved, &resolved) != VF_OK || vf_algorithm_is_auto(resolved))) {
    vf_state_remove_job_files(farm->config.state_dir, job->id);
    vf_job_destroy(job);
    return vf_farm_reply_errorf(r, VCMFARM__ERROR_CODE__ERROR_BAD_REQUEST,
                                "algorithm_resolved: '%.40s' is not an algorithm auto can resolve to", m->algorithm_resolved);
  }
  snprintf(job->algorithm_resolved, sizeof job->algorithm_resolved, "%s",
           !vf_algorithm_is_auto(job->settings.algorithm) ? vf_algorithm_name(job->settings.algorithm) : m->algorithm_resolved);
  job->submitted_at = vf_unix_now();
  if ((err = vf_job_set_stop(job, m->time_limit, m->target_rmse, m->target_error)) != VF_OK) {
    vf_state_remove_job_files(farm->config.state_dir, job->id);
    vf_job_destroy(job);
    return vf_farm_reply_fail(r, err);
  }
  /* Durable before acknowledged: scene text first (and the film holding a submitted
   * allocation), then the job list naming it. */
  if ((err = vf_state_save_scene(farm->config.state_dir, job)) != VF_OK ||
      (job->film->samples != NULL && (err = vf_state_save_film(farm->config.state_dir, job)) != VF_OK) ||
      (err = vf_farm_add_job(farm, job)) != VF_OK) {
    vf_state_remove_job_files(farm->config.state_dir, job->id);
    vf_job_destroy(job);
    return vf_farm_reply_fail(r, err);
  }
  if ((err = vf_state_save_index(farm)) != VF_OK) {
    farm->num_jobs--;
    vf_job_destroy(job);
    return vf_farm_reply_fail(r, err);
  }
  farm->next_job_id++;
  char limits[256];
  /* An open-ended job (no iteration count given, another condition set) is not described
   * by its cap of VF_JOB_MAX_ITERATIONS (as vf_job_forecast does not count against it). */
  int open_ended = job->iterations >= VF_JOB_MAX_ITERATIONS &&
                   (job->time_limit > 0.0 || job->target_rmse > 0.0 || job->target_error > 0.0);
  int n = open_ended ? snprintf(limits, sizeof limits, "from iteration %llu", (unsigned long long)job->first)
                     : snprintf(limits, sizeof limits, "at most %llu iteration%s from %llu",
                                (unsigned long long)job->iterations, job->iterations == 1 ? "" : "s",
                                (unsigned long long)job->first);
  if (job->time_limit > 0.0 && n > 0 && (size_t)n < sizeof limits)
    n += snprintf(limits + n, sizeof limits - (size_t)n, ", time limit %g s", job->time_limit);
  if (job->target_rmse > 0.0 && n > 0 && (size_t)n < sizeof limits)
    n += snprintf(limits + n, sizeof limits - (size_t)n, ", target RMSE %g", job->target_rmse);
  if (job->target_error > 0.0 && n > 0 && (size_t)n < sizeof limits)
    snprintf(limits + n, sizeof limits - (size_t)n, ", target error %g", job->target_error);
  char requires[VF_TAGS_MAX * (VF_TAG_MAX_BYTES + 1) + 1];
  vf_tags_format(&job->requires, requires, sizeof requires);
  vf_log("job %llu '%s' submitted: %s %s, %s%s, priority %d%s%s", (unsigned long long)job->id, job->name,
         builtin ? "built-in" : "JSON scene", builtin ? job->scene_text : job->film->scene_name[0] ? job->film->scene_name : "(no path)",
         limits, job->reference.rgb ? " (with a reference)" : "", job->priority, requires[0] ? ", requires " : "",
         requires);
  vf_events_add(&job->events, job->submitted_at, "job_submitted", job->id, "", "job '%s' submitted: %s, priority %d%s%s",
                job->name, limits, job->priority, requires[0] ? ", requires " : "", requires);
  if (job->film->samples != NULL) {
    vf_log("job %llu: submitted with its allocation, no pilot to run: pilot of %d iterations counted as done; %s",
           (unsigned long long)job->id, job->settings.pilot, job->allocation_summary);
    vf_events_add(&job->events, job->submitted_at, "pilot_done", job->id, "",
                  "submitted with its allocation (pilot of %d iterations counted as done); %s", job->settings.pilot,
                  job->allocation_summary);
  }
  farm->state_dirty = 1; /* the event, with the next write of the job list */
  vcmfarm__submitted__init(&r->submitted);
  r->submitted.job_id = job->id;
  r->env.body_case = VCMFARM__ENVELOPE__BODY_SUBMITTED;
  r->env.submitted = &r->submitted;
}

/* The status of one job carries its convergence log (the last entries of a long one). */
#define STATUS_LOG_ENTRIES 1000
static void attach_log(vf_farm_reply *r, Vcmfarm__JobStatus *s, const vf_convergence_log *log) {
  size_t n = log->count < STATUS_LOG_ENTRIES ? log->count : STATUS_LOG_ENTRIES, first = log->count - n;
  if (n == 0 || (r->log = calloc(n, sizeof *r->log)) == NULL || (r->log_ptrs = calloc(n, sizeof *r->log_ptrs)) == NULL)
    return;
  for (size_t i = 0; i < n; i++) {
    const vf_convergence_entry *e = &log->entries[first + i];
    Vcmfarm__ConvergenceEntry *c = &r->log[i];
    vcmfarm__convergence_entry__init(c);
    c->run = e->run;
    c->wall_seconds = e->wall_seconds;
    c->cpu_seconds = e->cpu_seconds;
    c->iterations = e->iterations;
    c->rmse = e->rmse;
    c->rel_mse = e->rel_mse;
    c->estimated_rmse = e->estimated_rmse;
    r->log_ptrs[i] = c;
  }
  s->n_convergence = n;
  s->convergence = r->log_ptrs;
}

/* The window over which rates are measured: several leases long. */
static double rate_window(const vf_farm *farm) {
  double w = 3.0 * farm->config.lease_seconds;
  return w < 30.0 ? 30.0 : w;
}

static void fill_event(Vcmfarm__Event *out, const vf_event *e) {
  vcmfarm__event__init(out);
  out->time = e->time;
  out->kind = (char *)e->kind;
  out->job_id = e->job_id;
  out->worker = (char *)e->worker;
  out->message = (char *)e->message;
}

/* Events of a log into the reply's arrays from *next on; their count. */
static size_t attach_events(vf_farm_reply *r, size_t *next, const vf_events *log, Vcmfarm__Event ***out) {
  *out = &r->event_ptrs[*next];
  for (unsigned i = 0; i < log->count; i++) {
    fill_event(&r->events[*next], vf_events_at(log, i));
    r->event_ptrs[*next] = &r->events[*next];
    (*next)++;
  }
  return log->count;
}

/* Tags of a list into the reply's array from *next on; their count. */
static size_t attach_tags(vf_farm_reply *r, size_t *next, const vf_tags *tags, char ***out) {
  *out = &r->tag_ptrs[*next];
  for (unsigned i = 0; i < tags->count; i++) r->tag_ptrs[(*next)++] = (char *)tags->tag[i];
  return tags->count;
}

static void fill_worker(vf_farm *farm, const vf_farm_worker *w, double now, Vcmfarm__WorkerStatus *s) {
  vcmfarm__worker_status__init(s);
  s->worker_id = w->id;
  s->name = (char *)w->name;
  s->threads = w->threads;
  vf_lease *l = vf_lease_find(&farm->leases, w->lease_id);
  if (l) {
    s->lease_job = l->job_id;
    s->lease_begin = l->begin;
    s->lease_end = l->end;
  }
  s->iterations_per_second = w->rate;
  s->last_seen_seconds = now - w->last_seen;
  s->state = (char *)vf_worker_state_name(farm, w);
  s->host = (char *)w->host;
  s->cores = w->cores;
  s->software_version = (char *)w->version;
  s->registered_at = w->registered_at;
  s->departed_at = w->departed_at;
  s->iterations_merged = w->iterations_merged;
  s->parts_merged = w->parts_merged;
  s->results_refused = w->results_refused;
  s->leases = w->leases;
  s->memory_bytes = w->memory_bytes;
}

void vf_jobs_status(vf_farm *farm, const Vcmfarm__StatusRequest *m, double now, vf_farm_reply *r) {
  size_t nj = 0, ne = farm->events.count;
  for (size_t i = 0; i < farm->num_jobs; i++)
    if (m->job_id == 0 || farm->jobs[i]->id == m->job_id) {
      nj++;
      ne += farm->jobs[i]->events.count;
    }
  if (m->job_id != 0 && nj == 0)
    return vf_farm_reply_errorf(r, VCMFARM__ERROR_CODE__ERROR_UNKNOWN_JOB, "no job %llu", (unsigned long long)m->job_id);
  size_t nw = farm->num_workers + farm->num_departed, nt = 0;
  for (size_t i = 0; i < farm->num_jobs; i++) nt += farm->jobs[i]->requires.count;
  for (size_t i = 0; i < farm->num_workers; i++) nt += farm->workers[i].tags.count;
  for (unsigned i = 0; i < farm->num_departed; i++) nt += vf_workers_departed(farm, i)->tags.count;
  r->tag_ptrs = calloc(nt ? nt : 1, sizeof *r->tag_ptrs);
  r->job_status = calloc(nj ? nj : 1, sizeof *r->job_status);
  r->job_status_ptrs = calloc(nj ? nj : 1, sizeof *r->job_status_ptrs);
  r->worker_status = calloc(nw ? nw : 1, sizeof *r->worker_status);
  r->worker_status_ptrs = calloc(nw ? nw : 1, sizeof *r->worker_status_ptrs);
  r->events = calloc(ne ? ne : 1, sizeof *r->events);
  r->event_ptrs = calloc(ne ? ne : 1, sizeof *r->event_ptrs);
  if (!r->job_status || !r->job_status_ptrs || !r->worker_status || !r->worker_status_ptrs || !r->events ||
      !r->event_ptrs || !r->tag_ptrs)
    return vf_farm_reply_fail(r, vf_error_set(VF_ENOMEM, "out of memory"));
  vcmfarm__status__init(&r->status);
  r->status.time = vf_unix_now();
  r->status.protocol_version = VF_PROTOCOL_VERSION;
  r->status.software_version = VF_VERSION;
  r->status.started_at = farm->started_at;
  for (size_t i = 0; i < farm->num_jobs; i++)
    r->status.iterations_per_second += vf_job_farm_rate(farm->jobs[i], now, rate_window(farm));
  for (size_t i = 0; i < farm->num_workers; i++)
    r->status.workers_busy += vf_lease_find(&farm->leases, farm->workers[i].lease_id) != NULL;
  size_t k = 0, next_event = 0, next_tag = 0;
  for (size_t i = 0; i < farm->num_jobs; i++) {
    vf_job *j = farm->jobs[i];
    if (m->job_id != 0 && j->id != m->job_id) continue;
    Vcmfarm__JobStatus *s = &r->job_status[k];
    vcmfarm__job_status__init(s);
    uint64_t leased = vf_lease_active_iterations(&farm->leases, j->id);
    s->job_id = j->id;
    s->name = j->name;
    s->state = (char *)vf_job_state(j, leased);
    s->priority = j->priority;
    s->first_iteration = j->first;
    s->iterations_total = j->iterations;
    s->iterations_done = vf_job_done(j);
    s->iterations_leased = leased;
    s->iterations_rendering = vf_lease_rendering_iterations(&farm->leases, j->id);
    s->settings = j->settings_text;
    s->message = j->message;
    s->results_refused = j->results_refused;
    /* Measured once per change of the film: a job ended before a restart comes back with
     * its log's last entry (vf_job_restore_measure) or is measured here once. */
    if (j->measured_iterations != vf_job_done(j) && (vf_job_runnable(j) || vf_job_done(j) > 0)) vf_job_measure(j);
    double rate = vf_job_runnable(j) ? vf_job_farm_rate(j, now, rate_window(farm)) : 0.0;
    vf_forecast f;
    vf_job_forecast(j, rate, &f);
    s->iterations_per_second = rate;
    s->seconds = j->seconds;
    s->eta_seconds = f.eta;
    s->progress = f.progress;
    s->progress_by = (char *)vf_stop_reason_name(f.by);
    s->error_slope = f.slope;
    s->time_limit = j->time_limit;
    s->target_rmse = j->target_rmse;
    s->target_error = j->target_error;
    s->has_reference = j->reference.rgb != NULL;
    s->rmse = j->measured_iterations != UINT64_MAX ? j->measured.rmse : NAN;
    s->estimated_rmse = j->measured_iterations != UINT64_MAX ? j->measured.estimated_rmse : NAN;
    s->stop_reason = j->end == VF_JOB_STOPPED ? j->message : "";
    if (j->end == VF_JOB_STOPPED) s->message = "";
    if (j->checkpoint_error[0] != '\0' && s->message[0] == '\0') s->message = j->checkpoint_error;
    s->stop_code = (char *)vf_stop_reason_name(j->stop);
    s->submitted_at = j->submitted_at;
    s->started_at = j->started_at;
    s->ended_at = j->ended_at;
    s->scene_name = j->film->scene_name;
    s->scene_hash = (ProtobufCBinaryData){32, j->scene_hash};
    s->algorithm_resolved = j->algorithm_resolved;
    s->n_requires = attach_tags(r, &next_tag, &j->requires, &s->requires);
    s->paused = j->paused != 0;
    s->nonfinite_samples = j->film->nonfinite_samples;
    s->biased_merges = j->film->biased_merges;
    s->pilot = (uint32_t)j->settings.pilot;
    s->pilot_done = vf_job_pilot_done(j);
    s->allocation = j->allocation_summary;
    s->n_events = attach_events(r, &next_event, &j->events, &s->events);
    s->events_dropped = j->events.dropped;
    for (size_t w = 0; w < farm->num_workers; w++) {
      vf_lease *l = vf_lease_find(&farm->leases, farm->workers[w].lease_id);
      s->workers += l != NULL && l->job_id == j->id;
    }
    if (m->job_id != 0) attach_log(r, s, &j->film->convergence);
    r->job_status_ptrs[k++] = s;
  }
  r->status.n_events = attach_events(r, &next_event, &farm->events, &r->status.events);
  r->status.events_dropped = farm->events.dropped;
  size_t kw = 0;
  for (size_t i = 0; i < farm->num_workers; i++, kw++) {
    fill_worker(farm, &farm->workers[i], now, &r->worker_status[kw]);
    r->worker_status[kw].n_tags = attach_tags(r, &next_tag, &farm->workers[i].tags, &r->worker_status[kw].tags);
    r->worker_status_ptrs[kw] = &r->worker_status[kw];
  }
  for (unsigned i = 0; i < farm->num_departed; i++, kw++) {
    fill_worker(farm, vf_workers_departed(farm, i), now, &r->worker_status[kw]);
    r->worker_status[kw].n_tags =
        attach_tags(r, &next_tag, &vf_workers_departed(farm, i)->tags, &r->worker_status[kw].tags);
    r->worker_status_ptrs[kw] = &r->worker_status[kw];
  }
  r->status.n_jobs = k;
  r->status.jobs = r->job_status_ptrs;
  r->status.n_workers = kw;
  r->status.workers = r->worker_status_ptrs;
  r->env.body_case = VCMFARM__ENVELOPE__BODY_STATUS;
  r->env.status = &r->status;
}

/* The reply to a fetch, without its chunk. */
static void film_reply(vf_farm_reply *r, Vcmfarm__Film__State state, uint64_t snapshot) {
  vcmfarm__film__init(&r->film);
  r->film.state = state;
  r->film.snapshot = snapshot;
  if (state == VCMFARM__FILM__STATE__WAIT) r->film.retry_ms = VF_SNAPSHOT_RETRY_MS;
  r->env.body_case = VCMFARM__ENVELOPE__BODY_FILM;
  r->env.film = &r->film;
}

void vf_jobs_fetch(vf_farm *farm, const Vcmfarm__FetchRequest *m, double now, vf_farm_reply *r) {
  vf_job *job = vf_farm_job(farm, m->job_id);
  if (job == NULL)
    return vf_farm_reply_errorf(r, VCMFARM__ERROR_CODE__ERROR_UNKNOWN_JOB, "no job %llu", (unsigned long long)m->job_id);
  uint64_t id = m->snapshot;
  int err;
  if (id == 0) {
    if (m->offset != 0)
      return vf_farm_reply_errorf(r, VCMFARM__ERROR_CODE__ERROR_BAD_REQUEST, "a fetch starts at offset 0, not %llu",
                                  (unsigned long long)m->offset);
    if ((err = vf_checkpoint_snapshot_start(farm, job, now, &id)) != VF_OK)
      return vf_farm_reply_fail(r, err);
    if (id == 0) return film_reply(r, VCMFARM__FILM__STATE__WAIT, 0);
  }
  /* The chunk and, after it, the hash: one block the reply owns. */
  vf_snapshot_info info;
  size_t len;
  err = vf_checkpoint_snapshot_read(farm, job->id, id, m->offset, m->max_chunk_bytes, now, sizeof info.hash, &r->film_bytes, &len, &info);
  if (err == 0) return film_reply(r, VCMFARM__FILM__STATE__WAIT, id);
  if (err == VF_ENOENT) {
    snprintf(r->text, sizeof r->text, "%s", vf_error_detail(err));
    film_reply(r, VCMFARM__FILM__STATE__GONE, id);
    r->film.message = r->text;
    return;
  }
  if (err < 0)
    return vf_farm_reply_fail(r, err);
  film_reply(r, VCMFARM__FILM__STATE__CHUNK, id);
  memcpy(r->film_bytes + len, info.hash, sizeof info.hash);
  r->film.offset = m->offset;
  r->film.data = (ProtobufCBinaryData){len, r->film_bytes};
  r->film.total_size = info.size;
  r->film.hash = (ProtobufCBinaryData){sizeof info.hash, r->film_bytes + len};
}

void vf_jobs_cancel(vf_farm *farm, const Vcmfarm__CancelRequest *m, double now, vf_farm_reply *r) {
  vf_job *job = vf_farm_job(farm, m->job_id);
  if (job == NULL)
    return vf_farm_reply_errorf(r, VCMFARM__ERROR_CODE__ERROR_UNKNOWN_JOB, "no job %llu", (unsigned long long)m->job_id);
  if (!vf_job_runnable(job)) {
    snprintf(r->text, sizeof r->text, "job %llu is %s already", (unsigned long long)job->id, vf_job_state(job, 0));
    return vf_farm_reply_ack(r, 0, r->text);
  }
  vf_job_finish(job, VF_STOP_CANCELLED, vf_unix_now(), NULL);
  vf_events_add(&job->events, job->ended_at, "job_cancelled", job->id, "", "job cancelled with %llu iteration%s done",
                (unsigned long long)vf_job_done(job), vf_job_done(job) == 1 ? "" : "s");
  vf_leases_end_job(farm, job->id, now);
  farm->state_dirty = 1;
  int err = vf_state_save_index(farm);
  vf_log("job %llu cancelled", (unsigned long long)job->id);
  if (err != VF_OK) return vf_farm_reply_fail(r, err);
  vf_farm_reply_ack(r, 1, "cancelled");
}

void vf_jobs_pause(vf_farm *farm, uint64_t job_id, int pause, vf_farm_reply *r) {
  vf_job *job = vf_farm_job(farm, job_id);
  if (job == NULL)
    return vf_farm_reply_errorf(r, VCMFARM__ERROR_CODE__ERROR_UNKNOWN_JOB, "no job %llu", (unsigned long long)job_id);
  uint64_t leased = vf_lease_active_iterations(&farm->leases, job->id);
  if (!vf_job_runnable(job)) {
    snprintf(r->text, sizeof r->text, "job %llu is %s already", (unsigned long long)job->id, vf_job_state(job, leased));
    return vf_farm_reply_ack(r, 0, r->text);
  }
  if ((job->paused != 0) == (pause != 0)) {
    snprintf(r->text, sizeof r->text, "job %llu is %s already", (unsigned long long)job->id,
             pause ? "paused" : "not paused");
    return vf_farm_reply_ack(r, 0, r->text);
  }
  job->paused = pause != 0;
  farm->state_dirty = 1;
  int err = vf_state_save_index(farm);
  if (err != VF_OK) { /* not durable: as it was */
    job->paused = !job->paused;
    return vf_farm_reply_fail(r, err);
  }
  unsigned holders = 0;
  for (size_t i = 0; i < farm->num_workers; i++) {
    vf_lease *l = vf_lease_find(&farm->leases, farm->workers[i].lease_id);
    holders += l != NULL && l->job_id == job->id;
  }
  if (pause) {
    snprintf(r->text, sizeof r->text, "paused job %llu: no new leases; %u worker%s finish%s what %s leased (%llu iteration%s)",
             (unsigned long long)job->id, holders, holders == 1 ? "" : "s", holders == 1 ? "es" : "",
             holders == 1 ? "it" : "they", (unsigned long long)leased, leased == 1 ? "" : "s");
  } else {
    snprintf(r->text, sizeof r->text, "resumed job %llu", (unsigned long long)job->id);
  }
  vf_log("job %llu %s", (unsigned long long)job->id, pause ? "paused" : "resumed");
  vf_events_add(&job->events, vf_unix_now(), pause ? "job_paused" : "job_resumed", job->id, "", "%s", r->text);
  farm->state_dirty = 1; /* the event, with the next write of the job list */
  vf_farm_reply_ack(r, 1, r->text);
}

void vf_jobs_remove(vf_farm *farm, const Vcmfarm__RemoveRequest *m, vf_farm_reply *r) {
  size_t at = 0;
  while (at < farm->num_jobs && farm->jobs[at]->id != m->job_id) at++;
  if (at == farm->num_jobs)
    return vf_farm_reply_errorf(r, VCMFARM__ERROR_CODE__ERROR_UNKNOWN_JOB, "no job %llu", (unsigned long long)m->job_id);
  vf_job *job = farm->jobs[at];
  if (vf_job_runnable(job)) {
    snprintf(r->text, sizeof r->text, "job %llu is %s: cancel it first", (unsigned long long)job->id,
             vf_job_state(job, vf_lease_active_iterations(&farm->leases, job->id)));
    return vf_farm_reply_ack(r, 0, r->text);
  }
  if (job->film_writing || job->pilot_writing || job->pilot_finishing || job->pilot_merging > 0) {
    snprintf(r->text, sizeof r->text, "job %llu's film is being written: try again", (unsigned long long)job->id);
    return vf_farm_reply_ack(r, 0, r->text);
  }
  memmove(&farm->jobs[at], &farm->jobs[at + 1], (farm->num_jobs - at - 1) * sizeof *farm->jobs);
  farm->num_jobs--;
  farm->state_dirty = 1;
  int err = vf_state_save_index(farm);
  if (err != VF_OK) { /* still named by the job list on disk: keep it */
    memmove(&farm->jobs[at + 1], &farm->jobs[at], (farm->num_jobs - at) * sizeof *farm->jobs);
    farm->jobs[at] = job;
    farm->num_jobs++;
    return vf_farm_reply_fail(r, err);
  }
  vf_state_remove_job_files(farm->config.state_dir, job->id);
  vf_checkpoint_snapshot_drop(farm, job->id);
  vf_poison_forget_job(farm, job->id);
  unsigned blobs = 0;
  for (size_t k = 0; k < job->files.count; k++) {
    const uint8_t *hash = job->files.refs[k].hash;
    int earlier = 0; /* one blob under two names */
    for (size_t e = 0; e < k; e++) earlier |= memcmp(job->files.refs[e].hash, hash, 32) == 0;
    if (!earlier && !vf_blobs_named(farm, hash, job) && vf_blob_store_remove(farm->config.state_dir, hash) == VF_OK)
      blobs++;
  }
  vf_log("job %llu removed, with %u blob%s no other job names", (unsigned long long)job->id, blobs,
         blobs == 1 ? "" : "s");
  snprintf(r->text, sizeof r->text, "removed job %llu and %u of its %zu file%s no other job names",
           (unsigned long long)job->id, blobs, job->files.count, job->files.count == 1 ? "" : "s");
  vf_job_destroy(job);
  vf_farm_reply_ack(r, 1, r->text);
}

void vf_jobs_finish(vf_farm *farm, vf_job *job, double now) {
  unsigned long long jid = (unsigned long long)job->id;
  if (job->end == VF_JOB_STOPPED) {
    vf_log("job %llu done: %s", jid, job->message);
    farm->state_dirty = 1;
  } else {
    vf_log("job %llu done", jid);
    vf_job_finish(job, VF_STOP_ITERATIONS, vf_unix_now(), NULL);
    farm->state_dirty = 1;
  }
  int told = 0; /* once per job, however it came to be finished again */
  for (unsigned i = 0; i < job->events.count; i++) told |= strcmp(vf_events_at(&job->events, i)->kind, "job_done") == 0;
  if (!told)
    vf_events_add(&job->events, job->ended_at > 0.0 ? job->ended_at : vf_unix_now(), "job_done", job->id, "",
                  "job done with %llu iteration%s: %s", (unsigned long long)vf_job_done(job),
                  vf_job_done(job) == 1 ? "" : "s", job->end == VF_JOB_STOPPED ? job->message : "all its iterations");
  vf_leases_end_job(farm, job->id, now);
  vf_checkpoint_final(farm, job);
}

/* The allocation computed (err 1) or not (err < 0): what follows, on the loop. */
static void pilot_finished(vf_farm *farm, vf_job *job, int err, double now) {
  unsigned long long jid = (unsigned long long)job->id;
  if (err == 1) err = vf_blobs_put_allocation(farm, job);
  if (err != VF_OK) {
    char why[256];
    snprintf(why, sizeof why, "its allocation of camera sub-paths: %s", vf_error_detail(err));
    vf_log("job %llu failed: %s", jid, why);
    vf_job_finish(job, VF_STOP_FAILED, vf_unix_now(), why);
    vf_events_add(&job->events, job->ended_at, "job_failed", job->id, "", "%s", job->message);
    vf_leases_end_job(farm, job->id, now);
    farm->state_dirty = 1;
    return;
  }
  vf_leases_end_pilot(farm, job->id, now);
  vf_log("job %llu: pilot of %d iterations done; %s", jid, job->settings.pilot, job->allocation_summary);
  vf_events_add(&job->events, vf_unix_now(), "pilot_done", job->id, "", "pilot of %d iterations done; %s",
                job->settings.pilot, job->allocation_summary);
  farm->state_dirty = 1;
}

/* The allocation computed on the merge thread from the complete pilot film, which nothing
 * changes or drops meanwhile (pilot_finishing): a 4K pilot's costs a good part of a
 * second, which the loop's replies need not wait for. */
typedef struct {
  vf_merge_item item;
  vf_farm *farm;
  uint64_t job_id;
  const vf_film *pilot; /* the job's pilot_film, borrowed */
  uint8_t *samples;     /* owned */
  int err;
  char detail[1024];
} allocation_item;

static void allocation_work(vf_merge_item *item) {
  allocation_item *a = (allocation_item *)item;
  vf_error_clear();
  a->err = vf_allocation_compute(a->pilot, a->samples, NULL);
  if (a->err != VF_OK) snprintf(a->detail, sizeof a->detail, "%s", vf_error_detail(a->err));
}

static void allocation_done(vf_merge_item *item) {
  allocation_item *a = (allocation_item *)item;
  vf_job *job = vf_farm_job(a->farm, a->job_id);
  if (job != NULL) {
    job->pilot_finishing = 0;
    int err = a->err == VF_OK ? vf_job_set_allocation(job, a->samples) : vf_error_set(a->err, "%s", a->detail);
    pilot_finished(a->farm, job, err, vf_seconds_now());
  }
  free(a->samples);
  free(a);
}

void vf_jobs_pilot_merged(vf_farm *farm, vf_job *job, double now) {
  if (!vf_job_pilot_complete(job)) return;
  if (farm->merger == NULL) return pilot_finished(farm, job, vf_job_finish_pilot(job), now);
  if (job->pilot_merging > 0 || job->pilot_writing || job->pilot_finishing) return; /* called again as they land */
  size_t pixels = (size_t)job->film->width * (size_t)job->film->height;
  allocation_item *a = calloc(1, sizeof *a);
  uint8_t *samples = malloc(pixels);
  if (a == NULL || samples == NULL) {
    free(a);
    free(samples);
    return pilot_finished(farm, job, vf_error_set(VF_ENOMEM, "out of memory for job %llu's allocation",
                                                  (unsigned long long)job->id), now);
  }
  *a = (allocation_item){.item = {.work = allocation_work, .done = allocation_done}, .farm = farm, .job_id = job->id,
                         .pilot = job->pilot_film, .samples = samples};
  job->pilot_finishing = 1;
  vf_merger_queue(farm->merger, &a->item);
}
