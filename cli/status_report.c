#include "status_report.h"

#include "options.h"
#include "../common/error.h"
#include "../common/forecast.h"
#include "../common/settings.h"
#include "../coordinator/farm_core.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* JSON has no NaN: unknown values are null. */
static void add_number_or_null(cJSON *o, const char *key, double v) {
  if (isfinite(v)) cJSON_AddNumberToObject(o, key, v);
  else cJSON_AddNullToObject(o, key);
}

/* A time of the coordinator's clock: 0 is unknown or not yet. */
static void add_time(cJSON *o, const char *key, double unix_seconds) {
  add_number_or_null(o, key, unix_seconds > 0.0 ? unix_seconds : NAN);
}

static void add_string_or_null(cJSON *o, const char *key, const char *s) {
  if (s && s[0]) cJSON_AddStringToObject(o, key, s);
  else cJSON_AddNullToObject(o, key);
}


/* The job's iteration count is a stop condition unless it is the open-ended cap that a
 * time or a target comes with (cli/options.h). */
static int iterations_is_condition(const Vcmfarm__JobStatus *j) {
  return j->iterations_total < VF_JOB_MAX_ITERATIONS ||
         !(j->time_limit > 0.0 || j->target_rmse > 0.0 || j->target_error > 0.0);
}

static void add_events(cJSON *parent, Vcmfarm__Event **events, size_t n, uint64_t dropped, unsigned kept) {
  cJSON *a = cJSON_AddArrayToObject(parent, "events");
  for (size_t i = 0; i < n; i++) {
    const Vcmfarm__Event *e = events[i];
    cJSON *o = cJSON_CreateObject();
    cJSON_AddItemToArray(a, o);
    cJSON_AddNumberToObject(o, "time", e->time);
    cJSON_AddStringToObject(o, "kind", e->kind);
    if (e->job_id) cJSON_AddNumberToObject(o, "job", (double)e->job_id);
    else cJSON_AddNullToObject(o, "job");
    add_string_or_null(o, "worker", e->worker);
    cJSON_AddStringToObject(o, "message", e->message);
  }
  cJSON_AddNumberToObject(parent, "events_dropped", (double)dropped);
  cJSON_AddNumberToObject(parent, "events_kept", kept);
}

/* What a job's estimated RMSE covers (common/settings.h): by the algorithm it runs, `auto`
 * and `auto-unbiased` by what they resolved to. */
static vf_estimate_scope estimate_scope(const Vcmfarm__JobStatus *j, const vf_settings *s) {
  vf_algorithm a = s->algorithm;
  if (vf_algorithm_is_auto(a) && vf_algorithm_parse(j->algorithm_resolved, &a) != VF_OK) a = s->algorithm;
  return vf_algorithm_estimate_scope(a);
}

/* The settings text as fields, with what `auto` resolved to. */
static void add_settings(cJSON *o, const Vcmfarm__JobStatus *j) {
  cJSON_AddStringToObject(o, "settings", j->settings);
  vf_settings s;
  if (vf_settings_parse(&s, j->settings) != 0) {
    cJSON_AddNullToObject(o, "resolved");
    return;
  }
  cJSON *r = cJSON_AddObjectToObject(o, "resolved");
  const char *requested = vf_algorithm_name(s.algorithm);
  add_string_or_null(r, "algorithm", vf_algorithm_is_auto(s.algorithm) ? j->algorithm_resolved : requested);
  /* What estimated_rmse measures: the error, or the variance alone (settings.h). */
  cJSON_AddStringToObject(r, "estimate_covers", vf_estimate_scope_name(estimate_scope(j, &s)));
  cJSON_AddStringToObject(r, "requested_algorithm", requested);
  cJSON_AddNumberToObject(r, "max_path_length", s.max_path_length);
  cJSON_AddNumberToObject(r, "radius_factor", s.radius_factor);
  cJSON_AddNumberToObject(r, "alpha", s.alpha);
  cJSON_AddNumberToObject(r, "seed", (double)s.seed);
  cJSON_AddNumberToObject(r, "width", s.width);
  cJSON_AddNumberToObject(r, "height", s.height);
}

