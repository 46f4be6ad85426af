/* The farm as the event loop drives it: one decoded, authenticated request in, its reply
 * out (vf_farm_handle, which hands each message to the module that answers it); and the
 * duties of the loop's tick: expiry, running time and time limits, checkpoints. No I/O
 * besides the state directory: the loop (coordinator/coordinator.c) owns the socket.
 * Single-threaded.
 *
 * This header is the top of the farm: its state is coordinator/farm_core.h and its reply
 * coordinator/farm_reply.h, and the requests are answered by coordinator/workers.h
 * (Register), leases.h (LeaseRequest, Heartbeat, LeaseRelease), results.h (LeaseResult),
 * jobs.h (SubmitJob, StatusRequest, FetchRequest, CancelRequest, RemoveRequest) and
 * blobs.h (BlobQuery, BlobPut, BlobRequest), none of which includes this header. */
#ifndef VF_FARM_H
#define VF_FARM_H

#include "farm_core.h"
#include "farm_reply.h"

/* Answers one authenticated request received at time `now` into *reply (always filled:
 * an Error when the request is refused). Any message of a registered worker counts as a
 * sign of life; the requests that need one are refused with ERROR_UNKNOWN_WORKER ("register
 * again") when the worker is unknown. */
void vf_farm_handle(vf_farm *farm, const Vcmfarm__Envelope *request, double now, vf_farm_reply *reply);

/* Drops the parts of results that received nothing for the worker timeout
 * (vf_results_expire), then declares workers silent that long lost and returns their
 * leases to the pool (vf_workers_expire). Returns the number of workers lost. */
int vf_farm_expire(vf_farm *farm, double now);

/* The coordinator itself was stalled for `gap` seconds up to `now` (its loop's ticks
 * stopped: SIGSTOP, a paused VM, swapping): nobody could be heard meanwhile, so the
 * workers' silence is excused by it (their last sign of life, the parts being received
 * and the grace period of a closing job, coordinator/deadline.h, move `gap` later, never
 * past now) and nobody is lost for it. Logged, and an event of the farm. */
void vf_farm_stalled(vf_farm *farm, double gap, double now);

/* Advances the running time of every running job to `now`, closes those whose time limit
 * it reaches and stops them once their leases' final parts are in or the grace period is
 * over (coordinator/deadline.h: revoking what is left, writing their film and the job
 * list), and writes the job list when a change waits for it (farm->state_urgent: a failed
 * lease, coordinator/poison.h). Call it often (the coordinator does every 200 ms): a time
 * limit is honoured to one call. */
void vf_farm_tick(vf_farm *farm, double now);

/* The farm's checkpoint: vf_checkpoint_write (coordinator/checkpoint.h). */
int vf_farm_checkpoint(vf_farm *farm, int all);

#endif
