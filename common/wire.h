/* Frames on the wire. Since protocol version 8 every message between vcmfarm peers is
 *
 *   header (44 bytes, in clear):
 *     [magic "VCMF" 4][protocol version u32][payload length n u32][sent_ms u64][nonce 24]
 *   [ciphertext n bytes][Poly1305 tag 16 bytes]
 *
 * (integers big-endian): the payload (an Envelope of proto/vcmfarm.proto, see
 * common/message.h) encrypted and authenticated with XChaCha20-Poly1305 (libsodium
 * crypto_aead_xchacha20poly1305_ietf) under a random 24-byte nonce, the header as
 * associated data. A reply's associated data is its header followed by the nonce of the
 * request it answers, so a reply opens only as the answer to that one request. Requests
 * and replies are sealed under different keys, both derived from the farm key with
 * crypto_kdf (subkeys 1 and 2, context "vcmfarm8"); the farm key itself is never a cipher
 * key. sent_ms is the sender's clock (Unix milliseconds): with the nonce it lets the
 * coordinator refuse a replayed request (coordinator/replay.h).
 *
 * Magic and version stay readable, and a frame of any version from 8 on keeps this header,
 * so peers of different versions can tell each other so. Versions 1 to 7 framed messages
 * as [magic][version][length][payload in clear][HMAC-SHA-512/256 tag 32 bytes under the
 * farm key]; such a frame is still authenticated (it can then only be refused as another
 * version) and the refusal answered in that layout, so an old peer reports the mismatch
 * instead of a silence.
 *
 * Frames are untrusted: vf_wire_open checks size, magic, length and tag, in that order,
 * before anything looks at the payload, and the version only once the tag is good, so a
 * peer without the key learns nothing from what it sent. What it is told is one fixed
 * refusal (vf_wire_refusal below): that the coordinator could not authenticate it. */
#ifndef VF_WIRE_H
#define VF_WIRE_H

#include <stddef.h>
#include <stdint.h>

#define VF_PROTOCOL_VERSION 13u
#define VF_WIRE_MAGIC "VCMF"
#define VF_WIRE_NONCE_SIZE 24u
#define VF_WIRE_HEADER_SIZE (20u + VF_WIRE_NONCE_SIZE)
#define VF_WIRE_TAG_SIZE 16u
#define VF_WIRE_OVERHEAD (VF_WIRE_HEADER_SIZE + VF_WIRE_TAG_SIZE)
/* Versions 1 to 7: 12-byte header, payload in clear, 32-byte HMAC tag. */
#define VF_WIRE_LEGACY_HEADER_SIZE 12u
#define VF_WIRE_LEGACY_TAG_SIZE 32u
/* Payloads above this are refused by both sides. No reply comes near it: a fetched film
 * and a blob travel in chunks of 16 MiB (docs/PROTOCOL.md, "Fetching a film"). */
#define VF_WIRE_MAX_PAYLOAD ((size_t)128 << 20)
#define VF_WIRE_MAX_FRAME (VF_WIRE_MAX_PAYLOAD + VF_WIRE_OVERHEAD)
/* What the coordinator receives, and so what a peer without the key can make it hold per
 * connection (nanomsg buffers a message whole before anything can check it): its
 * NN_RCVMAXSIZE. The largest requests are a LeaseResult (VF_WIRE_MAX_RESULT), a BlobPut
 * (a chunk of VF_BLOB_CHUNK_BYTES and its header) and a SubmitJob (a JSON scene text of at
 * most VF_WIRE_MAX_INLINE_SCENE, a longer one being sent first as a blob, with a table of
 * at most 1024 file names of at most 1023 bytes). Until version 7 this was 64 MiB. */
#define VF_WIRE_MAX_REQUEST (((size_t)4 << 20) + ((size_t)64 << 10))
#define VF_WIRE_MAX_INLINE_SCENE ((size_t)2 << 20)
#define VF_WIRE_MAX_REQUEST_FRAME (VF_WIRE_MAX_REQUEST + VF_WIRE_OVERHEAD)
/* A LeaseResult's payload: a dozen 64x64 tiles (328 KiB each). Larger ones are refused. */
#define VF_WIRE_MAX_RESULT ((size_t)4 << 20)
/* The coordinator's window of freshness (coordinator/replay.h): a request sent (by its
 * sender's clock) more than VF_WIRE_MAX_AGE_MS before the coordinator's clock, or more
 * than VF_WIRE_MAX_AHEAD_MS after it, is refused. Clocks of the farm's machines may thus
 * differ by up to a minute, and a request may wait another minute on the way. */
