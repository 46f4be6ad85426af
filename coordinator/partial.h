/* A partial result being assembled: the tiles (common/film_wire.h) of one part
 * [begin, end) of a lease, as they arrive in LeaseResult messages, staged in a film of
 * their own. The job's film is touched only when every tile is there: then the staged film
 * is merged whole (vf_job_merge, which refuses iterations already counted), so a part is
 * merged completely or not at all.
 *
 * Every message is untrusted: its header (size, scene hash, settings, tile count, times)
 * must be the job's and the same in every message of the part, and every tile is decoded
 * and checked (vf_film_tiles_decode) before any of the message's tiles is stored. */
#ifndef VF_PARTIAL_H
#define VF_PARTIAL_H

#include "../common/message.h"
#include "job.h"

#include <stdint.h>

typedef struct vf_partial vf_partial;

/* Starts the part [m->begin, m->end) of a job from its first message, checking the header
 * against the job (VF_EMISMATCH or VF_EINVAL with a detail). *out on success only. */
int vf_partial_create(const vf_job *job, const Vcmfarm__LeaseResult *m, vf_partial **out);
/* Drops a reference: the part is freed with the last (the lease's, from create, and one
 * per vf_partial_retain). */
void vf_partial_destroy(vf_partial *p);

/* Off the loop (coordinator/results.c): the loop keeps these, the merge thread only
 * vf_partial_add and vf_partial_take, one message at a time, in order. A reference held
 * by a message on the merge thread. */
void vf_partial_retain(vf_partial *p);
/* Counts `tiles` more handed to the merge thread; returns the count so far. */
uint32_t vf_partial_queue(vf_partial *p, uint32_t tiles);
/* A message of the part was refused (its first reason kept): the part cannot be merged. */
void vf_partial_fail(vf_partial *p, const char *why);
/* Why, or NULL. */
const char *vf_partial_failure(const vf_partial *p);

/* 1 when m belongs to this part: same range and header. */
int vf_partial_same(const vf_partial *p, const Vcmfarm__LeaseResult *m);

/* Decodes and checks every tile of m, then stores them. A tile received before is accepted again only
 * when identical (a message sent twice). VF_EINVAL with a detail, nothing stored. */
int vf_partial_add(vf_partial *p, const Vcmfarm__LeaseResult *m);

/* When the part last received tiles (as given to vf_partial_touch). */
void vf_partial_touch(vf_partial *p, double now);
double vf_partial_updated(const vf_partial *p);

uint32_t vf_partial_received(const vf_partial *p);
uint32_t vf_partial_total(const vf_partial *p);

/* When every tile is there: validates the staged film (vf_film_validate) and gives it to
 * the caller (*out, which destroys it); the part is spent. VF_EINVAL before that,
 * VF_EFILM when the whole does not hold together. */
int vf_partial_take(vf_partial *p, vf_film **out);

#endif
