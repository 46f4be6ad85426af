/* The workers registered with the farm. A worker is known only by the messages it sends
 * (the farm never calls it): it registers and gets a random id, the heartbeat interval and
 * the timeout; every message of it counts as a sign of life; one silent for the worker
 * timeout is lost, and its lease returns to the pool (coordinator/leases.h) with its merged
 * parts counted. A restarted coordinator knows no worker: they register again. */
#ifndef VF_WORKERS_H
#define VF_WORKERS_H

#include "farm_core.h"
#include "farm_reply.h"

/* Register -> Registered: a new worker with a fresh random id, its name sanitised. */
void vf_workers_register(vf_farm *farm, const Vcmfarm__Register *m, double now, vf_farm_reply *r);

/* Declares the workers silent for longer than the worker timeout lost and returns their
 * leases to the pool (kept as expired, for their late results). Returns how many. */
int vf_workers_expire(vf_farm *farm, double now);

#endif
