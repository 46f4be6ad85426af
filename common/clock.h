/* Monotonic wall-clock time in seconds, for rates, time limits and phase timings. */
#ifndef VF_CLOCK_H
#define VF_CLOCK_H

#include <time.h>

static inline double vf_seconds_now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

#endif
