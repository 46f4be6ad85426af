/* libvf_embree.so: Embree's functions for the renderer (embree_api.h, common/module.h). */
#include "embree_api.h"

#include <stddef.h>

VF_MODULE_FUNCTIONS(vf_embree_api, VF_EMBREE_API_VERSION, VF_EMBREE_FUNCTIONS)
