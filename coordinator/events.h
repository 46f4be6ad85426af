/* What happened to a job or to the farm's workers, for `status` and its readers: a worker
 * registered, stopping, left or lost; a lease expired or revoked; a result refused; a
 * checkpoint failed; a job failed. Each with its time (Unix seconds), the job and worker
 * it concerns and a sentence.
 *
 * Bounded: a log keeps its latest `capacity` events (a job VF_JOB_EVENTS, the farm
 * VF_FARM_EVENTS) and counts those it let go, so a peer that makes the coordinator refuse
 * results forever costs it no memory. The storage belongs to the owner (an array in the
 * job or the farm); the log borrows it. Single-threaded, as the farm. */
#ifndef VF_EVENTS_H
#define VF_EVENTS_H

#include <stdint.h>

typedef struct {
  double time;       /* Unix seconds */
  uint64_t job_id;   /* 0: none */
  char kind[24];     /* worker_lost, lease_expired, ... (docs/PROTOCOL.md, "Events") */
  char worker[128];  /* the worker's name, "" none */
  char message[256];
} vf_event;

typedef struct {
  vf_event *items;   /* borrowed: `capacity` of them */
  unsigned capacity, count, next;
  uint64_t dropped;  /* events no longer kept */
} vf_events;

/* An empty log over storage (capacity >= 1). */
void vf_events_init(vf_events *log, vf_event *storage, unsigned capacity);

/* Appends an event at `time`, the oldest one making room when full. Texts are cut to fit;
 * control characters become '?'. */
void vf_events_add(vf_events *log, double time, const char *kind, uint64_t job_id, const char *worker,
                   const char *fmt, ...) __attribute__((format(printf, 6, 7)));

/* The i-th event kept, 0 the oldest; NULL past the last. */
const vf_event *vf_events_at(const vf_events *log, unsigned i);

#endif
