/* libvf_http.so: libmicrohttpd's functions for the dashboard (http_api.h, common/module.h). */
#include "http_api.h"

#define ADDRESS(f) &f,
static const vf_http_api api = {{VF_HTTP_API_VERSION, sizeof(vf_http_api)}, VF_HTTP_FUNCTIONS(ADDRESS)};

__attribute__((visibility("default"))) const void *vf_module_open(int version, vf_module_error_fn error_set);

const void *vf_module_open(int version, vf_module_error_fn error_set) {
  (void)error_set;
  return version == VF_HTTP_API_VERSION ? &api : NULL;
}
