/* The merge thread: the heavy work of results, off the event loop. One thread takes work
 * items in the order the loop queues them (FIFO), runs each item's `work` there, and hands
 * it back to the loop, which runs its `done` in the same order. So the items of one lease,
 * and every change to one job's film, happen in the order the loop decided, whatever the
 * loop answers meanwhile: heartbeats and leases are answered while a part is decoded and
 * merged (docs/PROTOCOL.md, "Merging off the loop").
 *
 * What runs on the thread touches only what its item owns or what the loop has promised
 * not to read meanwhile (a job film's pixels while an addition to them is in flight:
 * vf_job's `merging`). The queue is bounded (VF_MERGER_QUEUE items): the loop asks
 * vf_merger_full before queuing and tells a sender to come back later when it is.
 *
 * The thread also measures itself: the seconds it spent working, so that the coordinator
 * can choose how often workers ship from its own load (coordinator/ship.h). */
#ifndef VF_MERGER_H
#define VF_MERGER_H

#include <stddef.h>

struct uv_loop_s;

#define VF_MERGER_QUEUE 32

typedef struct vf_merge_item vf_merge_item;
struct vf_merge_item {
  vf_merge_item *next;                  /* the merger's link */
  void (*work)(vf_merge_item *item);    /* on the merge thread */
  void (*done)(vf_merge_item *item);    /* back on the loop, in queue order; frees the item */
  double seconds;                       /* set by the merger: how long `work` ran */
};

typedef struct vf_merger vf_merger;

/* Starts the thread; items come back through this loop (which must outlive the merger).
 * VF_ENOMEM with a detail. *out on success only. */
int vf_merger_start(struct uv_loop_s *loop, vf_merger **out);
/* Finishes every item queued (each `done` runs, on the caller's thread, which must be the
 * loop's), then stops the thread and frees it. NULL: nothing. */
void vf_merger_stop(vf_merger *m);

/* Queues an item (the merger holds it until its `done`). Never fails: callers check
 * vf_merger_full first; the bound is theirs to keep. */
void vf_merger_queue(vf_merger *m, vf_merge_item *item);
/* Items queued or being worked on or waiting for their `done`. */
size_t vf_merger_pending(const vf_merger *m);
int vf_merger_full(const vf_merger *m);
/* Seconds the thread has spent in `work` since it started (any thread may ask). */
double vf_merger_busy_seconds(vf_merger *m);

#endif
