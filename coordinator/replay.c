#include "replay.h"

#include "../common/error.h"

#include <stdlib.h>
#include <string.h>

typedef struct {
  uint8_t nonce[VF_WIRE_NONCE_SIZE];
  int64_t sent_ms;
} seen_nonce;

typedef struct {
  uint8_t nonce[VF_WIRE_NONCE_SIZE]; /* of the request */
  uint8_t *frame;                    /* owned: the sealed reply */
  size_t len;
} kept_reply;

/* The nonces in the order they were let through (a ring), and an index of them: a table
 * of open addressing with linear probing, 2 slots per nonce, each 0 or 1 + a ring slot.
 * The latest replies in a ring of their own, searched whole (only a refused request looks). */
struct vf_replay {
  kept_reply replies[VF_REPLAY_REPLIES];
  size_t reply_first, reply_count, reply_bytes;
  seen_nonce *ring;
  size_t capacity, first, count;
  uint32_t *index;
  size_t index_mask;
  int64_t floor_ms; /* requests sent at or before this are refused: their nonces may be forgotten */
  int64_t start_ms; /* vf_replay_start's: requests sent before it are refused */
};

/* The nonces come from peers holding the farm key, drawn by randombytes: their first bytes
 * are as good a hash as any. */
static size_t home(const vf_replay *r, const uint8_t *nonce) {
  uint64_t h;
  memcpy(&h, nonce, sizeof h);
  return (size_t)h & r->index_mask;
}

int vf_replay_create(size_t capacity, vf_replay **out) {
  if (capacity == 0 || capacity > UINT32_MAX / 4) return vf_error_set(VF_EINVAL, "replay guard of %zu nonces", capacity);
  vf_replay *r = calloc(1, sizeof *r);
  if (r == NULL) return vf_error_set(VF_ENOMEM, "out of memory for the replay guard");
  size_t slots = 2;
  while (slots < 2 * capacity) slots *= 2;
  r->ring = calloc(capacity, sizeof *r->ring);
  r->index = calloc(slots, sizeof *r->index);
  if (r->ring == NULL || r->index == NULL) {
    vf_replay_destroy(r);
    return vf_error_set(VF_ENOMEM, "out of memory for a replay guard of %zu nonces", capacity);
  }
  r->capacity = capacity;
  r->index_mask = slots - 1;
  r->floor_ms = r->start_ms = INT64_MIN;
  *out = r;
  return VF_OK;
}

void vf_replay_destroy(vf_replay *r) {
  if (r == NULL) return;
  for (size_t i = 0; i < r->reply_count; i++) free(r->replies[(r->reply_first + i) % VF_REPLAY_REPLIES].frame);
  free(r->ring);
  free(r->index);
  free(r);
}

size_t vf_replay_count(const vf_replay *r) { return r->count; }

static int seen(const vf_replay *r, const uint8_t *nonce) {
  for (size_t i = home(r, nonce);; i = (i + 1) & r->index_mask) {
    uint32_t e = r->index[i];
    if (e == 0) return 0;
    if (memcmp(r->ring[e - 1].nonce, nonce, VF_WIRE_NONCE_SIZE) == 0) return 1;
  }
}

/* Removes ring slot `slot` from the index, shifting back the entries probed past it so
 * that every lookup still finds its entry without tombstones. */
static void unindex(vf_replay *r, size_t slot) {
  size_t i = home(r, r->ring[slot].nonce);
  while (r->index[i] != slot + 1) i = (i + 1) & r->index_mask;
  size_t j = i;
  for (;;) {
    r->index[i] = 0;
    for (;;) {
      j = (j + 1) & r->index_mask;
      if (r->index[j] == 0) return;
      size_t k = home(r, r->ring[r->index[j] - 1].nonce);
      /* the entry at j may move to i unless its home lies cyclically in (i, j] */
      int stays = i <= j ? (i < k && k <= j) : (i < k || k <= j);
      if (!stays) break;
    }
    r->index[i] = r->index[j];
    i = j;
  }
}

static void forget_oldest(vf_replay *r) {
  unindex(r, r->first);
  r->first = (r->first + 1) % r->capacity;
  r->count--;
}

void vf_replay_start(vf_replay *r, int64_t now_ms) { r->start_ms = now_ms; }

int vf_replay_before_start(const vf_replay *r, const vf_wire_stamp *stamp, int64_t now_ms) {
  return stamp->sent_ms >= now_ms - VF_WIRE_MAX_AGE_MS && stamp->sent_ms < r->start_ms;
}

