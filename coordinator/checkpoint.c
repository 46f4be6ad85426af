#include "checkpoint.h"

#include "../common/clock.h"
#include "../common/error.h"
#include "jobs.h"
#include "log.h"
#include "merger.h"
#include "ship.h"
#include "state.h"

#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <sodium.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <uv.h>

/* ---- fetch snapshots: the table ----
 * Kept by farm and job id, at most one per job. The table is the process's (a process may
 * run several farms, each on its own thread): the lock guards its links; an entry is only
 * ever read, changed or freed by its own farm's thread. */
typedef enum { SNAPSHOT_PENDING, SNAPSHOT_HASHING, SNAPSHOT_READY, SNAPSHOT_FAILED } snapshot_state;

typedef struct snapshot {
  struct snapshot *next;
  const vf_farm *farm; /* borrowed: the farm it belongs to */
  uint64_t job_id, id;
  uint64_t generation; /* it holds at least this generation of the job's film */
  snapshot_state state; /* PENDING: waits for the job's write in flight; HASHING: on the pool */
  int fd;               /* READY: open on the file; else -1 */
  vf_snapshot_info info;
  double last_request;
  unsigned readers, done; /* fetches that began with it, and that read its last chunk */
  char detail[1024];    /* FAILED: why */
} snapshot;

static pthread_mutex_t snapshots_lock = PTHREAD_MUTEX_INITIALIZER;
static snapshot *snapshots;

static snapshot *snapshot_find(const vf_farm *farm, uint64_t job_id) {
  pthread_mutex_lock(&snapshots_lock);
  snapshot *s = snapshots;
  while (s != NULL && (s->farm != farm || s->job_id != job_id)) s = s->next;
  pthread_mutex_unlock(&snapshots_lock);
  return s;
}

static void snapshot_insert(snapshot *s) {
  pthread_mutex_lock(&snapshots_lock);
  s->next = snapshots;
  snapshots = s;
  pthread_mutex_unlock(&snapshots_lock);
}

static void snapshot_free(snapshot *s) {
  pthread_mutex_lock(&snapshots_lock);
  snapshot **at = &snapshots;
  while (*at != NULL && *at != s) at = &(*at)->next;
  if (*at == s) *at = s->next;
  pthread_mutex_unlock(&snapshots_lock);
  if (s->fd >= 0) close(s->fd);
  free(s);
}

/* The farm's snapshots that `drop` selects (all of them with NULL) are freed. */
static void snapshots_free_if(const vf_farm *farm, int (*drop)(const snapshot *s, double now), double now) {
  for (;;) {
    pthread_mutex_lock(&snapshots_lock);
    snapshot *s = snapshots;
    while (s != NULL && (s->farm != farm || (drop != NULL && !drop(s, now)))) s = s->next;
    pthread_mutex_unlock(&snapshots_lock);
    if (s == NULL) return;
    vf_log("job %llu: fetch snapshot %016llx dropped (%s)", (unsigned long long)s->job_id, (unsigned long long)s->id,
           drop ? "unasked for too long" : "the coordinator stops");
    snapshot_free(s);
  }
}

/* ---- work on the thread pool: a film write, a snapshot's hash, or both ---- */

/* Lives from queue_work to its after-callback. */
typedef struct {
  uv_work_t work;
  vf_farm *farm; /* borrowed */
  uint64_t job_id;
  vf_film *film;        /* owned: the copy to write, or NULL (a snapshot of the file as it is) */
  char *path;           /* owned */
  uint64_t snapshot_id; /* nonzero: the file is then opened (unless fd is) and hashed for it */
  int fd;
  vf_snapshot_info info;
  int err;
  char detail[1024]; /* the error detail is per thread: carried back to the loop's */
  double seconds;
} film_work;

static int save_film(vf_farm *farm, vf_job *job, uint64_t snapshot_id);
static void snapshot_advance(vf_farm *farm, vf_job *job);

