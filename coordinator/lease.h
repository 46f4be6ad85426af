/* Leases: ranges of global iterations [begin, end) of one job handed to one worker.
 *
 * A lease is active until its result is merged, it is handed back, or its worker is lost
 * (silent for the worker timeout); then it is removed, or kept as expired so that a late
 * result can still be checked against the range it was for. The free iterations of a job
 * are those neither in its film nor in an active lease; ranges are always cut from them,
 * so active leases never overlap each other or the film. A lease's result arrives in parts
 * (coordinator/partial.h); each merged part [begin, c) moves its begin to c. */
#ifndef VF_LEASE_H
#define VF_LEASE_H

#include "../common/iterset.h"

#include <stddef.h>
#include <stdint.h>

typedef enum { VF_LEASE_ACTIVE, VF_LEASE_EXPIRED } vf_lease_state;

typedef struct {
  uint64_t id;        /* random, so ids never repeat across coordinator restarts */
  uint64_t job_id, worker_id;
  uint64_t begin, end; /* what is not merged yet: begin moves up as parts are merged */
  uint64_t first;      /* begin when granted */
  int pilot;           /* of the job's pilot iterations (coordinator/job.h): its parts are pilot parts */
  uint64_t reported;   /* iterations from first rendered, as the worker's last heartbeat said */
  vf_lease_state state;
  double granted;     /* vf_seconds_now() */
  double charged;     /* worker-seconds charged to the job when granted (coordinator/schedule.h) */
  struct vf_partial *partial; /* owned: tiles of the part [begin, ...) arriving, or NULL */
} vf_lease;

/* Expired leases kept for checking late results; the oldest are forgotten beyond this. */
#define VF_LEASE_KEEP_EXPIRED 256

typedef struct {
  vf_lease *leases; /* owned */
  size_t count, capacity;
} vf_lease_table;

void vf_lease_table_init(vf_lease_table *t);
void vf_lease_table_destroy(vf_lease_table *t);

/* Appends a lease (copied) with a fresh random id, written to *id on success. */
int vf_lease_add(vf_lease_table *t, uint64_t job_id, uint64_t worker_id, uint64_t begin, uint64_t end, double now,
                 uint64_t *id);
/* The lease with this id, or NULL. The pointer is valid until the table changes. */
vf_lease *vf_lease_find(vf_lease_table *t, uint64_t id);
void vf_lease_remove(vf_lease_table *t, uint64_t id);
/* Marks a lease expired, forgetting the oldest expired leases beyond the limit. */
void vf_lease_expire(vf_lease_table *t, uint64_t id);
/* Number of iterations of the job in active leases. */
uint64_t vf_lease_active_iterations(const vf_lease_table *t, uint64_t job_id);
/* Number of iterations of the job that workers have rendered in their active leases and
 * not shipped yet, as their heartbeats said. */
uint64_t vf_lease_rendering_iterations(const vf_lease_table *t, uint64_t job_id);

/* Finds the first free range of a job with iterations [first, first + total) done as
 * `done`: it starts at the smallest iteration of those neither done nor actively leased
 * and holds at most max_size of them. Returns 1 and writes *begin, *end when there is one, 0 when none is free,
 * or a negative error (VF_ENOMEM). *free_count receives the number of free iterations. */
int vf_lease_free_range(const vf_lease_table *t, uint64_t job_id, const vf_iterset *done, uint64_t first,
                        uint64_t total, uint64_t max_size, uint64_t *begin, uint64_t *end, uint64_t *free_count);

/* The lease size for a worker: target_seconds of its measured rate (iterations per
 * second; 0 when unknown, giving 1 iteration to measure it), at most a fair share
 * ceil(free / workers) so that the end of a job spreads over the farm, at least 1. */
uint64_t vf_lease_size(double rate, double target_seconds, uint64_t free_count, size_t workers);

#endif
