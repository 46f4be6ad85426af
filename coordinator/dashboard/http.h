/* The dashboard's HTTP server (docs/PROTOCOL.md, "Dashboard"), through libmicrohttpd:
 * its own listening thread and one thread per connection (at most VF_HTTP_CONNECTIONS),
 * never the coordinator's loop. It serves the page (coordinator/dashboard/web/, embedded at build
 * time: coordinator/dashboard/web_assets.h) and the JSON, PNG and film endpoints; what it knows of
 * the farm comes from coordinator/dashboard/dashboard.h, pictures from coordinator/dashboard/preview.h,
 * sessions from coordinator/dashboard/sessions.h.
 *
 * Reading is open to whoever reaches the address; every action is a POST carrying a
 * session token in the X-Vcmfarm-Session header (401 without one, 403 with a bad or
 * expired one; a GET of an action is 405). Bound to a loopback address, it answers only
 * requests whose Host is that address or localhost (a page elsewhere cannot reach it by
 * DNS rebinding). */
#ifndef VF_HTTP_H
#define VF_HTTP_H

#include "../../common/wire.h"

#define VF_HTTP_CONNECTIONS 32
#define VF_HTTP_SESSION_HEADER "X-Vcmfarm-Session"

struct vf_dashboard;
typedef struct vf_http vf_http;

/* Listens on address (vf_dashboard_start's form) for the dashboard (borrowed); key is
 * copied. *out is written only on success. VF_EUSAGE, VF_ENET, VF_ENOMEM with a detail. */
int vf_http_start(struct vf_dashboard *dashboard, const vf_wire_key *key, const char *address, vf_http **out);

/* Stops listening, waits for the connections' threads and frees it. NULL is a no-op. */
void vf_http_stop(vf_http *http);

#endif