/* Opens (unless open) and hashes the file, reading it in pieces. Touches only fw. */
static int hash_file(film_work *fw) {
  if (fw->fd < 0 && (fw->fd = open(fw->path, O_RDONLY | O_CLOEXEC)) < 0)
    return vf_error_set(VF_EIO, "%s: %s", fw->path, strerror(errno));
  struct stat st;
  if (fstat(fw->fd, &st) != 0) return vf_error_set(VF_EIO, "%s: %s", fw->path, strerror(errno));
  size_t piece = (size_t)1 << 20;
  uint8_t *buf = malloc(piece);
  if (buf == NULL) return vf_error_set(VF_ENOMEM, "out of memory hashing %s", fw->path);
  crypto_generichash_state state;
  crypto_generichash_init(&state, NULL, 0, sizeof fw->info.hash);
  uint64_t at = 0, size = (uint64_t)st.st_size;
  int err = VF_OK;
  while (err == VF_OK && at < size) {
    ssize_t got = pread(fw->fd, buf, size - at < piece ? (size_t)(size - at) : piece, (off_t)at);
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) err = vf_error_set(VF_EIO, "%s: read at %llu: %s", fw->path, (unsigned long long)at,
                                     got < 0 ? strerror(errno) : "the file ended early");
    else crypto_generichash_update(&state, buf, (size_t)got), at += (uint64_t)got;
  }
  free(buf);
  crypto_generichash_final(&state, fw->info.hash, sizeof fw->info.hash);
  fw->info.size = size;
  return err;
}

static void do_work(uv_work_t *work) {
  film_work *fw = work->data;
  double t0 = vf_seconds_now();
  vf_error_clear();
  fw->err = fw->film != NULL ? vf_film_write(fw->film, fw->path) : VF_OK;
  if (fw->err == VF_OK && fw->snapshot_id != 0) fw->err = hash_file(fw);
  if (fw->err != VF_OK) snprintf(fw->detail, sizeof fw->detail, "%s", vf_error_detail(fw->err));
  fw->seconds = vf_seconds_now() - t0;
}

/* Back on the loop after a film write: the copy of job_id's film taken at the write's start
 * is durable (err VF_OK) or failed (err, with its detail set). Marks the film clean unless
 * it changed meanwhile; a stopped job whose final film landed gets its end written to
 * state.json. */
/* A failed film checkpoint: logged and an event of the job. */
static void checkpoint_failed(vf_job *job, int err) {
  vf_log("checkpoint of job %llu failed: %s", (unsigned long long)job->id, vf_error_detail(err));
  vf_events_add(&job->events, vf_unix_now(), "checkpoint_failed", job->id, "", "film checkpoint failed: %s",
                vf_error_detail(err));
  /* Shown by status until a checkpoint lands (coordinator/jobs.c). */
  snprintf(job->checkpoint_error, sizeof job->checkpoint_error, "film checkpoint failed (retrying): %s",
           vf_error_detail(err));
  for (char *c = job->checkpoint_error; *c; c++)
    if ((unsigned char)*c < 0x20 || *c == 0x7f) *c = '?';
}

static void landed(vf_farm *farm, vf_job *job, int err, double seconds) {
  unsigned long long jid = (unsigned long long)job->id;
  job->film_writing = 0;
  if (err != VF_OK) {
    checkpoint_failed(job, err);
    return; /* still dirty: the next checkpoint tries again */
  }
  if (seconds >= 1.0) vf_log("job %llu: film checkpoint written in %.2f s (off the event loop)", jid, seconds);
  if (job->checkpoint_error[0] != '\0') {
    vf_log("job %llu: film checkpoint written again after failures", jid);
    vf_events_add(&job->events, vf_unix_now(), "checkpoint_written", job->id, "", "film checkpoint written again");
    job->checkpoint_error[0] = '\0';
  }
  if (job->writing_generation != job->film_generation) {
    /* Changed while being written; a final film is written again at once. */
    if (job->final_pending && (err = save_film(farm, job, 0)) != VF_OK) checkpoint_failed(job, err);
    return;
  }
  job->film_dirty = 0;
  if (job->final_pending) {
    job->final_pending = 0;
    farm->state_dirty = 1;
    if ((err = vf_state_save_index(farm)) != VF_OK) vf_log("writing the job list failed: %s", vf_error_detail(err));
  }
}

