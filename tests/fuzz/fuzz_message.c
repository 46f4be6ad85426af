/* libFuzzer target: the frame and message decoder, as the coordinator and the workers run
 * it on what arrives. Each input is tried twice: as a frame off the wire (size, magic,
 * length and tag are checked before anything looks at the payload), and as the payload of
 * a frame sealed with the farm's key, so that protobuf-c's decoding and our checks of the
 * decoded envelope see arbitrary authentic bytes; a result's tiles are decoded as the
 * coordinator decodes them. */
#include "common/film_wire.h"
#include "common/message.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static void decode(const vf_wire_key *key, const uint8_t *frame, size_t len) {
  Vcmfarm__Envelope *env = NULL;
  if (vf_message_unpack(key, frame, len, &env) != 0) return;
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
  decode(&key, data, size);
  uint8_t *frame = NULL;
  size_t len = 0;
  if (vf_wire_seal(&key, data, size, &frame, &len) == 0) decode(&key, frame, len);
  free(frame);
  return 0;
}
