/* The coordinator's state and its answers: jobs, registered workers, leases, and one
 * handler per request of proto/vcmfarm.proto. No I/O besides the state directory
 * (coordinator/state.h): the event loop (coordinator/coordinator.c) feeds it decoded,
 * authenticated requests and sends back the reply it builds. Single-threaded.
 *
 * Requests are untrusted even when authenticated: every id, range, size and text is
 * checked, and a bad one is answered with an Error naming it; nothing a peer sends can
 * make the farm count an iteration twice (see coordinator/job.h). */
#ifndef VF_FARM_H
#define VF_FARM_H

#include "../common/message.h"
#include "job.h"
#include "lease.h"

#include <stddef.h>
#include <stdint.h>

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

/* Writes a snapshot of a job's film to path off the farm's thread (coordinator/writer.h).
 * On VF_OK it owns the snapshot and later calls vf_farm_film_written, on the farm's
 * thread, once the file is durable or the write failed; on an error it took nothing. */
typedef int (*vf_farm_film_writer)(void *ctx, uint64_t job_id, vf_film *snapshot, const char *path);

typedef struct {
  vf_farm_config config;
  vf_job **jobs;           /* owned, by increasing id */
  size_t num_jobs, jobs_capacity;
  uint64_t next_job_id;
  vf_farm_worker *workers; /* owned */
  size_t num_workers, workers_capacity;
  vf_lease_table leases;
  int state_dirty;         /* the job list changed since state.json was written */
  double last_tick;        /* of vf_farm_tick; 0 before the first */
  /* NULL: films are written synchronously, on the caller's thread (tests, benchmarks,
   * the coordinator's final checkpoint); else checkpoints hand snapshots to it. */
  vf_farm_film_writer write_film;
  void *write_ctx;
  size_t writes_pending;   /* started, not yet reported by vf_farm_film_written */
  /* Blobs of the store read back and found intact, with the size and modification time
   * they had then (coordinator/blobs.c): read again only when those change. */
  struct vf_blob_checked *checked;
  size_t num_checked, checked_capacity;
} vf_farm;

/* The reply being built: the envelope and storage for every body. Packed by the caller,
 * then released with vf_farm_reply_release. */
typedef struct {
  Vcmfarm__Envelope env;
  Vcmfarm__Registered registered;
  Vcmfarm__Lease lease;
  Vcmfarm__Scene scene;
  Vcmfarm__Idle idle;
  Vcmfarm__HeartbeatAck heartbeat_ack;
  Vcmfarm__ResultAck result_ack;
  Vcmfarm__Submitted submitted;
  Vcmfarm__Status status;
  Vcmfarm__Film film;
  Vcmfarm__Error error;
  char text[1024];
  /* owned by the reply */
  Vcmfarm__JobStatus *job_status, **job_status_ptrs;
  Vcmfarm__WorkerStatus *worker_status, **worker_status_ptrs;
  uint8_t *film_bytes;
  Vcmfarm__ConvergenceEntry *log, **log_ptrs;
  /* ---- files of scenes by content hash (coordinator/blobs.h) ---- */
  Vcmfarm__BlobHave blob_have;
  Vcmfarm__Blob blob;
  ProtobufCBinaryData *missing;                 /* owned array; data borrowed from the request */
  uint8_t *blob_bytes;                          /* owned */
  Vcmfarm__BlobRef *file_refs, **file_ref_ptrs; /* owned; the lease's Scene.files */
} vf_farm_reply;

/* An empty farm; then vf_state_load fills in the jobs of a state directory. */
void vf_farm_init(vf_farm *farm, const vf_farm_config *config);
void vf_farm_destroy(vf_farm *farm);

/* Answers one authenticated request received at time `now` into *reply (always filled:
 * an Error when the request is refused). */
void vf_farm_handle(vf_farm *farm, const Vcmfarm__Envelope *request, double now, vf_farm_reply *reply);
/* An Error reply with this code and message (for requests refused before decoding). */
void vf_farm_reply_error(vf_farm_reply *reply, Vcmfarm__ErrorCode code, const char *message);
void vf_farm_reply_release(vf_farm_reply *reply);
/* For the handlers (coordinator/farm.c, jobs.c, blobs.c): an Error with a formatted
 * message, and a ResultAck. */
void vf_farm_reply_errorf(vf_farm_reply *reply, Vcmfarm__ErrorCode code, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
void vf_farm_reply_ack(vf_farm_reply *reply, int accepted, const char *message);

/* Ends every active lease of the job, kept as expired so that results on their way are
 * checked against them and refused; the job is charged the worker time they took. */
void vf_farm_end_job_leases(vf_farm *farm, uint64_t job_id, double now);

/* Declares workers silent for longer than the timeout lost and returns their leases to
 * the pool, and drops parts of results (coordinator/partial.h) that received nothing for
 * that long. Returns the number of workers lost. */
int vf_farm_expire(vf_farm *farm, double now);

/* Advances the running time of every running job to `now` and stops those whose time
 * limit it reaches (revoking their leases, writing their film and the job list). Call it
 * often (the coordinator does every 200 ms): a time limit is honoured to one call. */
void vf_farm_tick(vf_farm *farm, double now);

/* Appends a convergence entry to the film of every job merged into since its last entry,
 * then writes the film of every job changed since the last checkpoint, then state.json if
 * the job list or a running time changed; with `all`, every film and the state. Logs and
 * returns the first error, carrying on with the other jobs.
 *
 * With a film writer set, a film's checkpoint is a snapshot (a copy, made here) handed to
 * it; the film counts as written only when vf_farm_film_written says so, and a job whose
 * write is still in flight is skipped (it stays changed, so the next checkpoint takes it):
 * never two writes of one film at once. Without one, films are written here. */
int vf_farm_checkpoint(vf_farm *farm, int all);

/* The film writer's report on the farm's thread: the snapshot of job_id's film taken at
 * the last start is durable (err VF_OK) or failed (err, with its detail set), after
 * `seconds`. Marks the film clean unless it changed meanwhile; a completed job whose final
 * film landed gets its end written to state.json (coordinator/state.h). */
void vf_farm_film_written(vf_farm *farm, uint64_t job_id, int err, double seconds);

/* Film writes in flight (0 without a film writer). */
size_t vf_farm_writes_pending(const vf_farm *farm);

vf_job *vf_farm_job(const vf_farm *farm, uint64_t id);

#endif
