/* The farm's jobs as a whole: the users' requests about them (docs/PROTOCOL.md: submit,
 * status, fetch, cancel, remove), and a job's end when it completes or stops. */
#ifndef VF_COORDINATOR_JOBS_H
#define VF_COORDINATOR_JOBS_H

#include "farm_core.h"
#include "farm_reply.h"

/* SubmitJob: checks the job as untrusted input, keeps it durably (scene text, files,
 * reference, job list) and answers with its id. */
void vf_jobs_submit(vf_farm *farm, const Vcmfarm__SubmitJob *m, vf_farm_reply *r);
/* StatusRequest: every job (or one, with its convergence log) and every worker. */
void vf_jobs_status(vf_farm *farm, const Vcmfarm__StatusRequest *m, double now, vf_farm_reply *r);
/* FetchRequest: a chunk of the job's film file (a fetch snapshot, coordinator/checkpoint.h;
 * a new one has the film's latest measurement logged first), "wait" while it is being
 * written, or "gone" for a snapshot dropped meanwhile (docs/PROTOCOL.md, "Fetching a film"). */
void vf_jobs_fetch(vf_farm *farm, const Vcmfarm__FetchRequest *m, double now, vf_farm_reply *r);
/* CancelRequest: ends a runnable job and its leases. */
void vf_jobs_cancel(vf_farm *farm, const Vcmfarm__CancelRequest *m, double now, vf_farm_reply *r);
/* PauseRequest (pause set) or ResumeRequest: a paused job gets no new leases; the leases
 * out when it was paused stay valid, finish and ship as usual, so nothing rendered is lost
 * or counted twice. Saved in state.json before it is answered; an event of the job. A job
 * that has ended, or is already as asked, is refused (accepted false) with the reason. */
void vf_jobs_pause(vf_farm *farm, uint64_t job_id, int pause, vf_farm_reply *r);
/* RemoveRequest: forgets a job that has ended (not while its film is being written): the
 * job list without it is written first, then its files and the blobs no other job names
 * are removed, so a crash leaves at worst files nobody names. */
void vf_jobs_remove(vf_farm *farm, const Vcmfarm__RemoveRequest *m, vf_farm_reply *r);

/* A job that just completed (its film holds all its iterations) or stopped (another stop
 * condition held, job->end VF_JOB_STOPPED): logged, no more leases (the active ones are
 * revoked), and its final checkpoint started (vf_checkpoint_final). */
void vf_jobs_finish(vf_farm *farm, vf_job *job, double now);

/* After a pilot part of the job merged (or its pilot film was read back, or a pilot
 * film's addition or write landed): once the pilot film holds [0, pilot), the allocation
 * is computed (vf_job_finish_pilot; with a merge thread, there, once the pilot film's
 * additions and write in flight have landed: this is called again when they do), stored
 * as the blob leases name (vf_blobs_put_allocation), the pilot leases still out revoked,
 * and an event "pilot_done" with its summary added; the job's film, which holds it, is
 * written at the next checkpoint. A failure to compute or store it fails the job, saying
 * why. */
void vf_jobs_pilot_merged(vf_farm *farm, vf_job *job, double now);

#endif
