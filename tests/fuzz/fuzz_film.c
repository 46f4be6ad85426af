/* libFuzzer target: the film reader (vf_film_from_bytes: the same reader as every command
 * and the coordinator's checkpoints), on files that may be damaged anywhere. Run with
 * TMPDIR on a memory file system (tests/test_fuzz.sh): the reader goes through a file. */
#include "common/film.h"
#include "common/film_wire.h"

#include <stdint.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  vf_film *film = NULL;
  if (vf_film_from_bytes(data, size, "fuzz.exr", &film) == 0) {
    vf_film_estimate_rmse(film);
    vf_film_destroy(film);
  }
  return 0;
}
