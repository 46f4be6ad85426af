#include "client_cmd.h"

#include "options.h"
#include "../common/error.h"
#include "../common/farm_client.h"
#include "../common/file.h"
#include "../common/image.h"
#include "../worker/job_scene.h"
#include "../coordinator/job.h"
#include "../coordinator/schedule.h"
#include "fetch.h"
#include "submit.h"

#include <cjson/cJSON.h>
#include <dirent.h>
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <sodium.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Options every client command shares. */
typedef struct {
  const char *url, *secret;
  double timeout;
} connection;

#define CONNECTION_HELP                                                                    \
  "  -c, --coordinator URL  the coordinator: tcp://HOST:PORT or ipc://PATH (required)\n"  \
  "  -k, --secret FILE      the farm's key file (required)\n"                              \
  "      --timeout S        give up after S seconds without an answer (default 10)\n"     \
  "  -h, --help             this text\n"

static int connection_option(connection *conn, int c, int *err) {
  switch (c) {
  case 'c': conn->url = optarg; return 1;
  case 'k': conn->secret = optarg; return 1;
  case 'T': *err = vf_cli_double("--timeout", optarg, 0.01, 86400.0, &conn->timeout); return 1;
  default: return 0;
  }
}

/* A client of the coordinator the options name; *client on success only. */
static int connect_to(const connection *conn, vf_farm_client **client) {
  if (conn->url == NULL || conn->secret == NULL)
    return vf_error_set(VF_EUSAGE, "--coordinator URL and --secret FILE are required");
  vf_wire_key key;
  int err = vf_wire_key_load(conn->secret, &key);
  if (err == VF_OK) err = vf_farm_client_open(conn->url, &key, client);
  sodium_memzero(&key, sizeof key);
  return err;
}

/* One request, one reply of the expected kind. */
static int request(const connection *conn, Vcmfarm__Envelope *q, Vcmfarm__Envelope__BodyCase expected,
                   Vcmfarm__Envelope **reply) {
  vf_farm_client *client;
  int err = connect_to(conn, &client);
  if (err != VF_OK) return err;
  err = vf_farm_request(client, q, expected, (int)(conn->timeout * 1000.0), reply);
  vf_farm_client_close(client);
  return err;
}

static int parse_job_id(const char *text, uint64_t *id) {
  int err = vf_cli_u64("JOB", text, id);
  if (err == VF_OK && *id == 0) err = vf_error_set(VF_EUSAGE, "JOB: job ids start at 1");
  return err;
}

/* ---- submit ---- */

static const char submit_usage[] =
    "usage: vcmfarm submit SCENE --coordinator URL --secret FILE [options]\n"
    "\n"
    "Submits a job rendering global iterations K, K+1, ... (K = 0 by default) of SCENE (a built-in name or a\n"
    "JSON scene file) and prints the job id as the last line. The mesh and map files the\n"
    "scene names are sent by content hash, those the coordinator lacks first. The job\n"
    "stops at the first stop condition that holds.\n"
    "\n"
    "      --start-iteration K  the first global iteration (default 0; at most 2^53), to\n"
    "                           continue a film that holds [0, K)\n" VF_CLI_STOP_HELP
    "                           (the reference is sent with the job)\n"
    "  -P, --priority P         weight 1 to 1000 (default 1): jobs share the workers' time in\n"
    "                           proportion to their priorities\n"
    "  -N, --name NAME          a name for status (default: SCENE)\n"
    "      --camera NAME|INDEX  a glTF file's camera to render (default: its first)\n" VF_CLI_SETTINGS_HELP CONNECTION_HELP;

