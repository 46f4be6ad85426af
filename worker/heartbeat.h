/* A worker's heartbeat: a thread with its own connection to the coordinator that, while
 * a lease is held, tells the coordinator every interval that the worker is alive and how
 * far the lease has come, and learns whether the lease is still wanted.
 *
 * A thread rather than the render loop's progress callback, so that a single iteration
 * longer than the worker timeout (big scenes, slow machines) does not get a live worker
 * declared lost. The render thread polls vf_heartbeat_revoked between iterations. */
#ifndef VF_HEARTBEAT_H
#define VF_HEARTBEAT_H

#include "../common/wire.h"

#include <signal.h>
#include <stdint.h>

typedef struct vf_heartbeat vf_heartbeat;

/* Starts the thread (idle until a lease is set). url and key are copied. While a lease is
 * held and *terminating (borrowed, may be NULL) becomes non-zero, the thread tells the
 * coordinator at once, within 0.1 s, that the worker is stopping (Goodbye, done false; once),
 * and beats on until the lease is cleared. *out on success. */
int vf_heartbeat_start(const char *url, const vf_wire_key *key, volatile sig_atomic_t *terminating,
                       vf_heartbeat **out);
/* Stops and joins the thread; NULL is a no-op. */
void vf_heartbeat_stop(vf_heartbeat *hb);

/* Beats every interval_ms for this lease until vf_heartbeat_clear_lease: the worker
 * clears it only once the lease's last part is shipped and the rest handed back, so that
 * a part waiting to be taken (a busy coordinator, a congested gate) never silences it. */
void vf_heartbeat_set_lease(vf_heartbeat *hb, uint64_t worker_id, uint64_t lease_id, int interval_ms);
void vf_heartbeat_clear_lease(vf_heartbeat *hb);
/* Progress of the current lease, sent with the next beat. Any thread. */
void vf_heartbeat_progress(vf_heartbeat *hb, uint64_t iterations_done, double seconds);
/* 1 once the coordinator said the current lease is no longer valid. Any thread. */
int vf_heartbeat_revoked(vf_heartbeat *hb);
/* 1 once the coordinator said the lease's job reached its time limit (protocol 9): stop
 * after this iteration, ship what is rendered, hand back the rest. Any thread. */
int vf_heartbeat_deliver_now(vf_heartbeat *hb);

/* The ship interval of the coordinator's latest HeartbeatAck, in milliseconds; 0 none yet
 * (protocol 7). */
uint32_t vf_heartbeat_ship_interval_ms(vf_heartbeat *hb);

#endif
