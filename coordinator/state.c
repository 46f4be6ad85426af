#include "state.h"

#include "../common/blob.h"
#include "../common/clock.h"
#include "../common/error.h"
#include "../common/file.h"
#include "../common/image.h"
#include "../common/parse.h"
#include "blobs.h"
#include "jobs.h"
#include "log.h"
#include "poison.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <sodium.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

/* Format 2 (protocol 2) added stop conditions, running time and references, and made
 * the priority a weight of at least 1; format 1 reads with priorities below 1 raised to 1.
 * Format 3 (protocol 4) added a job's first iteration, 0 when reading formats 1 and 2.
 * Format 4 (protocol 6) added per job the times it was submitted, started and ended, the
 * machine-readable stop reason, what `auto` resolved to and its latest events; absent in
 * older files: times 0 (unknown), the reason derived from the end and its message, no
 * events. Format 5 (protocol 10) added per job whether it is paused and the tags it
 * requires; absent in older files: not paused, no requirement. Settings texts of any
 * format are read in today's canonical form. */
#define STATE_FORMAT 5
#define MAX_STATE_BYTES ((size_t)64 << 20)

static int path_of(char *buf, size_t n, const char *dir, const char *name, uint64_t id, const char *ext) {
  int len = id ? snprintf(buf, n, "%s/%s%llu%s", dir, name, (unsigned long long)id, ext)
               : snprintf(buf, n, "%s/%s", dir, name);
  if (len < 0 || (size_t)len >= n) return vf_error_set(VF_EINVAL, "%s: state directory path too long", dir);
  return VF_OK;
}

int vf_state_lock(const char *dir, int *fd) {
  if (mkdir(dir, 0700) != 0 && errno != EEXIST) return vf_error_set(VF_EIO, "%s: %s", dir, strerror(errno));
  char path[4096];
  int err = path_of(path, sizeof path, dir, "lock", 0, "");
  if (err != VF_OK) return err;
  int f = open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0600);
  if (f < 0) return vf_error_set(VF_EIO, "%s: %s", path, strerror(errno));
  if (flock(f, LOCK_EX | LOCK_NB) != 0) {
    close(f);
    return vf_error_set(VF_EIO, "%s: another coordinator uses this state directory", dir);
  }
  *fd = f;
  return VF_OK;
}

int vf_state_save_scene(const char *dir, const vf_job *job) {
  char path[4096];
  int err;
  /* The file table (if any) before the scene text that needs it. */
  if (job->files.count > 0 && ((err = path_of(path, sizeof path, dir, "job-", job->id, ".files")) != VF_OK ||
                               (err = vf_blob_table_save(&job->files, path)) != VF_OK))
    return err;
  if ((err = path_of(path, sizeof path, dir, "job-", job->id, ".scene")) != VF_OK) return err;
  return vf_file_write_atomic(path, job->scene_text, strlen(job->scene_text), 0600);
}

int vf_state_film_path(const char *dir, uint64_t id, char *buf, size_t n) {
  return path_of(buf, n, dir, "job-", id, ".exr");
}

int vf_state_pilot_path(const char *dir, uint64_t id, char *buf, size_t n) {
  return path_of(buf, n, dir, "job-", id, ".pilot.exr");
}

int vf_state_save_film(const char *dir, vf_job *job) {
  char path[4096];
  int err = path_of(path, sizeof path, dir, "job-", job->id, ".exr");
  if (err != VF_OK || job->film_unreadable) return err;
  if ((err = vf_film_write(job->film, path)) == VF_OK) {
    job->film_dirty = job->final_pending = 0;
    job->checkpoint_error[0] = '\0';
  }
  return err;
}

int vf_state_save_pilot(const char *dir, vf_job *job) {
  char path[4096];
  int err = vf_state_pilot_path(dir, job->id, path, sizeof path);
  if (err != VF_OK || job->pilot_film == NULL || job->film_unreadable) return err;
  if ((err = vf_film_write(job->pilot_film, path)) == VF_OK) job->pilot_dirty = 0;
  return err;
}

/* A job with a pilot resumes where it was: with the allocation its film has, or else from
 * its pilot film as written (absent: none merged; unreadable: the pilot starts again, which
 * renders the same iterations and so computes the same allocation), and computes the
 * allocation at once if that film is complete. */
