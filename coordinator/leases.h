/* The farm's leases as its workers see them (docs/PROTOCOL.md, "Jobs, leases and
 * results"): a lease request is answered with the first free range of the job the
 * scheduler picks (coordinator/schedule.h), sized for the lease duration at the worker's
 * rate and at most a fair share of what is left (vf_lease_size); a heartbeat learns whether
 * the lease still holds; a lease is handed back, or fails with its job. And how a lease
 * ends, whoever ends it: its worker holds it no more and its job is charged the worker
 * time it really took. The table of leases is coordinator/lease.h; their results,
 * coordinator/results.h. */
#ifndef VF_LEASES_H
#define VF_LEASES_H

#include "farm_core.h"
#include "farm_reply.h"

#include <stdint.h>

/* LeaseRequest of the registered worker w: a Lease of the job the scheduler picks among
 * those w is not blocked from (coordinator/poison.h), or Idle when none has free iterations. A lease the worker still holds returns to the pool. */
void vf_leases_grant(vf_farm *farm, vf_farm_worker *w, double now, vf_farm_reply *r);

/* Heartbeat of w: HeartbeatAck with lease_valid when the lease is w's, active and of a
 * runnable job; then it records the iterations the worker says it has rendered. */
void vf_leases_heartbeat(vf_farm *farm, vf_farm_worker *w, const Vcmfarm__Heartbeat *m, vf_farm_reply *r);

/* LeaseRelease of w: its active lease returns to the pool; with a failure (the worker
 * could not load or render the job), the lease failed: the worker is blocked from the job
 * and the failure counts towards the job's (coordinator/poison.h; the reason sanitised). */
void vf_leases_release(vf_farm *farm, const vf_farm_worker *w, const Vcmfarm__LeaseRelease *m, double now,
                       vf_farm_reply *r);

/* Ends a lease: its worker holds it no more, and an active one charges its job the worker
 * time it took, grant to now (vf_schedule_charge). Kept as expired with `keep`, so that a
 * late result is still checked against it, else removed. The pointer is invalid after. */
void vf_leases_end(vf_farm *farm, vf_lease *lease, int keep, double now);

/* Ends every active lease of the job, kept as expired so that results on their way are
 * checked against them and refused (by the job's state or by vf_film_merge). */
void vf_leases_end_job(vf_farm *farm, uint64_t job_id, double now);

/* Revokes, as vf_leases_end_job, the active leases of the job other than `except` that
 * overlap [begin, end): a late result covered them. Each is logged. */
void vf_leases_revoke(vf_farm *farm, uint64_t job_id, uint64_t begin, uint64_t end, uint64_t except, double now);

/* Revokes, as vf_leases_revoke, the job's pilot leases still active when its pilot
 * completed (their iterations are merged, by another's late result): its own leases start
 * from nothing. Each is logged. */
void vf_leases_end_pilot(vf_farm *farm, uint64_t job_id, double now);

#endif
