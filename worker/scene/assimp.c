/* Assimp through its module (assimp_api.h). */
#include "assimp_api.h"

#include "../../common/error.h"

#include <stddef.h>

static vf_module assimp = VF_MODULE_INIT(VF_ASSIMP_MODULE_FILE, "mesh and model import (Assimp)",
                                         VF_ASSIMP_API_VERSION, sizeof(vf_assimp_api));

const vf_assimp_api *vf_assimp_load(const char *label) {
  return vf_module_get(&assimp, label);
}

const vf_assimp_api *vf_assimp(void) {
  return vf_module_get(&assimp, "Assimp");
}