static void load_pilot(vf_farm *farm, vf_job *job) {
  const char *dir = farm->config.state_dir;
  unsigned long long jid = (unsigned long long)job->id;
  char path[4096];
  if (job->settings.pilot == 0 || job->film_unreadable ||
      path_of(path, sizeof path, dir, "job-", job->id, ".pilot.exr") != VF_OK)
    return;
  if (job->film->samples != NULL) {
    vf_job_allocation_loaded(job);
    vf_film_destroy(job->pilot_film);
    job->pilot_film = NULL;
    unlink(path);
    int err = vf_blobs_put_allocation(farm, job);
    if (err != VF_OK) vf_log("job %llu: %s", jid, vf_error_detail(err)); /* its workers report it as failed leases */
    return;
  }
  vf_film *pilot = NULL;
  int err = vf_film_read(path, &pilot);
  if (err == VF_ENOENT) return;
  if (err == VF_OK && (err = vf_job_restore_pilot(job, pilot)) != VF_OK) vf_film_destroy(pilot);
  if (err != VF_OK) {
    vf_log("job %llu: its pilot film %s is not used, the pilot starts again: %s", jid, path, vf_error_detail(err));
    return;
  }
  vf_log("job %llu: pilot resumed with %llu/%d iterations", jid,
         (unsigned long long)vf_iterset_count(&job->pilot_film->iterations), job->settings.pilot);
  vf_jobs_pilot_merged(farm, job, vf_seconds_now());
}

int vf_state_save_reference(const char *dir, vf_job *job, const uint8_t hash[32]) {
  char path[4096], blob[4200];
  int err = path_of(path, sizeof path, dir, "job-", job->id, ".reference.exr");
  if (err != VF_OK || (err = vf_blob_path(dir, hash, blob, sizeof blob)) != VF_OK) return err;
  unlink(path); /* left by a submission that failed before its job list was written */
  if (link(blob, path) != 0) return vf_error_set(VF_EIO, "%s: cannot link %s: %s", path, blob, strerror(errno));
  if ((err = vf_job_load_reference(job, path)) != VF_OK) {
    /* Name what was sent, not where we kept it. */
    const char *detail = vf_error_detail(err), *at = strstr(detail, path);
    char rest[1024];
    snprintf(rest, sizeof rest, "%s", at ? at + strlen(path) : detail);
    unlink(path);
    return vf_error_set(err == VF_EIO ? VF_EINVAL : err, "reference%s%s", at ? "" : ": ", rest);
  }
  return VF_OK;
}

void vf_state_remove_job_files(const char *dir, uint64_t id) {
  const char *ext[] = {".scene", ".files", ".exr", ".reference.exr", ".pilot.exr"};
  char path[4096];
  for (size_t i = 0; i < sizeof ext / sizeof *ext; i++)
    if (path_of(path, sizeof path, dir, "job-", id, ext[i]) == VF_OK) unlink(path);
}

static const char *end_name(vf_job_end e) {
  return e == VF_JOB_CANCELLED ? "cancelled" : e == VF_JOB_FAILED ? "failed" : e == VF_JOB_STOPPED ? "stopped" : "active";
}

static int save_events(cJSON *job, const vf_events *log) {
  cJSON *a = cJSON_AddArrayToObject(job, "events");
  if (a == NULL || cJSON_AddNumberToObject(job, "events_dropped", (double)log->dropped) == NULL) return VF_ENOMEM;
  for (unsigned i = 0; i < log->count; i++) {
    const vf_event *e = vf_events_at(log, i);
    cJSON *o = cJSON_CreateObject();
    if (o == NULL || !cJSON_AddItemToArray(a, o)) return VF_ENOMEM;
    cJSON_AddNumberToObject(o, "time", e->time);
    cJSON_AddStringToObject(o, "kind", e->kind);
    cJSON_AddStringToObject(o, "worker", e->worker);
    if (cJSON_AddStringToObject(o, "message", e->message) == NULL) return VF_ENOMEM;
  }
  return VF_OK;
}

/* The job's failed leases in a row, their workers and its blocklist (coordinator/poison.h);
 * a block's end as Unix time, since the monotonic clock starts again with the process. */
