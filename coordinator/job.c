#include "job.h"

#include "../common/allocation.h"
#include "../common/blob.h"
#include "../common/clock.h"
#include "../common/error.h"
#include "../common/metrics.h"
#include "../common/parse.h"
#include "schedule.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int check_name(const char *name) {
  size_t n = strlen(name);
  if (n > VF_JOB_MAX_NAME) return vf_error_set(VF_EINVAL, "job name: %zu bytes, at most %d", n, VF_JOB_MAX_NAME);
  for (size_t i = 0; i < n; i++)
    if ((unsigned char)name[i] < 0x20 || name[i] == 0x7f)
      return vf_error_set(VF_EINVAL, "job name: control character at byte %zu", i);
  /* status --json carries it: one name that is not UTF-8 would make the whole farm's JSON
   * invalid */
  if (!vf_utf8_valid(name, n)) return vf_error_set(VF_EINVAL, "job name: not valid UTF-8");
  return VF_OK;
}

static int check_builtin_name(const char *text, size_t len) {
  if (len == 0 || len > 63) return vf_error_set(VF_EINVAL, "scene: built-in name of %zu bytes", len);
  for (size_t i = 0; i < len; i++) {
    char c = text[i];
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' || c == '_'))
      return vf_error_set(VF_EINVAL, "scene: built-in name with character %d at byte %zu", c, i);
  }
  return VF_OK;
}

