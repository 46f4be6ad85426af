/* libvf_assimp.so: Assimp's functions for the scene library (assimp_api.h, common/module.h). */
#include "assimp_api.h"

#include <stddef.h>

VF_MODULE_FUNCTIONS(vf_assimp_api, VF_ASSIMP_API_VERSION, VF_ASSIMP_FUNCTIONS)
