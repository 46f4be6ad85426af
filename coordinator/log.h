/* The coordinator's log: one line per event on stderr, with the wall-clock time, so that
 * refusals, lost workers and checkpoints can be read back after the fact. */
#ifndef VF_COORDINATOR_LOG_H
#define VF_COORDINATOR_LOG_H

#include <stdarg.h>
#include <stdio.h>
#include <sys/time.h>
#include <time.h>

static inline void vf_log(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static inline void vf_log(const char *fmt, ...) {
  struct timeval tv;
  gettimeofday(&tv, NULL);
  struct tm tm;
  localtime_r(&tv.tv_sec, &tm);
  char line[2048];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(line, sizeof line, fmt, ap);
  va_end(ap);
  fprintf(stderr, "%02d:%02d:%02d.%03d coordinator: %s\n", tm.tm_hour, tm.tm_min, tm.tm_sec,
          (int)(tv.tv_usec / 1000), line);
}

#endif
