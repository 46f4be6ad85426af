/* The coordinator's TCP front (docs/PROTOCOL.md, "What a peer without the key costs").
 *
 * nanomsg reads a whole message into memory before anything can look at it, accepts every
 * connection, and does not say which connection a message is on until it is whole; so over
 * nanomsg's own tcp:// listener neither the number of connections nor the bytes held for
 * unfinished messages can be bounded. When the coordinator listens on tcp://, this gate
 * owns the TCP port instead, on the coordinator's libuv loop. It speaks the SP-over-TCP
 * framing that workers' and clients' nanomsg REQ sockets expect (an 8-byte protocol
 * header, then messages of a 64-bit big-endian size and the bytes), and hands every
 * message, once whole, to the coordinator's REP socket over a private ipc:// socket, one
 * unix connection per TCP connection, so that replies find their way back. Nothing is
 * decoded or checked here beyond the framing: keys, freshness and message types stay the
 * coordinator's (common/wire.h).
 *
 * What it bounds, whoever the peer (it cannot tell who holds the key):
 * - connections: at most max_connections at once; one more is accepted and closed at once;
 * - bytes: a message's size is read from its header and reserved before its first byte is
 *   read (more than max_message closes the connection); at most max_bytes are reserved over
 *   all connections, and a connection whose next message does not fit waits, unread (TCP
 *   backpressure), in arrival order. Messages of at most small_message bytes (heartbeats,
 *   leases, status) have a lane of their own, max_small_bytes, so that they never wait
 *   behind large ones a peer announced and never finishes. A message stays reserved until
 *   the coordinator answers it (its reply carries the request's id) or for answer_seconds,
 *   so the bound covers the copies inside nanomsg and the coordinator as well as the
 *   gate's own buffer; one connection has at most 8 requests unanswered;
 * - time: the protocol header within handshake_seconds; a message once begun keeps coming
 *   (stall_seconds between bytes, and all of it within stall_seconds + its size / min_rate,
 *   counted from when it got its room); a connection with nothing in flight for idle_seconds is
 *   closed (nanomsg's REQ sockets connect again by themselves); a peer that leaves more
 *   than max_unsent bytes of replies unread is closed.
 * Each connection costs the process three descriptors (the TCP socket, and both ends of its
 * unix connection); vf_gate_start lowers max_connections to what RLIMIT_NOFILE allows. */
#ifndef VF_GATE_H
#define VF_GATE_H

#include <stddef.h>
#include <stdint.h>

struct uv_loop_s;

typedef struct {
  size_t max_connections;   /* default 4096 */
  size_t max_bytes;         /* bytes reserved for large requests over all connections; default 256 MiB */
  size_t small_message;     /* default 64 KiB */
  size_t max_small_bytes;   /* bytes reserved for small requests; default 16 MiB */
  double min_rate;          /* bytes per second a message must average; default 64 KiB/s */
  size_t max_message;       /* a request's size on the wire (with nanomsg's 4-byte header) */
  size_t max_reply;         /* a reply's; larger is a broken upstream, and closes */
  size_t max_unsent;        /* reply bytes a peer may leave unread; default 64 MiB */
  double handshake_seconds; /* default 10 */
  double stall_seconds;     /* default 30 */
  double idle_seconds;      /* default 600 */
  double answer_seconds;    /* default 60 */
} vf_gate_limits;

/* The defaults above for max_message and max_reply of the caller's protocol. */
vf_gate_limits vf_gate_defaults(size_t max_message, size_t max_reply);

typedef struct {
  size_t connections;       /* open now */
  size_t bytes_reserved;    /* now, <= max_bytes */
  size_t waiting;           /* connections waiting for room */
  uint64_t accepted, refused_at_cap, closed_for_size, closed_for_time, closed_for_framing, closed_for_unread, closed_idle;
  uint64_t forwarded, answered, answers_given_up;
  size_t peak_bytes_reserved, peak_connections;
} vf_gate_stats;

typedef struct vf_gate vf_gate;

/* Listens on `tcp_url` (tcp://HOST:PORT: HOST an address, a name, or * for every IPv4
 * interface; PORT 0 picks one, see vf_gate_port) and forwards to the unix socket at
 * `upstream_path`, where a nanomsg REP socket is bound. Limits of 0 take the defaults.
 * VF_EUSAGE for a URL it cannot parse, VF_ENET when the port cannot be had, with a detail. */
int vf_gate_start(struct uv_loop_s *loop, const char *tcp_url, const char *upstream_path,
                  const vf_gate_limits *limits, vf_gate **out);

/* The port listened on. */
int vf_gate_port(const vf_gate *g);

/* Stops listening and closes every connection; their memory is freed as the loop runs
 * their close callbacks, and the gate itself by vf_gate_destroy after that. */
void vf_gate_close(vf_gate *g);
/* Frees the gate now, or, when its handles are still closing, as the loop finishes
 * closing them. NULL: nothing. */
void vf_gate_destroy(vf_gate *g);

void vf_gate_get_stats(const vf_gate *g, vf_gate_stats *s);
const vf_gate_limits *vf_gate_get_limits(const vf_gate *g);

#endif