static void add_job(cJSON *jobs, const Vcmfarm__JobStatus *j) {
  cJSON *o = cJSON_CreateObject();
  cJSON_AddItemToArray(jobs, o);
  cJSON_AddNumberToObject(o, "id", (double)j->job_id);
  cJSON_AddStringToObject(o, "name", j->name);
  cJSON_AddStringToObject(o, "state", j->state);
  cJSON_AddNumberToObject(o, "priority", j->priority);
  cJSON_AddBoolToObject(o, "paused", j->paused);
  cJSON *requires = cJSON_AddArrayToObject(o, "requires");
  for (size_t i = 0; i < j->n_requires; i++) cJSON_AddItemToArray(requires, cJSON_CreateString(j->requires[i]));
  cJSON *scene = cJSON_AddObjectToObject(o, "scene");
  add_string_or_null(scene, "name", j->scene_name);
  char hex[65] = "";
  for (size_t i = 0; i < j->scene_hash.len && i < 32; i++) snprintf(hex + 2 * i, 3, "%02x", j->scene_hash.data[i]);
  add_string_or_null(scene, "hash", hex);
  add_settings(o, j);
  add_time(o, "submitted_at", j->submitted_at);
  add_time(o, "started_at", j->started_at);
  add_time(o, "ended_at", j->ended_at);
  cJSON_AddNumberToObject(o, "first_iteration", (double)j->first_iteration);
  cJSON_AddNumberToObject(o, "iterations", (double)j->iterations_total);
  cJSON_AddNumberToObject(o, "iterations_done", (double)j->iterations_done);
  cJSON_AddNumberToObject(o, "iterations_leased", (double)j->iterations_leased);
  cJSON_AddNumberToObject(o, "iterations_rendering", (double)j->iterations_rendering);
  cJSON_AddNumberToObject(o, "progress", j->progress);
  add_string_or_null(o, "progress_by", j->progress_by);
  cJSON_AddNumberToObject(o, "iterations_per_second", j->iterations_per_second);
  cJSON_AddNumberToObject(o, "workers", j->workers);
  cJSON_AddNumberToObject(o, "seconds", j->seconds);
  add_number_or_null(o, "eta_seconds", j->eta_seconds >= 0.0 ? j->eta_seconds : NAN);
  add_number_or_null(o, "rmse", j->rmse);
  add_number_or_null(o, "estimated_rmse", j->estimated_rmse);
  add_number_or_null(o, "error_slope", j->error_slope > 0.0 ? j->error_slope : NAN);
  /* What the film counts beside its sums (common/film.h): samples refused as non-finite,
   * and light vertices upg merged with vertex merging's bias (its estimate then covers the
   * error but theirs). */
  cJSON_AddNumberToObject(o, "nonfinite_samples", (double)j->nonfinite_samples);
  cJSON_AddNumberToObject(o, "biased_merges", (double)j->biased_merges);
  /* A job with a pilot (docs/PROTOCOL.md, "Pilots"): its iterations, those merged, and the
   * allocation's summary once computed; null without one. */
  if (j->pilot > 0) {
    cJSON *pilot = cJSON_AddObjectToObject(o, "pilot");
    cJSON_AddNumberToObject(pilot, "iterations", j->pilot);
    cJSON_AddNumberToObject(pilot, "iterations_done", (double)j->pilot_done);
    add_string_or_null(pilot, "allocation", j->allocation);
  } else {
    cJSON_AddNullToObject(o, "pilot");
  }
  cJSON *stop = cJSON_AddObjectToObject(o, "stop");
  add_number_or_null(stop, "iterations", iterations_is_condition(j) ? (double)j->iterations_total : NAN);
  add_number_or_null(stop, "time", j->time_limit > 0.0 ? j->time_limit : NAN);
  cJSON_AddStringToObject(stop, "time_counts", "wall-clock seconds since the job's first lease");
  add_number_or_null(stop, "target_rmse", j->target_rmse > 0.0 ? j->target_rmse : NAN);
  add_number_or_null(stop, "target_error", j->target_error > 0.0 ? j->target_error : NAN);
  cJSON_AddBoolToObject(o, "reference", j->has_reference);
  add_string_or_null(o, "stop_reason", j->stop_code);
  cJSON_AddStringToObject(o, "stop_message", j->stop_reason);
  cJSON_AddNumberToObject(o, "results_refused", (double)j->results_refused);
  cJSON_AddStringToObject(o, "message", j->message);
  add_events(o, j->events, j->n_events, j->events_dropped, VF_JOB_EVENTS);
  if (j->n_convergence > 0) {
    cJSON *log = cJSON_AddArrayToObject(o, "convergence");
    for (size_t k = 0; k < j->n_convergence; k++) {
      const Vcmfarm__ConvergenceEntry *e = j->convergence[k];
      cJSON *c = cJSON_CreateObject();
      cJSON_AddItemToArray(log, c);
      cJSON_AddNumberToObject(c, "run", e->run);
      cJSON_AddNumberToObject(c, "wall_seconds", e->wall_seconds);
      cJSON_AddNumberToObject(c, "cpu_seconds", e->cpu_seconds);
      cJSON_AddNumberToObject(c, "iterations", (double)e->iterations);
      add_number_or_null(c, "rmse", e->rmse);
      add_number_or_null(c, "rel_mse", e->rel_mse);
      add_number_or_null(c, "estimated_rmse", e->estimated_rmse);
    }
  }
}

