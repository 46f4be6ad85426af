#include "job.h"

#include "../common/error.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int check_name(const char *name) {
  size_t n = strlen(name);
  if (n > VF_JOB_MAX_NAME) return vf_error_set(VF_EINVAL, "job name: %zu bytes, at most %d", n, VF_JOB_MAX_NAME);
  for (size_t i = 0; i < n; i++)
    if ((unsigned char)name[i] < 0x20 || name[i] == 0x7f)
      return vf_error_set(VF_EINVAL, "job name: control character at byte %zu", i);
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
                  uint64_t iterations, vf_job **out) {
  int err;
  if ((err = check_name(name)) != VF_OK) return err;
  if (scene_builtin && (err = check_builtin_name(scene_text, scene_len)) != VF_OK) return err;
  if (!scene_builtin && (scene_len == 0 || scene_len > VF_JOB_MAX_SCENE))
    return vf_error_set(VF_EINVAL, "scene: JSON text of %zu bytes, must be 1 to %zu", scene_len, VF_JOB_MAX_SCENE);
  if (memchr(scene_text, '\0', scene_len) != NULL) return vf_error_set(VF_EINVAL, "scene: text contains a NUL byte");
  if (hash_len != 32) return vf_error_set(VF_EINVAL, "scene_hash: %zu bytes, expected 32", hash_len);
  if (iterations < 1 || iterations > VF_JOB_MAX_ITERATIONS)
    return vf_error_set(VF_EINVAL, "iterations: %llu, must be 1 to %llu", (unsigned long long)iterations,
                        VF_JOB_MAX_ITERATIONS);
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
  job->id = id;
  snprintf(job->name, sizeof job->name, "%s", name);
  job->priority = priority;
  job->scene_builtin = scene_builtin;
  memcpy(job->scene_hash, scene_hash, 32);
  snprintf(job->settings_text, sizeof job->settings_text, "%s", canonical);
  job->settings = settings;
  job->iterations = iterations;
  *out = job;
  return VF_OK;
free_text:
  free(job->scene_text);
free_job:
  free(job);
  return err;
}

void vf_job_destroy(vf_job *job) {
  if (job == NULL) return;
  vf_film_destroy(job->film);
  free(job->scene_text);
  free(job);
}

uint64_t vf_job_done(const vf_job *job) { return vf_iterset_count(&job->film->iterations); }

int vf_job_complete(const vf_job *job) { return vf_job_done(job) >= job->iterations; }

int vf_job_runnable(const vf_job *job) { return job->end == VF_JOB_ACTIVE && !vf_job_complete(job); }

const char *vf_job_state(const vf_job *job, uint64_t leased) {
  if (job->end == VF_JOB_CANCELLED) return "cancelled";
  if (job->end == VF_JOB_FAILED) return "failed";
  if (vf_job_complete(job)) return "done";
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
  if (set->count > 0 && set->ranges[set->count - 1].end > job->iterations)
    return vf_error_set(VF_EMISMATCH, "film holds iterations beyond job %llu's %llu", (unsigned long long)job->id,
                        (unsigned long long)job->iterations);
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

int vf_job_merge(vf_job *job, const vf_film *film, double now) {
  int err = vf_film_merge(job->film, film);
  if (err != VF_OK) return err;
  job->film_dirty = 1;
  if (film->render_seconds > 0.0) {
    double r = (double)vf_iterset_count(&film->iterations) / film->render_seconds;
    job->rate = job->rate > 0.0 ? 0.7 * job->rate + 0.3 * r : r;
  }
  job->last_merge_time = now;
  return VF_OK;
}
