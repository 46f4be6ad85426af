/* The users' side of the farm: submitting a job, its status, its film, cancelling it and
 * removing it
 * (docs/PROTOCOL.md). The handlers answer into a vf_farm_reply like the rest of
 * coordinator/farm.c, which dispatches to them. */
#ifndef VF_COORDINATOR_JOBS_H
#define VF_COORDINATOR_JOBS_H

#include "farm.h"

/* SubmitJob: checks the job as untrusted input, keeps it durably (scene text, files,
 * reference, job list) and answers with its id. */
void vf_farm_submit(vf_farm *farm, const Vcmfarm__SubmitJob *m, vf_farm_reply *r);
/* StatusRequest: every job (or one, with its convergence log) and every worker. */
void vf_farm_status(vf_farm *farm, const Vcmfarm__StatusRequest *m, double now, vf_farm_reply *r);
/* FetchRequest: the job's film as an EXR file, its latest measurement logged first. */
void vf_farm_fetch(vf_farm *farm, const Vcmfarm__FetchRequest *m, vf_farm_reply *r);
/* CancelRequest: ends a runnable job and its leases. */
void vf_farm_cancel(vf_farm *farm, const Vcmfarm__CancelRequest *m, double now, vf_farm_reply *r);
/* RemoveRequest: forgets a job that has ended (not while its film is being written): the
 * job list without it is written first, then its files and the blobs no other job names
 * are removed, so a crash leaves at worst files nobody names. */
void vf_farm_remove(vf_farm *farm, const Vcmfarm__RemoveRequest *m, vf_farm_reply *r);

#endif
