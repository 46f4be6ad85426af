/* Poison jobs and the blocklist (docs/PROTOCOL.md, "Poison jobs"). A lease fails only for
 * what is the worker's doing: when the worker holding it reports that it cannot render
 * the job (LeaseRelease.failure), or when, before any part of that lease was merged, the
 * worker comes back under the same name (it crashed and was restarted) or is lost (silent
 * for the worker timeout) while other workers were heard (coordinator/workers.h). A
 * coordinator's own stall (vf_farm_stalled), a silence of every worker at once (the
 * coordinator cut off), a result waiting at the gate or a time limit fail no lease. A
 * failed lease:
 *
 *   - puts its worker on the job's blocklist for the forgive time (--forgive): that worker
 *     is not handed the job again until then (workers are known by name, so a restarted
 *     one is still blocked), and is then forgiven;
 *   - counts towards the job's failures in a row, which any merged part clears
 *     (vf_job_merge).
 *
 * The job fails (state `failed`, the reason in its message and events) once it has
 * VF_POISON_WORKERS (3) failures in a row and they come from as many distinct workers, or
 * every registered worker is blocked from it (a farm of fewer workers: no one is left to
 * try it; only after the coordinator has been up for a worker timeout, so that the
 * workers of a farm it restarted have registered again).
 * The failures in a row, their workers and the blocklist are saved with the job list
 * (coordinator/state.c) at the farm's next tick (farm->state_urgent), not at the next
 * checkpoint, so a restarted coordinator goes on counting and keeps blocking
 * until each forgive time that was set. Single-threaded, as the farm. */
#ifndef VF_POISON_H
#define VF_POISON_H

#include "farm_core.h"

#include <stdint.h>

#define VF_POISON_WORKERS VF_JOB_FAILED_WORKERS

/* A lease of job_id held by the worker named `worker` failed for `why` (a sentence): the
 * worker is blocked from the job, the failure counted, and the job failed (its leases
 * ended) when the rule above says so. Nothing when the job is gone or has ended. */
void vf_poison_lease_failed(vf_farm *farm, uint64_t job_id, const char *worker, const char *why, double now);

/* The worker named `worker` may not be handed job_id now. */
int vf_poison_blocked(const vf_farm *farm, const char *worker, uint64_t job_id, double now);

/* Forgives the workers whose time is up, and fails the jobs every registered worker is
 * blocked from (see above). Called from the farm's tick. */
void vf_poison_tick(vf_farm *farm, double now);

/* Blocklist entry i (i < farm->num_blocks), for saving: its worker's name (the farm's),
 * job, and the vf_seconds_now() time it is forgiven at. */
const char *vf_poison_block_at(const vf_farm *farm, size_t i, uint64_t *job_id, double *until);
/* Blocks `worker` from job_id until `until` (vf_seconds_now() time), as saved. */
void vf_poison_restore(vf_farm *farm, const char *worker, uint64_t job_id, double until);

/* Forgets the job's blocklist entries (the job was removed). */
void vf_poison_forget_job(vf_farm *farm, uint64_t job_id);

#endif