static int save_poison(cJSON *o, const vf_farm *farm, const vf_job *job) {
  cJSON *names = cJSON_AddArrayToObject(o, "failed_workers"), *blocked = cJSON_AddArrayToObject(o, "blocked");
  if (names == NULL || blocked == NULL || cJSON_AddNumberToObject(o, "lease_failures", job->lease_failures) == NULL)
    return VF_ENOMEM;
  for (unsigned k = 0; k < job->failed_workers_count; k++)
    if (!cJSON_AddItemToArray(names, cJSON_CreateString(job->failed_workers[k]))) return VF_ENOMEM;
  double now = vf_seconds_now(), unix_now = vf_unix_now();
  for (size_t i = 0; i < farm->num_blocks; i++) {
    uint64_t job_id;
    double until;
    const char *worker = vf_poison_block_at(farm, i, &job_id, &until);
    if (job_id != job->id || until <= now) continue;
    cJSON *b = cJSON_CreateObject();
    if (b == NULL || !cJSON_AddItemToArray(blocked, b) || cJSON_AddStringToObject(b, "worker", worker) == NULL ||
        cJSON_AddNumberToObject(b, "until", unix_now + (until - now)) == NULL)
      return VF_ENOMEM;
  }
  return VF_OK;
}

int vf_state_save_index(vf_farm *farm) {
  int err = VF_ENOMEM, built = 0; /* until the text is built; its detail is set at `done` only then */
  cJSON *root = cJSON_CreateObject(), *jobs = cJSON_AddArrayToObject(root, "jobs");
  if (root == NULL || jobs == NULL) goto done;
  cJSON_AddNumberToObject(root, "format", STATE_FORMAT);
  cJSON_AddNumberToObject(root, "next_job_id", (double)farm->next_job_id);
  for (size_t i = 0; i < farm->num_jobs; i++) {
    const vf_job *j = farm->jobs[i];
    /* A stopped job whose final film is not durable yet is still active on disk. */
    int unsettled = j->end == VF_JOB_STOPPED && j->final_pending;
    cJSON *o = cJSON_CreateObject();
    if (o == NULL || !cJSON_AddItemToArray(jobs, o)) goto done;
    char hex[65];
    sodium_bin2hex(hex, sizeof hex, j->scene_hash, 32);
    cJSON_AddNumberToObject(o, "id", (double)j->id);
    cJSON_AddStringToObject(o, "name", j->name);
    cJSON_AddNumberToObject(o, "priority", j->priority);
    cJSON_AddBoolToObject(o, "scene_builtin", j->scene_builtin);
    cJSON_AddStringToObject(o, "scene_hash", hex);
    cJSON_AddStringToObject(o, "settings", j->settings_text);
    cJSON_AddNumberToObject(o, "first_iteration", (double)j->first);
    if (!j->scene_builtin) cJSON_AddStringToObject(o, "scene_path", j->film->scene_name);
    cJSON_AddNumberToObject(o, "iterations", (double)j->iterations);
    cJSON_AddNumberToObject(o, "time_limit", j->time_limit);
    cJSON_AddNumberToObject(o, "target_rmse", j->target_rmse);
    cJSON_AddNumberToObject(o, "target_error", j->target_error);
    cJSON_AddBoolToObject(o, "reference", j->reference.rgb != NULL);
    cJSON_AddNumberToObject(o, "seconds", j->seconds);
    cJSON_AddStringToObject(o, "end", end_name(unsettled ? VF_JOB_ACTIVE : j->end));
    cJSON_AddStringToObject(o, "stop_reason", unsettled ? "" : vf_stop_reason_name(j->stop));
    cJSON_AddNumberToObject(o, "submitted_at", j->submitted_at);
    cJSON_AddNumberToObject(o, "started_at", j->started_at);
    cJSON_AddNumberToObject(o, "ended_at", unsettled ? 0.0 : j->ended_at);
    cJSON_AddStringToObject(o, "algorithm_resolved", j->algorithm_resolved);
    cJSON_AddBoolToObject(o, "paused", j->paused);
    cJSON *requires = cJSON_AddArrayToObject(o, "requires");
    for (unsigned k = 0; requires != NULL && k < j->requires.count; k++)
      if (!cJSON_AddItemToArray(requires, cJSON_CreateString(j->requires.tag[k]))) requires = NULL;
    if (requires == NULL || save_events(o, &j->events) != VF_OK || save_poison(o, farm, j) != VF_OK) goto done;
    if (cJSON_AddStringToObject(o, "message", unsettled ? "" : j->message) == NULL) goto done;
  }
  char *text = cJSON_Print(root);
  if (text == NULL) goto done;
  built = 1;
  char path[4096];
  if ((err = path_of(path, sizeof path, farm->config.state_dir, "state.json", 0, "")) == VF_OK)
    err = vf_file_write_atomic(path, text, strlen(text), 0600);
  free(text);
  if (err == VF_OK) {
    farm->state_dirty = farm->state_urgent = 0;
    for (size_t i = 0; i < farm->num_jobs; i++) farm->jobs[i]->seconds_saved = farm->jobs[i]->seconds;
  }
done:
  cJSON_Delete(root);
  /* Only a detail of its own: an older one (a film's write) must not be blamed on us. */
  if (!built) err = vf_error_set(VF_ENOMEM, "out of memory writing state.json");
  return err;
}

