/* Monotonic wall-clock time in seconds, for rates, time limits and phase timings; and the
 * calendar time, for timestamps people read (when a job was submitted, an event). */
#ifndef VF_CLOCK_H
#define VF_CLOCK_H

#include <time.h>

static inline double vf_seconds_now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Seconds since the Unix epoch (CLOCK_REALTIME: it may jump; never use it for durations). */
static inline double vf_unix_now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_REALTIME, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

#endif
