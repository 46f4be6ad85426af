/* A job of the farm: a scene, its settings, its stop conditions (global iterations
 * [first, first + iterations), a time limit, a target RMSE against a reference, a target estimated
 * error), a priority (its weight, coordinator/schedule.h), and the film the accepted
 * results have been merged into, whose convergence log the coordinator extends.
 *
 * The film is the truth about progress: an iteration is done exactly when it is in the
 * film's iteration set, and vf_film_merge refusing overlap is what makes a result count
 * once however often it arrives. The coordinator's modules share the struct. */
#ifndef VF_JOB_H
#define VF_JOB_H

#include "../common/blob.h"
#include "../common/film.h"
#include "../common/forecast.h"
#include "../common/image.h"
#include "../common/settings.h"
#include "../common/tags.h"
#include "events.h"

#include <stddef.h>
#include <stdint.h>

#define VF_JOB_MAX_NAME 127
#define VF_JOB_MAX_SCENE ((size_t)16 << 20) /* bytes of JSON scene text */
#define VF_JOB_MAX_ITERATIONS 1000000000ull
#define VF_JOB_MAX_FIRST (1ull << 53) /* exact in state.json's numbers */

/* A job ends cancelled, failed, or stopped by its time limit or a target error (shown as
 * "done" with the reason); reaching its iterations needs no mark: the film says so. */
typedef enum { VF_JOB_ACTIVE, VF_JOB_CANCELLED, VF_JOB_FAILED, VF_JOB_STOPPED } vf_job_end;

/* Recent merges, for the job's rate. */
#define VF_JOB_RATE_SAMPLES 64
/* Failed leases in a row from this many distinct workers make a poison job fail
 * (coordinator/poison.h). */
#define VF_JOB_FAILED_WORKERS 3
/* Events kept per job (the latest; older ones are counted, coordinator/events.h). */
#define VF_JOB_EVENTS 32