/* ---- loading ---- */

static int get_u64(const cJSON *o, const char *key, uint64_t max, uint64_t *out, const char *path) {
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
  if (!cJSON_IsNumber(v) || v->valuedouble < 0 || v->valuedouble > (double)max ||
      v->valuedouble != (double)(uint64_t)v->valuedouble)
    return vf_error_set(VF_EINVAL, "%s: \"%s\" missing or not a whole number in [0, %llu]", path, key,
                        (unsigned long long)max);
  *out = (uint64_t)v->valuedouble;
  return VF_OK;
}

static const char *get_str(const cJSON *o, const char *key) {
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
  return cJSON_IsString(v) ? v->valuestring : NULL;
}

/* A number >= 0 or absent (0); false when present and not such a number. */
static int get_nonneg(const cJSON *o, const char *key, double *out) {
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
  *out = 0.0;
  if (v == NULL) return 1;
  if (!cJSON_IsNumber(v) || !(v->valuedouble >= 0.0) || !isfinite(v->valuedouble)) return 0;
  *out = v->valuedouble;
  return 1;
}

/* The events of a job as saved (format 4), each field checked; at most the log's capacity
 * (the latest). False when malformed. */
static int load_events(const cJSON *o, vf_job *job) {
  const cJSON *a = cJSON_GetObjectItemCaseSensitive(o, "events"), *e;
  double dropped;
  if (a == NULL) return 1;
  if (!cJSON_IsArray(a) || !get_nonneg(o, "events_dropped", &dropped) || dropped > 1e15) return 0;
  int n = cJSON_GetArraySize(a), skip = n > VF_JOB_EVENTS ? n - VF_JOB_EVENTS : 0, i = 0;
  cJSON_ArrayForEach(e, a) {
    const cJSON *time = cJSON_GetObjectItemCaseSensitive(e, "time");
    const char *kind = get_str(e, "kind"), *worker = get_str(e, "worker"), *message = get_str(e, "message");
    if (!cJSON_IsNumber(time) || !isfinite(time->valuedouble) || !kind || !worker || !message ||
        strlen(kind) >= sizeof job->events_storage[0].kind)
      return 0;
    if (i++ < skip) continue;
    vf_events_add(&job->events, time->valuedouble, kind, job->id, worker, "%s", message);
  }
  job->events.dropped = (uint64_t)dropped + (uint64_t)skip;
  return 1;
}

/* A worker's name as saved: a string that fits vf_job.failed_workers. */
static const char *worker_name(const cJSON *v) {
  return cJSON_IsString(v) && strlen(v->valuestring) < sizeof ((vf_job *)0)->failed_workers[0] ? v->valuestring
                                                                                               : NULL;
}

/* save_poison's fields into the job, which is not the farm's yet; its blocks are checked
 * here and restored by restore_blocks once it is. Absent in a state of before they were
 * saved: nothing counted, nobody blocked. */
static int load_poison(vf_job *job, const cJSON *o, const char *state_path) {
  const cJSON *count = cJSON_GetObjectItemCaseSensitive(o, "lease_failures");
  const cJSON *names = cJSON_GetObjectItemCaseSensitive(o, "failed_workers");
  const cJSON *blocked = cJSON_GetObjectItemCaseSensitive(o, "blocked"), *e;
  int ok = (count == NULL || (cJSON_IsNumber(count) && count->valuedouble >= 0.0 && count->valuedouble <= 1e6)) &&
           (names == NULL || (cJSON_IsArray(names) && cJSON_GetArraySize(names) <= VF_JOB_FAILED_WORKERS)) &&
           (blocked == NULL || cJSON_IsArray(blocked));
  cJSON_ArrayForEach(e, names) ok = ok && worker_name(e) != NULL;
  cJSON_ArrayForEach(e, blocked) {
    const cJSON *until = cJSON_GetObjectItemCaseSensitive(e, "until");
    ok = ok && worker_name(cJSON_GetObjectItemCaseSensitive(e, "worker")) != NULL && cJSON_IsNumber(until) &&
         isfinite(until->valuedouble);
  }
  if (!ok)
    return vf_error_set(VF_EINVAL, "%s: job %llu: its failed leases or blocked workers are malformed", state_path,
                        (unsigned long long)job->id);
  job->lease_failures = count ? (unsigned)count->valuedouble : 0;
  job->failed_workers_count = 0;
  cJSON_ArrayForEach(e, names) snprintf(job->failed_workers[job->failed_workers_count++], sizeof job->failed_workers[0],
                                        "%s", e->valuestring);
  return VF_OK;
}

