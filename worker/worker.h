/* The farm worker's loop (docs/PROTOCOL.md): register with a coordinator, then ask for a
 * lease, render it with the one render loop (vf_render_range, worker/render/render.h), ship its
 * film as tiles during and at the end of the lease, and ask again, until told to stop.
 *
 * `vcmfarm worker` runs it (cli/worker_cmd.c). Every exchange is a request from here
 * answered by the coordinator, so a coordinator that restarts or a network that drops
 * only delays us: requests time out and are sent again with backoff, and an unknown-worker
 * answer makes us register again. */
#ifndef VF_WORKER_H
#define VF_WORKER_H

#include "../common/tags.h"
#include "../common/wire.h"

#include <signal.h>
#include <stdint.h>

/* The interval while the coordinator has said none. */
#define VF_WORKER_SHIP_SECONDS 5.0

typedef struct {
  const char *url;            /* the coordinator: tcp://HOST:PORT, ipc://PATH or inproc://NAME */
  vf_wire_key key;
  int threads;                /* render threads; <= 0: one per CPU */
  const char *name;           /* shown in status; NULL: HOST/PID */
  const vf_tags *tags;        /* given by the operator (--tags), borrowed; NULL: none */
  int no_auto_tags;           /* do not add the CPU's tags (worker/machine.h) */
  const char *cache_dir;      /* scene files by content hash (worker/blob_cache.h), opened by the caller */
  uint64_t cache_max_bytes;   /* trim the cache to this after fetching a job's files; 0: no limit */
  /* Seconds between parts of a lease (at least 50 times a part's cost); 0: the interval
   * the coordinator says in its Lease and HeartbeatAck replies (protocol 7), which it
   * chooses from its load; > 0 overrides it. */
  double ship_interval;
  int quiet;                  /* log failures only, not the ordinary course of leases */
  /* test hooks (vcmfarm worker --help) */
  int iteration_delay_ms;
  const char *stall_file;
  const char *abort_scene;    /* abort() (a crash, SIGABRT) on a lease whose built-in scene is
                               * this name or whose JSON scene text contains it */
} vf_worker_config;

/* Serves the coordinator until *stop becomes non-zero (a signal handler or another thread
 * may set it): then it finishes the iteration in progress, ships what the lease has
 * rendered, hands back the rest and returns VF_OK. Returns an error only when going on
 * cannot help (the key or the protocol version is refused). */
int vf_worker_run(const vf_worker_config *config, volatile sig_atomic_t *stop);

#endif
