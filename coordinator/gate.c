#include "gate.h"

#include "../common/clock.h"
#include "../common/error.h"
#include "log.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <uv.h>

#define SWEEP_MS 250
#define OUTSTANDING_MAX 8     /* requests of one connection forwarded and not yet answered */
#define PEER_LOG_SECONDS 10.0 /* what peers cause is logged at most once per kind in this time */
#define DESCRIPTORS_PER_CONNECTION 3
#define DESCRIPTORS_KEPT 256  /* for the state directory, nanomsg, the dashboard, ... */
/* Unix connections to the REP socket that nanomsg has not accepted yet (its SP header has
 * not come back). nanomsg listens with a backlog of 10, and a connect beyond a full
 * backlog fails at once (EAGAIN): a burst of TCP connections is passed on a few at a time. */
#define CONNECT_WINDOW 8

/* SP's protocol header (nanomsg's streamhdr): "\0SP\0", the protocol in 16 bits
 * big-endian, two zero bytes. REQ is 3 * 16 + 0, REP 3 * 16 + 1. */
#define SP_REQ 48
#define SP_REP 49
/* Over ipc://, each message starts with a type byte, 1 for a normal message. */
#define IPC_MESSAGE 1

typedef struct {
  uint32_t id;     /* the request id nanomsg's REQ puts first; a reply starts with it */
  size_t bytes;
  int lane;
  double since;
} outstanding;

/* Requests of at most small_message bytes (heartbeats, leases, status, ...) take their room
 * from a lane of their own, so that they never queue behind large ones (results, blob
 * chunks) that peers may announce and never finish. */
enum { LARGE, SMALL };

enum { LOG_REFUSED, LOG_SIZE, LOG_FRAMING, LOG_TIME, LOG_UNREAD, LOG_KINDS };

typedef enum { IN_HELLO, IN_HEADER, IN_BODY, IN_WAITING_ROOM, IN_FORWARDING } in_state;

typedef enum { CONNECT_NONE, CONNECT_QUEUED, CONNECT_WAITING } connect_state;

typedef struct conn {
  struct conn *prev, *next;       /* every connection */
  struct conn *connect_next;      /* waiting to connect to the REP socket, in arrival order */
  connect_state connecting;
  struct conn *wait_next;         /* waiting for room, in arrival order */
  vf_gate *gate;
  uv_tcp_t tcp;
  uv_pipe_t pipe;
  uv_connect_t connect;
  uv_write_t up_write;
  int handles_open, closing, pipe_ready;
  int waiting;      /* in the gate's queue for room */
  int blocked_self; /* OUTSTANDING_MAX requests unanswered: waits for one of its own */
  double accepted_at, last_byte, last_activity;
  /* requests, peer -> coordinator */
  in_state in;
  uint8_t hello[8], header[8], up_header[9];
  size_t hello_got, header_got;
  uint8_t *body;
  size_t body_len, body_got, reserved; /* reserved: the message being read or forwarded */
  int lane;                            /* its lane (SMALL or LARGE) */
  double body_deadline;                /* the whole message by then */
  outstanding out[OUTSTANDING_MAX];
  int num_out;
  /* replies, coordinator -> peer */
  uint8_t up_hello[8], reply_header[9];
  size_t up_hello_got, reply_header_got;
  uint8_t *reply;
  size_t reply_len, reply_got, unsent;
} conn;

typedef struct {
  uv_write_t req;
  conn *c;
  uint8_t header[8];
  uint8_t *body;
  size_t bytes;
} reply_write;

struct vf_gate {
  uv_loop_t *loop;
  uv_tcp_t server;
  uv_timer_t sweep;
  char *upstream;
  vf_gate_limits limits;
  vf_gate_stats stats;
  conn *conns;
  conn *wait_head[2], **wait_tail[2];
  conn *connect_head, **connect_tail;
  int connecting; /* CONNECT_WAITING connections, at most CONNECT_WINDOW */
  size_t lane_bytes[2];
  int port, closed, handles_open, free_when_closed;
  double log_last[LOG_KINDS];
  uint64_t log_skipped[LOG_KINDS];
};