static void add_worker(cJSON *workers, const Vcmfarm__WorkerStatus *w) {
  cJSON *o = cJSON_CreateObject();
  char id[17];
  snprintf(id, sizeof id, "%016llx", (unsigned long long)w->worker_id);
  cJSON_AddItemToArray(workers, o);
  cJSON_AddStringToObject(o, "id", id);
  cJSON_AddStringToObject(o, "name", w->name);
  cJSON_AddNumberToObject(o, "threads", w->threads);
  if (w->lease_job) {
    cJSON *l = cJSON_AddObjectToObject(o, "lease");
    cJSON_AddNumberToObject(l, "job", (double)w->lease_job);
    cJSON_AddNumberToObject(l, "begin", (double)w->lease_begin);
    cJSON_AddNumberToObject(l, "end", (double)w->lease_end);
  } else {
    cJSON_AddNullToObject(o, "lease");
  }
  cJSON_AddStringToObject(o, "state", w->state);
  add_string_or_null(o, "host", w->host);
  cJSON_AddNumberToObject(o, "cores", w->cores);
  cJSON *tags = cJSON_AddArrayToObject(o, "tags");
  for (size_t i = 0; i < w->n_tags; i++) cJSON_AddItemToArray(tags, cJSON_CreateString(w->tags[i]));
  if (w->memory_bytes > 0) cJSON_AddNumberToObject(o, "memory_bytes", (double)w->memory_bytes);
  else cJSON_AddNullToObject(o, "memory_bytes");
  add_string_or_null(o, "version", w->software_version);
  cJSON_AddNumberToObject(o, "iterations_per_second", w->iterations_per_second);
  cJSON_AddNumberToObject(o, "last_seen_seconds", w->last_seen_seconds);
  add_time(o, "registered_at", w->registered_at);
  add_time(o, "departed_at", w->departed_at);
  cJSON *t = cJSON_AddObjectToObject(o, "totals");
  cJSON_AddNumberToObject(t, "iterations_merged", (double)w->iterations_merged);
  cJSON_AddNumberToObject(t, "parts_merged", (double)w->parts_merged);
  cJSON_AddNumberToObject(t, "results_refused", (double)w->results_refused);
  cJSON_AddNumberToObject(t, "leases", (double)w->leases);
}