/* Whether the job is paused and the tags it requires (format 5), each checked as a
 * requirement from a peer is; absent: not paused, none. */
static int load_job_model(vf_job *job, const cJSON *o, const char *state_path) {
  const cJSON *paused = cJSON_GetObjectItemCaseSensitive(o, "paused");
  const cJSON *requires = cJSON_GetObjectItemCaseSensitive(o, "requires"), *e;
  if ((paused != NULL && !cJSON_IsBool(paused)) || (requires != NULL && !cJSON_IsArray(requires)))
    return vf_error_set(VF_EINVAL, "%s: job %llu: \"paused\" is not a boolean or \"requires\" not an array", state_path,
                        (unsigned long long)job->id);
  vf_tags tags;
  vf_tags_init(&tags);
  cJSON_ArrayForEach(e, requires) {
    int err = cJSON_IsString(e) ? vf_tags_add("requires", &tags, e->valuestring, strlen(e->valuestring), 1)
                                : vf_error_set(VF_EINVAL, "requires: an item is not a string");
    if (err != VF_OK)
      return vf_error_set(VF_EINVAL, "%s: job %llu: %s", state_path, (unsigned long long)job->id, vf_error_detail(err));
  }
  job->requires = tags;
  job->paused = cJSON_IsTrue(paused);
  return VF_OK;
}

/* The job's blocks as load_poison checked them, those not over yet. */
static void restore_blocks(vf_farm *farm, uint64_t job_id, const cJSON *o) {
  double now = vf_seconds_now(), unix_now = vf_unix_now();
  const cJSON *e;
  cJSON_ArrayForEach(e, cJSON_GetObjectItemCaseSensitive(o, "blocked")) {
    double until = cJSON_GetObjectItemCaseSensitive(e, "until")->valuedouble;
    if (until > unix_now)
      vf_poison_restore(farm, cJSON_GetObjectItemCaseSensitive(e, "worker")->valuestring, job_id,
                        now + (until - unix_now));
  }
}

/* A stop reason from a state file older than format 4: from how the job ended. */
static vf_stop_reason derived_stop(const vf_job *job) {
  switch (job->end) {
  case VF_JOB_CANCELLED: return VF_STOP_CANCELLED;
  case VF_JOB_FAILED: return VF_STOP_FAILED;
  case VF_JOB_STOPPED:
    return strncmp(job->message, "time", 4) == 0         ? VF_STOP_TIME
           : strncmp(job->message, "target RMSE", 11) == 0 ? VF_STOP_TARGET_RMSE
                                                          : VF_STOP_TARGET_ERROR;
  default: return vf_job_complete(job) ? VF_STOP_ITERATIONS : VF_STOP_NONE;
  }
}

/* The job's film could not be read back (err, with its detail): the job is failed with
 * the reason, unless it had ended already, and its film is never written over. 1 when it
 * failed now. */
static int unreadable_film(vf_farm *farm, vf_job *job, int err) {
  job->film_unreadable = 1;
  vf_log("job %llu: its film cannot be read back: %s", (unsigned long long)job->id, vf_error_detail(err));
  if (job->end != VF_JOB_ACTIVE) return 0;
  job->end = VF_JOB_FAILED;
  snprintf(job->message, sizeof job->message, "its film cannot be read back: %s", vf_error_detail(err));
  for (char *c = job->message; *c; c++)
    if ((unsigned char)*c < 0x20 || *c == 0x7f) *c = '?';
  job->ended_at = vf_unix_now();
  vf_events_add(&job->events, job->ended_at, "job_failed", job->id, "", "%s", job->message);
  farm->state_dirty = 1;
  return 1;
}