int vf_cmd_submit(int argc, char **argv) {
  static const struct option options[] = {
      VF_CLI_STOP_OPTIONS,
      VF_CLI_SETTINGS_OPTIONS,
      {"priority", required_argument, 0, 'P'},        {"name", required_argument, 0, 'N'},
      {"coordinator", required_argument, 0, 'c'},     {"secret", required_argument, 0, 'k'},
      {"timeout", required_argument, 0, 'T'},         {"start-iteration", required_argument, 0, 'K'},
      {"camera", required_argument, 0, 'M'},          {"help", no_argument, 0, 'h'},
      {0, 0, 0, 0}};
  uint64_t first = 0;
  const char *cmd = "submit", *name = NULL, *camera = NULL;
  vf_cli_settings overrides;
  vf_cli_stop stop = {0};
  connection conn = {NULL, NULL, 10.0};
  long long priority = 1;
  int err = VF_OK, c;
  vf_cli_settings_init(&overrides);
  optind = 0; /* 0: getopt starts again from scratch (glibc), forgetting the last argv */
  opterr = 0;
  while ((c = getopt_long(argc, argv, VF_CLI_STOP_SHORT VF_CLI_SETTINGS_SHORT "P:N:c:k:h", options, NULL)) != -1) {
    if (connection_option(&conn, c, &err) || vf_cli_settings_option(&overrides, c, optarg, &err) ||
        vf_cli_stop_option(&stop, c, optarg, &err)) {
      if (err != VF_OK) return vf_cli_fail(cmd, err);
      continue;
    }
    switch (c) {
    case 'P': err = vf_cli_int("--priority", optarg, VF_PRIORITY_MIN, VF_PRIORITY_MAX, &priority); break;
    case 'N': name = optarg; break;
    case 'M': camera = optarg; break;
    case 'K': err = vf_cli_u64("--start-iteration", optarg, &first); break;
    case 'h': fputs(submit_usage, stdout); return VF_EXIT_OK;
    default: return vf_cli_bad_option(cmd, argv, submit_usage);
    }
    if (err != VF_OK) return vf_cli_fail(cmd, err);
  }
  if (optind != argc - 1) {
    fprintf(stderr, "vcmfarm submit: expected exactly one SCENE\n%s", submit_usage);
    return VF_EXIT_BAD_INPUT;
  }
  /* A farm job stops at the first of its conditions to hold: iterations and time together too. */
  if ((err = vf_cli_stop_check(&stop, 0)) != VF_OK) return vf_cli_fail(cmd, err);
  uint64_t iterations = vf_cli_stop_iterations(&stop);
  vf_farm_client *client;
  if ((err = connect_to(&conn, &client)) != VF_OK) return vf_cli_fail(cmd, err);
  vf_submit_job job = {argv[optind], camera, name, &overrides, first, iterations, (int)priority,
                       stop.time_limit, stop.target_rmse, stop.target_error, stop.reference, "vcmfarm submit"};
  vf_submitted_job submitted;
  err = vf_submit(client, (int)(conn.timeout * 1000.0), &job, &submitted);
  vf_farm_client_close(client);
  if (err != VF_OK) return vf_cli_fail(cmd, err);
  fprintf(stderr, "vcmfarm submit: %s, %s, at most %llu iterations from %llu, priority %lld\n", argv[optind],
          submitted.settings_text, (unsigned long long)iterations, (unsigned long long)first, priority);
  printf("%llu\n", (unsigned long long)submitted.job_id);
  return VF_EXIT_OK;
}

/* ---- status ---- */

static const char status_usage[] =
    "usage: vcmfarm status [JOB] --coordinator URL --secret FILE [--json]\n"
    "\n"
    "Shows the farm's rate, every job (or JOB) and every worker. A job's state is one of\n"
    "queued, running, done, cancelled, failed; with --json it is the field \"state\". A job\n"
    "shows its rate, ETA and latest error; with JOB, its convergence log too.\n"
    "\n"
    "  -J, --json             JSON on stdout instead of text\n" CONNECTION_HELP;

/* JSON has no NaN: unknown values are null. */
static void add_number_or_null(cJSON *o, const char *key, double v) {
  if (isfinite(v)) cJSON_AddNumberToObject(o, key, v);
  else cJSON_AddNullToObject(o, key);
}

