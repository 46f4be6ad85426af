/* libFuzzer target: the texture decoders (PNG through libpng, JPEG through libjpeg, EXR
 * through OpenEXRCore), told apart by their first bytes as a scene's files are, and a
 * lookup of what decoded. */
#include "worker/render/texture_lookup.h"
#include "worker/scene/texture.h"

#include <stdint.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  vf_texture t;
  if (vf_texture_decode(data, size, "fuzz", &t) == 0) {
    float rgba[4];
    vf_texture_lookup(&t, 0.3f, 0.7f, VF_WRAP_REPEAT, VF_WRAP_MIRROR, 1, rgba);
    vf_texture_release(&t);
  }
  return 0;
}