static int load_job(vf_farm *farm, const cJSON *o, const char *state_path, uint64_t format) {
  const char *dir = farm->config.state_dir;
  uint64_t id = 0, first = 0, iterations = 0;
  int err;
  if ((err = get_u64(o, "id", (1ull << 53), &id, state_path)) != VF_OK ||
      (err = get_u64(o, "iterations", VF_JOB_MAX_ITERATIONS, &iterations, state_path)) != VF_OK ||
      (format >= 3 && (err = get_u64(o, "first_iteration", VF_JOB_MAX_FIRST, &first, state_path)) != VF_OK))
    return err;
  const cJSON *pr = cJSON_GetObjectItemCaseSensitive(o, "priority");
  if (!cJSON_IsNumber(pr) || pr->valuedouble < -2147483648.0 || pr->valuedouble > 2147483647.0)
    return vf_error_set(VF_EINVAL, "%s: job %llu: bad \"priority\"", state_path, (unsigned long long)id);
  const char *name = get_str(o, "name"), *hex = get_str(o, "scene_hash"), *settings_text = get_str(o, "settings");
  const char *end = get_str(o, "end"), *message = get_str(o, "message");
  const cJSON *builtin = cJSON_GetObjectItemCaseSensitive(o, "scene_builtin");
  uint8_t hash[32];
  size_t hash_len = 0;
  if (!name || !hex || !settings_text || !end || !message || !cJSON_IsBool(builtin) ||
      sodium_hex2bin(hash, sizeof hash, hex, strlen(hex), NULL, &hash_len, NULL) != 0 || hash_len != 32)
    return vf_error_set(VF_EINVAL, "%s: job %llu: a field is missing or malformed", state_path, (unsigned long long)id);
  /* Written by an older coordinator, the text may hold 17-digit numbers (settings.h). */
  char settings[512];
  snprintf(settings, sizeof settings, "%s", settings_text);
  vf_settings_canonicalize(settings, sizeof settings);
  double times[3];
  const char *stop_name = get_str(o, "stop_reason"), *resolved = get_str(o, "algorithm_resolved");
  if (!get_nonneg(o, "submitted_at", &times[0]) || !get_nonneg(o, "started_at", &times[1]) ||
      !get_nonneg(o, "ended_at", &times[2]) || (stop_name && vf_stop_reason_parse(stop_name) < 0) ||
      (resolved && strlen(resolved) >= 16))
    return vf_error_set(VF_EINVAL, "%s: job %llu: a time, the stop reason or the resolved algorithm is malformed",
                        state_path, (unsigned long long)id);
  char path[4096];
  uint8_t *scene;
  size_t scene_len;
  if ((err = path_of(path, sizeof path, dir, "job-", id, ".scene")) != VF_OK ||
      (err = vf_file_read_all(path, VF_JOB_MAX_SCENE, &scene, &scene_len)) != VF_OK)
    return err;
  double time_limit, target_rmse, target_error, seconds;
  const cJSON *has_reference = cJSON_GetObjectItemCaseSensitive(o, "reference");
  if (!get_nonneg(o, "time_limit", &time_limit) || !get_nonneg(o, "target_rmse", &target_rmse) ||
      !get_nonneg(o, "target_error", &target_error) || !get_nonneg(o, "seconds", &seconds) ||
      (has_reference != NULL && !cJSON_IsBool(has_reference))) {
    free(scene);
    return vf_error_set(VF_EINVAL, "%s: job %llu: a stop condition is malformed", state_path, (unsigned long long)id);
  }
  int priority = (int)pr->valuedouble;
  if (format == 1 && priority < 1) priority = 1; /* format 1: "higher first", any integer */
  /* A name saved by a build that took any bytes: shown with '?' rather than refused, which
   * would keep the coordinator from starting */
  char fit_name[VF_JOB_MAX_NAME + 1];
  snprintf(fit_name, sizeof fit_name, "%s", name);
  vf_utf8_sanitize(fit_name);
  name = fit_name;
  vf_job *job;
  err = vf_job_create(id, name, priority, cJSON_IsTrue(builtin), (const char *)scene, scene_len, hash, 32, settings,
                      first, iterations, &job);
  free(scene);
  const char *scene_path = get_str(o, "scene_path");
  if (err == VF_OK && scene_path && (err = vf_job_set_scene_path(job, scene_path)) != VF_OK) vf_job_destroy(job);
  if (err != VF_OK) return vf_error_set(err, "%s: job %llu: %s", state_path, (unsigned long long)id, vf_error_detail(err));
  job->end = strcmp(end, "cancelled") == 0 ? VF_JOB_CANCELLED
             : strcmp(end, "failed") == 0  ? VF_JOB_FAILED
             : strcmp(end, "stopped") == 0 ? VF_JOB_STOPPED
                                           : VF_JOB_ACTIVE;
  snprintf(job->message, sizeof job->message, "%s", message);
  job->seconds = job->seconds_saved = seconds;
  job->submitted_at = times[0];
  job->started_at = times[1];
  job->ended_at = times[2];
  if (resolved) snprintf(job->algorithm_resolved, sizeof job->algorithm_resolved, "%s", resolved);
  if (!load_events(o, job)) {
    err = vf_error_set(VF_EINVAL, "%s: job %llu: an event is malformed", state_path, (unsigned long long)id);
    goto destroy_job;
  }
  if ((err = load_poison(job, o, state_path)) != VF_OK || (err = load_job_model(job, o, state_path)) != VF_OK)
    goto destroy_job;
  vf_film *film = NULL;
  int failed_now = 0;
  /* The files of a JSON scene (absent: it names none); their blobs stay in DIR/blobs. */
  if ((err = path_of(path, sizeof path, dir, "job-", id, ".files")) != VF_OK) goto destroy_job;
  if ((err = vf_blob_table_load(path, &job->files)) == VF_ENOENT) err = VF_OK;
  if (err != VF_OK) goto destroy_job;
  if (cJSON_IsTrue(has_reference)) {
    if ((err = path_of(path, sizeof path, dir, "job-", id, ".reference.exr")) != VF_OK ||
        (err = vf_job_load_reference(job, path)) != VF_OK)
      goto destroy_job;
  }
  if ((err = vf_job_set_stop(job, time_limit, target_rmse, target_error)) != VF_OK) {
    err = vf_error_set(err, "%s: job %llu: %s", state_path, (unsigned long long)id, vf_error_detail(err));
    goto destroy_job;
  }
  if ((err = path_of(path, sizeof path, dir, "job-", id, ".exr")) != VF_OK) goto destroy_job;
  err = vf_film_read(path, &film);
  if (err == VF_OK && (err = film->pilot ? vf_error_set(VF_EMISMATCH, "it is a pilot's film, not an image")
                                         : vf_job_check_film(job, film)) != VF_OK) {
    err = vf_error_set(VF_EFILM, "%s: does not belong to job %llu: %s", path, (unsigned long long)id,
                       vf_error_detail(err));
    vf_film_destroy(film);
    film = NULL;
  }
  if (err == VF_ENOENT) {
    err = VF_OK;
  } else if (err != VF_OK) {
    /* One job's film unreadable (truncated, damaged, or extended past the job's range by
     * a `continue` while we were down): that job comes up failed, saying why, and its file
     * is left as it is, never written over; the farm's other jobs run. */
    failed_now = unreadable_film(farm, job, err);
    err = VF_OK;
  } else {
    vf_film_destroy(job->film);
    job->film = film;
  }
  /* The reason as saved, while the film agrees: a job complete by iterations whose final
   * film had not landed resumes from the last one, not complete. */
  job->stop = stop_name ? (vf_stop_reason)vf_stop_reason_parse(stop_name) : derived_stop(job);
  if (job->end == VF_JOB_ACTIVE && !vf_job_complete(job)) job->stop = VF_STOP_NONE, job->ended_at = 0.0;
  if (failed_now) job->stop = VF_STOP_FAILED;
  vf_job_restore_measure(job);
  if ((err = vf_farm_add_job(farm, job)) != VF_OK) goto destroy_job;
  restore_blocks(farm, id, o);
  load_pilot(farm, job);
  vf_log("resumed job %llu '%s': %llu/%llu iterations done%s%s", (unsigned long long)id, job->name,
         (unsigned long long)vf_job_done(job), (unsigned long long)iterations, job->end != VF_JOB_ACTIVE ? ", " : "",
         job->end != VF_JOB_ACTIVE ? end_name(job->end) : "");
  return VF_OK;
destroy_job:
  vf_job_destroy(job);
  return err;
}

