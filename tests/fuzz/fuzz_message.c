/* libFuzzer target: the frame and message decoder, as the coordinator and the workers run
 * it on what arrives. Each input is tried three ways: as a request off the wire (size,
 * magic, length and tag are checked before anything looks at the payload; a version-7
 * frame goes through the HMAC check of that layout), as the reply to a fixed request, and
 * as the payload of a request sealed with the farm's key, so that protobuf-c's decoding and
 * our checks of the decoded envelope see arbitrary authentic bytes; a result's tiles are
 * decoded as the coordinator decodes them. */
#include "common/film_wire.h"
#include "common/message.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static void decode(const vf_wire_key *key, const vf_wire_stamp *request, const uint8_t *frame, size_t len) {
  Vcmfarm__Envelope *env = NULL;
  vf_wire_stamp stamp;
  if (vf_message_unpack(key, request, frame, len, &env, &stamp) != 0) return;
  if (env->body_case == VCMFARM__ENVELOPE__BODY_RESULT && env->result) {
    vf_film_tile *tiles = NULL;
    if (vf_film_tiles_decode(env->result, 24, 16, &tiles) == 0)
      vf_film_tiles_free(tiles, env->result->n_tiles);
  }
  vf_message_name(env);
  vf_message_free(env);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  vf_wire_key key;
  memset(key.bytes, 0x5a, sizeof key.bytes);
  vf_wire_stamp request = {VF_PROTOCOL_VERSION, 0, {0}};
  memset(request.nonce, 0xa5, sizeof request.nonce);
  decode(&key, NULL, data, size);
  decode(&key, &request, data, size);
  uint8_t *frame = NULL;
  size_t len = 0;
  if (vf_wire_seal(&key, NULL, data, size, &frame, &len, NULL) == 0) decode(&key, NULL, frame, len);
  free(frame);
  return 0;
}