int vf_replay_check(vf_replay *r, const vf_wire_stamp *stamp, int64_t now_ms) {
  while (r->count > 0 && r->ring[r->first].sent_ms < now_ms - VF_WIRE_MAX_AGE_MS) forget_oldest(r);
  long long age = (long long)(now_ms - stamp->sent_ms);
  if (stamp->sent_ms < now_ms - VF_WIRE_MAX_AGE_MS)
    return vf_error_set(VF_EREPLAY, "stale: sent %.1f s ago, more than the %d s a request may take (a replay, or "
                        "clocks apart: set the farm's machines' clocks with NTP)",
                        (double)age / 1000.0, VF_WIRE_MAX_AGE_MS / 1000);
  if (stamp->sent_ms > now_ms + VF_WIRE_MAX_AHEAD_MS)
    return vf_error_set(VF_EREPLAY, "sent %.1f s in the future of this clock, more than the %d s of skew allowed "
                        "(set the farm's machines' clocks with NTP)",
                        (double)-age / 1000.0, VF_WIRE_MAX_AHEAD_MS / 1000);
  if (stamp->sent_ms < r->start_ms)
    return vf_error_set(VF_EREPLAY, "sent %.1f s ago, before this coordinator started (a replay of a request to its "
                        "earlier run, or a clock behind this one: set the farm's machines' clocks with NTP)",
                        (double)age / 1000.0);
  if (stamp->sent_ms <= r->floor_ms)
    return vf_error_set(VF_EREPLAY, "sent %.1f s ago, before the oldest request of the %zu remembered (more requests "
                        "arrived in %d s than the replay guard holds)",
                        (double)age / 1000.0, r->capacity, VF_WIRE_MAX_AGE_MS / 1000);
  if (seen(r, stamp->nonce))
    return vf_error_set(VF_EREPLAY, "replayed: a request with this nonce, sent %.1f s ago, was received already",
                        (double)age / 1000.0);
  if (r->count == r->capacity) {
    int64_t t = r->ring[r->first].sent_ms;
    if (t > r->floor_ms) r->floor_ms = t;
    forget_oldest(r);
    if (stamp->sent_ms <= r->floor_ms) /* older than what had to be forgotten to make room */
      return vf_error_set(VF_EREPLAY, "sent %.1f s ago, before the oldest request of the %zu remembered",
                          (double)age / 1000.0, r->capacity);
  }
  size_t slot = (r->first + r->count) % r->capacity;
  memcpy(r->ring[slot].nonce, stamp->nonce, VF_WIRE_NONCE_SIZE);
  r->ring[slot].sent_ms = stamp->sent_ms;
  size_t i = home(r, stamp->nonce);
  while (r->index[i] != 0) i = (i + 1) & r->index_mask;
  r->index[i] = (uint32_t)(slot + 1);
  r->count++;
  return VF_OK;
}

static void drop_oldest_reply(vf_replay *r) {
  kept_reply *k = &r->replies[r->reply_first];
  r->reply_bytes -= k->len;
  free(k->frame);
  k->frame = NULL;
  r->reply_first = (r->reply_first + 1) % VF_REPLAY_REPLIES;
  r->reply_count--;
}

void vf_replay_keep_reply(vf_replay *r, const vf_wire_stamp *request, const uint8_t *frame, size_t len) {
  if (len > VF_REPLAY_REPLY_MAX) return;
  uint8_t *copy = malloc(len ? len : 1);
  if (copy == NULL) return;
  memcpy(copy, frame, len);
  while (r->reply_count == VF_REPLAY_REPLIES || (r->reply_count > 0 && r->reply_bytes + len > VF_REPLAY_REPLY_BYTES))
    drop_oldest_reply(r);
  kept_reply *k = &r->replies[(r->reply_first + r->reply_count) % VF_REPLAY_REPLIES];
  memcpy(k->nonce, request->nonce, VF_WIRE_NONCE_SIZE);
  k->frame = copy;
  k->len = len;
  r->reply_count++;
  r->reply_bytes += len;
}

const uint8_t *vf_replay_reply(const vf_replay *r, const vf_wire_stamp *request, int64_t now_ms, size_t *len) {
  if (request->sent_ms < now_ms - VF_WIRE_MAX_AGE_MS || request->sent_ms > now_ms + VF_WIRE_MAX_AHEAD_MS) return NULL;
  for (size_t i = r->reply_count; i-- > 0;) { /* newest first */
    const kept_reply *k = &r->replies[(r->reply_first + i) % VF_REPLAY_REPLIES];
    if (memcmp(k->nonce, request->nonce, VF_WIRE_NONCE_SIZE) == 0) {
      *len = k->len;
      return k->frame;
    }
  }
  return NULL;
}
