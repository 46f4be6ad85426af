/* Fetching a job's film from a coordinator (docs/PROTOCOL.md, "Fetching a film"): the one
 * client loop of `vcmfarm fetch` and of `submit --wait`.
 *
 * The film travels in chunks of a snapshot the coordinator holds (coordinator/checkpoint.h).
 * They are written, in order, to a temporary file next to the output (common/atomic_file.h),
 * every field of every reply checked; once the last is in, the whole is checked against the
 * total size and the BLAKE2b-256 that every chunk repeats, and only then renamed over the
 * output. A transfer cut short, a chunk out of place or bytes that do not hash right are
 * refused with an error saying so, and the output is left exactly as it was. */
#ifndef VF_CLI_FETCH_H
#define VF_CLI_FETCH_H

#include "../common/farm_client.h"
#include "../common/film.h"

#include <stdint.h>

/* Fetches the film of job_id into output, each request waiting up to timeout_ms for its
 * reply, in chunks of at most chunk_bytes (0: as large as the coordinator sends them;
 * smaller chunks hold less memory in flight, larger ones take fewer requests). With film not NULL the file is also read back as a film (vf_film_read's checks)
 * before it replaces the output, and *film (the caller destroys it) receives it on success.
 * Errors: those of vf_farm_request (the coordinator's refusal, a timeout), VF_EPROTO for a
 * reply out of place, VF_EMISMATCH for bytes whose hash or size differ from the announced
 * ones, VF_EIO, VF_EFILM / VF_EEXR; each with a detail naming the job and the output. */
int vf_fetch_film(vf_farm_client *client, uint64_t job_id, const char *output, int timeout_ms, size_t chunk_bytes,
                  vf_film **film);

#endif
