/* libFuzzer target: the JSON scene parser with every field reader, the shapes and their
 * transforms, materials and textures. The scene may name two files held in memory, a
 * mesh "m.obj" with normals and texture coordinates and a texture "t.png", so that the
 * mesh and texture paths of a scene are reached as well; no other file exists. */
#include "worker/scene/scene.h"
#include "worker/scene/json.h"
#include "worker/scene/builtin.h"

#include <stdint.h>
#include <stdlib.h>

static const char obj[] = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nf 1/1/1 2/2/1 3/3/1\n";
/* a 2x1 RGBA PNG */
static const unsigned char png[] = {
    0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48, 0x44, 0x52, 0x00, 0x00,
    0x00, 0x02, 0x00, 0x00, 0x00, 0x01, 0x08, 0x06, 0x00, 0x00, 0x00, 0xf4, 0x22, 0x7f, 0x8a, 0x00, 0x00, 0x00,
    0x0e, 0x49, 0x44, 0x41, 0x54, 0x78, 0x9c, 0x63, 0xf8, 0xcf, 0xc0, 0x00, 0x42, 0x0d, 0x00, 0x0f, 0x7a, 0x03,
    0x7e, 0x77, 0xe9, 0x7f, 0x97, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  const vf_scene_memfile files[] = {{"m.obj", obj, sizeof obj - 1}, {"t.png", png, sizeof png}};
  vf_scene *scene = NULL;
  if (vf_scene_parse((const char *)data, size, "fuzz.json", "/nonexistent", files, 2, &scene) == 0)
    vf_scene_destroy(scene);
  return 0;
}