/* Back on the loop after a snapshot's file was hashed: it is ready, or failed. The fetch may
 * have been dropped meanwhile. */
static void hashed(film_work *fw, int err) {
  snapshot *s = snapshot_find(fw->farm, fw->job_id);
  if (s == NULL || s->id != fw->snapshot_id) return;
  if (err != VF_OK) {
    s->state = SNAPSHOT_FAILED;
    memcpy(s->detail, fw->detail, sizeof s->detail);
    return;
  }
  s->state = SNAPSHOT_READY;
  s->fd = fw->fd;
  s->info = fw->info;
  fw->fd = -1;
  if (fw->seconds >= 1.0)
    vf_log("job %llu: fetch snapshot %016llx of %llu bytes ready in %.2f s (off the event loop)",
           (unsigned long long)fw->job_id, (unsigned long long)fw->snapshot_id, (unsigned long long)fw->info.size,
           fw->seconds);
}

static void work_done(uv_work_t *work, int status) {
  film_work *fw = work->data;
  vf_farm *farm = fw->farm;
  int err = fw->err;
  if (status != 0) err = vf_error_set(VF_EIO, "%s: the write was cancelled: %s", fw->path, uv_strerror(status));
  else if (err != VF_OK) err = vf_error_set(err, "%s", fw->detail);
  if (err != VF_OK) snprintf(fw->detail, sizeof fw->detail, "%s", vf_error_detail(err));
  if (farm->checkpoints_pending > 0) farm->checkpoints_pending--;
  if (fw->snapshot_id != 0) hashed(fw, err);
  vf_job *job = vf_farm_job(farm, fw->job_id);
  if (job != NULL && fw->film != NULL) landed(farm, job, err, fw->seconds);
  if (job != NULL) snapshot_advance(farm, job); /* one waiting for this write */
  if (fw->fd >= 0) close(fw->fd);
  vf_film_destroy(fw->film);
  free(fw->path);
  free(fw);
}

/* Hands the work to the thread pool (on the caller's thread without a loop), which owns
 * film and fd on VF_OK; path is copied. */
static int queue_work(vf_farm *farm, uint64_t job_id, vf_film *film, const char *path, uint64_t snapshot_id, int fd) {
  film_work *fw = calloc(1, sizeof *fw);
  char *copy = strdup(path);
  if (fw == NULL || copy == NULL) {
    free(fw);
    free(copy);
    return vf_error_set(VF_ENOMEM, "out of memory starting a checkpoint of %s", path);
  }
  *fw = (film_work){.farm = farm, .job_id = job_id, .film = film, .path = copy, .snapshot_id = snapshot_id, .fd = fd};
  fw->work.data = fw;
  farm->checkpoints_pending++;
  if (farm->checkpoint_loop == NULL) {
    do_work(&fw->work);
    work_done(&fw->work, 0);
    return VF_OK;
  }
  int rv = uv_queue_work(farm->checkpoint_loop, &fw->work, do_work, work_done);
  if (rv != 0) {
    farm->checkpoints_pending--;
    free(copy);
    free(fw);
    return vf_error_set(VF_EIO, "%s: cannot start the checkpoint: %s", path, uv_strerror(rv));
  }
  return VF_OK;
}

/* A checkpoint written by the merge thread, the only thread that changes job films' pixels:
 * the metadata as the loop had it when it queued the write (its iteration set names
 * exactly the parts queued before, FIFO), the pixels the job film's own, read in place. No
 * copy of the film: neither its memory nor the loop's time for a memcpy. Merges wait
 * behind it meanwhile. */
