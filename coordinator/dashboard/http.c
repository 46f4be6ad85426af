#include "http.h"

#include "../../common/error.h"
#include "dashboard.h"
#include "http_api.h"
#include "../log.h"
#include "preview.h"
#include "sessions.h"
#include "web_assets.h"

#include <arpa/inet.h>
#include <cjson/cJSON.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <netinet/in.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static vf_module http_module = VF_MODULE_INIT(VF_HTTP_MODULE_FILE, "the dashboard's web server (libmicrohttpd)",
                                              VF_HTTP_API_VERSION, sizeof(vf_http_api));
/* libmicrohttpd's functions: set by vf_http_start before it starts a server, and read on
 * the server's threads, which exist only after that. */
static const vf_http_api *mhd;

#define BODY_MAX 4096          /* the largest request body: a session's proof, a priority */
#define EVENTS_MAX 200         /* events per answer, the latest */
#define PREVIEW_SIDE 512       /* a preview's longer side unless asked */
#define CONNECTION_SECONDS 30  /* an idle connection is closed */

struct vf_http {
  struct MHD_Daemon *daemon;
  vf_dashboard *dashboard; /* borrowed */
  vf_sessions *sessions;   /* owned */
  vf_previews *previews;   /* owned */
  int loopback;            /* bound to a loopback address: check Host */
  unsigned port;
};

typedef struct {
  char body[BODY_MAX + 1];
  size_t body_len;
  int too_big;
} request;

/* ---- answers ---- */

static void common_headers(struct MHD_Response *r, const char *content_type) {
  mhd->MHD_add_response_header(r, "Content-Type", content_type);
  mhd->MHD_add_response_header(r, "Cache-Control", "no-store");
  mhd->MHD_add_response_header(r, "X-Content-Type-Options", "nosniff");
  mhd->MHD_add_response_header(r, "X-Frame-Options", "DENY");
  mhd->MHD_add_response_header(r, "Referrer-Policy", "no-referrer");
}

/* Sends bytes (malloc'ed: taken, freed by libmicrohttpd) with this status and type. */
static enum MHD_Result send_owned(struct MHD_Connection *c, unsigned status, const char *type, void *bytes,
                                  size_t size, const char *disposition) {
  struct MHD_Response *r = mhd->MHD_create_response_from_buffer(size, bytes, MHD_RESPMEM_MUST_FREE);
  if (r == NULL) {
    free(bytes);
    return MHD_NO;
  }
  common_headers(r, type);
  if (disposition) mhd->MHD_add_response_header(r, "Content-Disposition", disposition);
  enum MHD_Result ok = mhd->MHD_queue_response(c, status, r);
  mhd->MHD_destroy_response(r);
  return ok;
}

static enum MHD_Result send_json(struct MHD_Connection *c, unsigned status, cJSON *doc) {
  char *text = cJSON_PrintUnformatted(doc);
  cJSON_Delete(doc);
  if (text == NULL) return MHD_NO;
  return send_owned(c, status, "application/json", text, strlen(text), NULL);
}