int vf_state_load(vf_farm *farm) {
  /* Blob transfers cut short by the last run (common/blob.h): the lock is ours, nobody
   * else writes them. */
  vf_blob_store_clean_parts(farm->config.state_dir, 0.0);
  char path[4096];
  int err = path_of(path, sizeof path, farm->config.state_dir, "state.json", 0, "");
  if (err != VF_OK) return err;
  uint8_t *text;
  size_t len;
  if ((err = vf_file_read_all(path, MAX_STATE_BYTES, &text, &len)) == VF_ENOENT) return VF_OK;
  if (err != VF_OK) return err;
  cJSON *root = cJSON_ParseWithLength((const char *)text, len);
  free(text);
  if (root == NULL) return vf_error_set(VF_EINVAL, "%s: not valid JSON", path);
  uint64_t format = 0, next_id = 0;
  const cJSON *jobs = cJSON_GetObjectItemCaseSensitive(root, "jobs"), *o;
  if ((err = get_u64(root, "format", 1000, &format, path)) != VF_OK) goto done;
  if (format < 1 || format > STATE_FORMAT) {
    err = vf_error_set(VF_EINVAL, "%s: state format %llu, this coordinator reads 1 to %d", path,
                       (unsigned long long)format, STATE_FORMAT);
    goto done;
  }
  if ((err = get_u64(root, "next_job_id", (1ull << 53), &next_id, path)) != VF_OK) goto done;
  if (!cJSON_IsArray(jobs)) {
    err = vf_error_set(VF_EINVAL, "%s: \"jobs\" is not an array", path);
    goto done;
  }
  cJSON_ArrayForEach(o, jobs) {
    if ((err = load_job(farm, o, path, format)) != VF_OK) goto done;
    if (farm->jobs[farm->num_jobs - 1]->id >= next_id) next_id = farm->jobs[farm->num_jobs - 1]->id + 1;
  }
  farm->next_job_id = next_id < 1 ? 1 : next_id;
done:
  cJSON_Delete(root);
  return err;
}

