#include "events.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

void vf_events_init(vf_events *log, vf_event *storage, unsigned capacity) {
  *log = (vf_events){storage, capacity, 0, 0, 0};
}

static void sanitize(char *s) {
  for (; *s; s++)
    if ((unsigned char)*s < 0x20 || *s == 0x7f) *s = '?';
}

void vf_events_add(vf_events *log, double time, const char *kind, uint64_t job_id, const char *worker,
                   const char *fmt, ...) {
  vf_event *e = &log->items[log->next];
  if (log->count == log->capacity) log->dropped++;
  else log->count++;
  log->next = (log->next + 1) % log->capacity;
  e->time = time;
  e->job_id = job_id;
  snprintf(e->kind, sizeof e->kind, "%s", kind);
  snprintf(e->worker, sizeof e->worker, "%s", worker ? worker : "");
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(e->message, sizeof e->message, fmt, ap);
  va_end(ap);
  sanitize(e->worker);
  sanitize(e->message);
}

const vf_event *vf_events_at(const vf_events *log, unsigned i) {
  if (i >= log->count) return NULL;
  return &log->items[(log->next + log->capacity - log->count + i) % log->capacity];
}