static void print_json(const Vcmfarm__Status *st) {
  cJSON *root = cJSON_CreateObject(), *jobs = cJSON_AddArrayToObject(root, "jobs"),
        *workers = cJSON_AddArrayToObject(root, "workers");
  for (size_t i = 0; i < st->n_jobs; i++) {
    const Vcmfarm__JobStatus *j = st->jobs[i];
    cJSON *o = cJSON_CreateObject();
    cJSON_AddItemToArray(jobs, o);
    cJSON_AddNumberToObject(o, "id", (double)j->job_id);
    cJSON_AddStringToObject(o, "name", j->name);
    cJSON_AddStringToObject(o, "state", j->state);
    cJSON_AddNumberToObject(o, "priority", j->priority);
    cJSON_AddNumberToObject(o, "first_iteration", (double)j->first_iteration);
    cJSON_AddNumberToObject(o, "iterations", (double)j->iterations_total);
    cJSON_AddNumberToObject(o, "iterations_done", (double)j->iterations_done);
    cJSON_AddNumberToObject(o, "iterations_leased", (double)j->iterations_leased);
    cJSON_AddNumberToObject(o, "iterations_rendering", (double)j->iterations_rendering);
    cJSON_AddNumberToObject(o, "progress",
                            j->iterations_total ? (double)j->iterations_done / (double)j->iterations_total : 0.0);
    cJSON_AddNumberToObject(o, "iterations_per_second", j->iterations_per_second);
    cJSON_AddNumberToObject(o, "workers", j->workers);
    cJSON_AddNumberToObject(o, "seconds", j->seconds);
    add_number_or_null(o, "eta_seconds", j->eta_seconds >= 0.0 ? j->eta_seconds : NAN);
    add_number_or_null(o, "rmse", j->rmse);
    add_number_or_null(o, "estimated_rmse", j->estimated_rmse);
    cJSON *stop = cJSON_AddObjectToObject(o, "stop");
    cJSON_AddNumberToObject(stop, "iterations", (double)j->iterations_total);
    add_number_or_null(stop, "time", j->time_limit > 0.0 ? j->time_limit : NAN);
    add_number_or_null(stop, "target_rmse", j->target_rmse > 0.0 ? j->target_rmse : NAN);
    add_number_or_null(stop, "target_error", j->target_error > 0.0 ? j->target_error : NAN);
    cJSON_AddBoolToObject(o, "reference", j->has_reference);
    cJSON_AddStringToObject(o, "stop_reason", j->stop_reason);
    cJSON_AddNumberToObject(o, "results_refused", (double)j->results_refused);
    cJSON_AddStringToObject(o, "settings", j->settings);
    cJSON_AddStringToObject(o, "message", j->message);
    if (j->n_convergence > 0) {
      cJSON *log = cJSON_AddArrayToObject(o, "convergence");
      for (size_t k = 0; k < j->n_convergence; k++) {
        const Vcmfarm__ConvergenceEntry *e = j->convergence[k];
        cJSON *c = cJSON_CreateObject();
        cJSON_AddItemToArray(log, c);
        cJSON_AddNumberToObject(c, "run", e->run);
        cJSON_AddNumberToObject(c, "wall_seconds", e->wall_seconds);
        cJSON_AddNumberToObject(c, "cpu_seconds", e->cpu_seconds);
        cJSON_AddNumberToObject(c, "iterations", (double)e->iterations);
        add_number_or_null(c, "rmse", e->rmse);
        add_number_or_null(c, "rel_mse", e->rel_mse);
        add_number_or_null(c, "estimated_rmse", e->estimated_rmse);
      }
    }
  }
  cJSON_AddNumberToObject(root, "iterations_per_second", st->iterations_per_second);
  cJSON_AddNumberToObject(root, "workers_busy", st->workers_busy);
  for (size_t i = 0; i < st->n_workers; i++) {
    const Vcmfarm__WorkerStatus *w = st->workers[i];
    cJSON *o = cJSON_CreateObject();
    char id[17];
    snprintf(id, sizeof id, "%016llx", (unsigned long long)w->worker_id);
    cJSON_AddItemToArray(workers, o);
    cJSON_AddStringToObject(o, "id", id);
    cJSON_AddStringToObject(o, "name", w->name);
    cJSON_AddNumberToObject(o, "threads", w->threads);
    if (w->lease_job) {
      cJSON *l = cJSON_AddObjectToObject(o, "lease");
      cJSON_AddNumberToObject(l, "job", (double)w->lease_job);
      cJSON_AddNumberToObject(l, "begin", (double)w->lease_begin);
      cJSON_AddNumberToObject(l, "end", (double)w->lease_end);
    } else {
      cJSON_AddNullToObject(o, "lease");
    }
    cJSON_AddNumberToObject(o, "iterations_per_second", w->iterations_per_second);
    cJSON_AddNumberToObject(o, "last_seen_seconds", w->last_seen_seconds);
  }
  char *text = cJSON_Print(root);
  if (text) puts(text);
  free(text);
  cJSON_Delete(root);
}

