/* The farm's state: its jobs, the workers registered with it, the leases they hold, and
 * the bookkeeping of its checkpoints and blob store. One struct, shared by the modules that
 * answer requests (coordinator/workers.h, leases.h, results.h, jobs.h, blobs.h) and by those
 * that keep it durable (state.h, checkpoint.h); the event loop drives the whole through
 * coordinator/farm.h, which sits above them all. Here: its life, and finding and adding
 * what it holds. Single-threaded: only the event loop's thread touches it.
 *
 * Everything a peer sends is untrusted even when authenticated: every handler checks
 * every id, range, size and text, and nothing a peer sends can make the farm count an
 * iteration twice (see coordinator/job.h). */
#ifndef VF_FARM_CORE_H
#define VF_FARM_CORE_H

#include "job.h"
#include "lease.h"

#include <stddef.h>
#include <stdint.h>

struct uv_loop_s; /* libuv's uv_loop_t */

typedef struct {
  uint64_t id;        /* random */
  char name[128];
  unsigned cores, threads;
  double last_seen;   /* vf_seconds_now() of its last message */
  double rate;        /* iterations per second, smoothed over its results; 0 unknown */
  uint64_t lease_id;  /* its active lease, 0 none */
} vf_farm_worker;

typedef struct {
  const char *state_dir;   /* borrowed */
  double worker_timeout;   /* seconds of silence after which a worker is lost */
  double lease_seconds;    /* target duration of a lease */
} vf_farm_config;

typedef struct vf_farm {
  vf_farm_config config;
  vf_job **jobs;           /* owned, by increasing id */
  size_t num_jobs, jobs_capacity;
  uint64_t next_job_id;
  vf_farm_worker *workers; /* owned (coordinator/workers.h) */
  size_t num_workers, workers_capacity;
  vf_lease_table leases;   /* coordinator/leases.h */
  int state_dirty;         /* the job list changed since state.json was written */
  double last_tick;        /* of vf_farm_tick; 0 before the first */
  /* Checkpoints (coordinator/checkpoint.h): when set (borrowed), films are written by
   * this loop's thread pool; NULL, on the caller's thread (tests, benchmarks, the
   * coordinator's final checkpoint). */
  struct uv_loop_s *checkpoint_loop;
  size_t checkpoints_pending; /* film writes started on the pool, not landed yet */
  /* Blobs of the store read back and found intact, with the size and modification time
   * they had then (coordinator/blobs.c): read again only when those change. */
  struct vf_blob_checked *checked;
  size_t num_checked, checked_capacity;
} vf_farm;

/* An empty farm; then vf_state_load fills in the jobs of a state directory. */
void vf_farm_init(vf_farm *farm, const vf_farm_config *config);
/* Frees its jobs, workers, leases and caches; the farm is empty afterwards. */
void vf_farm_destroy(vf_farm *farm);

/* The job or the registered worker with this id, or NULL. A worker's pointer is valid
 * until a worker registers or is lost. */
vf_job *vf_farm_job(const vf_farm *farm, uint64_t id);
vf_farm_worker *vf_farm_find_worker(vf_farm *farm, uint64_t id);

/* Appends a job (ids increase: the caller gives it the next one); the farm owns it on
 * VF_OK, the caller keeps it on VF_ENOMEM. */
int vf_farm_add_job(vf_farm *farm, vf_job *job);

#endif