/* {"error": message} with this status. */
static enum MHD_Result send_error(struct MHD_Connection *c, unsigned status, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static enum MHD_Result send_error(struct MHD_Connection *c, unsigned status, const char *fmt, ...) {
  char message[512];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(message, sizeof message, fmt, ap);
  va_end(ap);
  cJSON *doc = cJSON_CreateObject();
  cJSON_AddStringToObject(doc, "error", message);
  return send_json(c, status, doc);
}

static enum MHD_Result not_allowed(struct MHD_Connection *c, const char *allow) {
  char message[] = "{\"error\": \"method not allowed\"}";
  struct MHD_Response *r = mhd->MHD_create_response_from_buffer(strlen(message), message, MHD_RESPMEM_MUST_COPY);
  if (r == NULL) return MHD_NO;
  common_headers(r, "application/json");
  mhd->MHD_add_response_header(r, "Allow", allow);
  enum MHD_Result ok = mhd->MHD_queue_response(c, MHD_HTTP_METHOD_NOT_ALLOWED, r);
  mhd->MHD_destroy_response(r);
  return ok;
}

/* ---- reading ---- */

static enum MHD_Result send_asset(struct MHD_Connection *c, const vf_web_asset *a) {
  struct MHD_Response *r =
      mhd->MHD_create_response_from_buffer(a->size, (void *)a->bytes, MHD_RESPMEM_PERSISTENT);
  if (r == NULL) return MHD_NO;
  common_headers(r, a->content_type);
  mhd->MHD_add_response_header(r, "Content-Security-Policy",
                          "default-src 'self'; img-src 'self' blob:; style-src 'self'; script-src 'self'; "
                          "connect-src 'self'; frame-ancestors 'none'; base-uri 'none'; form-action 'none'");
  enum MHD_Result ok = mhd->MHD_queue_response(c, MHD_HTTP_OK, r);
  mhd->MHD_destroy_response(r);
  return ok;
}

static enum MHD_Result send_status(vf_http *h, struct MHD_Connection *c, uint64_t job_id) {
  char *json = NULL;
  size_t len = 0;
  int status = vf_dashboard_status(h->dashboard, job_id, &json, &len);
  if (status == 200) return send_owned(c, MHD_HTTP_OK, "application/json", json, len, NULL);
  if (status == 404) return send_error(c, MHD_HTTP_NOT_FOUND, "no job %llu", (unsigned long long)job_id);
  return send_error(c, MHD_HTTP_SERVICE_UNAVAILABLE, "the coordinator has no status to give now: try again");
}

static int newer_first(const void *a, const void *b) {
  double ta = cJSON_GetNumberValue(cJSON_GetObjectItem(*(cJSON *const *)a, "time"));
  double tb = cJSON_GetNumberValue(cJSON_GetObjectItem(*(cJSON *const *)b, "time"));
  return ta < tb ? 1 : ta > tb ? -1 : 0;
}

/* The farm's events and every job's, the latest first, those after ?since= only. */
static enum MHD_Result send_events(vf_http *h, struct MHD_Connection *c) {
  const char *since_text = mhd->MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "since");
  double since = since_text ? strtod(since_text, NULL) : 0.0;
  char *json = NULL;
  size_t len = 0;
  if (vf_dashboard_status(h->dashboard, 0, &json, &len) != 200)
    return send_error(c, MHD_HTTP_SERVICE_UNAVAILABLE, "the coordinator has no status to give now: try again");
  cJSON *doc = cJSON_ParseWithLength(json, len);
  free(json);
  if (doc == NULL) return send_error(c, MHD_HTTP_INTERNAL_SERVER_ERROR, "the status does not parse");
  cJSON *all[EVENTS_MAX * 4];
  size_t n = 0;
  cJSON *lists[1 + 256];
  size_t num_lists = 0;
  lists[num_lists++] = cJSON_GetObjectItem(doc, "events");
  cJSON *job;
  cJSON_ArrayForEach(job, cJSON_GetObjectItem(doc, "jobs")) if (num_lists < sizeof lists / sizeof *lists)
      lists[num_lists++] = cJSON_GetObjectItem(job, "events");
  for (size_t l = 0; l < num_lists; l++) {
    cJSON *e;
    cJSON_ArrayForEach(e, lists[l]) {
      if (cJSON_GetNumberValue(cJSON_GetObjectItem(e, "time")) <= since) continue;
      if (n == sizeof all / sizeof *all) { /* keep the newest: sort, cut to the answer's size */
        qsort(all, n, sizeof *all, newer_first);
        n = EVENTS_MAX;
      }
      all[n++] = e;
    }
  }
  qsort(all, n, sizeof *all, newer_first);
  if (n > EVENTS_MAX) n = EVENTS_MAX;
  cJSON *out = cJSON_CreateObject();
  cJSON_AddItemToObject(out, "time", cJSON_Duplicate(cJSON_GetObjectItem(doc, "time"), 1));
  cJSON *events = cJSON_AddArrayToObject(out, "events");
  for (size_t i = 0; i < n; i++) cJSON_AddItemToArray(events, cJSON_Duplicate(all[i], 1));
  cJSON_Delete(doc);
  return send_json(c, MHD_HTTP_OK, out);
}

