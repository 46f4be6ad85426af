/* How often workers ship (docs/PROTOCOL.md, "How often workers ship"): the coordinator
 * chooses the interval from its own load and the size of the films, and tells every worker
 * in its Lease and HeartbeatAck replies; once it is above its minimum, leases last at least
 * that long, so that a lease's end is not an extra part.
 *
 * The model: a part of P pixels costs the merge thread s(P) seconds (decoding its tiles,
 * validating, adding), measured as the thread's work per part merged, smoothed, per pixel
 * (a prior of VF_SHIP_PRIOR_SECONDS_PER_PIXEL until measured), plus the loop's time
 * authenticating and unpacking its messages and the thread's checkpoint writes shared out
 * over the parts (they hold the thread as parts do). With N registered workers each
 * shipping every T seconds the thread is busy rho = N s / T; the interval is the T that
 * makes rho VF_SHIP_TARGET_LOAD, within [VF_SHIP_MIN_SECONDS, VF_SHIP_MAX_SECONDS], and
 * never shorter while the merge thread or the loop is saturated (their measured load above
 * 0.9: the estimate was low, or requests other than results load the loop). It grows at
 * once and shrinks by at most a tenth per second, so a burst of parts does not make it
 * swing. A worker ships no more often than it says, nor than 50 times what its last part
 * cost it (worker/worker.c). */
#ifndef VF_SHIP_H
#define VF_SHIP_H

#include "farm_core.h"

#include <stdint.h>

#define VF_SHIP_MIN_SECONDS 5.0
#define VF_SHIP_MAX_SECONDS (4.0 * 3600.0)
#define VF_SHIP_TARGET_LOAD 0.5
/* Merge-thread seconds per pixel of a part before any is measured: a 1920x1080 part of a
 * noisy vcm film decoded, validated and added on the project's machine (docs/BENCHMARKS.md,
 * "Merging one result"). */
#define VF_SHIP_PRIOR_SECONDS_PER_PIXEL 2.5e-7
/* The most iterations of a lease whose worker's rate is unknown: it is bounded by time
 * instead (Lease.seconds_ms), and hands back what it did not render. */
#define VF_LEASE_UNKNOWN_RATE 1e6

/* Recomputes the interval (farm->ship_seconds) from the loads at `now`; the loop calls it
 * with every tick. */
void vf_ship_tick(vf_farm *farm, double now);

/* Before a lease is granted: the interval grows to the model's for the workers registered
 * now, before the next tick, so that the leases of a farm starting a job already follow it. */
void vf_ship_workers_changed(vf_farm *farm);

/* Accounts `seconds` of work for results (the merge thread's: decoding, adding, and the
 * film checkpoints it writes between them; the loop's on a result message); ends_part for
 * a part's addition, which ends the part. */
void vf_ship_part_work(vf_farm *farm, double seconds, int ends_part);

/* The interval in milliseconds for a Lease or HeartbeatAck. */
uint32_t vf_ship_interval_ms(const vf_farm *farm);
/* The seconds a lease should last: --lease-seconds, or the interval if that is longer and
 * above its minimum (a loaded coordinator: a lease's end is a part, so leases last as long
 * as the interval). */
double vf_ship_lease_seconds(const vf_farm *farm);
/* When a "busy" sender should send again: about the time a part takes to merge. */
uint32_t vf_ship_retry_ms(const vf_farm *farm);
/* Merge seconds of one part of a film of this many pixels, as measured (or the prior). */
double vf_ship_part_seconds(const vf_farm *farm, double pixels);

#endif