/* "1h02m", "3m05s", "12.3 s" */
static void format_duration(char *buf, size_t n, double s) {
  if (s < 0.0 || !isfinite(s)) snprintf(buf, n, "unknown");
  else if (s < 60.0) snprintf(buf, n, "%.1f s", s);
  else if (s < 3600.0) snprintf(buf, n, "%dm%02ds", (int)(s / 60.0), (int)fmod(s, 60.0));
  else snprintf(buf, n, "%dh%02dm", (int)(s / 3600.0), (int)fmod(s / 60.0, 60.0));
}

static void print_text(const Vcmfarm__Status *st) {
  printf("farm: %.2f iterations/s, %u of %zu workers busy\n", st->iterations_per_second, st->workers_busy,
         st->n_workers);
  for (size_t i = 0; i < st->n_jobs; i++) {
    const Vcmfarm__JobStatus *j = st->jobs[i];
    char ran[32], eta[32], stop[256] = "", *p = stop;
    format_duration(ran, sizeof ran, j->seconds);
    format_duration(eta, sizeof eta, j->eta_seconds);
    size_t left = sizeof stop;
    int n = snprintf(p, left, "%llu iterations", (unsigned long long)j->iterations_total);
    if (j->time_limit > 0.0 && n > 0 && (size_t)n < left) p += n, left -= (size_t)n, n = snprintf(p, left, ", %g s", j->time_limit);
    if (j->target_rmse > 0.0 && n > 0 && (size_t)n < left)
      p += n, left -= (size_t)n, n = snprintf(p, left, ", RMSE %g", j->target_rmse);
    if (j->target_error > 0.0 && n > 0 && (size_t)n < left)
      p += n, left -= (size_t)n, n = snprintf(p, left, ", est. RMSE %g", j->target_error);
    printf("job %llu '%s': %s, %llu iterations done, %llu leased (%llu of them rendered, not merged yet), "
           "priority %d; stops at %s\n",
           (unsigned long long)j->job_id, j->name, j->state, (unsigned long long)j->iterations_done,
           (unsigned long long)j->iterations_leased, (unsigned long long)j->iterations_rendering, j->priority, stop);
    printf("  ran %s, %.2f it/s on %u workers, ETA %s, est. RMSE %.4g", ran, j->iterations_per_second, j->workers,
           strcmp(j->state, "done") == 0 ? "done" : eta, j->estimated_rmse);
    if (j->has_reference) printf(", RMSE %.4g", j->rmse);
    if (j->results_refused) printf(", %llu results refused", (unsigned long long)j->results_refused);
    printf("\n");
    if (j->stop_reason[0]) printf("  stopped: %s\n", j->stop_reason);
    if (j->message[0]) printf("  %s\n", j->message);
    if (j->n_convergence > 0) {
      printf("  %4s %12s %12s %10s %12s %12s %12s\n", "run", "worker s", "cpu s", "iterations", "RMSE", "rel. MSE",
             "est. RMSE");
      for (size_t k = 0; k < j->n_convergence; k++) {
        const Vcmfarm__ConvergenceEntry *e = j->convergence[k];
        printf("  %4u %12.2f %12.2f %10llu %12.5g %12.5g %12.5g\n", e->run, e->wall_seconds, e->cpu_seconds,
               (unsigned long long)e->iterations, e->rmse, e->rel_mse, e->estimated_rmse);
      }
    }
  }
  for (size_t i = 0; i < st->n_workers; i++) {
    const Vcmfarm__WorkerStatus *w = st->workers[i];
    printf("worker %s (%u threads): ", w->name, w->threads);
    if (w->lease_job)
      printf("job %llu [%llu,%llu)", (unsigned long long)w->lease_job, (unsigned long long)w->lease_begin,
             (unsigned long long)w->lease_end);
    else
      printf("idle");
    printf(", %.2f it/s, seen %.1f s ago\n", w->iterations_per_second, w->last_seen_seconds);
  }
  if (st->n_jobs == 0 && st->n_workers == 0) printf("no jobs, no workers\n");
}

