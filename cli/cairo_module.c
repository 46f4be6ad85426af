/* libvf_cairo.so: cairo's functions for the command line's drawings (cairo_api.h,
 * common/module.h). */
#include "cairo_api.h"

#define ADDRESS(f) &f,
static const vf_cairo_api api = {{VF_CAIRO_API_VERSION, sizeof(vf_cairo_api)}, VF_CAIRO_FUNCTIONS(ADDRESS)};

__attribute__((visibility("default"))) const void *vf_module_open(int version, vf_module_error_fn error_set);

const void *vf_module_open(int version, vf_module_error_fn error_set) {
  (void)error_set;
  return version == VF_CAIRO_API_VERSION ? &api : NULL;
}
