/* Freshness of requests: the coordinator's guard against replays.
 *
 * Every request carries its sender's clock and a random nonce inside the authenticated
 * header (common/wire.h). A request is fresh when its time lies within the window
 * [now - VF_WIRE_MAX_AGE_MS, now + VF_WIRE_MAX_AHEAD_MS] of the coordinator's clock and
 * its nonce has not been seen. The guard remembers the nonces of the requests it let
 * through until they leave the window, at most `capacity` of them (oldest first out);
 * when one has to be forgotten early, the guard also refuses from then on every request
 * sent at or before that one's time, so a forgotten nonce can never be replayed: under a
 * flood beyond capacity the window only shrinks, it never leaks.
 *
 * Checked after authentication and before anything else looks at the request; a refused
 * request has no effect at all. The guard also keeps the latest small replies, so that a
 * request sent again is answered as it was (vf_replay_keep_reply). Not thread-safe (the
 * coordinator's loop owns it). */
#ifndef VF_REPLAY_H
#define VF_REPLAY_H

#include "../common/wire.h"

#include <stddef.h>
#include <stdint.h>

/* 2^17 nonces (5 MiB): two minutes of a thousand requests a second. */
#define VF_REPLAY_CAPACITY ((size_t)1 << 17)

typedef struct vf_replay vf_replay;

/* *out (free with vf_replay_destroy) is written only on success; VF_ENOMEM otherwise. */
int vf_replay_create(size_t capacity, vf_replay **out);
void vf_replay_destroy(vf_replay *r);

/* The guard of a coordinator starting at now_ms: it remembers no nonce of its earlier runs,
 * so it refuses every request sent before it started (a request captured before a restart
 * cannot be replayed to it). A worker whose clock lags the coordinator's is refused for as
 * long as the lag after a restart; its retries, new frames, pass then. */
void vf_replay_start(vf_replay *r, int64_t now_ms);

/* 1 when the request of `stamp` lies in the window of now_ms but was sent before the
 * guard's start, the one reason vf_replay_check refuses it: the coordinator asks its sender to send it again, as a new frame, instead of leaving
 * it unanswered (a request queued while the coordinator started, or sent to its earlier
 * run). A replayer learns nothing from that answer and cannot make the new frame. */
int vf_replay_before_start(const vf_replay *r, const vf_wire_stamp *stamp, int64_t now_ms);

/* Checks the request of `stamp` at now_ms (Unix milliseconds) and, when it is fresh,
 * remembers its nonce. VF_EREPLAY with a detail saying why otherwise: sent too long ago,
 * sent in the future (clocks too far apart), or its nonce seen already (a replay, or
 * nanomsg's resend of a request whose connection broke). */
int vf_replay_check(vf_replay *r, const vf_wire_stamp *stamp, int64_t now_ms);

/* How many nonces it holds now. */
size_t vf_replay_count(const vf_replay *r);

/* The replies to the latest requests, by their requests' nonces, so that a request sent
 * again (nanomsg resends a request whose connection broke, with the same nonce) is
 * answered at once with the reply it had, still without effect: at most VF_REPLAY_REPLIES
 * replies of at most VF_REPLAY_REPLY_MAX bytes each, VF_REPLAY_REPLY_BYTES in all (oldest
 * first out; larger replies, film and blob chunks and leases of big scenes, are not kept:
 * their requests are asked again after a timeout). */
#define VF_REPLAY_REPLIES 256
#define VF_REPLAY_REPLY_MAX ((size_t)64 << 10)
#define VF_REPLAY_REPLY_BYTES ((size_t)4 << 20)

/* Keeps a copy of the sealed reply to the request of `request` (quietly not, when it is too
 * large or memory is short: it is an optimisation). */
void vf_replay_keep_reply(vf_replay *r, const vf_wire_stamp *request, const uint8_t *frame, size_t len);

/* The kept reply to a request refused as seen already (borrowed, valid until the next call
 * on r), or NULL: none kept, or the request is outside the window of now_ms (a stale
 * request gets nothing). */
const uint8_t *vf_replay_reply(const vf_replay *r, const vf_wire_stamp *request, int64_t now_ms, size_t *len);

#endif