int vf_cmd_status(int argc, char **argv) {
  static const struct option options[] = {
      {"json", no_argument, 0, 'J'},       {"coordinator", required_argument, 0, 'c'},
      {"secret", required_argument, 0, 'k'}, {"timeout", required_argument, 0, 'T'},
      {"help", no_argument, 0, 'h'},       {0, 0, 0, 0}};
  const char *cmd = "status";
  connection conn = {NULL, NULL, 10.0};
  int json = 0, err = VF_OK, c;
  optind = 0; /* 0: getopt starts again from scratch (glibc), forgetting the last argv */
  opterr = 0;
  while ((c = getopt_long(argc, argv, "Jc:k:h", options, NULL)) != -1) {
    if (connection_option(&conn, c, &err)) {
      if (err != VF_OK) return vf_cli_fail(cmd, err);
      continue;
    }
    if (c == 'J') json = 1;
    else if (c == 'h') return fputs(status_usage, stdout), VF_EXIT_OK;
    else return vf_cli_bad_option(cmd, argv, status_usage);
  }
  Vcmfarm__StatusRequest m = VCMFARM__STATUS_REQUEST__INIT;
  if (optind == argc - 1) {
    if ((err = parse_job_id(argv[optind], &m.job_id)) != VF_OK) return vf_cli_fail(cmd, err);
  } else if (optind != argc) {
    fprintf(stderr, "vcmfarm status: at most one JOB\n%s", status_usage);
    return VF_EXIT_BAD_INPUT;
  }
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_STATUS_REQUEST;
  q.status_request = &m;
  if ((err = request(&conn, &q, VCMFARM__ENVELOPE__BODY_STATUS, &reply)) != VF_OK) return vf_cli_fail(cmd, err);
  if (json) print_json(reply->status);
  else print_text(reply->status);
  vf_message_free(reply);
  return VF_EXIT_OK;
}

/* ---- fetch ---- */

static const char fetch_usage[] =
    "usage: vcmfarm fetch JOB -o FILM.exr --coordinator URL --secret FILE\n"
    "\n"
    "Writes the current film of JOB (a valid film at any moment, holding the iterations\n"
    "merged so far) to FILM.exr, atomically: it arrives in chunks, is checked whole (size,\n"
    "hash, film) and only then replaces FILM.exr, which a failed fetch leaves as it was.\n"
    "\n"
    "  -o, --output FILM.exr  the film to write (required)\n" CONNECTION_HELP;

int vf_cmd_fetch(int argc, char **argv) {
  static const struct option options[] = {
      {"output", required_argument, 0, 'o'}, {"coordinator", required_argument, 0, 'c'},
      {"secret", required_argument, 0, 'k'}, {"timeout", required_argument, 0, 'T'},
      {"help", no_argument, 0, 'h'},         {0, 0, 0, 0}};
  const char *cmd = "fetch", *output = NULL;
  connection conn = {NULL, NULL, 60.0};
  int err = VF_OK, c;
  optind = 0; /* 0: getopt starts again from scratch (glibc), forgetting the last argv */
  opterr = 0;
  while ((c = getopt_long(argc, argv, "o:c:k:h", options, NULL)) != -1) {
    if (connection_option(&conn, c, &err)) {
      if (err != VF_OK) return vf_cli_fail(cmd, err);
      continue;
    }
    if (c == 'o') output = optarg;
    else if (c == 'h') return fputs(fetch_usage, stdout), VF_EXIT_OK;
    else return vf_cli_bad_option(cmd, argv, fetch_usage);
  }
  if (optind != argc - 1 || output == NULL) {
    fprintf(stderr, "vcmfarm fetch: expected one JOB and -o FILM.exr\n%s", fetch_usage);
    return VF_EXIT_BAD_INPUT;
  }
  uint64_t job_id;
  vf_farm_client *client;
  if ((err = parse_job_id(argv[optind], &job_id)) != VF_OK || (err = connect_to(&conn, &client)) != VF_OK)
    return vf_cli_fail(cmd, err);
  /* Read back before it replaces FILM.exr: what lands there is a checked film. */
  vf_film *film = NULL;
  err = vf_fetch_film(client, job_id, output, (int)(conn.timeout * 1000.0), &film);
  vf_farm_client_close(client);
  vf_film_destroy(film);
  return err == VF_OK ? VF_EXIT_OK : vf_cli_fail(cmd, err);
}

