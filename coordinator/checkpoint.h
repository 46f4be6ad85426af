/* Checkpoints: a job's film, and the job list, written durably to the state directory
 * (coordinator/state.h), so that a restarted coordinator resumes every job from them.
 *
 * When: every `--checkpoint-interval` the film of each job merged into since its last
 * checkpoint, with a convergence-log entry first, and state.json when the job list or a
 * running time changed (vf_checkpoint_write); a job's final film as soon as it completes or
 * stops (vf_checkpoint_final); everything at SIGTERM/SIGINT.
 *
 * How: writing a 1920x1080 job film (ZIP compression of 23 float channels, fsync, rename)
 * takes seconds; on the event loop it would leave every worker and client unanswered that
 * long. So with farm->checkpoint_loop set, the film is copied on the loop (a memcpy, tens
 * of milliseconds at that size) and libuv's thread pool (uv_queue_work) writes the copy
 * atomically (temporary file, fsync, rename, fsync of the directory: vf_film_write); back
 * on the loop, the film is marked clean only if no merge changed it meanwhile. A job whose
 * write is in flight is skipped (it stays changed, so the next checkpoint takes it): one
 * film is never written by two threads. Without a loop, films are written on the caller's
 * thread. Until a stopped job's final film is durable, state.json records it as active
 * (coordinator/state.h). */
#ifndef VF_CHECKPOINT_H
#define VF_CHECKPOINT_H

#include "farm_core.h"

#include <stddef.h>

/* Appends a convergence entry to the film of every job merged into since its last entry,
 * then checkpoints the film of every job changed since its last checkpoint, then state.json
 * if the job list or a running time changed; with `all`, every film and the state. Logs
 * and returns the first error, carrying on with the other jobs. */
int vf_checkpoint_write(vf_farm *farm, int all);

/* The final checkpoint of a job that completed or stopped: a last convergence entry, its
 * film written at once (job->final_pending until it is durable) and state.json if the job
 * list changed. Failures are logged; the next checkpoints try again. */
void vf_checkpoint_final(vf_farm *farm, vf_job *job);

/* Film writes in flight on the thread pool (0 without a loop). Stop only at 0: each
 * write reports back to the farm. */
size_t vf_checkpoint_pending(const vf_farm *farm);

#endif
