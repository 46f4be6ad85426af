/* libvf_http.so: libmicrohttpd's functions for the dashboard (http_api.h, common/module.h). */
#include "http_api.h"

#include <stddef.h>

VF_MODULE_FUNCTIONS(vf_http_api, VF_HTTP_API_VERSION, VF_HTTP_FUNCTIONS)
