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

#include "../common/message.h"
#include "../common/tags.h"
#include "events.h"
#include "job.h"
#include "lease.h"

#include <stddef.h>
#include <stdint.h>

struct uv_loop_s; /* libuv's uv_loop_t */
struct vf_merger;  /* coordinator/merger.h */
struct vf_farm_reply; /* coordinator/farm_reply.h */

/* A registered worker is active (idle or busy: whether it holds a lease) or stopping (it
 * said goodbye and finishes its lease); one that said it is done has left, one silent for
 * the worker timeout is lost. Those two are kept among the departed for status. */
typedef enum { VF_WORKER_ACTIVE, VF_WORKER_STOPPING, VF_WORKER_LEFT, VF_WORKER_LOST } vf_worker_state;

typedef struct {
  uint64_t id;        /* random */
  char name[128];
  char host[64];      /* its host name, as it says (version 6) */
  char version[32];   /* its software version */
  unsigned cores, threads;
  vf_tags tags;          /* what it carries (version 10): given and found (common/tags.h) */
  uint64_t memory_bytes; /* its machine's memory, as it says; 0 unknown */
  vf_worker_state state;
  double last_seen;   /* vf_seconds_now() of its last message */
  double registered_at, departed_at; /* Unix seconds; departed_at 0 while registered */
  double rate;        /* iterations per second, smoothed over its results; 0 unknown */
  uint64_t lease_id;  /* its active lease, 0 none */
  /* totals since it registered */
  uint64_t iterations_merged, parts_merged, results_refused, leases;
} vf_farm_worker;

/* Workers that left or were lost, kept for status (the latest; older ones are forgotten). */
#define VF_FARM_DEPARTED 16
/* Events of the farm's workers kept (coordinator/events.h). */
#define VF_FARM_EVENTS 64

typedef struct {
  const char *state_dir;   /* borrowed */
  double worker_timeout;   /* seconds of silence after which a worker is lost */
  double lease_seconds;    /* target duration of a lease */
  double forgive_seconds;  /* a worker blocked from a job is forgiven after this (coordinator/poison.h) */
} vf_farm_config;

typedef struct vf_farm {
  vf_farm_config config;
  vf_job **jobs;           /* owned, by increasing id */
  size_t num_jobs, jobs_capacity;
  uint64_t next_job_id;
  vf_farm_worker *workers; /* owned (coordinator/workers.h) */
  size_t num_workers, workers_capacity;
  vf_farm_worker departed[VF_FARM_DEPARTED]; /* ring of the latest that left or were lost */
  unsigned num_departed, departed_next;
  vf_events events;        /* the workers' events, over events_storage */
  vf_event events_storage[VF_FARM_EVENTS];
  double started_at;       /* Unix seconds, vf_farm_init */
  vf_lease_table leases;   /* coordinator/leases.h */
  int state_dirty;         /* the job list changed since state.json was written */
  /* The open, flocked lock file of the state directory (vf_state_lock), owned; -1 when the
   * farm holds none (tests of the farm alone). vf_state_recreate replaces it. */
  int state_lock_fd;
  /* A change that should not wait for the next checkpoint (a failed lease counted, a
   * worker blocked: coordinator/poison.h): state.json is written at the next tick. */
  int state_urgent;
  double last_tick;        /* of vf_farm_tick; 0 before the first */
  /* Checkpoints (coordinator/checkpoint.h): when set (borrowed), films are written by
   * this loop's thread pool; NULL, on the caller's thread (tests, benchmarks, the
   * coordinator's final checkpoint). */
  struct uv_loop_s *checkpoint_loop;
  size_t checkpoints_pending; /* film writes started on the pool, not landed yet */
  struct vf_poison_block *blocks; /* owned: the blocklist (coordinator/poison.c) */
  size_t num_blocks, blocks_capacity;
  /* Blobs of the store read back and found intact, with the size and modification time
   * they had then (coordinator/blobs.c): read again only when those change. */
  struct vf_blob_checked *checked;
  size_t num_checked, checked_capacity;
  /* Merging off the loop (coordinator/merger.h, results.h): when set (borrowed), results
   * are decoded and added on the merge thread and answered later; NULL, on the caller's
   * thread at once (tests, benchmarks). */
  struct vf_merger *merger;
  /* The request being handled, set by vf_farm_handle's caller with a token of its own: a
   * handler that answers later takes the request (sets it NULL, then owns it) and answers
   * through reply_later(reply_ctx, token, reply), on the loop. */
  Vcmfarm__Envelope *request;
  uint64_t request_token;
  void (*reply_later)(void *ctx, uint64_t token, struct vf_farm_reply *reply);
  void *reply_ctx;
  /* How often workers ship (coordinator/ship.h): the loop's and the merge thread's load. */
  double ship_seconds;     /* the interval now */
  double part_seconds;     /* merge work per part of the film's size, smoothed; 0 unknown */
  double part_pixels;      /* pixels of the parts part_seconds was measured on */
  double part_work, part_work_since; /* merge work since the last sample of it, from when */
  unsigned part_work_parts;          /* parts merged since then */
  double load_at, load_busy; /* the merge thread's busy seconds at time load_at */
  double merge_load;       /* the merge thread's utilisation, smoothed */
  double loop_busy, loop_load; /* seconds the loop spent handling requests; its utilisation */
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