typedef struct {
  vf_merge_item item;
  film_work *fw;
  const vf_film *pixels; /* the job's film: alive while film_writing (a job is not removed then) */
} write_item;

/* A film's metadata without pixels (`shell`) lent the pixels of the job's film for one
 * write on the merge thread, and without them again after: no copy of the pixels. */
static void lend_pixels(vf_film *shell, const vf_film *pixels) {
  shell->sum = pixels->sum;
  shell->square_sum = pixels->square_sum;
}

static void return_pixels(vf_film *shell) { shell->sum = shell->square_sum = NULL; }

static void write_work(vf_merge_item *item) {
  write_item *w = (write_item *)item;
  lend_pixels(w->fw->film, w->pixels);
  do_work(&w->fw->work);
  return_pixels(w->fw->film);
}

static void write_done(vf_merge_item *item) {
  write_item *w = (write_item *)item;
  vf_ship_part_work(w->fw->farm, item->seconds, 0); /* the thread's time, as parts' is */
  work_done(&w->fw->work, 0);
  free(w);
}

static int queue_write(vf_farm *farm, vf_job *job, const char *path, uint64_t snapshot_id) {
  vf_film *shell;
  int err = vf_film_clone_metadata(job->film, &shell);
  if (err != VF_OK) return err;
  film_work *fw = calloc(1, sizeof *fw);
  write_item *w = calloc(1, sizeof *w);
  char *copy = strdup(path);
  if (fw == NULL || w == NULL || copy == NULL) {
    free(fw);
    free(w);
    free(copy);
    vf_film_destroy(shell);
    return vf_error_set(VF_ENOMEM, "out of memory starting a checkpoint of %s", path);
  }
  *fw = (film_work){.farm = farm, .job_id = job->id, .film = shell, .path = copy, .snapshot_id = snapshot_id,
                    .fd = -1};
  fw->work.data = fw;
  *w = (write_item){.item = {.work = write_work, .done = write_done}, .fw = fw, .pixels = job->film};
  farm->checkpoints_pending++;
  job->film_writing = 1;
  job->writing_generation = job->film_generation;
  vf_merger_queue(farm->merger, &w->item);
  return VF_OK;
}

/* Starts the checkpoint of one film: written here without a loop (unless for a snapshot),
 * else a copy handed to the thread pool (the job's film keeps changing meanwhile), and
 * hashed after for snapshot_id when nonzero. A job whose write is in flight is left dirty:
 * its landing or the next checkpoint takes it. */
static int save_film(vf_farm *farm, vf_job *job, uint64_t snapshot_id) {
  if (job->film_writing) return VF_OK;
  if (job->film_unreadable) /* left as it is for the user (coordinator/state.h) */
    return snapshot_id ? vf_error_set(VF_EIO, "job %llu: its film cannot be read back", (unsigned long long)job->id)
                       : VF_OK;
  char path[4096];
  int err = vf_state_film_path(farm->config.state_dir, job->id, path, sizeof path);
  /* Behind the additions queued before it: no wait for them to land. */
  if (err == VF_OK && farm->merger != NULL) return queue_write(farm, job, path, snapshot_id);
  if (farm->checkpoint_loop == NULL && snapshot_id == 0) return vf_state_save_film(farm->config.state_dir, job);
  vf_film *copy;
  if (err != VF_OK || (err = vf_film_clone(job->film, &copy)) != VF_OK) return err;
  job->film_writing = 1;
  job->writing_generation = job->film_generation;
  if ((err = queue_work(farm, job->id, copy, path, snapshot_id, -1)) != VF_OK) {
    job->film_writing = 0;
    vf_film_destroy(copy);
  }
  return err;
}

/* A pilot film's write, on the merge thread behind the additions queued before it: its
 * pixels borrowed from the job's pilot_film (not dropped while pilot_writing), its
 * metadata a copy taken when it was queued, which describes exactly those additions. */
