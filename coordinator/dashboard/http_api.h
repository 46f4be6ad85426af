/* The libmicrohttpd functions the dashboard's server calls (http.c), as a table that the
 * module libvf_http.so (http_module.c) fills with libmicrohttpd's own: it and GnuTLS are
 * loaded by a coordinator that serves a dashboard, when it starts serving, not by every
 * command (common/module.h). Members have the names and types of libmicrohttpd's
 * functions; a call `mhd->MHD_queue_response(...)` is libmicrohttpd's. */
#ifndef VF_DASHBOARD_HTTP_API_H
#define VF_DASHBOARD_HTTP_API_H

#include "../../common/module.h"

#include <microhttpd.h>

/* Changed whenever the list changes (a module of another version is refused by name). */
#define VF_HTTP_API_VERSION 1
#define VF_HTTP_MODULE_FILE "libvf_http.so"

#define VF_HTTP_FUNCTIONS(X)                                                                  \
  X(MHD_start_daemon) X(MHD_stop_daemon) X(MHD_get_daemon_info) X(MHD_get_connection_info) \
  X(MHD_lookup_connection_value) X(MHD_create_response_from_buffer) X(MHD_add_response_header) \
  X(MHD_create_response_from_fd64) X(MHD_queue_response) X(MHD_destroy_response)

typedef struct {
  vf_module_head head; /* VF_HTTP_API_VERSION, sizeof(vf_http_api) */
  VF_HTTP_FUNCTIONS(VF_MODULE_MEMBER)
} vf_http_api;

#endif