int vf_job_create(uint64_t id, const char *name, int priority, int scene_builtin, const char *scene_text,
                  size_t scene_len, const uint8_t *scene_hash, size_t hash_len, const char *settings_text,
                  uint64_t first, uint64_t iterations, vf_job **out) {
  int err;
  if ((err = check_name(name)) != VF_OK) return err;
  if (scene_builtin && (err = check_builtin_name(scene_text, scene_len)) != VF_OK) return err;
  if (!scene_builtin && (scene_len == 0 || scene_len > VF_JOB_MAX_SCENE))
    return vf_error_set(VF_EINVAL, "scene: JSON text of %zu bytes, must be 1 to %zu", scene_len, VF_JOB_MAX_SCENE);
  if (memchr(scene_text, '\0', scene_len) != NULL) return vf_error_set(VF_EINVAL, "scene: text contains a NUL byte");
  if (hash_len != 32) return vf_error_set(VF_EINVAL, "scene_hash: %zu bytes, expected 32", hash_len);
  if (priority < VF_PRIORITY_MIN || priority > VF_PRIORITY_MAX)
    return vf_error_set(VF_EINVAL, "priority: %d, must be %d to %d", priority, VF_PRIORITY_MIN, VF_PRIORITY_MAX);
  if (iterations < 1 || iterations > VF_JOB_MAX_ITERATIONS)
    return vf_error_set(VF_EINVAL, "iterations: %llu, must be 1 to %llu", (unsigned long long)iterations,
                        VF_JOB_MAX_ITERATIONS);
  if (first > VF_JOB_MAX_FIRST)
    return vf_error_set(VF_EINVAL, "first_iteration: %llu, must be at most 2^53", (unsigned long long)first);
  vf_settings settings;
  char canonical[512];
  if (strlen(settings_text) >= sizeof canonical)
    return vf_error_set(VF_EINVAL, "settings: text longer than %zu bytes", sizeof canonical - 1);
  if ((err = vf_settings_parse(&settings, settings_text)) != VF_OK ||
      (err = vf_settings_validate(&settings)) != VF_OK)
    return vf_error_set(VF_EINVAL, "settings: %s", vf_error_detail(err));
  if (vf_settings_format(&settings, canonical, sizeof canonical) != VF_OK || strcmp(canonical, settings_text) != 0)
    return vf_error_set(VF_EINVAL, "settings: '%s' is not in canonical form ('%s')", settings_text, canonical);
  vf_job *job = calloc(1, sizeof *job);
  if (job == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  if ((job->scene_text = malloc(scene_len + 1)) == NULL) {
    err = vf_error_set(VF_ENOMEM, "out of memory for the scene text");
    goto free_job;
  }
  memcpy(job->scene_text, scene_text, scene_len);
  job->scene_text[scene_len] = '\0';
  if ((err = vf_film_create(settings.width, settings.height, &job->film)) != VF_OK) goto free_text;
  memcpy(job->film->scene_hash, scene_hash, 32);
  snprintf(job->film->settings_text, sizeof job->film->settings_text, "%s", canonical);
  if (scene_builtin) snprintf(job->film->scene_name, sizeof job->film->scene_name, "%s", job->scene_text);
  if (settings.pilot > 0) {
    if ((err = vf_film_clone(job->film, &job->pilot_film)) != VF_OK) goto free_film;
    job->pilot_film->pilot = 1;
  }
  job->id = id;
  snprintf(job->name, sizeof job->name, "%s", name);
  job->priority = priority;
  job->scene_builtin = scene_builtin;
  memcpy(job->scene_hash, scene_hash, 32);
  snprintf(job->settings_text, sizeof job->settings_text, "%s", canonical);
  job->settings = settings;
  job->first = first;
  job->iterations = iterations;
  job->measured_iterations = job->logged_iterations = UINT64_MAX;
  vf_events_init(&job->events, job->events_storage, VF_JOB_EVENTS);
  *out = job;
  return VF_OK;
free_film:
  vf_film_destroy(job->film);
free_text:
  free(job->scene_text);
free_job:
  free(job);
  return err;
}

int vf_job_set_scene_path(vf_job *job, const char *path) {
  size_t n = strlen(path);
  if (n == 0 || job->scene_builtin) return VF_OK;
  if (n >= sizeof job->film->scene_name)
    return vf_error_set(VF_EINVAL, "scene_path: %zu bytes, at most %zu", n, sizeof job->film->scene_name - 1);
  for (size_t i = 0; i < n; i++)
    if ((unsigned char)path[i] < 0x20 || path[i] == 0x7f)
      return vf_error_set(VF_EINVAL, "scene_path: control character at byte %zu", i);
  if (!vf_utf8_valid(path, n))
    return vf_error_set(VF_EINVAL, "scene_path: not valid UTF-8 (a film's attributes must be)");
  memcpy(job->film->scene_name, path, n + 1);
  return VF_OK;
}

void vf_job_destroy(vf_job *job) {
  if (job == NULL) return;
  vf_film_destroy(job->film);
  vf_film_destroy(job->pilot_film);
  vf_image_destroy(&job->reference);
  free(job->scene_text);
  vf_blob_table_clear(&job->files);
  free(job);
}

uint64_t vf_job_done(const vf_job *job) { return vf_iterset_count(&job->film->iterations); }

int vf_job_complete(const vf_job *job) { return job->end == VF_JOB_STOPPED || vf_job_done(job) >= job->iterations; }

int vf_job_set_requires(vf_job *job, char *const *tags, size_t count) {
  vf_tags requires;
  vf_tags_init(&requires);
  if (count > VF_TAGS_MAX) {
    vf_tags_init(&job->requires);
    return vf_error_set(VF_EINVAL, "requires: %zu tags, at most %d", count, VF_TAGS_MAX);
  }
  for (size_t i = 0; i < count; i++) {
    int err = tags[i] ? vf_tags_add("requires", &requires, tags[i], strlen(tags[i]), 1)
                      : vf_error_set(VF_EINVAL, "requires: tag %zu missing", i);
    if (err != VF_OK) {
      vf_tags_init(&job->requires);
      return err;
    }
  }
  job->requires = requires;
  return VF_OK;
}

int vf_job_runnable(const vf_job *job) { return job->end == VF_JOB_ACTIVE && !vf_job_complete(job); }

const char *vf_job_state(const vf_job *job, uint64_t leased) {
  if (job->end == VF_JOB_CANCELLED) return "cancelled";
  if (job->end == VF_JOB_FAILED) return "failed";
  /* Done only once its final film is durable (coordinator/checkpoint.h): until then a
   * crash would bring it back short of what it merged. */
  if (vf_job_complete(job)) return job->final_pending ? "running" : "done";
  if (job->paused) return "paused";
  return vf_job_done(job) > 0 || leased > 0 ? "running" : "queued";
}

int vf_job_check_film(const vf_job *job, const vf_film *film) {
  if (film->width != job->film->width || film->height != job->film->height)
    return vf_error_set(VF_EMISMATCH, "film is %dx%d, job %llu is %dx%d", film->width, film->height,
                        (unsigned long long)job->id, job->film->width, job->film->height);
  if (memcmp(film->scene_hash, job->scene_hash, 32) != 0)
    return vf_error_set(VF_EMISMATCH, "film's scene hash differs from job %llu's", (unsigned long long)job->id);
  if (strcmp(film->settings_text, job->settings_text) != 0)
    return vf_error_set(VF_EMISMATCH, "film's settings '%s' differ from job %llu's '%s'", film->settings_text,
                        (unsigned long long)job->id, job->settings_text);
  const vf_iterset *set = &film->iterations;
  if (film->pilot) {
    if (job->settings.pilot == 0)
      return vf_error_set(VF_EMISMATCH, "a pilot's film, but job %llu has no pilot", (unsigned long long)job->id);
    if (set->count > 0 && set->ranges[set->count - 1].end > (uint64_t)job->settings.pilot)
      return vf_error_set(VF_EMISMATCH, "pilot film holds iterations outside job %llu's pilot [0,%d)",
                          (unsigned long long)job->id, job->settings.pilot);
    return VF_OK;
  }
  if (set->count > 0 && (set->ranges[0].begin < job->first || set->ranges[set->count - 1].end > job->first + job->iterations))
    return vf_error_set(VF_EMISMATCH, "film holds iterations outside job %llu's [%llu,%llu)", (unsigned long long)job->id,
                        (unsigned long long)job->first, (unsigned long long)(job->first + job->iterations));
  return VF_OK;
}

int vf_job_check_result(const vf_job *job, const vf_film *film, uint64_t begin, uint64_t end) {
  int err = vf_job_check_film(job, film);
  if (err != VF_OK) return err;
  const vf_iterset *set = &film->iterations;
  if (set->count != 1 || set->ranges[0].begin != begin || set->ranges[0].end != end) {
    char text[128];
    if (vf_iterset_format(set, text, sizeof text) != VF_OK) snprintf(text, sizeof text, "(many ranges)");
    return vf_error_set(VF_EMISMATCH, "film holds iterations %s, the result claims [%llu,%llu)", text,
                        (unsigned long long)begin, (unsigned long long)end);
  }
  return VF_OK;
}

static void merged(vf_job *job, const vf_film *film, double now);

int vf_job_in_pilot(const vf_job *job) { return job->settings.pilot > 0 && job->film->samples == NULL; }

uint64_t vf_job_pilot_done(const vf_job *job) {
  if (job->settings.pilot == 0) return 0;
  return job->film->samples != NULL || job->pilot_film == NULL ? (uint64_t)job->settings.pilot
                                                              : vf_iterset_count(&job->pilot_film->iterations);
}

int vf_job_merge_pilot(vf_job *job, const vf_film *film) {
  if (!vf_job_in_pilot(job) || job->pilot_film == NULL)
    return vf_error_set(VF_EINVAL, "job %llu's pilot is done: its allocation is computed", (unsigned long long)job->id);
  int err = vf_film_merge(job->pilot_film, film);
  if (err == VF_OK) job->pilot_dirty = 1;
  return err;
}

int vf_job_merge_pilot_deferred(vf_job *job, const vf_film *film) {
  if (!vf_job_in_pilot(job) || job->pilot_film == NULL)
    return vf_error_set(VF_EINVAL, "job %llu's pilot is done: its allocation is computed", (unsigned long long)job->id);
  int err = vf_film_merge_metadata(job->pilot_film, film);
  if (err != VF_OK) return err;
  job->pilot_merging++;
  job->pilot_dirty = 1;
  return VF_OK;
}

int vf_job_pilot_complete(const vf_job *job) {
  return vf_job_in_pilot(job) && job->pilot_film != NULL &&
         vf_iterset_count(&job->pilot_film->iterations) >= (uint64_t)job->settings.pilot;
}

int vf_job_finish_pilot(vf_job *job) {
  if (!vf_job_pilot_complete(job)) return 0;
  size_t pixels = (size_t)job->film->width * (size_t)job->film->height;
  uint8_t *samples = malloc(pixels);
  if (samples == NULL)
    return vf_error_set(VF_ENOMEM, "out of memory for job %llu's allocation", (unsigned long long)job->id);
  /* The pilot's film is no image (film->pilot): vf_allocation_compute reads it as the local
   * render's pilot, a film of [0, pilot) of the job's settings. */
  int err = vf_allocation_compute(job->pilot_film, samples, NULL);
  if (err == VF_OK) err = vf_job_set_allocation(job, samples);
  free(samples);
  return err;
}

int vf_job_set_allocation(vf_job *job, const uint8_t *samples) {
  int err = vf_film_set_samples(job->film, samples);
  if (err != VF_OK) return err;
  vf_job_allocation_loaded(job);
  /* The job's film carries what its pilot cost, as vf_render_pilot's does. */
  job->film->render_seconds += job->pilot_film->render_seconds;
  job->film->cpu_seconds += job->pilot_film->cpu_seconds;
  vf_film_destroy(job->pilot_film);
  job->pilot_film = NULL;
  job->pilot_dirty = 0;
  job->film_dirty = 1;
  job->film_generation++;
  return 1;
}

int vf_job_allocation_allowed(const vf_job *job) {
  if (job->settings.pilot == 0)
    return vf_error_set(VF_EINVAL, "allocation: the job's settings have no pilot (pilot=N): an allocation of camera "
                        "sub-paths is what a pilot decides, and only a job with one renders with it");
  if (vf_settings_choose_by_pilots(&job->settings))
    return vf_error_set(VF_EINVAL, "allocation: the job's algorithm is auto with a pilot, which chooses the algorithm "
                        "by rendering pilots: name the algorithm the allocation is for");
  return VF_OK;
}

int vf_job_submit_allocation(vf_job *job, const uint8_t *samples) {
  int err = vf_job_allocation_allowed(job);
  if (err != VF_OK) return err;
  if (!vf_job_in_pilot(job) || job->pilot_film == NULL)
    return vf_error_set(VF_EINVAL, "allocation: job %llu has one already", (unsigned long long)job->id);
  size_t pixels = (size_t)job->film->width * (size_t)job->film->height;
  if ((err = vf_allocation_check_algorithm(samples, pixels, job->settings.algorithm, "allocation")) != VF_OK) return err;
  err = vf_job_set_allocation(job, samples); /* an empty pilot film: no times to add */
  return err < 0 ? err : VF_OK;
}

void vf_job_allocation_loaded(vf_job *job) {
  if (job->film->samples == NULL) return;
  size_t pixels = (size_t)job->film->width * (size_t)job->film->height;
  vf_blob_hash(job->film->samples, pixels, job->allocation_hash);
  vf_allocation_report a;
  vf_allocation_describe(job->film->samples, pixels, &a);
  vf_allocation_summary(&a, job->allocation_summary, sizeof job->allocation_summary);
}

int vf_job_restore_pilot(vf_job *job, vf_film *pilot) {
  if (!pilot->pilot) return vf_error_set(VF_EMISMATCH, "not a pilot's film");
  if (!vf_job_in_pilot(job))
    return vf_error_set(VF_EMISMATCH, "job %llu is not in its pilot", (unsigned long long)job->id);
  int err = vf_job_check_film(job, pilot);
  if (err != VF_OK) return err;
  vf_film_destroy(job->pilot_film);
  job->pilot_film = pilot;
  return VF_OK;
}

int vf_job_merge(vf_job *job, const vf_film *film, double now) {
  int err = vf_film_merge(job->film, film);
  if (err != VF_OK) return err;
  merged(job, film, now);
  return VF_OK;
}

int vf_job_merge_deferred(vf_job *job, const vf_film *film, double now) {
  int err = vf_film_merge_metadata(job->film, film);
  if (err != VF_OK) return err;
  job->merging++;
  merged(job, film, now);
  return VF_OK;
}

static void merged(vf_job *job, const vf_film *film, double now) {
  job->lease_failures = job->failed_workers_count = 0; /* progress: not a poison job */
  job->film_dirty = 1;
  job->film_generation++;
  job->merges[job->merges_next].time = now;
  job->merges[job->merges_next].iterations = vf_iterset_count(&film->iterations);
  job->merges_next = (job->merges_next + 1) % VF_JOB_RATE_SAMPLES;
  if (job->merges_count < VF_JOB_RATE_SAMPLES) job->merges_count++;
  if (film->render_seconds > 0.0) {
    double r = (double)vf_iterset_count(&film->iterations) / film->render_seconds;
    job->rate = job->rate > 0.0 ? 0.7 * job->rate + 0.3 * r : r;
  }
  job->last_merge_time = now;
}

int vf_job_set_stop(vf_job *job, double time_limit, double target_rmse, double target_error) {
  const struct {
    const char *name;
    double value, max;
  } fields[] = {{"time_limit", time_limit, 366.0 * 86400.0}, {"target_rmse", target_rmse, 1e30},
                {"target_error", target_error, 1e30}};
  for (size_t i = 0; i < sizeof fields / sizeof *fields; i++)
    if (!(fields[i].value >= 0.0 && fields[i].value <= fields[i].max))
      return vf_error_set(VF_EINVAL, "%s: %g, must be 0 (none) or positive, at most %g", fields[i].name,
                          fields[i].value, fields[i].max);
  if (target_rmse > 0.0 && job->reference.rgb == NULL)
    return vf_error_set(VF_EINVAL, "target_rmse: needs a reference image");
  job->time_limit = time_limit;
  job->target_rmse = target_rmse;
  job->target_error = target_error;
  return VF_OK;
}

int vf_job_load_reference(vf_job *job, const char *path) {
  vf_image img = {0};
  int err = vf_image_read_exr(path, &img);
  if (err != VF_OK) return err;
  if (img.width != job->film->width || img.height != job->film->height) {
    err = vf_error_set(VF_EMISMATCH, "reference is %dx%d, job %llu renders %dx%d", img.width, img.height,
                       (unsigned long long)job->id, job->film->width, job->film->height);
    vf_image_destroy(&img);
    return err;
  }
  vf_image_destroy(&job->reference);
  job->reference = img;
  return VF_OK;
}

int vf_job_measure(vf_job *job) {
  if (job->merging > 0) return VF_OK; /* its pixels are being added to: the last measurement stands */
  const vf_film *film = job->film;
  uint64_t n = vf_job_done(job);
  vf_convergence_entry e = {0, film->render_seconds, film->cpu_seconds, n, NAN, NAN, vf_film_estimate_rmse(film)};
  if (job->reference.rgb != NULL && n > 0) {
    size_t count = 3 * (size_t)film->width * (size_t)film->height;
    float *mean = malloc(count * sizeof *mean);
    if (mean == NULL) return vf_error_set(VF_ENOMEM, "out of memory measuring job %llu", (unsigned long long)job->id);
    vf_film_mean(film, mean);
    vf_error_metrics m;
    if (vf_metrics_compute(mean, job->reference.rgb, film->width, film->height, NULL, &m) == VF_OK && m.pixels > 0) {
      e.rmse = m.rmse_all;
      e.rel_mse = m.rel_mse_all;
    }
    free(mean);
  }
  job->measured = e;
  job->measured_iterations = n;
  return VF_OK;
}

int vf_job_log(vf_job *job) {
  uint64_t n = vf_job_done(job);
  if (n == 0 || n == job->logged_iterations || job->merging > 0) return VF_OK; /* merging: the next one logs */
  const vf_convergence_log *log = &job->film->convergence;
  if (log->count > 0 && log->entries[log->count - 1].iterations == n) {
    job->logged_iterations = n;
    return VF_OK;
  }
  int err;
  if (job->measured_iterations != n && (err = vf_job_measure(job)) != VF_OK) return err;
  vf_convergence_entry e = job->measured;
  e.run = log->count > 0 ? log->entries[log->count - 1].run : 0;
  if ((err = vf_convergence_append(&job->film->convergence, &e)) != VF_OK) return err;
  job->logged_iterations = n;
  job->film_dirty = 1;
  job->film_generation++;
  return VF_OK;
}

void vf_job_finish(vf_job *job, vf_stop_reason why, double at, const char *message) {
  if (job->stop != VF_STOP_NONE) return;
  job->stop = why;
  job->ended_at = at;
  if (why == VF_STOP_CANCELLED) job->end = VF_JOB_CANCELLED;
  else if (why == VF_STOP_FAILED) job->end = VF_JOB_FAILED;
  else if (why != VF_STOP_ITERATIONS) job->end = VF_JOB_STOPPED;
  if (message) {
    snprintf(job->message, sizeof job->message, "%s", message);
    for (char *c = job->message; *c; c++)
      if ((unsigned char)*c < 0x20) *c = '?';
  }
}

void vf_job_restore_measure(vf_job *job) {
  const vf_convergence_log *log = &job->film->convergence;
  uint64_t n = vf_job_done(job);
  if (log->count == 0 || log->entries[log->count - 1].iterations != n) return;
  job->measured = log->entries[log->count - 1];
  job->measured_iterations = job->logged_iterations = n;
}

int vf_job_check_stop(vf_job *job) {
  if (job->end != VF_JOB_ACTIVE || vf_job_complete(job)) return 0;
  char text[256];
  if (job->time_limit > 0.0 && job->seconds >= job->time_limit && job->time_up) {
    snprintf(text, sizeof text, "time limit of %g s reached", job->time_limit);
    vf_job_finish(job, VF_STOP_TIME, vf_unix_now(), text);
    return 1;
  }
  if (job->target_rmse <= 0.0 && job->target_error <= 0.0) return 0;
  if (job->merging > 0) return 0; /* tested again when the addition lands */
  uint64_t n = vf_job_done(job);
  int err;
  if (job->measured_iterations != n && (err = vf_job_measure(job)) != VF_OK) return err;
  const vf_convergence_entry *e = &job->measured;
  if (job->target_rmse > 0.0 && e->rmse <= job->target_rmse) {
    snprintf(text, sizeof text, "target RMSE %g reached: %.6g at %llu iterations", job->target_rmse, e->rmse,
             (unsigned long long)n);
    vf_job_finish(job, VF_STOP_TARGET_RMSE, vf_unix_now(), text);
    return 1;
  }
  if (job->target_error > 0.0 && e->estimated_rmse <= job->target_error) {
    snprintf(text, sizeof text, "target estimated error %g reached: %.6g at %llu iterations", job->target_error,
             e->estimated_rmse, (unsigned long long)n);
    vf_job_finish(job, VF_STOP_TARGET_ERROR, vf_unix_now(), text);
    return 1;
  }
  return 0;
}

double vf_job_farm_rate(const vf_job *job, double now, double window) {
  uint64_t iterations = 0;
  double oldest = now;
  for (unsigned i = 0; i < job->merges_count; i++) {
    if (now - job->merges[i].time > window) continue;
    iterations += job->merges[i].iterations;
    if (job->merges[i].time < oldest) oldest = job->merges[i].time;
  }
  /* The span covers the whole window, or the job's running time when shorter: merges come
   * in bursts, and the burst itself is no measure of the time it took. */
  double span = job->seconds < window ? job->seconds : window;
  if (span < now - oldest) span = now - oldest;
  return iterations > 0 && span > 0.0 ? (double)iterations / span : 0.0;
}

/* The error measurements of the job: its convergence log's latest entries, then its latest
 * measurement when newer; `rmse` picks which error. Returns how many (at most max). */
static size_t error_points(const vf_job *job, int rmse, vf_error_point *p, size_t max) {
  const vf_convergence_log *log = &job->film->convergence;
  size_t n = 0, first = log->count > max - 1 ? log->count - (max - 1) : 0;
  for (size_t i = first; i < log->count; i++)
    p[n++] = (vf_error_point){log->entries[i].iterations,
                              rmse ? log->entries[i].rmse : log->entries[i].estimated_rmse};
  if (job->measured_iterations != UINT64_MAX && (n == 0 || p[n - 1].iterations < job->measured_iterations))
    p[n++] = (vf_error_point){job->measured_iterations, rmse ? job->measured.rmse : job->measured.estimated_rmse};
  return n;
}

void vf_job_forecast(const vf_job *job, double rate, vf_forecast *out) {
  if (job->end != VF_JOB_ACTIVE || vf_job_complete(job)) {
    *out = (vf_forecast){job->stop != VF_STOP_NONE ? job->stop : VF_STOP_ITERATIONS, 1.0, 0.0, 0.0};
    return;
  }
  vf_error_point rmse_log[VF_FORECAST_POINTS + 1], estimated_log[VF_FORECAST_POINTS + 1];
  int others = job->time_limit > 0.0 || job->target_rmse > 0.0 || job->target_error > 0.0;
  int measured = job->measured_iterations != UINT64_MAX;
  vf_forecast_input in = {
      .done = vf_job_done(job),
      .iterations = job->iterations >= VF_JOB_MAX_ITERATIONS && others ? 0 : job->iterations,
      .seconds = job->seconds,
      .time_limit = job->time_limit,
      .rate = rate,
      .target_rmse = job->target_rmse,
      .rmse = measured ? job->measured.rmse : NAN,
      .rmse_log = rmse_log,
      .rmse_count = error_points(job, 1, rmse_log, VF_FORECAST_POINTS + 1),
      .target_error = job->target_error,
      .estimated_rmse = measured ? job->measured.estimated_rmse : NAN,
      .estimated_log = estimated_log,
      .estimated_count = error_points(job, 0, estimated_log, VF_FORECAST_POINTS + 1),
  };
  vf_forecast_compute(&in, out);
}