typedef struct {
  vf_merge_item item;
  vf_farm *farm;
  uint64_t job_id;
  vf_film *shell;        /* owned: pilot_film's metadata, without pixels */
  const vf_film *pixels; /* the job's pilot_film */
  char path[4096];
  int err;
  char detail[1024];
} pilot_write_item;

static void pilot_write_work(vf_merge_item *item) {
  pilot_write_item *w = (pilot_write_item *)item;
  vf_error_clear();
  lend_pixels(w->shell, w->pixels);
  w->err = vf_film_write(w->shell, w->path);
  return_pixels(w->shell);
  if (w->err != VF_OK) snprintf(w->detail, sizeof w->detail, "%s", vf_error_detail(w->err));
}

static void pilot_write_done(vf_merge_item *item) {
  pilot_write_item *w = (pilot_write_item *)item;
  vf_job *job = vf_farm_job(w->farm, w->job_id);
  vf_ship_part_work(w->farm, item->seconds, 0);
  if (job != NULL) {
    job->pilot_writing = 0;
    if (w->err != VF_OK) {
      job->pilot_dirty = 1; /* the next checkpoint tries again */
      vf_log("job %llu: writing its pilot film failed: %s", (unsigned long long)job->id, w->detail);
    }
    vf_jobs_pilot_merged(w->farm, job, vf_seconds_now()); /* the pilot may have completed meanwhile */
  }
  vf_film_destroy(w->shell);
  free(w);
}

/* The pilot film's checkpoint: on the merge thread when there is one (a 4K pilot film takes
 * about a second to write), else here. Nothing while a write of it is in flight or its
 * allocation is being computed (pilot_dirty stays: the next checkpoint takes it). */
static int save_pilot(vf_farm *farm, vf_job *job) {
  if (job->pilot_writing || job->pilot_finishing || job->pilot_film == NULL || job->film_unreadable) return VF_OK;
  if (farm->merger == NULL) return vf_state_save_pilot(farm->config.state_dir, job);
  pilot_write_item *w = calloc(1, sizeof *w);
  if (w == NULL) return vf_error_set(VF_ENOMEM, "out of memory starting a checkpoint of job %llu's pilot film",
                                     (unsigned long long)job->id);
  int err = vf_state_pilot_path(farm->config.state_dir, job->id, w->path, sizeof w->path);
  if (err == VF_OK) err = vf_film_clone_metadata(job->pilot_film, &w->shell);
  if (err != VF_OK) {
    free(w);
    return err;
  }
  w->item = (vf_merge_item){.work = pilot_write_work, .done = pilot_write_done};
  w->farm = farm;
  w->job_id = job->id;
  w->pixels = job->pilot_film;
  job->pilot_writing = 1;
  job->pilot_dirty = 0; /* what merges after this sets it again */
  vf_merger_queue(farm->merger, &w->item);
  return VF_OK;
}

void vf_checkpoint_final(vf_farm *farm, vf_job *job) {
  job->final_pending = 1;
  vf_state_recreate(farm);
  int err = vf_job_log(job);
  if (err == VF_OK) err = save_film(farm, job, 0);
  if (err != VF_OK) return checkpoint_failed(job, err);
  if (farm->state_dirty && (err = vf_state_save_index(farm)) != VF_OK)
    vf_log("writing the job list failed: %s", vf_error_detail(err)); /* state_dirty: the next checkpoint tries again */
}

