/* The results of leases (docs/PROTOCOL.md, "Results in tiles"): a worker ships a lease's
 * result in parts [begin, c), each as LeaseResult messages of tiles staged in a film of its
 * own (coordinator/partial.h). Every message is checked against its lease, its job and the
 * part received so far, and refused with the reason (counted in the job's
 * results_refused) when anything is wrong; with its last tile, the part is merged whole
 * into the job's film, which refuses iterations already counted (vf_job_merge), and the
 * lease then starts at c. A late result of an expired lease is merged when nothing of it is
 * counted yet, and revokes the leases reassigned over it. */
#ifndef VF_RESULTS_H
#define VF_RESULTS_H

#include "farm_core.h"
#include "farm_reply.h"

/* LeaseResult -> ResultAck: tiles of the part [m->begin, m->end) that starts where the
 * lease's unmerged iterations do; "merged" with the last tile ("already merged" for a
 * part sent again), and the job finishes when that completes it (coordinator/jobs.h). */
void vf_results_receive(vf_farm *farm, const Vcmfarm__LeaseResult *m, double now, vf_farm_reply *r);

/* With a merge thread (farm->merger), vf_results_receive calls this for a message that
 * passed the lease's checks: the message's tiles are decoded and stored on the merge
 * thread and the message is answered when that is done (r->deferred, farm->request taken;
 * farm->reply_later answers), or at once "busy" (retry_ms) when the thread's queue is full,
 * when VF_PARTS_STAGED_MAX parts are being received, or when a message of the lease is on
 * the thread already. The reply is the one vf_results_receive would give. */
void vf_results_receive_later(vf_farm *farm, vf_lease *l, const Vcmfarm__LeaseResult *m, double now,
                              vf_farm_reply *r);

/* Adds a merged part's pixels (`film`, taken) to the job's film on the merge thread;
 * job->merging, raised by vf_job_merge_deferred, falls when they are in. A pilot part's
 * (film->pilot) go to the job's pilot film, and job->pilot_merging, raised by
 * vf_job_merge_pilot_deferred, falls (vf_jobs_pilot_merged follows). */
void vf_results_add_pixels(vf_farm *farm, vf_job *job, vf_film *film);

/* Parts being received at once, each a film as large as its job's staged in memory: the
 * bound of the coordinator's memory for results (docs/PROTOCOL.md). */
#define VF_PARTS_STAGED_MAX 2

/* Drops the parts that received nothing for the worker timeout: their sender is gone, and
 * each holds a film as large as its job's. */
void vf_results_expire(vf_farm *farm, double now);

#endif
