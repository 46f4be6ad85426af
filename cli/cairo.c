/* cairo through its module (cairo_api.h). */
#include "cairo_api.h"

#include <stddef.h>

static vf_module cairo_module = VF_MODULE_INIT(VF_CAIRO_MODULE_FILE, "drawing (cairo)", VF_CAIRO_API_VERSION,
                                               sizeof(vf_cairo_api));

const vf_cairo_api *vf_cairo_load(const char *label) {
  return vf_module_get(&cairo_module, label);
}

const vf_cairo_api *vf_cairo(void) {
  return vf_module_get(&cairo_module, "cairo");
}
