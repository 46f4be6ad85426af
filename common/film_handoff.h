/* Films handed from a worker to a coordinator in the same process, without encoding.
 *
 * `vcmfarm render` runs a coordinator and a worker on two threads of one process
 * (cli/farm_render.c). Its worker would otherwise encode every part as compressed tiles that
 * the coordinator decodes into a staged film of its own: two copies of the film beside the
 * job's, and seconds of deflate on the render thread. Instead it deposits the part's film
 * here and sends the usual LeaseResult header with the deposit's token and no tiles
 * (proto/vcmfarm.proto, film_handoff); the coordinator takes the film out by that token and
 * runs every check of a result on it before merging (coordinator/results.c). Only the two
 * roles of one process share a handoff, so a token means nothing to anyone else: a
 * coordinator without one refuses such a result.
 *
 * Any thread may call any function; a film is owned by the handoff from put to take. */
#ifndef VF_FILM_HANDOFF_H
#define VF_FILM_HANDOFF_H

#include "film.h"

#include <stdint.h>

typedef struct vf_film_handoff vf_film_handoff;

/* *out on success only; VF_ENOMEM. */
int vf_film_handoff_create(vf_film_handoff **out);
/* Destroys the films still deposited, then the handoff. */
void vf_film_handoff_destroy(vf_film_handoff *h);

/* Deposits film (the handoff owns it now) under a fresh token (never 0), written to *token.
 * VF_ENOMEM (film still the caller's). */
int vf_film_handoff_put(vf_film_handoff *h, vf_film *film, uint64_t *token);

/* The film deposited under token, now the caller's; NULL when there is none (never put,
 * or taken already). */
vf_film *vf_film_handoff_take(vf_film_handoff *h, uint64_t token);

#endif
