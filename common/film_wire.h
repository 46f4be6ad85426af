/* Films as bytes, for messages: the film file format (docs/FILM.md) held in memory.
 *
 * Built on the public film API through a private temporary file in $TMPDIR (or /tmp),
 * removed before returning: the bytes are exactly what vf_film_write puts on disk and
 * vf_film_read's checks apply unchanged to what arrives from the network. */
#ifndef VF_FILM_WIRE_H
#define VF_FILM_WIRE_H

#include "film.h"

#include <stddef.h>
#include <stdint.h>

/* Encodes film; *data (malloc'ed, the caller frees) and *len are written only on success.
 * Fails like vf_film_write, or VF_EINVAL when the file would exceed max_len bytes. */
int vf_film_to_bytes(const vf_film *film, size_t max_len, uint8_t **data, size_t *len);

/* Decodes and validates untrusted bytes; *out (caller destroys) is written only on
 * success. Fails like vf_film_read (VF_EEXR / VF_EFILM with a detail), the file name in
 * details being `name`. */
int vf_film_from_bytes(const uint8_t *data, size_t len, const char *name, vf_film **out);

#endif