typedef struct {
  uint64_t id;
  char name[VF_JOB_MAX_NAME + 1];
  int priority; /* weight, VF_PRIORITY_MIN..VF_PRIORITY_MAX (coordinator/schedule.h) */
  vf_tags requires; /* a worker is leased it only when it satisfies all (common/tags.h) */
  int paused;   /* no new leases; those outstanding finish and ship (vf_job_state "paused") */
  int scene_builtin;    /* 1: scene_text is a built-in scene name; 0: JSON scene text */
  char *scene_text;     /* owned, NUL-terminated */
  vf_blob_table files;  /* owned: the files a JSON scene names, by content hash; their
                         * bytes are in the state directory's blob store */
  uint8_t scene_hash[32];
  char settings_text[512];
  vf_settings settings;
  uint64_t first;       /* its first global iteration: 0, or where an earlier render stopped */
  uint64_t iterations;  /* the job is done when the film holds [first, first + iterations) */
  double time_limit;    /* > 0: stop after this many seconds of running */
  double target_rmse;   /* > 0: stop once the RMSE against the reference is at most this */
  double target_error;  /* > 0: stop once the estimated RMSE is at most this */
  vf_image reference;   /* owned; rgb NULL when the job has none */
  vf_job_end end;       /* cancelled, failed or stopped, else active */
  char message[256];    /* why it failed or stopped */
  vf_stop_reason stop;  /* why it ended, machine-readable (VF_STOP_NONE while active) */
  double submitted_at, started_at, ended_at; /* Unix seconds; 0 not yet (or unknown, older state) */
  char algorithm_resolved[16]; /* what `auto` resolves to for its scene, "" unknown */
  vf_events events;     /* what happened to it, over events_storage */
  vf_event events_storage[VF_JOB_EVENTS];
  vf_film *film;        /* owned; every accepted result merged */
  /* A job with a pilot (settings.pilot > 0, common/allocation.h) runs it first: until its
   * film has its allocation of camera sub-paths (film->samples) it is in its pilot phase
   * (vf_job_in_pilot), its leases are of the pilot's iterations [0, pilot) and their parts
   * merge into pilot_film, never into film. Once pilot_film holds [0, pilot), the
   * allocation is computed from it, once (vf_job_finish_pilot): a pure function of the
   * pilot's exact sums, so a coordinator that restarts during or after the pilot comes to
   * the same (coordinator/state.h keeps pilot_film and, in film's file, the allocation). */
  vf_film *pilot_film;  /* owned; NULL without a pilot and once the allocation is computed */
  int pilot_dirty;      /* pilot_film merged into since it was last written */
  /* With a merge thread, pilot parts and pilot_film's writes go through it as the film's
   * do: pilot_merging counts additions to pilot_film's pixels not landed yet, pilot_writing
   * a write in flight (its pixels borrowed), pilot_finishing the allocation being computed
   * from the complete pilot_film there. pilot_film is neither read on the loop nor dropped
   * while any is set; the allocation is computed once all have landed. */
  unsigned pilot_merging;
  int pilot_writing;
  int pilot_finishing;
  uint8_t allocation_hash[32]; /* BLAKE2b-256 of film->samples (the blob leases name), when set */
  char allocation_summary[192]; /* vf_allocation_summary's, for status; "" before */
  int film_dirty;       /* merged into since the last checkpoint */
  int film_unreadable;  /* its file could not be read back (coordinator/state.h): never written over */
  /* Checkpoints run off the event loop (coordinator/checkpoint.h) on a snapshot of the film:
   * film_generation counts changes of the film, so that a write that lands after further
   * merges does not clear film_dirty; at most one write of a job is in flight. */
  uint64_t film_generation;
  uint64_t writing_generation; /* of the snapshot being written */
  int film_writing;            /* a write of this film is in flight */
  int final_pending;           /* completed or stopped, its final film not yet durable */
  /* Additions of parts to the film's pixels on the merge thread (coordinator/merger.h)
   * not landed yet. The iteration set and everything else of the film is the loop's and
   * already holds those parts; the pixels are not to be read on the loop while this is
   * nonzero (no measurement, copy or checkpoint then; they wait for it to land). */
  unsigned merging;
  uint64_t results_refused;
  /* Leases failed since the last merge (coordinator/poison.h), and the distinct workers
   * whose they were, by name; a merge clears both. */
  unsigned lease_failures;
  unsigned failed_workers_count;
  char failed_workers[VF_JOB_FAILED_WORKERS][128];
  /* The last checkpoint of its film failed, and why; "" when the last one landed. */
  char checkpoint_error[256];
  double rate;          /* iterations per second of one worker on this job, smoothed; 0 unknown */
  double last_merge_time;
  double seconds;       /* running so far: wall-clock seconds since its first lease */
  /* Its time limit (coordinator/deadline.h): vf_seconds_now() when the job closed (its
   * leases deliver their final parts), 0 before; time_up once they have, or the grace
   * period is over: only then does the time limit stop it (vf_job_check_stop). */
  double closed_at;
  int time_up;
  double seconds_saved; /* `seconds` as last written to state.json */
  struct {
    double time;
    uint64_t iterations;
  } merges[VF_JOB_RATE_SAMPLES]; /* ring of the latest merges */
  unsigned merges_count, merges_next;
  /* the latest measurement of the film (vf_job_measure) */
  vf_convergence_entry measured;
  uint64_t measured_iterations; /* iterations when measured; UINT64_MAX never */
  uint64_t logged_iterations;   /* iterations of the log's last entry; UINT64_MAX none */
  /* scheduling (coordinator/schedule.h) */
  double service;       /* worker-seconds charged */
  int schedule_idle;    /* had nothing to lease when last looked at */
} vf_job;

/* Creates a job with an empty film stamped with scene hash and settings. Takes no
 * ownership: scene_text is copied. Checks every field as untrusted input (name length and
 * characters, built-in name syntax, scene size, canonical valid settings, first iteration, iteration count)
 * and returns VF_EINVAL with a detail naming the field otherwise. *out on success only. */
