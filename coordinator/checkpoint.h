/* Checkpoints: a job's film, and the job list, written durably to the state directory
 * (coordinator/state.h), so that a restarted coordinator resumes every job from them; and
 * the snapshots that clients fetch films from, which are checkpoints held open.
 *
 * When: every `--checkpoint-interval` the film of each job merged into since its last
 * checkpoint, with a convergence-log entry first, and state.json when the job list or a
 * running time changed (vf_checkpoint_write); a job's final film as soon as it completes or
 * stops (vf_checkpoint_final); a film a fetch needs (vf_checkpoint_snapshot_start);
 * everything at SIGTERM/SIGINT.
 *
 * How: writing a 1920x1080 job film (fsync, rename) takes seconds; on the event loop it
 * would leave every worker and client unanswered that long. So with farm->checkpoint_loop
 * set, the film is copied on the loop (a memcpy, tens of milliseconds at that size) and
 * libuv's thread pool (uv_queue_work) writes the copy atomically (temporary file, fsync,
 * rename, fsync of the directory: vf_film_write); back on the loop, the film is marked
 * clean only if no merge changed it meanwhile. A job whose write is in flight is skipped
 * (it stays changed, so the next checkpoint takes it): one film is never written by two
 * threads. Without a loop, films are written on the caller's thread. Until a stopped job's
 * final film is durable, state.json records it as active (coordinator/state.h).
 *
 * Fetch snapshots (docs/PROTOCOL.md, "Fetching a film"). A client reads a job's film in
 * chunks of a snapshot: the job's film file as one checkpoint wrote it, held by an open
 * descriptor (a later checkpoint renames a new file over the name, which leaves the
 * snapshot's bytes alone), with its size and BLAKE2b-256 computed on the thread pool. The
 * file on disk is the snapshot when the film has not changed since it was written; else a
 * checkpoint is written for it (after the write in flight, if any). At most one per job;
 * it is dropped once every fetch that began with it has read its last chunk, after
 * VF_SNAPSHOT_IDLE_SECONDS without a request, with its job (vf_checkpoint_snapshot_drop)
 * and when the coordinator stops.
 * What it costs the coordinator: a descriptor (and, on disk, the file until then); while
 * its checkpoint is written, the film's copy, as any checkpoint; one chunk per reply. */
#ifndef VF_CHECKPOINT_H
#define VF_CHECKPOINT_H

#include "farm_core.h"

#include <stddef.h>
#include <stdint.h>

/* Appends a convergence entry to the film of every job merged into since its last entry,
 * then checkpoints the film of every job changed since its last checkpoint, then state.json
 * if the job list or a running time changed; with `all` (the coordinator stopping),
 * state.json in any case, and every fetch snapshot is dropped. A film whose checkpoint
 * landed and that has not changed since is not written again, not even then: a farm of
 * many finished 1920x1080 jobs stops without seconds of writing each. Logs and returns
 * the first error, carrying on with the other jobs. */
int vf_checkpoint_write(vf_farm *farm, int all);

/* The final checkpoint of a job that completed or stopped: a last convergence entry, its
 * film written at once (job->final_pending until it is durable) and state.json if the job
 * list changed. Failures are logged; the next checkpoints try again. */
void vf_checkpoint_final(vf_farm *farm, vf_job *job);

/* Film writes and snapshot hashes in flight on the thread pool (0 without a loop). Stop
 * only at 0: each reports back to the farm. */
size_t vf_checkpoint_pending(const vf_farm *farm);

/* ---- fetch snapshots ---- */

#define VF_FETCH_CHUNK_BYTES ((size_t)16 << 20) /* the most one reply carries */
#define VF_FETCH_CHUNK_MIN ((size_t)64 << 10)    /* the least a client may ask for (FetchRequest) */
#define VF_SNAPSHOT_IDLE_SECONDS 20.0            /* unasked this long, a snapshot is dropped */
#define VF_SNAPSHOT_RETRY_MS 50u                 /* what a client waits before asking again */

typedef struct {
  uint64_t size;    /* bytes of the file */
  uint8_t hash[32]; /* BLAKE2b-256 of them */
} vf_snapshot_info;

/* A fetch of the job's film begins at `now`: the job's snapshot if it holds the film as it
 * is (nothing merged since it was taken: a second client joins the first), else a new one,
 * the film's latest measurement appended to its convergence log first (vf_job_log). *id
 * (on VF_OK) is the snapshot's id, or 0 when the job's snapshot is older than its film and
 * still in use: ask again. VF_ENOMEM, VF_EIO with a detail. */
int vf_checkpoint_snapshot_start(vf_farm *farm, vf_job *job, double now, uint64_t *id);

/* Reads the chunk of snapshot `id` of the job at offset (at most VF_FETCH_CHUNK_BYTES, and
 * at most `most` bytes when that is not 0, but never less than VF_FETCH_CHUNK_MIN) at
 * `now`. Returns 1 with the chunk in *data (malloc'ed with `room` bytes more after the
 * chunk, for the caller; the caller frees it), *n and *info; the snapshot is dropped once
 * its last chunk has been read as often as fetches began with it. Returns 0 while the snapshot is being written or hashed (ask again).
 * Errors: VF_ENOENT when the job has no snapshot `id` (gone: start again), VF_EINVAL for
 * an offset past its end, VF_EIO (with the detail; the snapshot is dropped) when its
 * checkpoint or the read failed. */
int vf_checkpoint_snapshot_read(vf_farm *farm, uint64_t job_id, uint64_t id, uint64_t offset, size_t most,
                                double now, size_t room, uint8_t **data, size_t *n, vf_snapshot_info *info);

/* Drops the job's snapshot (a removed job); no-op when it has none. */
void vf_checkpoint_snapshot_drop(vf_farm *farm, uint64_t job_id);

/* Drops the snapshots nobody asked for during the last VF_SNAPSHOT_IDLE_SECONDS. */
void vf_checkpoint_snapshot_expire(vf_farm *farm, double now);

/* A job whose pixels were being added on the merge thread (job->merging, now 0): the
 * final film and the fetch snapshot that waited for them are started. */
void vf_checkpoint_resume(vf_farm *farm, vf_job *job);

#endif