/* A number argument within [lo, hi], else def; *bad when given but not such a number. */
static double number_arg(struct MHD_Connection *c, const char *name, double lo, double hi, double def, int *bad) {
  const char *text = mhd->MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, name);
  if (text == NULL || text[0] == '\0') return def;
  char *end;
  double v = strtod(text, &end);
  if (*end != '\0' || !isfinite(v) || v < lo || v > hi) {
    *bad = 1;
    return def;
  }
  return v;
}

static enum MHD_Result send_picture(vf_http *h, struct MHD_Connection *c, uint64_t job_id, int full) {
  int bad = 0;
  double exposure = number_arg(c, "exposure", -20.0, 20.0, 0.0, &bad);
  int side = (int)number_arg(c, "size", 16, VF_PREVIEW_MAX_SIDE, PREVIEW_SIDE, &bad);
  if (bad)
    return send_error(c, MHD_HTTP_BAD_REQUEST, "exposure is a number from -20 to 20, size an integer from 16 to %d",
                      VF_PREVIEW_MAX_SIDE);
  uint8_t *png = NULL;
  size_t size = 0;
  char message[512];
  int status = vf_previews_png(h->previews, job_id, exposure, full ? 0 : side, &png, &size, message, sizeof message);
  if (status != 200) return send_error(c, (unsigned)status, "job %llu: %s", (unsigned long long)job_id, message);
  char disposition[96];
  snprintf(disposition, sizeof disposition, "attachment; filename=\"job-%llu.png\"", (unsigned long long)job_id);
  return send_owned(c, MHD_HTTP_OK, "image/png", png, size, full ? disposition : NULL);
}

/* The job's film as its latest checkpoint wrote it (the file is replaced by rename, so the
 * descriptor holds one whole version). */
static enum MHD_Result send_film(vf_http *h, struct MHD_Connection *c, uint64_t job_id) {
  char path[4200];
  snprintf(path, sizeof path, "%s/job-%llu.exr", vf_dashboard_state_dir(h->dashboard), (unsigned long long)job_id);
  int fd = open(path, O_RDONLY | O_CLOEXEC);
  struct stat st;
  if (fd < 0 && errno == ENOENT)
    return send_error(c, MHD_HTTP_NOT_FOUND, "job %llu: no film checkpoint yet", (unsigned long long)job_id);
  if (fd < 0 || fstat(fd, &st) != 0) {
    if (fd >= 0) close(fd);
    return send_error(c, MHD_HTTP_INTERNAL_SERVER_ERROR, "%s: %s", path, strerror(errno));
  }
  struct MHD_Response *r = mhd->MHD_create_response_from_fd64((uint64_t)st.st_size, fd); /* takes fd */
  if (r == NULL) {
    close(fd);
    return MHD_NO;
  }
  char disposition[96];
  snprintf(disposition, sizeof disposition, "attachment; filename=\"job-%llu.exr\"", (unsigned long long)job_id);
  common_headers(r, "image/x-exr");
  mhd->MHD_add_response_header(r, "Content-Disposition", disposition);
  enum MHD_Result ok = mhd->MHD_queue_response(c, MHD_HTTP_OK, r);
  mhd->MHD_destroy_response(r);
  return ok;
}

/* ---- sessions and actions ---- */