int vf_checkpoint_write(vf_farm *farm, int all) {
  int first = VF_OK;
  char first_detail[1024] = ""; /* later calls record details of their own */
  if (all) snapshots_free_if(farm, NULL, 0.0);
  vf_state_recreate(farm);
  for (size_t i = 0; i < farm->num_jobs; i++) {
    vf_job *j = farm->jobs[i];
    int err = vf_job_log(j);
    if (err != VF_OK) vf_log("job %llu: convergence entry: %s", (unsigned long long)j->id, vf_error_detail(err));
    if (j->seconds != j->seconds_saved) farm->state_dirty = 1;
    if (j->pilot_dirty && (err = save_pilot(farm, j)) != VF_OK) {
      vf_log("job %llu: writing its pilot film failed: %s", (unsigned long long)j->id, vf_error_detail(err));
      if (first == VF_OK) {
        first = err;
        snprintf(first_detail, sizeof first_detail, "job %llu's pilot film: %s", (unsigned long long)j->id,
                 vf_error_detail(err));
      }
    }
    if (!j->film_dirty) continue; /* on disk as it is: also when stopping */
    err = save_film(farm, j, 0);
    if (err != VF_OK) {
      checkpoint_failed(j, err);
      if (first == VF_OK) {
        first = err;
        snprintf(first_detail, sizeof first_detail, "job %llu's film: %s", (unsigned long long)j->id,
                 vf_error_detail(err));
      }
    }
  }
  if (farm->state_dirty || all) {
    int err = vf_state_save_index(farm);
    if (err != VF_OK) {
      vf_log("writing the job list failed: %s", vf_error_detail(err));
      if (first == VF_OK) {
        first = err;
        snprintf(first_detail, sizeof first_detail, "%s", vf_error_detail(err));
      }
    }
  }
  return first == VF_OK ? VF_OK : vf_error_set(first, "%s", first_detail);
}

size_t vf_checkpoint_pending(const vf_farm *farm) { return farm->checkpoints_pending; }

void vf_checkpoint_resume(vf_farm *farm, vf_job *job) {
  if (job->merging > 0) return;
  if (job->final_pending) {
    /* Its last measurement, skipped while pixels were being added: a write in flight
     * lands with an older generation, and the final film is written again then. */
    int err = vf_job_log(job);
    if (err == VF_OK && job->film_dirty && !job->film_writing) err = save_film(farm, job, 0);
    if (err != VF_OK) checkpoint_failed(job, err);
  }
  snapshot_advance(farm, job);
}

/* ---- fetch snapshots ---- */

/* Takes the job's pending snapshot further once no write of its film is in flight: the
 * file on disk when it holds the film as it is, else a checkpoint written for it. */
static void snapshot_advance(vf_farm *farm, vf_job *job) {
  snapshot *s = snapshot_find(farm, job->id);
  if (s == NULL || s->state != SNAPSHOT_PENDING || job->film_writing) return;
  char path[4096];
  int err = vf_state_film_path(farm->config.state_dir, job->id, path, sizeof path), fd = -1;
  s->state = SNAPSHOT_HASHING;
  s->generation = job->film_generation;
  if (err == VF_OK && !job->film_dirty && (fd = open(path, O_RDONLY | O_CLOEXEC)) >= 0) {
    if ((err = queue_work(farm, job->id, NULL, path, s->id, fd)) != VF_OK) close(fd);
  } else if (err == VF_OK) {
    err = save_film(farm, job, s->id); /* never written yet, or changed since */
  }
  if (err != VF_OK && (s = snapshot_find(farm, job->id)) != NULL && s->state == SNAPSHOT_HASHING) {
    s->state = SNAPSHOT_FAILED;
    snprintf(s->detail, sizeof s->detail, "%s", vf_error_detail(err));
  }
}