/* mkdir -p: each missing component of dir, 0700. */
static int make_dirs(const char *dir) {
  char path[4096];
  if (snprintf(path, sizeof path, "%s", dir) >= (int)sizeof path)
    return vf_error_set(VF_EINVAL, "%s: state directory path too long", dir);
  for (char *c = path + 1;; c++) {
    if (*c != '/' && *c != '\0') continue;
    char kept = *c;
    *c = '\0';
    if (mkdir(path, 0700) != 0 && errno != EEXIST) return vf_error_set(VF_EIO, "%s: %s", path, strerror(errno));
    if ((*c = kept) == '\0') return VF_OK;
  }
}

int vf_state_recreate(vf_farm *farm) {
  const char *dir = farm->config.state_dir;
  struct stat st;
  /* Deleted: the path is gone. Emptied (its files deleted, or the directory deleted and made
   * again by someone else, or a deletion that lost a race with a file being written and left
   * the directory behind): the held lock file has no name any more. */
  int deleted = stat(dir, &st) != 0 && errno == ENOENT;
  int emptied = !deleted && farm->state_lock_fd >= 0 && fstat(farm->state_lock_fd, &st) == 0 && st.st_nlink == 0;
  if (!deleted && !emptied) return 0;
  int err = make_dirs(dir), lock_fd = -1;
  if (err == VF_OK) err = vf_state_lock(dir, &lock_fd);
  if (err != VF_OK) {
    vf_log("the state directory %s is %s and cannot be made again: %s; the jobs' films stay in memory, retried at "
           "the next checkpoint", dir, deleted ? "gone" : "emptied", vf_error_detail(err));
    return err;
  }
  if (farm->state_lock_fd >= 0) close(farm->state_lock_fd);
  farm->state_lock_fd = lock_fd;
  vf_log("the state directory %s was %s: made again; every job's scene, reference, film and the job list are "
         "written again", dir, deleted ? "deleted" : "emptied");
  for (size_t i = 0; i < farm->num_jobs; i++) {
    vf_job *job = farm->jobs[i];
    char path[4096];
    if ((err = vf_state_save_scene(dir, job)) != VF_OK)
      vf_log("job %llu: its scene cannot be written again: %s", (unsigned long long)job->id, vf_error_detail(err));
    if (job->reference.rgb != NULL && path_of(path, sizeof path, dir, "job-", job->id, ".reference.exr") == VF_OK &&
        (err = vf_image_write_exr(path, &job->reference)) != VF_OK)
      vf_log("job %llu: its reference cannot be written again: %s", (unsigned long long)job->id, vf_error_detail(err));
    if (job->files.count > 0)
      vf_log("job %llu: the blobs of its scene's %zu files went with the directory: workers render it from their "
             "caches; submit the scene again if one cannot", (unsigned long long)job->id, job->files.count);
    if (!job->film_unreadable) job->film_dirty = 1;
    job->pilot_dirty = job->pilot_film != NULL;
    /* The allocation is in memory: its blob is made again for the workers that lack it. */
    if ((err = vf_blobs_put_allocation(farm, job)) != VF_OK) vf_log("%s", vf_error_detail(err));
  }
  farm->state_dirty = 1;
  return 1;
}
