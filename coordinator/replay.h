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
 * request has no effect at all. Not thread-safe (the coordinator's loop owns it). */
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

/* Checks the request of `stamp` at now_ms (Unix milliseconds) and, when it is fresh,
 * remembers its nonce. VF_EREPLAY with a detail saying why otherwise: sent too long ago,
 * sent in the future (clocks too far apart), or its nonce seen already (a replay, or
 * nanomsg's resend of a request whose connection broke). */
int vf_replay_check(vf_replay *r, const vf_wire_stamp *stamp, int64_t now_ms);

/* How many nonces it holds now. */
size_t vf_replay_count(const vf_replay *r);

#endif
