/* The workers registered with the farm. A worker is known only by the messages it sends
 * (the farm never calls it): it registers and gets a random id, the heartbeat interval and
 * the timeout; every message of it counts as a sign of life; one silent for the worker
 * timeout is lost, and its lease returns to the pool (coordinator/leases.h) with its merged
 * parts counted. One told to stop says goodbye (version 6): first that it is stopping (it
 * finishes its lease, which stays valid), then that it is done (it has left; a lease it
 * still holds returns to the pool). The latest VF_FARM_DEPARTED workers that left or were
 * lost are kept for status, with their totals. A restarted coordinator knows no worker:
 * they register again. */
#ifndef VF_WORKERS_H
#define VF_WORKERS_H

#include "farm_core.h"
#include "farm_reply.h"

/* Register -> Registered: a new worker with a fresh random id, its name sanitised. One
 * still registered under that name is that worker restarted (names identify workers): it
 * is lost at once, and its lease, if no part of it was merged, failed (coordinator/poison.h). */
void vf_workers_register(vf_farm *farm, const Vcmfarm__Register *m, double now, vf_farm_reply *r);

/* A worker's silence is its own (counts as a failed lease, coordinator/poison.h) only when
 * another worker was heard at least this fraction of the worker timeout after it fell
 * silent. When all fall silent together the coordinator is the one cut off (its network,
 * a stall it could not see), and blaming every worker would fail a healthy job. */
#define VF_WORKERS_HEARD_FRACTION 0.5

/* Declares the workers silent for longer than the worker timeout lost and returns their
 * leases to the pool (kept as expired, for their late results); a lease of which no part
 * was merged failed (coordinator/poison.h) when the silence is the worker's own (above).
 * Returns how many. */
int vf_workers_expire(vf_farm *farm, double now);

/* The coordinator was stalled for `gap` seconds: every registered worker's last sign of
 * life moves that much later (never past now), as if heard at the same pace meanwhile. */
void vf_workers_excuse(vf_farm *farm, double gap, double now);

/* Goodbye -> ResultAck: stopping (done false) or left (done true; the worker is departed
 * and its pointer invalid afterwards). */
void vf_workers_goodbye(vf_farm *farm, vf_farm_worker *w, const Vcmfarm__Goodbye *m, double now, vf_farm_reply *r);

/* The registered or departed worker with this id (a late result may come from a worker
 * already lost: its totals and events still name it), or NULL. */
vf_farm_worker *vf_workers_find_any(vf_farm *farm, uint64_t id);

/* The i-th departed worker kept, 0 the oldest; NULL past the last. */
const vf_farm_worker *vf_workers_departed(const vf_farm *farm, unsigned i);

/* "idle", "busy" (holds a lease), "stopping", "left" or "lost". */
const char *vf_worker_state_name(vf_farm *farm, const vf_farm_worker *w);

#endif
