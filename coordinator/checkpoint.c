#include "checkpoint.h"

#include "../common/clock.h"
#include "../common/error.h"
#include "log.h"
#include "state.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <uv.h>

/* One film write on the thread pool: lives from start_write to its after-callback. */
typedef struct {
  uv_work_t work;
  vf_farm *farm; /* borrowed */
  uint64_t job_id;
  vf_film *snapshot; /* owned */
  char *path;        /* owned */
  int err;
  char detail[1024]; /* the error detail is per thread: carried back to the loop's */
  double seconds;
} film_write;

static int save_film(vf_farm *farm, vf_job *job);

/* Back on the loop: the snapshot of job_id's film taken at the write's start is durable
 * (err VF_OK) or failed (err, with its detail set). Marks the film clean unless it changed
 * meanwhile; a stopped job whose final film landed gets its end written to state.json. */
static void landed(vf_farm *farm, uint64_t job_id, int err, double seconds) {
  if (farm->checkpoints_pending > 0) farm->checkpoints_pending--;
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

/* On a thread of libuv's pool: touches only the write's own snapshot and path. */
static void write_film(uv_work_t *work) {
  film_write *fw = work->data;
  double t0 = vf_seconds_now();
  vf_error_clear();
  fw->err = vf_film_write(fw->snapshot, fw->path);
  if (fw->err != VF_OK) snprintf(fw->detail, sizeof fw->detail, "%s", vf_error_detail(fw->err));
  fw->seconds = vf_seconds_now() - t0;
}

static void written(uv_work_t *work, int status) {
  film_write *fw = work->data;
  int err = fw->err;
  if (status != 0) err = vf_error_set(VF_EIO, "%s: the write was cancelled: %s", fw->path, uv_strerror(status));
  else if (err != VF_OK) err = vf_error_set(err, "%s", fw->detail);
  vf_film_destroy(fw->snapshot);
  landed(fw->farm, fw->job_id, err, fw->seconds);
  free(fw->path);
  free(fw);
}

/* Hands the snapshot to the thread pool, which owns it on VF_OK; path is copied. */
static int start_write(vf_farm *farm, uint64_t job_id, vf_film *snapshot, const char *path) {
  film_write *fw = calloc(1, sizeof *fw);
  char *copy = strdup(path);
  if (fw == NULL || copy == NULL) {
    free(fw);
    free(copy);
    return vf_error_set(VF_ENOMEM, "out of memory starting a checkpoint of %s", path);
  }
  fw->work.data = fw;
  fw->farm = farm;
  fw->job_id = job_id;
  fw->snapshot = snapshot;
  fw->path = copy;
  int rv = uv_queue_work(farm->checkpoint_loop, &fw->work, write_film, written);
  if (rv != 0) {
    free(copy);
    free(fw);
    return vf_error_set(VF_EIO, "%s: cannot start the checkpoint: %s", path, uv_strerror(rv));
  }
  return VF_OK;
}

/* Starts the checkpoint of one film: written here without a loop, else a snapshot handed
 * to the thread pool (the job's film keeps changing meanwhile). A job whose write is in
 * flight is left dirty: its landing or the next checkpoint takes it. */
static int save_film(vf_farm *farm, vf_job *job) {
  if (job->film_writing) return VF_OK;
  if (farm->checkpoint_loop == NULL) return vf_state_save_film(farm->config.state_dir, job);
  char path[4096];
  int err = vf_state_film_path(farm->config.state_dir, job->id, path, sizeof path);
  vf_film *snapshot;
  if (err != VF_OK || (err = vf_film_clone(job->film, &snapshot)) != VF_OK) return err;
  if ((err = start_write(farm, job->id, snapshot, path)) != VF_OK) {
    vf_film_destroy(snapshot);
    return err;
  }
  job->film_writing = 1;
  job->writing_generation = job->film_generation;
  farm->checkpoints_pending++;
  return VF_OK;
}

void vf_checkpoint_final(vf_farm *farm, vf_job *job) {
  job->final_pending = 1;
  int err = vf_job_log(job);
  if (err == VF_OK) err = save_film(farm, job);
  if (err == VF_OK && farm->state_dirty) err = vf_state_save_index(farm);
  if (err != VF_OK) vf_log("job %llu: checkpoint failed: %s", (unsigned long long)job->id, vf_error_detail(err));
}

int vf_checkpoint_write(vf_farm *farm, int all) {
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

size_t vf_checkpoint_pending(const vf_farm *farm) { return farm->checkpoints_pending; }
