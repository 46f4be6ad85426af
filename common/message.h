/* Envelopes (proto/vcmfarm.proto) in sealed frames (common/wire.h).
 *
 * protobuf-c errors enter our code here and become VF_EPROTO. A decoded Envelope has been
 * authenticated, carries this build's protocol version in both frame and message, and has
 * a body; the fields inside the body are still untrusted and the receiver checks them. */
#ifndef VF_MESSAGE_H
#define VF_MESSAGE_H

#include "proto/vcmfarm.pb-c.h"
#include "wire.h"

#include <stddef.h>
#include <stdint.h>

/* Sets env->protocol_version and frames the packed envelope: a request when request is
 * NULL, else the reply to the request of that stamp (vf_wire_seal). *frame (malloc'ed, the
 * caller frees), *len and *stamp (may be NULL) are written only on success. */
int vf_message_pack(const vf_wire_key *key, const vf_wire_stamp *request, Vcmfarm__Envelope *env, uint8_t **frame,
                    size_t *len, vf_wire_stamp *stamp);

/* Opens and decodes a frame: a request when request is NULL, else the reply to the request
 * of that stamp. *out (free with vf_message_free) is written only on success, *stamp (may
 * be NULL) on success and on VF_EVERSION; errors are those of vf_wire_open, or VF_EPROTO
 * when the payload is not an Envelope, its protocol_version differs from the frame's, or
 * it has no body this version knows. */
int vf_message_unpack(const vf_wire_key *key, const vf_wire_stamp *request, const uint8_t *frame, size_t len,
                      Vcmfarm__Envelope **out, vf_wire_stamp *stamp);
void vf_message_free(Vcmfarm__Envelope *env);

/* A short name of the body ("register", "lease-result"...) for logs. */
const char *vf_message_name(const Vcmfarm__Envelope *env);

#endif