static const char *client_address(struct MHD_Connection *c, char *buf, size_t n) {
  const union MHD_ConnectionInfo *info = mhd->MHD_get_connection_info(c, MHD_CONNECTION_INFO_CLIENT_ADDRESS);
  snprintf(buf, n, "?");
  if (info == NULL || info->client_addr == NULL) return buf;
  const struct sockaddr *sa = info->client_addr;
  if (sa->sa_family == AF_INET) inet_ntop(AF_INET, &((const struct sockaddr_in *)sa)->sin_addr, buf, (socklen_t)n);
  else if (sa->sa_family == AF_INET6)
    inet_ntop(AF_INET6, &((const struct sockaddr_in6 *)sa)->sin6_addr, buf, (socklen_t)n);
  return buf;
}

static enum MHD_Result open_session(vf_http *h, struct MHD_Connection *c, const request *q) {
  cJSON *body = cJSON_ParseWithLength(q->body, q->body_len);
  const char *nonce = cJSON_GetStringValue(cJSON_GetObjectItem(body, "nonce"));
  const char *proof = cJSON_GetStringValue(cJSON_GetObjectItem(body, "proof"));
  char token[VF_SESSION_TEXT], from[64];
  if (nonce == NULL || proof == NULL) {
    cJSON_Delete(body);
    return send_error(c, MHD_HTTP_BAD_REQUEST, "the body must be {\"nonce\": \"...\", \"proof\": \"...\"}");
  }
  int ok = vf_sessions_open(h->sessions, nonce, proof, token);
  cJSON_Delete(body);
  client_address(c, from, sizeof from);
  if (!ok) {
    vf_log("dashboard: refused a sign-in from %s", from);
    return send_error(c, MHD_HTTP_FORBIDDEN, "the proof does not match the nonce: a wrong key, or a nonce spent or "
                                             "older than %.0f s", VF_NONCE_SECONDS);
  }
  vf_log("dashboard: session opened from %s", from);
  cJSON *doc = cJSON_CreateObject();
  cJSON_AddStringToObject(doc, "token", token);
  cJSON_AddNumberToObject(doc, "expires_in", VF_SESSION_SECONDS);
  cJSON_AddStringToObject(doc, "header", VF_HTTP_SESSION_HEADER);
  return send_json(c, MHD_HTTP_OK, doc);
}

/* 0 when the request carries a live session; else the answer (401 or 403) was queued and
 * *answer holds libmicrohttpd's result. */
static int refuse_without_session(vf_http *h, struct MHD_Connection *c, enum MHD_Result *answer) {
  const char *token = mhd->MHD_lookup_connection_value(c, MHD_HEADER_KIND, VF_HTTP_SESSION_HEADER);
  if (token == NULL || token[0] == '\0') {
    *answer = send_error(c, MHD_HTTP_UNAUTHORIZED, "this action needs a session: sign in with the farm key "
                                                   "(POST /api/session), then send its token in %s",
                         VF_HTTP_SESSION_HEADER);
    return 1;
  }
  if (!vf_sessions_check(h->sessions, token)) {
    *answer = send_error(c, MHD_HTTP_FORBIDDEN, "the session token is unknown or expired: sign in again");
    return 1;
  }
  return 0;
}

static enum MHD_Result act(vf_http *h, struct MHD_Connection *c, const request *q, uint64_t job_id,
                           const char *verb) {
  vf_dashboard_action a = {.job_id = job_id};
  if (strcmp(verb, "cancel") == 0) {
    a.verb = VF_DASHBOARD_CANCEL;
  } else if (strcmp(verb, "remove") == 0) {
    a.verb = VF_DASHBOARD_REMOVE;
  } else if (strcmp(verb, "pause") == 0) {
    a.verb = VF_DASHBOARD_PAUSE;
  } else if (strcmp(verb, "resume") == 0) {
    a.verb = VF_DASHBOARD_RESUME;
  } else {
    cJSON *body = cJSON_ParseWithLength(q->body, q->body_len);
    cJSON *p = cJSON_GetObjectItem(body, "priority");
    double v = cJSON_IsNumber(p) ? p->valuedouble : NAN;
    cJSON_Delete(body);
    if (!(v == floor(v) && fabs(v) < 1e6))
      return send_error(c, MHD_HTTP_BAD_REQUEST, "the body must be {\"priority\": N}, N an integer weight");
    a.verb = VF_DASHBOARD_PRIORITY;
    a.priority = (int)v;
  }
  char message[256];
  int status = vf_dashboard_act(h->dashboard, &a, message, sizeof message);
  cJSON *doc = cJSON_CreateObject();
  cJSON_AddBoolToObject(doc, "ok", status == 200);
  cJSON_AddStringToObject(doc, status == 200 ? "message" : "error", message);
  return send_json(c, (unsigned)status, doc);
}

