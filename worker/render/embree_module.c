/* libvf_embree.so: Embree's functions for the renderer (embree_api.h, common/module.h). */
#include "embree_api.h"

#define ADDRESS(f) &f,
static const vf_embree_api api = {{VF_EMBREE_API_VERSION, sizeof(vf_embree_api)}, VF_EMBREE_FUNCTIONS(ADDRESS)};

__attribute__((visibility("default"))) const void *vf_module_open(int version, vf_module_error_fn error_set);

const void *vf_module_open(int version, vf_module_error_fn error_set) {
  (void)error_set;
  return version == VF_EMBREE_API_VERSION ? &api : NULL;
}
