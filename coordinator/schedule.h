/* Weighted sharing of the workers between jobs (docs/PROTOCOL.md, "Priorities").
 *
 * A job's priority is a weight from 1 to 1000: over any stretch of time in which two jobs
 * both have free iterations, the worker time each receives is proportional to its weight
 * (priority 2 gets twice the worker-seconds of priority 1). Worker time, not iterations or
 * leases, is what is shared, because jobs differ in cost per iteration and workers in speed.
 *
 * The scheme is virtual-time fair queueing (stride scheduling): each job carries the
 * worker-seconds it has been charged (`service`); its virtual time is service / weight;
 * a free worker gets a lease of the runnable job of least virtual time (ties: oldest job).
 * A lease is charged when granted with its expected duration (its iterations at the
 * worker's measured rate) and corrected to its real duration (grant to result, hand-back
 * or expiry) when it ends, so a slow or lost worker costs its job what it really took.
 * A job that starts (or becomes runnable again) enters at the least virtual time of the
 * jobs already running, so it neither starves them to catch up nor waits behind them. */
#ifndef VF_SCHEDULE_H
#define VF_SCHEDULE_H

#include "job.h"

#include <stddef.h>
#include <stdint.h>

#define VF_PRIORITY_MIN 1
#define VF_PRIORITY_MAX 1000

/* service / weight. */
double vf_schedule_vtime(const vf_job *job);

/* Of the jobs for which eligible(ctx, job) is positive, the one of least virtual time
 * (ties: lowest id); NULL when none is. A job eligible for the first time since it was
 * last passed over as ineligible (0: job->schedule_idle) first has its service raised so
 * that its virtual time is the least of the other eligible jobs'. Negative: eligible, but
 * not for this request (a worker blocked from it, coordinator/poison.h): skipped, and not
 * idle, so it keeps its place among the others. */
vf_job *vf_schedule_pick(vf_job *const *jobs, size_t count, int (*eligible)(void *ctx, const vf_job *job), void *ctx);

/* The worker-seconds to charge when a lease of `size` iterations is granted: at the
 * worker's measured rate, else the job's rate per worker, else `fallback` seconds. */
double vf_schedule_estimate(uint64_t size, double worker_rate, double job_rate, double fallback);

/* Charges a job seconds of worker time (negative to correct an estimate). */
void vf_schedule_charge(vf_job *job, double seconds);

#endif