static const uint8_t hello_rep[8] = {0, 'S', 'P', 0, 0, SP_REP, 0, 0};
static const uint8_t hello_req[8] = {0, 'S', 'P', 0, 0, SP_REQ, 0, 0};

vf_gate_limits vf_gate_defaults(size_t max_message, size_t max_reply) {
  vf_gate_limits l = {.max_connections = 4096,
                      .max_bytes = (size_t)256 << 20,
                      .small_message = (size_t)64 << 10,
                      .max_small_bytes = (size_t)16 << 20,
                      .min_rate = 65536.0,
                      .max_message = max_message,
                      .max_reply = max_reply,
                      .max_unsent = (size_t)64 << 20,
                      .handshake_seconds = 10.0,
                      .stall_seconds = 30.0,
                      .idle_seconds = 600.0,
                      .answer_seconds = 60.0};
  return l;
}

static uint64_t get_be64(const uint8_t *p) {
  uint64_t v = 0;
  for (int i = 0; i < 8; i++) v = v << 8 | p[i];
  return v;
}

static void put_be64(uint8_t *p, uint64_t v) {
  for (int i = 7; i >= 0; i--, v >>= 8) p[i] = (uint8_t)v;
}

static uint32_t get_be32(const uint8_t *p) {
  return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

/* A line about what a peer did, at most one of a kind per PEER_LOG_SECONDS, with the count
 * of those left out: peers cannot fill the log. */
static void peer_log(vf_gate *g, int kind, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void peer_log(vf_gate *g, int kind, const char *fmt, ...) {
  double now = vf_seconds_now();
  if (g->log_last[kind] > 0 && now - g->log_last[kind] < PEER_LOG_SECONDS) {
    g->log_skipped[kind]++;
    return;
  }
  char line[512];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(line, sizeof line, fmt, ap);
  va_end(ap);
  if (g->log_skipped[kind] > 0)
    vf_log("tcp: %s (and %llu more like it in the last %.0f s)", line, (unsigned long long)g->log_skipped[kind],
           now - g->log_last[kind]);
  else
    vf_log("tcp: %s", line);
  g->log_last[kind] = now;
  g->log_skipped[kind] = 0;
}

/* ---- room: the bytes reserved over all connections ---- */

static void read_downstream(conn *c);

static size_t lane_limit(const vf_gate *g, int lane) {
  return lane == SMALL ? g->limits.max_small_bytes : g->limits.max_bytes;
}

static void give_back(vf_gate *g, int lane, size_t bytes) {
  g->lane_bytes[lane] -= bytes;
  g->stats.bytes_reserved -= bytes;
  /* Wake waiters in arrival order while the first fits: a large message is not overtaken
   * forever by smaller ones behind it. */
  while (g->wait_head[lane] != NULL) {
    conn *w = g->wait_head[lane];
    if (g->lane_bytes[lane] + w->body_len > lane_limit(g, lane)) break;
    g->wait_head[lane] = w->wait_next;
    if (g->wait_head[lane] == NULL) g->wait_tail[lane] = &g->wait_head[lane];
    w->wait_next = NULL;
    w->waiting = 0;
    g->stats.waiting--;
    read_downstream(w); /* takes its room */
  }
}

/* The connection has read a header (body_len): it takes its room now, or queues for it. */
static void want_room(conn *c) {
  vf_gate *g = c->gate;
  c->in = IN_WAITING_ROOM;
  if (c->num_out == OUTSTANDING_MAX) {
    c->blocked_self = 1;
    return;
  }
  int lane = c->lane = c->body_len <= g->limits.small_message ? SMALL : LARGE;
  if (g->wait_head[lane] == NULL && g->lane_bytes[lane] + c->body_len <= lane_limit(g, lane)) {
    read_downstream(c);
    return;
  }
  c->waiting = 1;
  c->wait_next = NULL;
  *g->wait_tail[lane] = c;
  g->wait_tail[lane] = &c->wait_next;
  g->stats.waiting++;
}

/* One of c's requests is answered or given up: its room comes back. */
static void settle(conn *c, int i) {
  vf_gate *g = c->gate;
  size_t bytes = c->out[i].bytes;
  int lane = c->out[i].lane;
  c->out[i] = c->out[--c->num_out];
  if (c->blocked_self && !c->closing) {
    c->blocked_self = 0;
    want_room(c);
  }
  give_back(g, lane, bytes);
}

static void unqueue(conn *c) {
  vf_gate *g = c->gate;
  if (!c->waiting) return;
  conn **p = &g->wait_head[c->lane];
  while (*p != c) p = &(*p)->wait_next;
  *p = c->wait_next;
  if (*p == NULL) g->wait_tail[c->lane] = p;
  c->wait_next = NULL;
  c->waiting = 0;
  g->stats.waiting--;
}

/* ---- closing ---- */

static void on_closed(uv_handle_t *h) {
  conn *c = h->data;
  if (--c->handles_open > 0) return;
  vf_gate *g = c->gate;
  size_t held[2] = {0, 0};
  held[c->lane] = c->reserved;
  for (int i = 0; i < c->num_out; i++) held[c->out[i].lane] += c->out[i].bytes;
  c->reserved = 0;
  c->num_out = 0;
  if (c->prev) c->prev->next = c->next;
  else g->conns = c->next;
  if (c->next) c->next->prev = c->prev;
  g->stats.connections--;
  free(c->body);
  free(c->reply);
  free(c);
  for (int lane = 0; lane < 2; lane++)
    if (held[lane] > 0) give_back(g, lane, held[lane]);
}

static void pump_connects(vf_gate *g);

static void close_conn(conn *c) {
  if (c->closing) return;
  c->closing = 1;
  unqueue(c);
  vf_gate *g = c->gate;
  if (c->connecting == CONNECT_QUEUED) {
    conn **p = &g->connect_head;
    while (*p != c) p = &(*p)->connect_next;
    *p = c->connect_next;
    if (*p == NULL) g->connect_tail = p;
  } else if (c->connecting == CONNECT_WAITING) {
    g->connecting--;
  }
  c->connecting = CONNECT_NONE;
  pump_connects(g);
  uv_close((uv_handle_t *)&c->tcp, on_closed);
  uv_close((uv_handle_t *)&c->pipe, on_closed);
}

/* ---- requests: peer -> gate -> coordinator ---- */

static void on_forwarded(uv_write_t *w, int status) {
  conn *c = w->data;
  free(c->body);
  c->body = NULL;
  if (c->closing) return; /* its room comes back in on_closed */
  if (status < 0) {
    close_conn(c);
    return;
  }
  c->in = IN_HEADER;
  c->header_got = 0;
  read_downstream(c);
}

/* A whole request: remembered as outstanding (its room stays taken until its answer) and
 * written to the coordinator's socket; the peer is not read meanwhile. */
static void forward(conn *c) {
  vf_gate *g = c->gate;
  outstanding *o = &c->out[c->num_out++];
  o->id = c->body_len >= 4 ? get_be32(c->body) : 0;
  o->bytes = c->reserved;
  o->lane = c->lane;
  o->since = vf_seconds_now();
  c->reserved = 0;
  c->in = IN_FORWARDING;
  g->stats.forwarded++;
  c->up_header[0] = IPC_MESSAGE;
  put_be64(c->up_header + 1, c->body_len);
  uv_buf_t bufs[2] = {uv_buf_init((char *)c->up_header, 9), uv_buf_init((char *)c->body, (unsigned)c->body_len)};
  c->up_write.data = c;
  if (uv_write(&c->up_write, (uv_stream_t *)&c->pipe, bufs, 2, on_forwarded) != 0) close_conn(c);
}

/* A header read: the size is checked (-1: too large). */
static int check_size(conn *c) {
  vf_gate *g = c->gate;
  uint64_t size = get_be64(c->header);
  if (size > g->limits.max_message) {
    peer_log(g, LOG_SIZE, "a peer announced a message of %llu bytes, more than the %zu a request may have; closed",
             (unsigned long long)size, g->limits.max_message);
    g->stats.closed_for_size++;
    return -1;
  }
  c->body_len = (size_t)size;
  c->body_got = 0;
  return 0;
}

static void take_room(conn *c) {
  vf_gate *g = c->gate;
  c->reserved = c->body_len;
  g->lane_bytes[c->lane] += c->body_len;
  g->stats.bytes_reserved += c->body_len;
  c->last_byte = vf_seconds_now(); /* the wait was the gate's, not the peer's */
  c->body_deadline = c->last_byte + g->limits.stall_seconds + (double)c->body_len / g->limits.min_rate;
  if (g->stats.bytes_reserved > g->stats.peak_bytes_reserved) g->stats.peak_bytes_reserved = g->stats.bytes_reserved;
  c->in = IN_BODY;
}

/* What is left to read of a message of `len` bytes, `got` read: the whole rest (in pieces of
 * at most 1 GiB, what a uv_buf_t holds), never a byte of the next message. */
static uv_buf_t rest_of(uint8_t *message, size_t got, size_t len) {
  size_t left = len - got;
  return uv_buf_init((char *)message + got, (unsigned)(left < (1u << 30) ? left : (1u << 30)));
}

static void alloc_downstream(uv_handle_t *h, size_t suggested, uv_buf_t *buf) {
  conn *c = h->data;
  (void)suggested;
  switch (c->in) {
  case IN_HELLO: *buf = uv_buf_init((char *)c->hello + c->hello_got, (unsigned)(8 - c->hello_got)); break;
  case IN_HEADER: *buf = uv_buf_init((char *)c->header + c->header_got, (unsigned)(8 - c->header_got)); break;
  case IN_BODY: *buf = rest_of(c->body, c->body_got, c->body_len); break;
  default: *buf = uv_buf_init(NULL, 0); break; /* not reading: libuv stops with UV_ENOBUFS */
  }
}

static void on_downstream(uv_stream_t *s, ssize_t n, const uv_buf_t *buf);

/* Reads the peer in the state it is in, starting a body whose room is free. */
static void read_downstream(conn *c) {
  if (c->closing) return;
  if (c->in == IN_WAITING_ROOM) {
    take_room(c);
    if ((c->body = malloc(c->body_len ? c->body_len : 1)) == NULL) {
      vf_log("tcp: out of memory for a message of %zu bytes; connection closed", c->body_len);
      close_conn(c);
      return;
    }
    if (c->body_len == 0) {
      forward(c);
      return;
    }
  }
  uv_read_start((uv_stream_t *)&c->tcp, alloc_downstream, on_downstream);
}

static void on_downstream(uv_stream_t *s, ssize_t n, const uv_buf_t *buf) {
  conn *c = s->data;
  vf_gate *g = c->gate;
  (void)buf;
  if (n == 0) return;
  if (n < 0) {
    close_conn(c); /* the peer left, or UV_ENOBUFS past a state that reads nothing */
    return;
  }
  double now = vf_seconds_now();
  c->last_byte = c->last_activity = now;
  switch (c->in) {
  case IN_HELLO:
    if ((c->hello_got += (size_t)n) < 8) return;
    if (memcmp(c->hello, hello_req, 8) != 0) {
      g->stats.closed_for_framing++;
      peer_log(g, LOG_FRAMING, "a peer's first bytes are not the SP header of a REQ socket; closed");
      close_conn(c);
      return;
    }
    c->in = IN_HEADER;
    c->header_got = 0;
    return;
  case IN_HEADER: {
    if ((c->header_got += (size_t)n) < 8) return;
    if (check_size(c) < 0) {
      close_conn(c);
      return;
    }
    uv_read_stop(s);
    want_room(c);
    return;
  }
  case IN_BODY:
    if ((c->body_got += (size_t)n) < c->body_len) return;
    uv_read_stop(s);
    if (c->pipe_ready) forward(c);
    else c->in = IN_FORWARDING; /* forwarded once the coordinator's socket is connected */
    return;
  default: return;
  }
}

/* ---- replies: coordinator -> gate -> peer ---- */

static void on_reply_sent(uv_write_t *w, int status) {
  reply_write *r = (reply_write *)w;
  conn *c = r->c;
  c->unsent -= r->bytes;
  free(r->body);
  free(r);
  if (status < 0 && !c->closing) close_conn(c);
}

static void answered(conn *c, uint32_t id) {
  for (int i = 0; i < c->num_out; i++) {
    if (c->out[i].id != id) continue;
    c->gate->stats.answered++;
    settle(c, i);
    return;
  }
}

static void send_reply(conn *c) {
  vf_gate *g = c->gate;
  uint8_t *body = c->reply;
  size_t len = c->reply_len;
  c->reply = NULL;
  if (len >= 4) answered(c, get_be32(body));
  if (c->closing) {
    free(body);
    return;
  }
  reply_write *r = malloc(sizeof *r);
  if (r == NULL) {
    free(body);
    close_conn(c);
    return;
  }
  r->c = c;
  r->body = body;
  r->bytes = len + 8;
  put_be64(r->header, len);
  c->unsent += r->bytes;
  uv_buf_t bufs[2] = {uv_buf_init((char *)r->header, 8), uv_buf_init((char *)body, (unsigned)len)};
  if (uv_write(&r->req, (uv_stream_t *)&c->tcp, bufs, 2, on_reply_sent) != 0) {
    c->unsent -= r->bytes;
    free(body);
    free(r);
    close_conn(c);
    return;
  }
  if (c->unsent > g->limits.max_unsent) {
    peer_log(g, LOG_UNREAD, "a peer left %zu bytes of replies unread; closed", c->unsent);
    g->stats.closed_for_unread++;
    close_conn(c);
  }
}

static void alloc_upstream(uv_handle_t *h, size_t suggested, uv_buf_t *buf) {
  conn *c = h->data;
  (void)suggested;
  if (c->up_hello_got < 8)
    *buf = uv_buf_init((char *)c->up_hello + c->up_hello_got, (unsigned)(8 - c->up_hello_got));
  else if (c->reply == NULL)
    *buf = uv_buf_init((char *)c->reply_header + c->reply_header_got, (unsigned)(9 - c->reply_header_got));
  else
    *buf = rest_of(c->reply, c->reply_got, c->reply_len);
}

static void on_upstream(uv_stream_t *s, ssize_t n, const uv_buf_t *buf) {
  conn *c = s->data;
  vf_gate *g = c->gate;
  (void)buf;
  if (n == 0) return;
  if (n < 0) {
    close_conn(c); /* the coordinator dropped this pipe */
    return;
  }
  if (c->up_hello_got < 8) {
    if ((c->up_hello_got += (size_t)n) < 8) return;
    if (memcmp(c->up_hello, hello_rep, 8) != 0) {
      vf_log("tcp: the coordinator's socket did not answer as a REP socket; connection closed");
      close_conn(c);
      return;
    }
    c->connecting = CONNECT_NONE; /* nanomsg accepted it: room in its backlog for the next */
    g->connecting--;
    pump_connects(g);
    return;
  }
  if (c->reply == NULL) {
    if ((c->reply_header_got += (size_t)n) < 9) return;
    c->reply_header_got = 0;
    uint64_t size = get_be64(c->reply_header + 1);
    if (c->reply_header[0] != IPC_MESSAGE || size > g->limits.max_reply) {
      vf_log("tcp: a reply of type %u and %llu bytes from the coordinator's socket; connection closed",
             c->reply_header[0], (unsigned long long)size);
      close_conn(c);
      return;
    }
    c->reply_len = (size_t)size;
    c->reply_got = 0;
    if ((c->reply = malloc(size ? size : 1)) == NULL) {
      close_conn(c);
      return;
    }
    if (size == 0) send_reply(c);
    return;
  }
  if ((c->reply_got += (size_t)n) < c->reply_len) return;
  c->last_activity = vf_seconds_now();
  send_reply(c);
}

static void on_pipe_connected(uv_connect_t *req, int status) {
  conn *c = req->data;
  if (c->closing) return;
  if (status < 0) {
    vf_log("tcp: cannot reach the coordinator's socket: %s; connection closed", uv_strerror(status));
    close_conn(c);
    return;
  }
  uv_buf_t hello = uv_buf_init((char *)hello_req, 8);
  if (uv_try_write((uv_stream_t *)&c->pipe, &hello, 1) != 8) { /* an empty new socket takes 8 bytes */
    close_conn(c);
    return;
  }
  c->pipe_ready = 1;
  uv_read_start((uv_stream_t *)&c->pipe, alloc_upstream, on_upstream);
  if (c->in == IN_FORWARDING) forward(c); /* a request was whole before the socket was */
}

static void pump_connects(vf_gate *g) {
  while (!g->closed && g->connecting < CONNECT_WINDOW && g->connect_head != NULL) {
    conn *c = g->connect_head;
    g->connect_head = c->connect_next;
    if (g->connect_head == NULL) g->connect_tail = &g->connect_head;
    c->connect_next = NULL;
    c->connecting = CONNECT_WAITING;
    g->connecting++;
    uv_pipe_connect(&c->connect, &c->pipe, g->upstream, on_pipe_connected);
  }
}

/* ---- accepting ---- */

static void on_refused_closed(uv_handle_t *h) { free(h); }

static void refuse(vf_gate *g, uv_stream_t *server) {
  uv_tcp_t *t = malloc(sizeof *t);
  if (t == NULL) return;
  uv_tcp_init(g->loop, t);
  if (uv_accept(server, (uv_stream_t *)t) == 0) {
    /* A reset rather than a polite close: the peer learns at once. */
    uv_tcp_close_reset(t, on_refused_closed);
  } else {
    uv_close((uv_handle_t *)t, on_refused_closed);
  }
  g->stats.refused_at_cap++;
  peer_log(g, LOG_REFUSED, "a connection refused at the cap of %zu", g->limits.max_connections);
}

static void on_connection(uv_stream_t *server, int status) {
  vf_gate *g = server->data;
  if (status < 0) {
    vf_log("tcp: accept: %s", uv_strerror(status));
    return;
  }
  if (g->stats.connections >= g->limits.max_connections) {
    refuse(g, server);
    return;
  }
  conn *c = calloc(1, sizeof *c);
  if (c == NULL) {
    refuse(g, server);
    return;
  }
  c->gate = g;
  uv_tcp_init(g->loop, &c->tcp);
  uv_pipe_init(g->loop, &c->pipe, 0);
  c->tcp.data = c->pipe.data = c->connect.data = c;
  c->handles_open = 2;
  c->next = g->conns;
  if (g->conns) g->conns->prev = c;
  g->conns = c;
  g->stats.connections++;
  if (g->stats.connections > g->stats.peak_connections) g->stats.peak_connections = g->stats.connections;
  if (uv_accept(server, (uv_stream_t *)&c->tcp) != 0) {
    close_conn(c);
    return;
  }
  g->stats.accepted++;
  c->accepted_at = c->last_byte = c->last_activity = vf_seconds_now();
  c->in = IN_HELLO;
  uv_tcp_nodelay(&c->tcp, 1);
  uv_tcp_keepalive(&c->tcp, 1, 60);
  uv_buf_t hello = uv_buf_init((char *)hello_rep, 8);
  if (uv_try_write((uv_stream_t *)&c->tcp, &hello, 1) != 8) {
    close_conn(c);
    return;
  }
  c->connecting = CONNECT_QUEUED;
  *g->connect_tail = c;
  g->connect_tail = &c->connect_next;
  pump_connects(g);
  uv_read_start((uv_stream_t *)&c->tcp, alloc_downstream, on_downstream);
}

/* ---- deadlines ---- */

static void on_sweep(uv_timer_t *t) {
  vf_gate *g = t->data;
  double now = vf_seconds_now();
  const vf_gate_limits *l = &g->limits;
  for (conn *c = g->conns, *next; c != NULL; c = next) {
    next = c->next;
    if (c->closing) continue;
    for (int i = 0; i < c->num_out;) {
      if (now - c->out[i].since < l->answer_seconds) {
        i++;
        continue;
      }
      g->stats.answers_given_up++; /* never answered: its room comes back anyway */
      settle(c, i);
    }
    if (c->closing) continue;
    const char *why = NULL;
    if ((c->in == IN_HELLO || !c->pipe_ready) && now - c->accepted_at > l->handshake_seconds)
      why = "no protocol header";
    else if (((c->in == IN_HEADER && c->header_got > 0) || c->in == IN_BODY) && now - c->last_byte > l->stall_seconds)
      why = "a message stalled";
    else if (c->in == IN_BODY && now > c->body_deadline)
      why = "a message came too slowly";
    if (why != NULL) {
      peer_log(g, LOG_TIME, "%s within the time allowed; connection closed", why);
      g->stats.closed_for_time++;
      close_conn(c);
    } else if (c->in == IN_HEADER && c->header_got == 0 && c->num_out == 0 && c->unsent == 0 &&
               now - c->last_activity > l->idle_seconds) {
      g->stats.closed_idle++; /* nanomsg's REQ sockets connect again when they need to */
      close_conn(c);
    }
  }
}

/* ---- the listener ---- */

/* tcp://HOST:PORT into an address; HOST may be [v6], a literal, a name, or *. */
static int parse_url(const char *url, struct sockaddr_storage *addr) {
  if (strncmp(url, "tcp://", 6) != 0) return vf_error_set(VF_EUSAGE, "%s: not a tcp:// URL", url);
  const char *hp = url + 6, *colon = strrchr(hp, ':');
  if (colon == NULL || colon == hp) return vf_error_set(VF_EUSAGE, "%s: no HOST:PORT", url);
  char *end;
  long port = strtol(colon + 1, &end, 10);
  if (*end != '\0' || end == colon + 1 || port < 0 || port > 65535)
    return vf_error_set(VF_EUSAGE, "%s: the port is not a number from 0 to 65535", url);
  char host[256];
  size_t n = (size_t)(colon - hp);
  if (n >= sizeof host) return vf_error_set(VF_EUSAGE, "%s: the host is too long", url);
  memcpy(host, hp, n);
  host[n] = '\0';
  if (n >= 2 && host[0] == '[' && host[n - 1] == ']') {
    memmove(host, host + 1, n - 2);
    host[n - 2] = '\0';
  }
  if (strcmp(host, "*") == 0) strcpy(host, "0.0.0.0");
  char service[8];
  snprintf(service, sizeof service, "%ld", port);
  struct addrinfo hints = {.ai_family = AF_UNSPEC, .ai_socktype = SOCK_STREAM, .ai_flags = AI_PASSIVE}, *res;
  int rc = getaddrinfo(host, service, &hints, &res);
  if (rc != 0) return vf_error_set(VF_EUSAGE, "%s: cannot resolve %s: %s", url, host, gai_strerror(rc));
  memcpy(addr, res->ai_addr, res->ai_addrlen);
  freeaddrinfo(res);
  return VF_OK;
}

/* Connections the descriptor limit allows, raising the soft limit to the hard one. */
static size_t descriptor_room(void) {
  struct rlimit r;
  if (getrlimit(RLIMIT_NOFILE, &r) != 0) return SIZE_MAX;
  if (r.rlim_cur < r.rlim_max) {
    struct rlimit raised = {r.rlim_max, r.rlim_max};
    if (setrlimit(RLIMIT_NOFILE, &raised) == 0) r = raised;
  }
  if (r.rlim_cur == RLIM_INFINITY) return SIZE_MAX;
  if (r.rlim_cur <= DESCRIPTORS_KEPT) return 1;
  return (size_t)((r.rlim_cur - DESCRIPTORS_KEPT) / DESCRIPTORS_PER_CONNECTION);
}

int vf_gate_start(uv_loop_t *loop, const char *tcp_url, const char *upstream_path, const vf_gate_limits *limits,
                  vf_gate **out) {
  struct sockaddr_storage addr;
  int err = parse_url(tcp_url, &addr);
  if (err != VF_OK) return err;
  vf_gate *g = calloc(1, sizeof *g);
  if (g == NULL || (g->upstream = strdup(upstream_path)) == NULL) {
    free(g);
    return vf_error_set(VF_ENOMEM, "out of memory");
  }
  vf_gate_limits d = vf_gate_defaults(limits->max_message, limits->max_reply);
  g->limits = *limits;
  if (!g->limits.max_connections) g->limits.max_connections = d.max_connections;
  if (!g->limits.max_bytes) g->limits.max_bytes = d.max_bytes;
  if (!g->limits.small_message) g->limits.small_message = d.small_message;
  if (!g->limits.max_small_bytes) g->limits.max_small_bytes = d.max_small_bytes;
  if (g->limits.min_rate <= 0) g->limits.min_rate = d.min_rate;
  if (g->limits.max_small_bytes < g->limits.small_message) g->limits.max_small_bytes = g->limits.small_message;
  if (!g->limits.max_unsent) g->limits.max_unsent = d.max_unsent;
  if (g->limits.handshake_seconds <= 0) g->limits.handshake_seconds = d.handshake_seconds;
  if (g->limits.stall_seconds <= 0) g->limits.stall_seconds = d.stall_seconds;
  if (g->limits.idle_seconds <= 0) g->limits.idle_seconds = d.idle_seconds;
  if (g->limits.answer_seconds <= 0) g->limits.answer_seconds = d.answer_seconds;
  if (g->limits.max_bytes < g->limits.max_message) g->limits.max_bytes = g->limits.max_message; /* one must fit */
  size_t room = descriptor_room();
  if (g->limits.max_connections > room) {
    vf_log("tcp: at most %zu connections, not %zu: the descriptor limit (ulimit -n) allows %d per connection",
           room, g->limits.max_connections, DESCRIPTORS_PER_CONNECTION);
    g->limits.max_connections = room;
  }
  g->loop = loop;
  g->wait_tail[LARGE] = &g->wait_head[LARGE];
  g->wait_tail[SMALL] = &g->wait_head[SMALL];
  g->connect_tail = &g->connect_head;
  uv_tcp_init(loop, &g->server);
  uv_timer_init(loop, &g->sweep);
  g->server.data = g->sweep.data = g;
  int rc = uv_tcp_bind(&g->server, (struct sockaddr *)&addr, 0);
  if (rc == 0) rc = uv_listen((uv_stream_t *)&g->server, SOMAXCONN, on_connection);
  if (rc != 0) {
    err = vf_error_set(VF_ENET, "cannot listen on %s: %s", tcp_url, uv_strerror(rc));
    g->free_when_closed = 1; /* when the caller's loop has run the close callbacks */
    vf_gate_close(g);
    return err;
  }
  struct sockaddr_storage bound;
  int len = sizeof bound;
  if (uv_tcp_getsockname(&g->server, (struct sockaddr *)&bound, &len) == 0)
    g->port = ntohs(bound.ss_family == AF_INET6 ? ((struct sockaddr_in6 *)&bound)->sin6_port
                                                : ((struct sockaddr_in *)&bound)->sin_port);
  uv_timer_start(&g->sweep, on_sweep, SWEEP_MS, SWEEP_MS);
  *out = g;
  return VF_OK;
}

int vf_gate_port(const vf_gate *g) { return g->port; }

static void free_gate(vf_gate *g) {
  free(g->upstream);
  free(g);
}

static void on_gate_handle_closed(uv_handle_t *h) {
  vf_gate *g = h->data;
  if (--g->handles_open == 0 && g->free_when_closed) free_gate(g);
}

void vf_gate_close(vf_gate *g) {
  if (g == NULL || g->closed) return;
  g->closed = 1;
  g->handles_open = 2;
  uv_close((uv_handle_t *)&g->server, on_gate_handle_closed);
  uv_close((uv_handle_t *)&g->sweep, on_gate_handle_closed);
  for (conn *c = g->conns; c != NULL; c = c->next) close_conn(c);
}

void vf_gate_destroy(vf_gate *g) {
  if (g == NULL) return;
  if (g->closed && g->handles_open > 0) g->free_when_closed = 1; /* its handles' callbacks free it */
  else free_gate(g);
}

void vf_gate_get_stats(const vf_gate *g, vf_gate_stats *s) { *s = g->stats; }

const vf_gate_limits *vf_gate_get_limits(const vf_gate *g) { return &g->limits; }
