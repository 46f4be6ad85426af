/* libvf_cairo.so: cairo's functions for the command line's drawings (cairo_api.h,
 * common/module.h). */
#include "cairo_api.h"

#include <stddef.h>

VF_MODULE_FUNCTIONS(vf_cairo_api, VF_CAIRO_API_VERSION, VF_CAIRO_FUNCTIONS)