int vf_checkpoint_snapshot_start(vf_farm *farm, vf_job *job, double now, uint64_t *id) {
  snapshot *s = snapshot_find(farm, job->id);
  if (s != NULL && s->state == SNAPSHOT_FAILED) { /* its fetch was told, or will not ask again */
    snapshot_free(s);
    s = NULL;
  }
  if (s != NULL && s->generation == job->film_generation) { /* joined */
    s->last_request = now;
    s->readers++;
    *id = s->id;
    return VF_OK;
  }
  if (s != NULL) { /* older than the film, and in use (else it expires): wait for its end */
    *id = 0;
    return VF_OK;
  }
  int err = vf_job_log(job); /* the film as fetched carries its latest measurement */
  if (err != VF_OK) return err;
  if ((s = calloc(1, sizeof *s)) == NULL) return vf_error_set(VF_ENOMEM, "out of memory for a fetch");
  s->farm = farm;
  s->job_id = job->id;
  while (s->id == 0) randombytes_buf(&s->id, sizeof s->id);
  s->generation = job->film_generation;
  s->state = SNAPSHOT_PENDING;
  s->fd = -1;
  s->last_request = now;
  s->readers = 1;
  uint64_t new_id = s->id;
  snapshot_insert(s);
  snapshot_advance(farm, job); /* may fail it: the first read says why */
  *id = new_id;
  return VF_OK;
}

int vf_checkpoint_snapshot_read(vf_farm *farm, uint64_t job_id, uint64_t id, uint64_t offset, size_t most,
                                double now, size_t room, uint8_t **data, size_t *n, vf_snapshot_info *info) {
  snapshot *s = snapshot_find(farm, job_id);
  if (s == NULL || s->id != id)
    return vf_error_set(VF_ENOENT, "job %llu has no fetch snapshot %016llx (read whole, unasked for %.0f s, or "
                        "the coordinator restarted): start again", (unsigned long long)job_id,
                        (unsigned long long)id, VF_SNAPSHOT_IDLE_SECONDS);
  s->last_request = now;
  if (s->state == SNAPSHOT_FAILED) {
    int err = vf_error_set(VF_EIO, "job %llu: the film could not be prepared for fetching: %s",
                           (unsigned long long)job_id, s->detail);
    snapshot_free(s);
    return err;
  }
  if (s->state != SNAPSHOT_READY) return 0;
  if (offset > s->info.size)
    return vf_error_set(VF_EINVAL, "fetch at offset %llu, past the end of job %llu's film of %llu bytes",
                        (unsigned long long)offset, (unsigned long long)job_id, (unsigned long long)s->info.size);
  size_t limit = most == 0 || most > VF_FETCH_CHUNK_BYTES ? VF_FETCH_CHUNK_BYTES
                 : most < VF_FETCH_CHUNK_MIN                 ? VF_FETCH_CHUNK_MIN
                                                             : most;
  size_t len = s->info.size - offset < limit ? (size_t)(s->info.size - offset) : limit;
  uint8_t *chunk = malloc(len + room + 1);
  if (chunk == NULL) return vf_error_set(VF_ENOMEM, "out of memory for a chunk of %zu bytes", len);
  for (size_t at = 0; at < len;) {
    ssize_t got = pread(s->fd, chunk + at, len - at, (off_t)(offset + at));
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) {
      int err = vf_error_set(VF_EIO, "job %llu: reading its film at %llu: %s", (unsigned long long)job_id,
                             (unsigned long long)(offset + at), got < 0 ? strerror(errno) : "the file ended early");
      free(chunk);
      snapshot_free(s);
      return err;
    }
    at += (size_t)got;
  }
  *info = s->info;
  if (offset + len == s->info.size && ++s->done >= s->readers) {
    vf_log("job %llu: film of %llu bytes fetched (snapshot %016llx, by %u fetch%s)", (unsigned long long)job_id,
           (unsigned long long)s->info.size, (unsigned long long)id, s->done, s->done > 1 ? "es" : "");
    snapshot_free(s);
  }
  *data = chunk;
  *n = len;
  return 1;
}

void vf_checkpoint_snapshot_drop(vf_farm *farm, uint64_t job_id) {
  snapshot *s = snapshot_find(farm, job_id);
  if (s != NULL) snapshot_free(s);
}

static int idle(const snapshot *s, double now) { return now - s->last_request > VF_SNAPSHOT_IDLE_SECONDS; }

void vf_checkpoint_snapshot_expire(vf_farm *farm, double now) { snapshots_free_if(farm, idle, now); }
