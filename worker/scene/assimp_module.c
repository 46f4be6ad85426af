/* libvf_assimp.so: Assimp's functions for the scene library (assimp_api.h, common/module.h). */
#include "assimp_api.h"

#include <stddef.h>

#define ADDRESS(f) &f,
static const vf_assimp_api api = {{VF_ASSIMP_API_VERSION, sizeof(vf_assimp_api)}, VF_ASSIMP_FUNCTIONS(ADDRESS)};

__attribute__((visibility("default"))) const void *vf_module_open(int version, vf_module_error_fn error_set);

const void *vf_module_open(int version, vf_module_error_fn error_set) {
  (void)error_set;
  return version == VF_ASSIMP_API_VERSION ? &api : NULL;
}
