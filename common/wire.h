/* Frames on the wire: every message between vcmfarm peers is
 *
 *   [magic "VCMF" 4 bytes][protocol version u32][payload length u32][payload][tag 32 bytes]
 *
 * (integers big-endian), where tag = HMAC-SHA-512/256 (libsodium crypto_auth) of
 * everything before it under the farm's shared key. This layout is the same in every
 * protocol version, so peers of different versions can tell each other so; the payload
 * (an Envelope of proto/vcmfarm.proto, see common/message.h) may change between versions.
 *
 * Frames are untrusted: vf_wire_open checks size, magic, length and tag, in that order,
 * before anything else looks at the payload, and the version only once the tag is good,
 * so a peer without the key learns nothing and provokes nothing. */
#ifndef VF_WIRE_H
#define VF_WIRE_H

#include <stddef.h>
#include <stdint.h>

#define VF_PROTOCOL_VERSION 7u
#define VF_WIRE_MAGIC "VCMF"
#define VF_WIRE_HEADER_SIZE 12u
#define VF_WIRE_TAG_SIZE 32u
/* Payloads above this are refused by both sides (and by nanomsg's NN_RCVMAXSIZE before
 * they are buffered). Since version 5 no reply comes near it: a fetched film travels in
 * chunks of 16 MiB (docs/PROTOCOL.md, "Fetching a film"). */
#define VF_WIRE_MAX_PAYLOAD ((size_t)128 << 20)
#define VF_WIRE_MAX_FRAME (VF_WIRE_MAX_PAYLOAD + VF_WIRE_HEADER_SIZE + VF_WIRE_TAG_SIZE)
/* What the coordinator receives: results travel as tiles in messages of at most
 * VF_WIRE_MAX_RESULT, so the largest request is a submission (a JSON scene of at most
 * 16 MiB and a reference image). The coordinator's NN_RCVMAXSIZE. */
#define VF_WIRE_MAX_REQUEST ((size_t)64 << 20)
#define VF_WIRE_MAX_REQUEST_FRAME (VF_WIRE_MAX_REQUEST + VF_WIRE_HEADER_SIZE + VF_WIRE_TAG_SIZE)
/* A LeaseResult's payload: a dozen 64x64 tiles (328 KiB each). Larger ones are refused. */
#define VF_WIRE_MAX_RESULT ((size_t)4 << 20)

typedef struct {
  uint8_t bytes[32];
} vf_wire_key;

/* Reads a key file: 64 hexadecimal digits (optionally followed by a newline). Refuses a
 * file that others than its owner may read (VF_EINVAL, "chmod 600"), a malformed file
 * (VF_EINVAL) or a missing one (VF_ENOENT); *key is written only on success. */
int vf_wire_key_load(const char *path, vf_wire_key *key);

/* Writes a new random key to path with permissions 0600, atomically (common/atomic_file.h:
 * a crash leaves no partial key). Refuses to replace an existing file (VF_EINVAL). */
int vf_wire_key_generate(const char *path);

/* Frames payload: *frame (malloc'ed, the caller frees) and *frame_len are written only on
 * success. VF_EINVAL when len exceeds VF_WIRE_MAX_PAYLOAD. */
int vf_wire_seal(const vf_wire_key *key, const uint8_t *payload, size_t len, uint8_t **frame, size_t *frame_len);

/* Checks a received frame. On success *payload points into frame (borrowed, valid as long
 * as frame) and *payload_len is its length. Errors, with a detail saying what was wrong:
 * VF_EPROTO (too short, bad magic, length above the limit or not matching the frame),
 * VF_EAUTH (tag does not verify: the peer does not hold this key, or the frame was
 * altered), VF_EVERSION (authentic, but another protocol version). */
int vf_wire_open(const vf_wire_key *key, const uint8_t *frame, size_t len, const uint8_t **payload,
                 size_t *payload_len);

#endif
