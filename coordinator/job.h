/* A job of the farm: a scene, its settings, the stop condition (global iterations
 * [0, iterations)), a priority, and the film the accepted results have been merged into.
 *
 * The film is the truth about progress: an iteration is done exactly when it is in the
 * film's iteration set, and vf_film_merge refusing overlap is what makes a result count
 * once however often it arrives. The coordinator's modules share the struct. */
#ifndef VF_JOB_H
#define VF_JOB_H

#include "../common/film.h"
#include "../common/settings.h"

#include <stddef.h>
#include <stdint.h>

#define VF_JOB_MAX_NAME 127
#define VF_JOB_MAX_SCENE ((size_t)16 << 20) /* bytes of JSON scene text */
#define VF_JOB_MAX_ITERATIONS 1000000000ull

typedef enum { VF_JOB_ACTIVE, VF_JOB_CANCELLED, VF_JOB_FAILED } vf_job_end;

typedef struct {
  uint64_t id;
  char name[VF_JOB_MAX_NAME + 1];
  int priority; /* higher first */
  int scene_builtin;    /* 1: scene_text is a built-in scene name; 0: JSON scene text */
  char *scene_text;     /* owned, NUL-terminated */
  uint8_t scene_hash[32];
  char settings_text[512];
  vf_settings settings;
  uint64_t iterations;  /* the job is done when the film holds [0, iterations) */
  vf_job_end end;       /* cancelled or failed, else active */
  char message[256];    /* why it failed */
  vf_film *film;        /* owned; every accepted result merged */
  int film_dirty;       /* merged into since the last checkpoint */
  uint64_t results_refused;
  double rate;          /* iterations per second of the farm on this job, smoothed; 0 unknown */
  double last_merge_time;
} vf_job;

/* Creates a job with an empty film stamped with scene hash and settings. Takes no
 * ownership: scene_text is copied. Checks every field as untrusted input (name length and
 * characters, built-in name syntax, scene size, canonical valid settings, iteration count)
 * and returns VF_EINVAL with a detail naming the field otherwise. *out on success only. */
int vf_job_create(uint64_t id, const char *name, int priority, int scene_builtin, const char *scene_text,
                  size_t scene_len, const uint8_t *scene_hash, size_t hash_len, const char *settings_text,
                  uint64_t iterations, vf_job **out);
void vf_job_destroy(vf_job *job);

/* "queued", "running", "done", "cancelled" or "failed"; `leased` is the number of
 * iterations currently leased out. */
const char *vf_job_state(const vf_job *job, uint64_t leased);
uint64_t vf_job_done(const vf_job *job);
int vf_job_complete(const vf_job *job);
/* Active and not complete: leases may be handed out. */
int vf_job_runnable(const vf_job *job);

/* Checks that a film belongs to the job: size, scene hash, settings, and iterations
 * within [0, iterations). VF_EMISMATCH with a detail. */
int vf_job_check_film(const vf_job *job, const vf_film *film);

/* Checks a result film against the job and the range [begin, end) it claims: size, scene
 * hash, settings and an iteration set of exactly that range. VF_EMISMATCH with a detail. */
int vf_job_check_result(const vf_job *job, const vf_film *film, uint64_t begin, uint64_t end);

/* Merges a checked result. VF_EOVERLAP (film unchanged) if any of its iterations is
 * already counted. */
int vf_job_merge(vf_job *job, const vf_film *film, double now);

#endif
