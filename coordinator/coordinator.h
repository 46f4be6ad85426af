/* The coordinator's event loop: one libuv loop on one thread owns a nanomsg REP socket,
 * the farm (coordinator/farm.h), a tick timer and the termination signals. Film
 * checkpoints are written beside it by libuv's thread pool (coordinator/checkpoint.h).
 *
 * nanomsg sockets are not file descriptors, but they expose two (NN_RCVFD, NN_SNDFD) that
 * become readable when a message can be received or sent; uv_poll watches them and the
 * socket is then used with NN_DONTWAIT, so the loop never blocks on the network. A REP
 * socket answers one request at a time: while a reply waits for room to be sent, the loop
 * stops receiving (backpressure instead of an unbounded queue).
 *
 * On tcp:// the TCP port is the gate's (coordinator/gate.h), which bounds connections and
 * the bytes of requests in flight and hands whole messages to the REP socket, bound to a
 * private ipc:// socket in a directory of its own (mode 0700) under $TMPDIR.
 *
 * Messages that fail decoding are logged and get no answer; those that fail
 * authentication get the fixed refusal (common/wire.h), within a budget of bytes a second,
 * else no answer; an authentic message of another protocol version gets an Error saying
 * so. */
#ifndef VF_COORDINATOR_H
#define VF_COORDINATOR_H

#include "../common/wire.h"
#include "dashboard/dashboard.h"

#include <signal.h>

typedef struct {
  const char *listen_url;      /* tcp://HOST:PORT (through coordinator/gate.h), ipc://PATH or inproc://NAME */
  size_t max_connections;      /* tcp:// only: connections at once (0: 4096) */
  size_t max_in_flight;        /* tcp:// only: bytes of requests held at once (0: 256 MiB) */
  const char *state_dir;
  const char *secret_path;     /* key file (vcmfarm keygen), read when key is NULL */
  const vf_wire_key *key;      /* else this key (copied) */
  double worker_timeout;       /* seconds; default 15 */
  double lease_seconds;        /* target lease duration; default 20 */
  double checkpoint_interval;  /* seconds between film checkpoints; default 10 */
  double forgive_seconds;      /* a worker blocked from a job is forgiven after this (coordinator/poison.h); default 300 */
  /* How it is stopped: SIGINT and SIGTERM when handle_signals, and always when *stop
   * (if not NULL; any thread may set it) becomes non-zero, seen within 10 ms. */
  int handle_signals;
  volatile sig_atomic_t *stop;
  int quiet;                   /* no log lines (coordinator/log.h) */
  /* The web dashboard (coordinator/dashboard/dashboard.h): served on http_address when it is not
   * NULL, with status_json as the status document's form (required then). */
  const char *http_address;
  vf_status_json_fn status_json;
} vf_coordinator_config;

/* Resumes the jobs of the state directory and serves until stopped (above), then stops
 * answering, waits for the checkpoints in flight and writes a final one. Returns VF_OK
 * after a clean shutdown, or the error that prevented starting (key, state directory,
 * bind) or the final checkpoint, with a detail. */
int vf_coordinator_run(const vf_coordinator_config *config);

#endif
