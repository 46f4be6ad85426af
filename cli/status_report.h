/* The coordinator's Status as `vcmfarm status` shows it: text for people, JSON for
 * programs (the web dashboard reads the same fields). The JSON's shape is documented in
 * docs/PROTOCOL.md, "Status"; every number the coordinator does not know is null, never
 * a sentinel (JSON has no NaN, and -1 or 10^9 would be read as values). */
#ifndef VF_STATUS_REPORT_H
#define VF_STATUS_REPORT_H

#include "../common/message.h"

#include <stdio.h>

/* The whole status as one JSON document on out. */
void vf_status_print_json(const Vcmfarm__Status *status, FILE *out);

/* The same document on one line, malloc'ed (the caller frees it); NULL when out of
 * memory. The coordinator's dashboard serves it (vf_coordinator_config.status_json). */
char *vf_status_json_text(const Vcmfarm__Status *status);

/* The status as text on out: the farm, each job (with its log and events when the status
 * is of one job), each worker. */
void vf_status_print_text(const Vcmfarm__Status *status, FILE *out);

/* One line on a job's progress ("running, 42% (time), ETA 3.2 s, est. RMSE 0.031"), no
 * newline, into buf. */
void vf_status_job_line(const Vcmfarm__JobStatus *job, char *buf, size_t n);

#endif
