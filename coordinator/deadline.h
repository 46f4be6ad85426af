/* Deadlines: a job's time limit loses no iteration a worker rendered before it
 * (docs/PROTOCOL.md, "Deadlines").
 *
 * Until protocol 8 a job that reached its time limit was stopped at once and its active
 * leases revoked: whatever their workers had rendered since their last part was dropped
 * (a sixth of a 60 s job on one worker). Now the deadline travels with the lease and the
 * job closes instead of stopping:
 *
 *   - a lease of a job with a time limit says how much running time the job had left
 *     when it was granted (Lease.deadline_ms, version 9); the worker stops at the first
 *     iteration boundary past that on its own clock, ships what it rendered as its final
 *     part and hands back the rest;
 *   - when the job's running time reaches the limit on the coordinator's clock the job is
 *     *closing*: no worker is handed it again, its leases stay valid, their heartbeats are
 *     answered "deliver now" (HeartbeatAck.deliver_now: for a worker whose clock ran slow,
 *     or after the coordinator itself was paused), and the parts that arrive are merged as
 *     any part is;
 *   - it stops ("time limit of S s reached") once none of its leases is active, or when
 *     the grace period (vf_deadline_grace) has passed since it closed; a lease still
 *     active then is revoked, and only what it had not delivered within the grace is lost.
 *
 * Single-threaded, as the farm. */
#ifndef VF_DEADLINE_H
#define VF_DEADLINE_H

#include "farm_core.h"

#include <stdint.h>

/* The grace period is the worker timeout, at least this many seconds: a worker that is
 * alive delivers its final part within an iteration and a part's shipping, and one that
 * is not is lost within the worker timeout anyway. */
#define VF_DEADLINE_GRACE_MIN 5.0

/* Seconds a closing job waits for the final parts of its leases. */
double vf_deadline_grace(const vf_farm *farm);

/* The job has a time limit and its running time has reached it (closing, or about to be
 * at the next tick): it is handed to no one, and its leases deliver now. */
int vf_deadline_reached(const vf_job *job);

/* Milliseconds of running time the job has left, for Lease.deadline_ms: 0 when it has no
 * time limit, at least 1 when it has reached it, at most UINT32_MAX (49 days; the
 * heartbeat's deliver_now covers a longer one). */
uint32_t vf_deadline_lease_ms(const vf_job *job);

/* The tick's part for a runnable job with a time limit: closes it when its running time
 * reached the limit (logged, an event), and stops it (vf_jobs_finish: done, its final
 * film written) once none of its leases is active or the grace period is over. Returns 1
 * when it stopped the job. */
int vf_deadline_tick(vf_farm *farm, vf_job *job, double now);

#endif