/* ---- routing ---- */

/* "/api/jobs/ID" or "/api/jobs/ID/REST": the id (> 0) and REST ("" for none); 0 else. */
static uint64_t job_path(const char *url, const char **rest) {
  const char *p = url + strlen("/api/jobs/");
  if (*p < '0' || *p > '9') return 0;
  char *end;
  errno = 0;
  unsigned long long id = strtoull(p, &end, 10);
  if (errno != 0 || (*end != '\0' && *end != '/')) return 0;
  *rest = *end == '/' ? end + 1 : end;
  return id;
}

static int host_allowed(vf_http *h, struct MHD_Connection *c) {
  if (!h->loopback) return 1;
  const char *host = mhd->MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Host");
  if (host == NULL) return 0;
  static const char *const names[] = {"127.0.0.1", "localhost", "[::1]"};
  for (size_t i = 0; i < sizeof names / sizeof *names; i++) {
    char allowed[64];
    snprintf(allowed, sizeof allowed, "%s:%u", names[i], h->port);
    if (strcmp(host, allowed) == 0 || (h->port == 80 && strcmp(host, names[i]) == 0)) return 1;
  }
  return 0;
}

static enum MHD_Result route(vf_http *h, struct MHD_Connection *c, const char *url, const char *method,
                             const request *q) {
  int get = strcmp(method, MHD_HTTP_METHOD_GET) == 0 || strcmp(method, MHD_HTTP_METHOD_HEAD) == 0;
  int post = strcmp(method, MHD_HTTP_METHOD_POST) == 0;
  if (!host_allowed(h, c)) return send_error(c, MHD_HTTP_MISDIRECTED_REQUEST, "this dashboard answers to its own address only");
  if (q->too_big) return send_error(c, MHD_HTTP_CONTENT_TOO_LARGE, "a request body has at most %d bytes", BODY_MAX);

  const vf_web_asset *asset = vf_web_asset_find(strcmp(url, "/index.html") == 0 ? "/" : url);
  if (asset) return get ? send_asset(c, asset) : not_allowed(c, "GET");
  if (strcmp(url, "/api/status") == 0) return get ? send_status(h, c, 0) : not_allowed(c, "GET");
  if (strcmp(url, "/api/events") == 0) return get ? send_events(h, c) : not_allowed(c, "GET");
  if (strcmp(url, "/api/session/nonce") == 0) {
    if (!post) return not_allowed(c, "POST");
    char nonce[VF_SESSION_TEXT];
    vf_sessions_nonce(h->sessions, nonce);
    cJSON *doc = cJSON_CreateObject();
    cJSON_AddStringToObject(doc, "nonce", nonce);
    cJSON_AddNumberToObject(doc, "expires_in", VF_NONCE_SECONDS);
    cJSON_AddStringToObject(doc, "proof", "hex of HMAC-SHA-256 under the farm key of \"" VF_SESSION_PROOF_PREFIX
                                          "\" followed by the nonce");
    return send_json(c, MHD_HTTP_OK, doc);
  }
  if (strcmp(url, "/api/session") == 0) return post ? open_session(h, c, q) : not_allowed(c, "POST");
  if (strcmp(url, "/api/session/close") == 0) {
    if (!post) return not_allowed(c, "POST");
    const char *token = mhd->MHD_lookup_connection_value(c, MHD_HEADER_KIND, VF_HTTP_SESSION_HEADER);
    if (token) vf_sessions_close(h->sessions, token);
    cJSON *doc = cJSON_CreateObject();
    cJSON_AddBoolToObject(doc, "ok", 1);
    return send_json(c, MHD_HTTP_OK, doc);
  }
  const char *rest = "";
  uint64_t job_id = strncmp(url, "/api/jobs/", 10) == 0 ? job_path(url, &rest) : 0;
  if (job_id == 0) return send_error(c, MHD_HTTP_NOT_FOUND, "no such page: %.200s", url);
  if (rest[0] == '\0') return get ? send_status(h, c, job_id) : not_allowed(c, "GET");
  if (strcmp(rest, "preview.png") == 0) return get ? send_picture(h, c, job_id, 0) : not_allowed(c, "GET");
  static const char *const actions[] = {"cancel", "remove", "priority", "film", "image", "pause", "resume"};
  for (size_t i = 0; i < sizeof actions / sizeof *actions; i++) {
    if (strcmp(rest, actions[i]) != 0) continue;
    if (!post) return not_allowed(c, "POST");
    enum MHD_Result answer;
    if (refuse_without_session(h, c, &answer)) return answer;
    if (i == 3) return send_film(h, c, job_id);
    if (i == 4) return send_picture(h, c, job_id, 1);
    return act(h, c, q, job_id, rest);
  }
  return send_error(c, MHD_HTTP_NOT_FOUND, "no such page: %.200s", url);
}

