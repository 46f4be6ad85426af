#include "message.h"

#include "error.h"

#include <stdlib.h>

int vf_message_pack(const vf_wire_key *key, const vf_wire_stamp *request, Vcmfarm__Envelope *env, uint8_t **frame,
                    size_t *len, vf_wire_stamp *stamp) {
  env->protocol_version = VF_PROTOCOL_VERSION;
  size_t size = vcmfarm__envelope__get_packed_size(env);
  if (size > VF_WIRE_MAX_PAYLOAD)
    return vf_error_set(VF_EINVAL, "%s message of %zu bytes exceeds the limit of %zu", vf_message_name(env), size,
                        VF_WIRE_MAX_PAYLOAD);
  uint8_t *payload = malloc(size ? size : 1);
  if (payload == NULL) return vf_error_set(VF_ENOMEM, "no memory for a %zu-byte message", size);
  vcmfarm__envelope__pack(env, payload);
  int err = vf_wire_seal(key, request, payload, size, frame, len, stamp);
  free(payload);
  return err;
}

int vf_message_unpack(const vf_wire_key *key, const vf_wire_stamp *request, const uint8_t *frame, size_t len,
                      Vcmfarm__Envelope **out, vf_wire_stamp *stamp) {
  uint8_t *payload;
  size_t payload_len;
  vf_wire_stamp s;
  int err = vf_wire_open(key, request, frame, len, &payload, &payload_len, &s);
  if (err == VF_EVERSION && stamp) *stamp = s;
  if (err != VF_OK) return err;
  Vcmfarm__Envelope *env = vcmfarm__envelope__unpack(NULL, payload_len, payload);
  free(payload);
  if (env == NULL) return vf_error_set(VF_EPROTO, "authentic frame whose payload is not a valid Envelope");
  if (env->protocol_version != VF_PROTOCOL_VERSION) {
    err = vf_error_set(VF_EPROTO, "Envelope says protocol version %u inside a version %u frame",
                       env->protocol_version, VF_PROTOCOL_VERSION);
    goto free_env;
  }
  if (env->body_case == VCMFARM__ENVELOPE__BODY__NOT_SET) {
    err = vf_error_set(VF_EPROTO, "message without a body (or with one this version does not know)");
    goto free_env;
  }
  *out = env;
  if (stamp) *stamp = s;
  return VF_OK;
free_env:
  vcmfarm__envelope__free_unpacked(env, NULL);
  return err;
}

void vf_message_free(Vcmfarm__Envelope *env) {
  if (env) vcmfarm__envelope__free_unpacked(env, NULL);
}

const char *vf_message_name(const Vcmfarm__Envelope *env) {
  switch (env->body_case) {
  case VCMFARM__ENVELOPE__BODY_REGISTER: return "register";
  case VCMFARM__ENVELOPE__BODY_LEASE_REQUEST: return "lease-request";
  case VCMFARM__ENVELOPE__BODY_HEARTBEAT: return "heartbeat";
  case VCMFARM__ENVELOPE__BODY_RESULT: return "lease-result";
  case VCMFARM__ENVELOPE__BODY_RELEASE: return "lease-release";
  case VCMFARM__ENVELOPE__BODY_GOODBYE: return "goodbye";
  case VCMFARM__ENVELOPE__BODY_SUBMIT: return "submit";
  case VCMFARM__ENVELOPE__BODY_STATUS_REQUEST: return "status-request";
  case VCMFARM__ENVELOPE__BODY_FETCH: return "fetch";
  case VCMFARM__ENVELOPE__BODY_CANCEL: return "cancel";
  case VCMFARM__ENVELOPE__BODY_REMOVE: return "remove";
  case VCMFARM__ENVELOPE__BODY_PAUSE: return "pause";
  case VCMFARM__ENVELOPE__BODY_RESUME: return "resume";
  case VCMFARM__ENVELOPE__BODY_REGISTERED: return "registered";
  case VCMFARM__ENVELOPE__BODY_LEASE: return "lease";
  case VCMFARM__ENVELOPE__BODY_IDLE: return "idle";
  case VCMFARM__ENVELOPE__BODY_HEARTBEAT_ACK: return "heartbeat-ack";
  case VCMFARM__ENVELOPE__BODY_RESULT_ACK: return "result-ack";
  case VCMFARM__ENVELOPE__BODY_SUBMITTED: return "submitted";
  case VCMFARM__ENVELOPE__BODY_STATUS: return "status";
  case VCMFARM__ENVELOPE__BODY_FILM: return "film";
  case VCMFARM__ENVELOPE__BODY_ERROR: return "error";
  case VCMFARM__ENVELOPE__BODY_BLOB_QUERY: return "blob-query";
  case VCMFARM__ENVELOPE__BODY_BLOB_PUT: return "blob-put";
  case VCMFARM__ENVELOPE__BODY_BLOB_REQUEST: return "blob-request";
  case VCMFARM__ENVELOPE__BODY_BLOB_HAVE: return "blob-have";
  case VCMFARM__ENVELOPE__BODY_BLOB: return "blob";
  default: return "unknown";
  }
}