/* ---- cancel, remove ---- */

static const char cancel_usage[] =
    "usage: vcmfarm cancel JOB --coordinator URL --secret FILE\n"
    "\n"
    "Cancels JOB: no new leases, results refused; its film so far stays fetchable.\n\n" CONNECTION_HELP;

static const char remove_usage[] =
    "usage: vcmfarm remove JOB --coordinator URL --secret FILE\n"
    "\n"
    "Forgets JOB, which must have ended (done, cancelled or failed; cancel it first\n"
    "otherwise): the coordinator deletes its film and scene, and the scene files no other\n"
    "job names. Fetch the film first if you need it.\n\n" CONNECTION_HELP;

/* `cancel JOB` and `remove JOB`: one request answered by a ResultAck. */
static int job_request(int argc, char **argv, const char *cmd, const char *usage, Vcmfarm__Envelope__BodyCase body) {
  static const struct option options[] = {{"coordinator", required_argument, 0, 'c'},
                                          {"secret", required_argument, 0, 'k'},
                                          {"timeout", required_argument, 0, 'T'},
                                          {"help", no_argument, 0, 'h'},
                                          {0, 0, 0, 0}};
  connection conn = {NULL, NULL, 10.0};
  int err = VF_OK, c;
  optind = 0; /* 0: getopt starts again from scratch (glibc), forgetting the last argv */
  opterr = 0;
  while ((c = getopt_long(argc, argv, "c:k:h", options, NULL)) != -1) {
    if (connection_option(&conn, c, &err)) {
      if (err != VF_OK) return vf_cli_fail(cmd, err);
      continue;
    }
    if (c == 'h') return fputs(usage, stdout), VF_EXIT_OK;
    return vf_cli_bad_option(cmd, argv, usage);
  }
  if (optind != argc - 1) {
    fprintf(stderr, "vcmfarm %s: expected one JOB\n%s", cmd, usage);
    return VF_EXIT_BAD_INPUT;
  }
  uint64_t job_id;
  if ((err = parse_job_id(argv[optind], &job_id)) != VF_OK) return vf_cli_fail(cmd, err);
  Vcmfarm__CancelRequest cancel = VCMFARM__CANCEL_REQUEST__INIT;
  Vcmfarm__RemoveRequest remove = VCMFARM__REMOVE_REQUEST__INIT;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = body;
  if (body == VCMFARM__ENVELOPE__BODY_CANCEL) {
    cancel.job_id = job_id;
    q.cancel = &cancel;
  } else {
    remove.job_id = job_id;
    q.remove = &remove;
  }
  if ((err = request(&conn, &q, VCMFARM__ENVELOPE__BODY_RESULT_ACK, &reply)) != VF_OK) return vf_cli_fail(cmd, err);
  int accepted = reply->result_ack->accepted;
  fprintf(stderr, "vcmfarm %s: %s\n", cmd, reply->result_ack->message);
  vf_message_free(reply);
  return accepted ? VF_EXIT_OK : VF_EXIT_FAILURE;
}

int vf_cmd_cancel(int argc, char **argv) {
  return job_request(argc, argv, "cancel", cancel_usage, VCMFARM__ENVELOPE__BODY_CANCEL);
}

int vf_cmd_remove(int argc, char **argv) {
  return job_request(argc, argv, "remove", remove_usage, VCMFARM__ENVELOPE__BODY_REMOVE);
}

/* ---- keygen ---- */

int vf_cmd_keygen(int argc, char **argv) {
  if (argc == 2 && (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0)) {
    printf("usage: vcmfarm keygen FILE\n\nWrites a new random farm key (64 hex digits) to FILE with permissions 0600;\n"
           "coordinator, workers and clients all need a copy. Never replaces an existing file.\n");
    return VF_EXIT_OK;
  }
  if (argc != 2) {
    fprintf(stderr, "usage: vcmfarm keygen FILE\n");
    return VF_EXIT_BAD_INPUT;
  }
  int err = vf_wire_key_generate(argv[1]);
  return err == VF_OK ? VF_EXIT_OK : vf_cli_fail("keygen", err);
}
