/* The coordinator's log: one line per event on stderr, with the wall-clock time, so that
 * refusals, lost workers and checkpoints can be read back after the fact. */
#ifndef VF_COORDINATOR_LOG_H
#define VF_COORDINATOR_LOG_H

void vf_log(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

/* Process-wide: 1 drops every line (tests that run a coordinator in their own process). */
void vf_log_set_quiet(int quiet);

#endif