static cJSON *status_json(const Vcmfarm__Status *st) {
  cJSON *root = cJSON_CreateObject();
  add_time(root, "time", st->time);
  cJSON *c = cJSON_AddObjectToObject(root, "coordinator");
  add_string_or_null(c, "version", st->software_version);
  cJSON_AddNumberToObject(c, "protocol", st->protocol_version);
  add_time(c, "started_at", st->started_at);
  cJSON_AddNumberToObject(root, "iterations_per_second", st->iterations_per_second);
  cJSON_AddNumberToObject(root, "workers_busy", st->workers_busy);
  cJSON *jobs = cJSON_AddArrayToObject(root, "jobs");
  for (size_t i = 0; i < st->n_jobs; i++) add_job(jobs, st->jobs[i]);
  cJSON *workers = cJSON_AddArrayToObject(root, "workers");
  for (size_t i = 0; i < st->n_workers; i++) add_worker(workers, st->workers[i]);
  add_events(root, st->events, st->n_events, st->events_dropped, VF_FARM_EVENTS);
  return root;
}

void vf_status_print_json(const Vcmfarm__Status *st, FILE *out) {
  cJSON *root = status_json(st);
  char *text = cJSON_Print(root);
  if (text) fprintf(out, "%s\n", text);
  free(text);
  cJSON_Delete(root);
}

char *vf_status_json_text(const Vcmfarm__Status *st) {
  cJSON *root = status_json(st);
  char *text = cJSON_PrintUnformatted(root);
  cJSON_Delete(root);
  return text;
}

/* "1h02m", "3m05s", "12.3 s" */
static void format_duration(char *buf, size_t n, double s) {
  if (s < 0.0 || !isfinite(s)) snprintf(buf, n, "unknown");
  else if (s < 60.0) snprintf(buf, n, "%.1f s", s);
  else if (s < 3600.0) snprintf(buf, n, "%dm%02ds", (int)(s / 60.0), (int)fmod(s, 60.0));
  else snprintf(buf, n, "%dh%02dm", (int)(s / 3600.0), (int)fmod(s / 60.0, 60.0));
}

/* A Unix time as local "2024-05-01 12:03:07", or "-" for 0. */
static void format_time(char *buf, size_t n, double unix_seconds) {
  struct tm tm;
  time_t t = (time_t)unix_seconds;
  if (unix_seconds <= 0.0 || localtime_r(&t, &tm) == NULL || strftime(buf, n, "%Y-%m-%d %H:%M:%S", &tm) == 0)
    snprintf(buf, n, "-");
}

