/* Submitting a job to a coordinator (`vcmfarm submit`): the scene is loaded here as the
 * workers will load it, so that a broken scene, bad settings or a wrong reference are refused
 * before anything is sent; a JSON scene's files then go to the coordinator by content
 * hash (those it lacks), and the job last. A job with a pilot whose allocation of camera
 * sub-paths is known here (the one `--algorithm auto` chose by the candidates' pilots, or
 * FILM's with --allocation-from) sends it as a blob too (protocol 12): the farm then renders
 * with those counts from the start, runs no pilot, and its film is the local render's with
 * the same allocation, whatever made it; auto's pilots' seconds go with it (protocol 13)
 * and count in the film's times. */
#ifndef VF_SUBMIT_H
#define VF_SUBMIT_H

#include "options.h"
#include "../common/farm_client.h"
#include "../common/settings.h"
#include "../common/tags.h"

#include <stdint.h>

typedef struct {
  const char *source;               /* a built-in scene name, a JSON scene file or a model file */
  const char *camera;               /* a model file's camera (--camera), or NULL */
  const char *name;                 /* for status; NULL: source */
  const vf_cli_settings *overrides; /* over the scene's own settings; NULL: none */
  uint64_t first, iterations;       /* global iterations [first, first + iterations) */
  int priority;
  double time_limit, target_rmse, target_error; /* 0: none */
  const char *reference;            /* a reference EXR, or NULL */
  const char *log_prefix;           /* "vcmfarm submit": the line saying what was sent; NULL: none */
  const vf_tags *requires;          /* tags a worker must satisfy (--require), or NULL: none */
  const char *allocation_from;      /* --allocation-from FILM: its allocation ships with the job;
                                     * NULL: none (auto with a pilot ships the one it chose) */
} vf_submit_job;

typedef struct {
  uint64_t job_id;
  vf_settings settings;             /* as the job renders them */
  char settings_text[512];
  char scene_source[4200];          /* the loaded scene's vf_scene.source */
} vf_submitted_job;

/* Loads and checks the scene, settings and reference, sends the files and the job
 * through client (each request waits up to timeout_ms; a file at least two minutes).
 * On VF_OK *out describes the job. Errors carry a detail: a broken scene or reference
 * (as vf_scene_load), or the coordinator's refusal (VF_EREFUSED), or the network's. */
int vf_submit(vf_farm_client *client, int timeout_ms, const vf_submit_job *job, vf_submitted_job *out);

/* The job's name (or the scene's path standing for it) and the scene file's absolute path
 * as the coordinator and the film keep them: VF_EUSAGE naming the problem for a name that
 * is not UTF-8 or above VF_JOB_MAX_NAME bytes, a path that is not UTF-8 or does not fit a
 * film (511 bytes). vf_submit checks them first; the command checks them before it
 * connects, so that nothing is sent or waited for. */
int vf_submit_check_texts(const vf_submit_job *job);

#endif
