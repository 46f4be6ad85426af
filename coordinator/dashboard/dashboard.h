/* The web dashboard's side of the coordinator (docs/PROTOCOL.md, "Dashboard"): what the
 * HTTP server (coordinator/dashboard/http.h, libmicrohttpd's own threads) may know of the farm, and
 * what it may ask of it, without ever touching the farm itself.
 *
 * The farm is single-threaded (coordinator/farm_core.h), so the two threads meet in this
 * module only, under one mutex:
 *  - the loop publishes the status JSON (the document of `vcmfarm status --json`, and of
 *    `status --json JOB` for the jobs being watched) about once a second while someone
 *    reads it (nobody reading: nothing is built), and at once after an action or when a
 *    reader finds it stale; a reader copies the latest text and never waits more than
 *    VF_DASHBOARD_WAIT_SECONDS for the loop;
 *  - an action (cancel, remove, priority, pause, resume) is queued and the loop woken
 *    (uv_async); the loop runs it through the same handlers as the farm's messages
 *    (coordinator/jobs.h) and hands back an HTTP status and a sentence.
 * Films, previews and sessions need no loop: coordinator/dashboard/preview.h reads the checkpoint
 * files, coordinator/dashboard/sessions.h keeps its own table. */
#ifndef VF_DASHBOARD_H
#define VF_DASHBOARD_H

#include "../../common/message.h"
#include "../../common/wire.h"
#include "../farm_core.h"

#include <stddef.h>
#include <stdint.h>

struct uv_loop_s;

/* A Status as JSON text, malloc'ed (the caller frees it), NULL when out of memory: the
 * command line's form of it (cli/status_report.h), handed down so that the page and
 * `status --json` read the same document. */
typedef char *(*vf_status_json_fn)(const Vcmfarm__Status *status);

#define VF_DASHBOARD_WAIT_SECONDS 3.0 /* the longest a request waits for the loop */

typedef struct vf_dashboard vf_dashboard;

/* Starts serving the dashboard on address ("HOST:PORT" with a numeric IPv4 or [IPv6]
 * host or "localhost", or "PORT" alone for 127.0.0.1; port 0 picks a free one, which the
 * log line names) for this farm, on this loop's thread (both borrowed until
 * vf_dashboard_destroy); key (copied) is the farm's, which signs in a browser
 * (coordinator/dashboard/sessions.h). *out is written only on success. VF_EUSAGE for an address it
 * cannot read, VF_ENET when it cannot listen, VF_ENOMEM. */
int vf_dashboard_start(vf_farm *farm, struct uv_loop_s *loop, const vf_wire_key *key, const char *address,
                       vf_status_json_fn status_json, vf_dashboard **out);

/* On the loop's thread, once it stops serving: no more requests are answered (those
 * waiting get 503), the HTTP threads are joined and the dashboard's handles closing; run
 * the loop until they are closed, then vf_dashboard_destroy. NULL is a no-op. */
void vf_dashboard_stop(vf_dashboard *dashboard);
void vf_dashboard_destroy(vf_dashboard *dashboard);

/* ---- for the HTTP threads (coordinator/dashboard/http.c) ---- */

/* A copy of the latest status JSON (job_id 0), or of job_id's (`status --json JOB`, with
 * its convergence log), no older than about a second unless the loop is busy (then what
 * it published last). Returns 200 with *json (malloc'ed, NUL-terminated) and *len, 404
 * for a job the farm does not have, 503 when nothing could be had (stopping, or the loop
 * has not published within VF_DASHBOARD_WAIT_SECONDS). */
int vf_dashboard_status(vf_dashboard *dashboard, uint64_t job_id, char **json, size_t *len);

typedef enum {
  VF_DASHBOARD_CANCEL,
  VF_DASHBOARD_REMOVE,
  VF_DASHBOARD_PRIORITY,
  VF_DASHBOARD_PAUSE, /* coordinator/jobs.h, vf_jobs_pause */
  VF_DASHBOARD_RESUME
} vf_dashboard_verb;

typedef struct {
  vf_dashboard_verb verb;
  uint64_t job_id;
  int priority; /* VF_DASHBOARD_PRIORITY: the new weight */
} vf_dashboard_action;

/* Runs the action on the loop and waits for it: returns the HTTP status (200 done, 400
 * bad priority, 404 no such job, 409 refused in the job's state, 500 the state directory
 * failed, 503 stopping or the loop did not answer in VF_DASHBOARD_WAIT_SECONDS: it may
 * still run) with a sentence in message. */
int vf_dashboard_act(vf_dashboard *dashboard, const vf_dashboard_action *action, char *message, size_t n);

/* The farm's state directory (films are DIR/job-ID.exr), borrowed. */
const char *vf_dashboard_state_dir(const vf_dashboard *dashboard);

#endif