static enum MHD_Result on_request(void *cls, struct MHD_Connection *c, const char *url, const char *method,
                                  const char *version, const char *upload_data, size_t *upload_data_size,
                                  void **con_cls) {
  vf_http *h = cls;
  request *q = *con_cls;
  if (q == NULL) { /* the headers: the body (if any) comes in the next calls */
    if ((q = calloc(1, sizeof *q)) == NULL) return MHD_NO;
    *con_cls = q;
    return MHD_YES;
  }
  if (*upload_data_size > 0) {
    if (*upload_data_size > BODY_MAX - q->body_len) q->too_big = 1;
    else memcpy(q->body + q->body_len, upload_data, *upload_data_size), q->body_len += *upload_data_size;
    *upload_data_size = 0;
    return MHD_YES;
  }
  return route(h, c, url, method, q);
}

static void on_completed(void *cls, struct MHD_Connection *c, void **con_cls, enum MHD_RequestTerminationCode code) {
  free(*con_cls);
  *con_cls = NULL;
}

static void on_log(void *cls, const char *fmt, va_list ap) {
  char line[512];
  vsnprintf(line, sizeof line, fmt, ap);
  size_t n = strlen(line);
  while (n > 0 && line[n - 1] == '\n') line[--n] = '\0';
  vf_log("dashboard: %s", line);
}

/* "HOST:PORT", "[V6]:PORT" or "PORT" into *addr. */
static int parse_address(const char *text, struct sockaddr_storage *addr, int *v6, int *loopback) {
  char host[128] = "127.0.0.1";
  const char *port_text = text;
  const char *colon = strrchr(text, ':');
  if (colon) {
    size_t n = (size_t)(colon - text);
    if (n == 0 || n >= sizeof host) return vf_error_set(VF_EUSAGE, "--http %s: expected HOST:PORT", text);
    memcpy(host, text, n);
    host[n] = '\0';
    port_text = colon + 1;
  }
  char *end;
  long port = strtol(port_text, &end, 10);
  if (port_text[0] == '\0' || *end != '\0' || port < 0 || port > 65535)
    return vf_error_set(VF_EUSAGE, "--http %s: the port must be a number from 0 to 65535", text);
  memset(addr, 0, sizeof *addr);
  size_t n = strlen(host);
  if (host[0] == '[' && host[n - 1] == ']') {
    struct sockaddr_in6 *a = (struct sockaddr_in6 *)addr;
    host[n - 1] = '\0';
    if (inet_pton(AF_INET6, host + 1, &a->sin6_addr) != 1)
      return vf_error_set(VF_EUSAGE, "--http %s: '%s' is not an IPv6 address", text, host + 1);
    a->sin6_family = AF_INET6;
    a->sin6_port = htons((uint16_t)port);
    *v6 = 1;
    *loopback = IN6_IS_ADDR_LOOPBACK(&a->sin6_addr);
    return VF_OK;
  }
  struct sockaddr_in *a = (struct sockaddr_in *)addr;
  if (strcmp(host, "localhost") == 0) snprintf(host, sizeof host, "127.0.0.1");
  if (inet_pton(AF_INET, host, &a->sin_addr) != 1)
    return vf_error_set(VF_EUSAGE, "--http %s: '%s' is not an IPv4 address, [IPv6] address or localhost", text, host);
  a->sin_family = AF_INET;
  a->sin_port = htons((uint16_t)port);
  *v6 = 0;
  *loopback = (ntohl(a->sin_addr.s_addr) >> 24) == 127;
  return VF_OK;
}