#define VF_WIRE_MAX_AGE_MS 120000
#define VF_WIRE_MAX_AHEAD_MS 60000

typedef struct {
  uint8_t bytes[32];
} vf_wire_key;

/* What identifies a frame once it is open: its version, its sender's clock and its nonce.
 * The stamp of a request is what its reply is bound to. */
typedef struct {
  uint32_t version;
  int64_t sent_ms;
  uint8_t nonce[VF_WIRE_NONCE_SIZE];
} vf_wire_stamp;

/* Reads a key file: 64 hexadecimal digits (optionally followed by a newline). Refuses a
 * file that others than its owner may read (VF_EINVAL, "chmod 600"), a malformed file
 * (VF_EINVAL) or a missing one (VF_ENOENT); *key is written only on success. */
int vf_wire_key_load(const char *path, vf_wire_key *key);

/* Writes a new random key to path with permissions 0600, atomically (common/atomic_file.h:
 * a crash leaves no partial key). Refuses to replace an existing file (VF_EINVAL). */
int vf_wire_key_generate(const char *path);

/* The sender's clock as frames carry it: Unix milliseconds. */
int64_t vf_wire_now_ms(void);

/* Frames payload. request NULL: a request (request key, fresh nonce, this clock); else the
 * reply to the request of that stamp (reply key, bound to its nonce; a reply to a frame of
 * version 1 to 7, which can only be a version refusal, is framed as those versions did).
 * *frame (malloc'ed, the caller frees), *frame_len and *stamp (the new frame's; may be
 * NULL) are written only on success. VF_EINVAL when len exceeds VF_WIRE_MAX_PAYLOAD. */
int vf_wire_seal(const vf_wire_key *key, const vf_wire_stamp *request, const uint8_t *payload, size_t len,
                 uint8_t **frame, size_t *frame_len, vf_wire_stamp *stamp);

/* The coordinator's answer to a request it cannot authenticate (docs/PROTOCOL.md, "A wrong
 * key"): a frame of version 8 with an empty payload and every other byte zero (sent_ms,
 * nonce and tag). It is the same for every request, key and coordinator, so it tells the
 * peer nothing but that its request did not authenticate; it is no longer than the
 * shortest request it answers; no authentic reply ever equals it (its nonce is random).
 * A version-8 peer that predates it fails to open it as a reply, as not authenticated. */
#define VF_WIRE_REFUSAL_SIZE VF_WIRE_OVERHEAD
extern const uint8_t vf_wire_refusal[VF_WIRE_REFUSAL_SIZE];

/* Whether frame is the refusal above, byte for byte. */
int vf_wire_is_refusal(const uint8_t *frame, size_t len);

/* Whether the peer of a request frame that did not authenticate knows the refusal: its
 * header (unauthenticated) says version 8 or later. Peers of versions 1 to 7 do not. */
int vf_wire_knows_refusal(const uint8_t *frame, size_t len);

/* Opens a received frame: a request when request is NULL, else the reply to the request of
 * that stamp. On success *payload (malloc'ed, the caller frees; never NULL, even for an
 * empty payload), *payload_len and *stamp (may be NULL) are written. Errors, with a detail
 * saying what was wrong: VF_EPROTO (too short, bad magic, length above the limit or not
 * matching the frame), VF_EAUTH (tag does not verify: the peer does not hold this key, the
 * frame was altered, or it is not the reply to this request), VF_EVERSION (authentic, but
 * another protocol version: then *stamp is written too, so that the refusal can answer
 * it). */
int vf_wire_open(const vf_wire_key *key, const vf_wire_stamp *request, const uint8_t *frame, size_t len,
                 uint8_t **payload, size_t *payload_len, vf_wire_stamp *stamp);

#endif