int vf_job_create(uint64_t id, const char *name, int priority, int scene_builtin, const char *scene_text,
                  size_t scene_len, const uint8_t *scene_hash, size_t hash_len, const char *settings_text,
                  uint64_t first, uint64_t iterations, vf_job **out);
void vf_job_destroy(vf_job *job);

/* Records in the job's film where a JSON scene's file is on the submitting machine (what
 * `continue` loads; a built-in scene's film names it already). Empty: nothing. VF_EINVAL
 * with a detail for a path too long for the film or with control characters. */
int vf_job_set_scene_path(vf_job *job, const char *path);

/* Sets the tags a worker must satisfy to be leased the job (common/tags.h), `count` of
 * them, checked as untrusted input: at most VF_TAGS_MAX, each a well-formed requirement.
 * VF_EINVAL with a detail naming the tag ("requires: ..."); the job keeps none then. */
int vf_job_set_requires(vf_job *job, char *const *tags, size_t count);

/* Sets the stop conditions besides the iterations, checked as untrusted input: each is 0
 * (none) or finite and positive, time at most a year; target_rmse needs a reference.
 * VF_EINVAL with a detail naming the field. */
int vf_job_set_stop(vf_job *job, double time_limit, double target_rmse, double target_error);

/* Reads the job's reference image from path (any RGB EXR, a film's mean included) and
 * checks its size is the film's. VF_ENOENT, VF_EEXR, VF_EMISMATCH with a detail; the job
 * keeps no reference then. */
int vf_job_load_reference(vf_job *job, const char *path);

/* Measures the film now into job->measured: its estimated RMSE, and RMSE and relative
 * MSE against the reference when there is one (else NaN). VF_ENOMEM. */
int vf_job_measure(vf_job *job);

/* Appends the latest measurement (measuring first if the film changed since) to the film's
 * convergence log, in the log's last run (0 for the first entry): a farm job is one
 * history. Nothing when the log's last entry already has this many iterations.
 * VF_ENOMEM. */
int vf_job_log(vf_job *job);

/* Checks the stop conditions other than the iterations, measuring when a target error
 * needs it; when one holds the job is marked stopped (vf_job_finish) with the reason in
 * job->stop and, as a sentence, job->message, and 1 is returned, else 0 (or a negative
 * error of vf_job_measure). The time limit holds only once job->time_up is set: reaching
 * it closes the job first, for its workers' final parts (coordinator/deadline.h). */
int vf_job_check_stop(vf_job *job);

/* Marks the job ended at Unix time `at` for `why`: cancelled, failed (with the message),
 * stopped by time or a target, or, for VF_STOP_ITERATIONS, complete (job->end stays
 * active: the film says so). Records stop and ended_at once; later calls change nothing. */
void vf_job_finish(vf_job *job, vf_stop_reason why, double at, const char *message);

/* The job's latest measurement restored from its film's convergence log when the log's
 * last entry has the film's iterations (a film read back after a restart): status then
 * shows the errors without measuring. */
void vf_job_restore_measure(vf_job *job);

/* Iterations per second of the whole farm on this job, over the merges of the last
 * `window` seconds; 0 when unknown. */
double vf_job_farm_rate(const vf_job *job, double now, double window);

/* The forecast (common/forecast.h) of the job at `rate` iterations per second: the stop
 * condition expected to hold first, the progress towards it and its ETA; targets
 * extrapolated from the slope of its convergence log and latest measurement. Its
 * iteration count is a condition unless it is the open-ended VF_JOB_MAX_ITERATIONS and
 * another condition is set. An ended job: progress 1, ETA 0, `by` its stop reason. */
void vf_job_forecast(const vf_job *job, double rate, vf_forecast *out);

/* "queued", "running", "paused", "done", "cancelled" or "failed"; `leased` is the number
 * of iterations currently leased out. A complete job is "running" until its final film is
 * durable (final_pending clear); a runnable job that is paused is "paused", whether or
 * not leases granted before the pause are still out. */
const char *vf_job_state(const vf_job *job, uint64_t leased);
uint64_t vf_job_done(const vf_job *job);
/* Its film holds [first, first + iterations), or it was stopped by another condition. */
int vf_job_complete(const vf_job *job);
/* Active and not complete: leases may be handed out. */
int vf_job_runnable(const vf_job *job);