int vf_http_start(vf_dashboard *dashboard, const vf_wire_key *key, const char *address, vf_http **out) {
  struct sockaddr_storage addr;
  int v6 = 0, loopback = 0;
  int err = parse_address(address, &addr, &v6, &loopback);
  if (err != VF_OK) return err;
  const vf_http_api *api = vf_module_get(&http_module, "--http");
  if (api == NULL) return VF_EMODULE;
  mhd = api;
  vf_http *h = calloc(1, sizeof *h);
  if (h == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  h->dashboard = dashboard;
  h->loopback = loopback;
  if ((err = vf_sessions_create(key, &h->sessions)) != VF_OK ||
      (err = vf_previews_create(vf_dashboard_state_dir(dashboard), &h->previews)) != VF_OK)
    goto fail;
  unsigned flags = MHD_USE_THREAD_PER_CONNECTION | MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_POLL | MHD_USE_ERROR_LOG;
  if (v6) flags |= MHD_USE_IPv6;
  h->daemon = mhd->MHD_start_daemon(flags, 0, NULL, NULL, on_request, h, MHD_OPTION_EXTERNAL_LOGGER, on_log, NULL,
                               MHD_OPTION_SOCK_ADDR, (struct sockaddr *)&addr, MHD_OPTION_CONNECTION_LIMIT,
                               (unsigned)VF_HTTP_CONNECTIONS, MHD_OPTION_CONNECTION_TIMEOUT,
                               (unsigned)CONNECTION_SECONDS, MHD_OPTION_NOTIFY_COMPLETED, on_completed, NULL,
                               MHD_OPTION_END);
  if (h->daemon == NULL) {
    err = vf_error_set(VF_ENET, "--http %s: cannot listen there (%s)", address, strerror(errno));
    goto fail;
  }
  const union MHD_DaemonInfo *info = mhd->MHD_get_daemon_info(h->daemon, MHD_DAEMON_INFO_BIND_PORT);
  h->port = info ? info->port : 0;
  char host[64];
  if (v6) inet_ntop(AF_INET6, &((struct sockaddr_in6 *)&addr)->sin6_addr, host, sizeof host);
  else inet_ntop(AF_INET, &((struct sockaddr_in *)&addr)->sin_addr, host, sizeof host);
  vf_log("dashboard on http://%s%s%s:%u/%s", v6 ? "[" : "", host, v6 ? "]" : "", h->port,
         loopback ? "" : " (not loopback: reachable from the network; actions still need the farm key)");
  *out = h;
  return VF_OK;
fail:
  vf_previews_destroy(h->previews);
  vf_sessions_destroy(h->sessions);
  free(h);
  return err;
}

void vf_http_stop(vf_http *h) {
  if (h == NULL) return;
  mhd->MHD_stop_daemon(h->daemon);
  vf_previews_destroy(h->previews);
  vf_sessions_destroy(h->sessions);
  free(h);
}
