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

/* Drops the parts that received nothing for the worker timeout: their sender is gone, and
 * each holds a film as large as its job's. */
void vf_results_expire(vf_farm *farm, double now);

#endif