/* Appends to a growing text: p advances, left shrinks; nothing once full. */
static void append(char **p, size_t *left, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void append(char **p, size_t *left, const char *fmt, ...) {
  if (*left <= 1) return;
  va_list ap;
  va_start(ap, fmt);
  int n = vsnprintf(*p, *left, fmt, ap);
  va_end(ap);
  if (n < 0) return;
  size_t used = (size_t)n < *left ? (size_t)n : *left - 1;
  *p += used;
  *left -= used;
}

void vf_status_job_line(const Vcmfarm__JobStatus *j, char *buf, size_t n) {
  char eta[32];
  format_duration(eta, sizeof eta, j->eta_seconds);
  char *p = buf;
  size_t left = n;
  buf[0] = '\0';
  append(&p, &left, "%s, %llu %s done", j->state, (unsigned long long)j->iterations_done,
         vf_cli_plural(j->iterations_done, "iteration", "iterations"));
  if (j->pilot > 0 && j->allocation[0] == '\0')
    append(&p, &left, ", pilot: %llu/%u iterations", (unsigned long long)j->pilot_done, j->pilot);
  if (j->progress_by[0] &&
      (strcmp(j->state, "running") == 0 || strcmp(j->state, "queued") == 0 || strcmp(j->state, "paused") == 0))
    append(&p, &left, ", %.0f%% (%s), ETA %s", 100.0 * j->progress, j->progress_by, eta);
  if (isfinite(j->estimated_rmse)) {
    vf_settings s;
    int variance = vf_settings_parse(&s, j->settings) == VF_OK && estimate_scope(j, &s) == VF_ESTIMATE_VARIANCE;
    append(&p, &left, ", est. RMSE %.4g%s", j->estimated_rmse, variance ? " (variance only)" : "");
  }
  if (j->biased_merges > 0)
    append(&p, &left, ", %llu light %s merged with bias", (unsigned long long)j->biased_merges,
           vf_cli_plural(j->biased_merges, "vertex", "vertices"));
  if (j->nonfinite_samples > 0)
    append(&p, &left, ", %llu non-finite %s", (unsigned long long)j->nonfinite_samples,
           vf_cli_plural(j->nonfinite_samples, "sample", "samples"));
  if (j->has_reference && isfinite(j->rmse)) append(&p, &left, ", RMSE %.4g", j->rmse);
}

/* "stops at the first of: 1000 iterations, 60 s (...), ..." */
static void stop_text(const Vcmfarm__JobStatus *j, char *buf, size_t n) {
  char *p = buf;
  size_t left = n;
  const char *sep = "";
  buf[0] = '\0';
  if (iterations_is_condition(j)) {
    append(&p, &left, "%llu %s", (unsigned long long)j->iterations_total, vf_cli_plural(j->iterations_total, "iteration", "iterations"));
    sep = ", ";
  }
  if (j->time_limit > 0.0) {
    append(&p, &left, "%s%g s (wall clock since its first lease)", sep, j->time_limit);
    sep = ", ";
  }
  if (j->target_rmse > 0.0) {
    append(&p, &left, "%sRMSE %g", sep, j->target_rmse);
    sep = ", ";
  }
  if (j->target_error > 0.0) append(&p, &left, "%sest. RMSE %g", sep, j->target_error);
}

static void print_events(FILE *out, Vcmfarm__Event **events, size_t n, uint64_t dropped, const char *indent) {
  if (n == 0) return;
  fprintf(out, "%sevents (the latest %zu", indent, n);
  if (dropped) fprintf(out, "; %llu older not kept", (unsigned long long)dropped);
  fprintf(out, "):\n");
  for (size_t i = 0; i < n; i++) {
    char at[32];
    format_time(at, sizeof at, events[i]->time);
    fprintf(out, "%s  %s %s: %s\n", indent, at, events[i]->kind, events[i]->message);
  }
}

void vf_status_print_text(const Vcmfarm__Status *st, FILE *out) {
  unsigned registered = 0;
  for (size_t i = 0; i < st->n_workers; i++)
    registered += strcmp(st->workers[i]->state, "left") != 0 && strcmp(st->workers[i]->state, "lost") != 0;
  fprintf(out, "farm: %.2f iterations/s, %u of %u %s busy\n", st->iterations_per_second, st->workers_busy, registered,
          vf_cli_plural(registered, "worker", "workers"));
  int one_job = st->n_jobs == 1 && st->jobs[0]->n_convergence > 0;
  for (size_t i = 0; i < st->n_jobs; i++) {
    const Vcmfarm__JobStatus *j = st->jobs[i];
    char ran[32], line[512], stop[256], submitted[32], started[32], ended[32];
    format_duration(ran, sizeof ran, j->seconds);
    vf_status_job_line(j, line, sizeof line);
    stop_text(j, stop, sizeof stop);
    fprintf(out, "job %llu '%s': %s\n", (unsigned long long)j->job_id, j->name, line);
    fprintf(out, "  %llu leased (%llu of them rendered, not merged yet), priority %d; stops at the first of: %s\n",
            (unsigned long long)j->iterations_leased, (unsigned long long)j->iterations_rendering, j->priority, stop);
    if (j->n_requires > 0) {
      fprintf(out, "  requires");
      for (size_t k = 0; k < j->n_requires; k++) fprintf(out, "%s%s", k ? "," : " ", j->requires[k]);
      fprintf(out, " (leased only to workers satisfying all)\n");
    }
    if (j->pilot > 0 && j->allocation[0] != '\0')
      fprintf(out, "  pilot of %u iterations done; allocation: %s\n", j->pilot, j->allocation);
    fprintf(out, "  ran %s, %.2f it/s on %u %s", ran, j->iterations_per_second, j->workers,
            vf_cli_plural(j->workers, "worker", "workers"));
    if (j->results_refused)
      fprintf(out, ", %llu %s refused", (unsigned long long)j->results_refused,
              vf_cli_plural(j->results_refused, "result", "results"));
    fprintf(out, "\n");
    format_time(submitted, sizeof submitted, j->submitted_at);
    format_time(started, sizeof started, j->started_at);
    format_time(ended, sizeof ended, j->ended_at);
    fprintf(out, "  submitted %s, started %s, ended %s\n", submitted, started, ended);
    if (one_job) {
      fprintf(out, "  scene %s, hash ", j->scene_name[0] ? j->scene_name : "(unnamed)");
      for (size_t k = 0; k < j->scene_hash.len; k++) fprintf(out, "%02x", j->scene_hash.data[k]);
      fprintf(out, "\n  %s%s%s\n", j->settings, j->algorithm_resolved[0] && strstr(j->settings, "=auto") ? "; resolved to " : "",
              j->algorithm_resolved[0] && strstr(j->settings, "=auto") ? j->algorithm_resolved : "");
    }
    if (j->stop_code[0]) fprintf(out, "  stopped: %s%s%s%s\n", j->stop_code, j->stop_reason[0] ? " (" : "", j->stop_reason,
                                 j->stop_reason[0] ? ")" : "");
    if (j->message[0]) fprintf(out, "  %s\n", j->message);
    if (one_job) print_events(out, j->events, j->n_events, j->events_dropped, "  ");
    if (j->n_convergence > 0) {
      fprintf(out, "  %4s %12s %12s %10s %12s %12s %12s\n", "run", "worker s", "cpu s", "iterations", "RMSE", "rel. MSE",
              "est. RMSE");
      for (size_t k = 0; k < j->n_convergence; k++) {
        const Vcmfarm__ConvergenceEntry *e = j->convergence[k];
        fprintf(out, "  %4u %12.2f %12.2f %10llu %12.5g %12.5g %12.5g\n", e->run, e->wall_seconds, e->cpu_seconds,
                (unsigned long long)e->iterations, e->rmse, e->rel_mse, e->estimated_rmse);
      }
    }
  }
  for (size_t i = 0; i < st->n_workers; i++) {
    const Vcmfarm__WorkerStatus *w = st->workers[i];
    fprintf(out, "worker %s (%s%s%u %s, %u %s): %s", w->name, w->host[0] ? w->host : "", w->host[0] ? ", " : "",
            w->threads, vf_cli_plural(w->threads, "thread", "threads"), w->cores, vf_cli_plural(w->cores, "core", "cores"), w->state);
    for (size_t k = 0; k < w->n_tags; k++) fprintf(out, "%s%s", k ? "," : ", tags ", w->tags[k]);
    if (w->lease_job)
      fprintf(out, ", job %llu [%llu,%llu)", (unsigned long long)w->lease_job, (unsigned long long)w->lease_begin,
              (unsigned long long)w->lease_end);
    fprintf(out, ", %.2f it/s, seen %.1f s ago, %llu %s merged", w->iterations_per_second, w->last_seen_seconds,
            (unsigned long long)w->iterations_merged, vf_cli_plural(w->iterations_merged, "iteration", "iterations"));
    if (w->results_refused)
      fprintf(out, ", %llu %s refused", (unsigned long long)w->results_refused,
              vf_cli_plural(w->results_refused, "result", "results"));
    fprintf(out, "\n");
  }
  if (!one_job) print_events(out, st->events, st->n_events, st->events_dropped, "");
  if (st->n_jobs == 0 && st->n_workers == 0) fprintf(out, "no jobs, no workers\n");
}