/* Checks that a film belongs to the job: size, scene hash, settings, and iterations
 * within [first, first + iterations), or for a pilot's film (film->pilot) within [0,
 * pilot) of a job with a pilot. VF_EMISMATCH with a detail. */
int vf_job_check_film(const vf_job *job, const vf_film *film);

/* Checks a result film against the job and the range [begin, end) it claims: size, scene
 * hash, settings and an iteration set of exactly that range. VF_EMISMATCH with a detail. */
int vf_job_check_result(const vf_job *job, const vf_film *film, uint64_t begin, uint64_t end);

/* In its pilot phase: a pilot and no allocation yet (see pilot_film above). */
int vf_job_in_pilot(const vf_job *job);
/* Iterations of the pilot merged: those of pilot_film, or all once the allocation is set;
 * 0 without a pilot. */
uint64_t vf_job_pilot_done(const vf_job *job);

/* Merges a checked pilot part (film->pilot) into pilot_film, pixels and all. VF_EINVAL
 * when the job is not in its pilot phase (the pilot is done: the part is late), VF_EOVERLAP
 * (nothing merged) if any of its iterations is already there. */
int vf_job_merge_pilot(vf_job *job, const vf_film *film);

/* vf_job_merge_pilot but for the pixels, which the caller adds (the merge thread:
 * vf_film_add_pixels into pilot_film) and then lowers pilot_merging, raised here. */
int vf_job_merge_pilot_deferred(vf_job *job, const vf_film *film);

/* In its pilot phase with pilot_film holding all of [0, pilot). */
int vf_job_pilot_complete(const vf_job *job);

/* When pilot_film holds all of [0, pilot): computes the allocation from it
 * (vf_allocation_compute) and gives it to the job (vf_job_set_allocation); returns 1. 0
 * while the pilot is not complete or the job has no pilot phase; VF_ENOMEM or the
 * computation's error, the job unchanged. */
int vf_job_finish_pilot(vf_job *job);

/* Gives the job's film the allocation computed from its complete pilot_film (width x
 * height counts, copied), with the pilot's times (as the local render's film has them),
 * records its hash and drops pilot_film; returns 1, or VF_ENOMEM with the job unchanged. */
int vf_job_set_allocation(vf_job *job, const uint8_t *samples);

/* A job submitted with its allocation (SubmitJob.allocation, version 12: width x height
 * counts, validated by the caller, copied): the job's film takes it at once and its pilot
 * counts as done, so it runs no pilot (vf_job_in_pilot is 0). VF_EINVAL naming what is
 * wrong when the job's settings cannot take one (no pilot, or auto choosing the algorithm
 * by its pilots, which would not know which algorithm the counts were decided for);
 * VF_ENOMEM; the job unchanged then. */
int vf_job_submit_allocation(vf_job *job, const uint8_t *samples);
/* Those checks alone: VF_OK when the job's settings can take an allocation. */
int vf_job_allocation_allowed(const vf_job *job);

/* Records the hash and summary of the allocation the job's film has (a film read back
 * with one); nothing when it has none. */
void vf_job_allocation_loaded(vf_job *job);

/* Takes a pilot film read back from the state directory (checked: vf_job_check_film,
 * and a pilot's) as the job's pilot_film; VF_EMISMATCH with a detail, the film not taken. */
int vf_job_restore_pilot(vf_job *job, vf_film *pilot);

/* Merges a checked result. VF_EOVERLAP (film unchanged) if any of its iterations is
 * already counted. */
int vf_job_merge(vf_job *job, const vf_film *film, double now);

/* The same, but the addition of the result's pixels is left to the caller (the merge
 * thread: vf_film_add_pixels), who then lowers job->merging, raised here. Everything
 * else (iteration set, times, log, rate) is done on return, so the result counts from
 * now on and nothing can refuse it later. */
int vf_job_merge_deferred(vf_job *job, const vf_film *film, double now);

#endif
