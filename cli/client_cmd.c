#include "client_cmd.h"

#include "options.h"
#include "../common/error.h"
#include "../common/farm_client.h"
#include "../common/file.h"
#include "../common/image.h"
#include "../worker/scene/job_scene.h"
#include "../coordinator/job.h"
#include "../coordinator/schedule.h"
#include "../common/clock.h"
#include "fetch.h"
#include "interrupt.h"
#include "render_job.h"
#include "status_report.h"
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

/* An open-ended submit (a time or a target, no --iterations) is one farm job. */
_Static_assert(VF_CLI_ITERATIONS_OPEN_ENDED <= VF_JOB_MAX_ITERATIONS, "open-ended jobs must fit in a job");

/* Options every client command shares. */
typedef struct {
  const char *url, *secret;
  double timeout;
} connection;

#define CONNECTION_HELP                                                                    \
  "  -c, --coordinator URL  the coordinator: tcp://HOST:PORT or ipc://PATH (required)\n"  \
  "  -k, --secret FILE      the farm's key file (required)\n"                              \
  "      --timeout S        give up after S seconds without an answer (default 10)\n"     \
  "  -h, --help             this text\n"                                                 \
  "\n"                                                                                    \
  "Exit status: 0 done, 1 failure (no coordinator answered, the network, the disk), 2\n"  \
  "bad input: the command line, a key the coordinator refuses, a job it does not have\n" \
  "or a request that does not fit the job's state (then nothing is written or done).\n"

static int connection_option(connection *conn, int c, int *err) {
  switch (c) {
  case 'c':
    conn->url = optarg;
    *err = vf_cli_address("--coordinator", optarg);
    return 1;
  case 'k': conn->secret = optarg; return 1;
  case 'T': *err = vf_cli_double("--timeout", optarg, 0.01, 86400.0, &conn->timeout); return 1;
  default: return 0;
  }
}

/* A client of the coordinator the options name, connected: a coordinator that is down is
 * said so within a second (vf_farm_client_wait_connected), not after --timeout. *client on
 * success only. */
static int connect_to(const connection *conn, vf_farm_client **client) {
  if (conn->url == NULL || conn->secret == NULL)
    return vf_error_set(VF_EUSAGE, "--coordinator URL and --secret FILE are required");
  vf_wire_key key;
  vf_farm_client *c = NULL;
  int err = vf_wire_key_load(conn->secret, &key);
  if (err == VF_OK) err = vf_farm_client_open(conn->url, &key, &c);
  sodium_memzero(&key, sizeof key);
  if (err == VF_OK && (err = vf_farm_client_wait_connected(c, (int)(conn->timeout * 1000.0))) != VF_OK) {
    vf_farm_client_close(c);
    return err;
  }
  if (err == VF_OK) *client = c;
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

/* A long option's value that no short option and no shared option (cli/options.h) has. */
#define OPT_REQUIRE 0x1001


static const char submit_usage[] =
    "usage: vcmfarm submit SCENE --coordinator URL --secret FILE [options]\n"
    "\n"
    "Submits a job rendering global iterations K, K+1, ... (K = 0 by default) of SCENE and\n"
    "prints the job id as the last line. SCENE is a built-in name (cornell, furnace...,\n"
    "docs/SCENES.md), a JSON scene file, a glTF 2.0 file (.gltf, .glb), an OBJ file (with\n"
    "its .mtl) or a Mitsuba 3 scene (.xml), rendered as `render` does; a Mitsuba scene\n"
    "travels as the JSON scene it converts to. The files the scene\n"
    "names (meshes, maps, textures, a glTF's buffers, an OBJ's .mtl) are sent by content\n"
    "hash, those the coordinator lacks first. The job stops at the first stop condition\n"
    "that holds.\n"
    "\n"
    "      --start-iteration K  the first global iteration (default 0; at most 2^53), to\n"
    "                           continue a film that holds [0, K)\n" VF_CLI_STOP_HELP
    "                           (the reference is sent with the job)\n"
    "  -P, --priority P         weight 1 to 1000 (default 1): jobs share the workers' time in\n"
    "                           proportion to their priorities\n"
    "      --require TAG[,TAG]  lease the job only to workers satisfying every TAG: one it\n"
    "                           carries (worker --tags, or found: avx2, avx512), or mem>=N\n"
    "                           with a unit K, M, G or T (its memory, e.g. mem>=64G); at\n"
    "                           most 16 tags of 1 to 32 bytes, given once or in several\n"
    "                           options\n"
    "  -N, --name NAME          a name for status (default: SCENE)\n"
    "      --camera NAME|INDEX  a glTF file's camera or Mitsuba scene's sensor to render\n"
    "                           (default: its first)\n"
    "  -w, --wait               wait until the job ends (its progress on stderr), then fetch\n"
    "                           its film to -o; SIGINT stops waiting, not the job. Exit\n"
    "                           status 0 when it is done, 1 when it failed or was cancelled\n"
    "  -o, --output FILM.exr    with --wait: where the film goes (required with it)\n" VF_CLI_PREVIEW_HELP
    VF_CLI_SETTINGS_HELP VF_CLI_ALLOCATION_FROM_HELP
    "                           (sent with the job, as -a auto --pilot N sends the one it\n"
    "                           chose: the farm runs no pilot)\n" CONNECTION_HELP;

/* Status of one job until it ends, then its film to `output`: submit --wait. The job keeps
 * running on the farm whatever happens here (SIGINT only stops the waiting). *done says
 * whether the job ended done (not failed, cancelled, or still running when interrupted). */
static int wait_and_fetch(vf_farm_client *client, const connection *conn, uint64_t job_id, const char *output,
                          const char *preview, double exposure, int *done) {
  *done = 0;
  Vcmfarm__StatusRequest m = VCMFARM__STATUS_REQUEST__INIT;
  m.job_id = job_id;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply = NULL;
  q.body_case = VCMFARM__ENVELOPE__BODY_STATUS_REQUEST;
  q.status_request = &m;
  int tty = isatty(STDERR_FILENO), err = VF_OK, ended = 0;
  double last_line = 0.0;
  char line[512] = "", state[16] = "";
  vf_interrupt_saved saved;
  vf_interrupt_catch(&saved);
  while (!ended && !vf_interrupted) {
    err = vf_farm_request(client, &q, VCMFARM__ENVELOPE__BODY_STATUS, (int)(conn->timeout * 1000.0), &reply);
    if (err == VF_OK && reply->status->n_jobs == 1) {
      const Vcmfarm__JobStatus *j = reply->status->jobs[0];
      vf_status_job_line(j, line, sizeof line);
      snprintf(state, sizeof state, "%s", j->state);
      ended = strcmp(j->state, "queued") != 0 && strcmp(j->state, "running") != 0 && strcmp(j->state, "paused") != 0;
    } else if (err == VF_OK) {
      err = vf_error_set(VF_EPROTO, "the status of job %llu lacks it", (unsigned long long)job_id);
    }
    vf_message_free(reply);
    reply = NULL;
    if (err == VF_EREFUSED || err == VF_EPROTO || err == VF_EVERSION || err == VF_EAUTH || err == VF_ENOJOB) break;
    double now = vf_seconds_now();
    if (err != VF_OK) { /* the coordinator away (restarting?): keep asking */
      fprintf(stderr, "%svcmfarm submit: %s; asking again\n", tty ? "\n" : "", vf_error_detail(err));
      err = VF_OK;
    } else if (tty) {
      fprintf(stderr, "\r  job %llu: %s   ", (unsigned long long)job_id, line);
    } else if (ended || now - last_line >= 10.0) {
      fprintf(stderr, "vcmfarm submit: job %llu: %s\n", (unsigned long long)job_id, line);
      last_line = now;
    }
    if (!ended) {
      struct timespec ts = {0, 500000000L};
      nanosleep(&ts, NULL);
    }
  }
  if (tty && line[0]) fputc('\n', stderr);
  int interrupted = vf_interrupted != 0;
  vf_interrupt_restore(&saved);
  if (err != VF_OK) return err;
  if (interrupted) {
    fprintf(stderr, "vcmfarm submit: stopped waiting; job %llu goes on (vcmfarm fetch %llu -o ... when it is done)\n",
            (unsigned long long)job_id, (unsigned long long)job_id);
    return VF_OK;
  }
  vf_film *film = NULL;
  if ((err = vf_fetch_film(client, job_id, output, (int)(conn->timeout * 1000.0) * 6, 0, &film)) != VF_OK) return err;
  if (preview) err = vf_preview_write(film, preview, exposure);
  if (err == VF_OK)
    fprintf(stderr, "vcmfarm submit: job %llu %s; wrote %s%s%s\n", (unsigned long long)job_id, state, output,
            preview ? " and " : "", preview ? preview : "");
  vf_film_destroy(film);
  *done = strcmp(state, "done") == 0;
  return err;
}

int vf_cmd_submit(int argc, char **argv) {
  static const struct option options[] = {
      VF_CLI_STOP_OPTIONS,
      VF_CLI_SETTINGS_OPTIONS,
      {"priority", required_argument, 0, 'P'},        {"name", required_argument, 0, 'N'},
      {"coordinator", required_argument, 0, 'c'},     {"secret", required_argument, 0, 'k'},
      {"timeout", required_argument, 0, 'T'},         {"start-iteration", required_argument, 0, 'K'},
      {"camera", required_argument, 0, 'M'},          {"wait", no_argument, 0, 'w'},
      {"output", required_argument, 0, 'o'},          {"preview", required_argument, 0, 'p'},
      {"exposure", required_argument, 0, 'e'},        {"help", no_argument, 0, 'h'},
      {"require", required_argument, 0, OPT_REQUIRE},
      {"allocation-from", required_argument, 0, VF_CLI_OPT_ALLOCATION_FROM}, {0, 0, 0, 0}};
  uint64_t first = 0;
  vf_tags requires;
  vf_tags_init(&requires);
  const char *cmd = "submit", *name = NULL, *camera = NULL, *output = NULL, *preview = NULL, *allocation_from = NULL;
  double exposure = 0.0;
  int wait = 0;
  vf_cli_settings overrides;
  vf_cli_stop stop = {0};
  connection conn = {NULL, NULL, 10.0};
  long long priority = 1;
  int err = VF_OK, c;
  vf_cli_settings_init(&overrides);
  optind = 0; /* 0: getopt starts again from scratch (glibc), forgetting the last argv */
  while ((c = vf_cli_getopt(argc, argv, VF_CLI_STOP_SHORT VF_CLI_SETTINGS_SHORT "P:N:c:k:wo:p:e:h", options)) !=
         -1) {
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
    case OPT_REQUIRE: err = vf_tags_parse("--require", optarg, &requires, 1); break;
    case VF_CLI_OPT_ALLOCATION_FROM: allocation_from = optarg; break;
    case 'w': wait = 1; break;
    case 'o': output = optarg; break;
    case 'p': preview = optarg; break;
    case 'e': err = vf_cli_double("--exposure", optarg, -64.0, 64.0, &exposure); break;
    case 'h': fputs(submit_usage, stdout); return VF_EXIT_OK;
    default: return vf_cli_bad_option(cmd);
    }
    if (err != VF_OK) return vf_cli_fail(cmd, err);
  }
  if (optind != argc - 1) return vf_cli_usage_error("submit", "expected exactly one SCENE");
  /* A farm job stops at the first of its conditions to hold: iterations and time together too. */
  if ((err = vf_cli_stop_check(&stop, 0)) != VF_OK) return vf_cli_fail(cmd, err);
  if ((output || preview) && !wait)
    return vf_cli_fail(cmd, vf_error_set(VF_EUSAGE, "-o and --preview go with --wait (else: vcmfarm fetch JOB -o ...)"));
  if (wait && output == NULL) return vf_cli_fail(cmd, vf_error_set(VF_EUSAGE, "--wait needs -o FILM.exr"));
  if (output && ((err = vf_cli_writable("-o", output)) != VF_OK ||
                 (err = vf_cli_extension("-o", output, ".exr", "an OpenEXR film")) != VF_OK))
    return vf_cli_fail(cmd, err);
  if (preview && (err = vf_cli_preview_check(preview)) != VF_OK) return vf_cli_fail(cmd, err);
  uint64_t iterations = vf_cli_stop_iterations(&stop);
  vf_submit_job job = {argv[optind], camera, name, &overrides, first, iterations, (int)priority,
                       stop.time_limit, stop.target_rmse, stop.target_error, stop.reference, "vcmfarm submit",
                       &requires, allocation_from};
  vf_farm_client *client;
  if ((err = vf_submit_check_texts(&job)) != VF_OK) return vf_cli_fail(cmd, err);
  if ((err = connect_to(&conn, &client)) != VF_OK) return vf_cli_fail(cmd, err);
  vf_submitted_job submitted;
  err = vf_submit(client, (int)(conn.timeout * 1000.0), &job, &submitted);
  if (err != VF_OK) {
    vf_farm_client_close(client);
    return vf_cli_fail(cmd, err);
  }
  char limits[256] = "";
  if (stop.iterations > 0 || !vf_cli_stop_open_ended(&stop))
    snprintf(limits, sizeof limits, ", at most %llu iteration%s", (unsigned long long)iterations, iterations == 1 ? "" : "s");
  if (stop.time_limit > 0.0)
    snprintf(limits + strlen(limits), sizeof limits - strlen(limits), ", at most %g s from its first lease",
             stop.time_limit);
  if (stop.target_rmse > 0.0)
    snprintf(limits + strlen(limits), sizeof limits - strlen(limits), ", until RMSE %g", stop.target_rmse);
  if (stop.target_error > 0.0)
    snprintf(limits + strlen(limits), sizeof limits - strlen(limits), ", until est. RMSE %g", stop.target_error);
  char required[VF_TAGS_MAX * (VF_TAG_MAX_BYTES + 1) + 1];
  vf_tags_format(&requires, required, sizeof required);
  fprintf(stderr, "vcmfarm submit: %s, %s%s, from iteration %llu, priority %lld%s%s\n", argv[optind],
          submitted.settings_text, limits, (unsigned long long)first, priority, required[0] ? ", requires " : "", required);
  printf("%llu\n", (unsigned long long)submitted.job_id);
  fflush(stdout);
  int done = 1;
  if (wait) err = wait_and_fetch(client, &conn, submitted.job_id, output, preview, exposure, &done);
  vf_farm_client_close(client);
  if (err != VF_OK) return vf_cli_fail(cmd, err);
  return done ? VF_EXIT_OK : VF_EXIT_FAILURE;
}

/* ---- status ---- */

static const char status_usage[] =
    "usage: vcmfarm status [JOB] --coordinator URL --secret FILE [--json]\n"
    "\n"
    "Shows the farm's rate, every job (or JOB) and every worker. A job's state is one of\n"
    "queued, running, paused, done, cancelled, failed; with --json it is the field\n"
    "\"state\". A job shows its rate, its progress and ETA towards the stop condition\n"
    "expected to end it, its latest error, why it stopped and the tags it requires; with\n"
    "JOB, its scene, settings, events and convergence log too. Workers are idle, busy,\n"
    "stopping, left or lost (the latest that left or were lost stay listed), with their\n"
    "tags. The JSON is described in docs/PROTOCOL.md, \"Status\".\n"
    "\n"
    "  -J, --json             JSON on stdout instead of text\n" CONNECTION_HELP;

int vf_cmd_status(int argc, char **argv) {
  static const struct option options[] = {
      {"json", no_argument, 0, 'J'},       {"coordinator", required_argument, 0, 'c'},
      {"secret", required_argument, 0, 'k'}, {"timeout", required_argument, 0, 'T'},
      {"help", no_argument, 0, 'h'},       {0, 0, 0, 0}};
  const char *cmd = "status";
  connection conn = {NULL, NULL, 10.0};
  int json = 0, err = VF_OK, c;
  optind = 0; /* 0: getopt starts again from scratch (glibc), forgetting the last argv */
  while ((c = vf_cli_getopt(argc, argv, "Jc:k:h", options)) != -1) {
    if (connection_option(&conn, c, &err)) {
      if (err != VF_OK) return vf_cli_fail(cmd, err);
      continue;
    }
    if (c == 'J') json = 1;
    else if (c == 'h') return fputs(status_usage, stdout), VF_EXIT_OK;
    else return vf_cli_bad_option(cmd);
  }
  Vcmfarm__StatusRequest m = VCMFARM__STATUS_REQUEST__INIT;
  if (optind == argc - 1) {
    if ((err = parse_job_id(argv[optind], &m.job_id)) != VF_OK) return vf_cli_fail(cmd, err);
  } else if (optind != argc) {
    return vf_cli_usage_error("status", "at most one JOB");
  }
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_STATUS_REQUEST;
  q.status_request = &m;
  if ((err = request(&conn, &q, VCMFARM__ENVELOPE__BODY_STATUS, &reply)) != VF_OK) return vf_cli_fail(cmd, err);
  if (json) vf_status_print_json(reply->status, stdout);
  else vf_status_print_text(reply->status, stdout);
  vf_message_free(reply);
  return VF_EXIT_OK;
}

/* ---- fetch ---- */

static const char fetch_usage[] =
    "usage: vcmfarm fetch JOB -o FILM.exr [--preview IMAGE.png] [-q] --coordinator URL --secret FILE\n"
    "\n"
    "Writes the current film of JOB (a valid film at any moment, holding the iterations\n"
    "merged so far) to FILM.exr, atomically: it arrives in chunks, is checked whole (size,\n"
    "hash, film) and only then replaces FILM.exr, which a failed fetch leaves as it was.\n"
    "\n"
    "  -o, --output FILM.exr  the film to write (required)\n" VF_CLI_PREVIEW_HELP
    "  -q, --quiet            no line saying what was written\n" CONNECTION_HELP;

int vf_cmd_fetch(int argc, char **argv) {
  static const struct option options[] = {
      {"output", required_argument, 0, 'o'}, {"coordinator", required_argument, 0, 'c'},
      {"secret", required_argument, 0, 'k'}, {"timeout", required_argument, 0, 'T'},
      {"preview", required_argument, 0, 'p'}, {"exposure", required_argument, 0, 'e'},
      {"quiet", no_argument, 0, 'q'},        {"help", no_argument, 0, 'h'},
      {0, 0, 0, 0}};
  const char *cmd = "fetch", *output = NULL, *preview = NULL;
  double exposure = 0.0;
  connection conn = {NULL, NULL, 60.0};
  int quiet = 0, err = VF_OK, c;
  optind = 0; /* 0: getopt starts again from scratch (glibc), forgetting the last argv */
  while ((c = vf_cli_getopt(argc, argv, "o:p:e:c:k:qh", options)) != -1) {
    if (connection_option(&conn, c, &err)) {
      if (err != VF_OK) return vf_cli_fail(cmd, err);
      continue;
    }
    if (c == 'o') output = optarg;
    else if (c == 'p') preview = optarg;
    else if (c == 'e') err = vf_cli_double("--exposure", optarg, -64.0, 64.0, &exposure);
    else if (c == 'q') quiet = 1;
    else if (c == 'h') return fputs(fetch_usage, stdout), VF_EXIT_OK;
    else return vf_cli_bad_option(cmd);
    if (err != VF_OK) return vf_cli_fail(cmd, err);
  }
  if (optind != argc - 1 || output == NULL) return vf_cli_usage_error("fetch", "expected one JOB and -o FILM.exr");
  if ((err = vf_cli_writable("-o", output)) != VF_OK ||
      (err = vf_cli_extension("-o", output, ".exr", "an OpenEXR film")) != VF_OK ||
      (preview && (err = vf_cli_preview_check(preview)) != VF_OK))
    return vf_cli_fail(cmd, err);
  uint64_t job_id;
  vf_farm_client *client;
  if ((err = parse_job_id(argv[optind], &job_id)) != VF_OK || (err = connect_to(&conn, &client)) != VF_OK)
    return vf_cli_fail(cmd, err);
  /* Read back before it replaces FILM.exr: what lands there is a checked film. */
  vf_film *film = NULL;
  err = vf_fetch_film(client, job_id, output, (int)(conn.timeout * 1000.0), 0, &film);
  vf_farm_client_close(client);
  if (err == VF_OK && preview) err = vf_preview_write(film, preview, exposure);
  if (err == VF_OK && !quiet) {
    char set[256];
    uint64_t count = vf_iterset_count(&film->iterations);
    if (vf_iterset_format(&film->iterations, set, sizeof set) != VF_OK) snprintf(set, sizeof set, "(long)");
    fprintf(stderr, "wrote %s%s%s: job %llu, %llu %s %s\n", output, preview ? " and " : "", preview ? preview : "",
            (unsigned long long)job_id, (unsigned long long)count, vf_cli_plural(count, "iteration", "iterations"),
            set);
  }
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

static const char pause_usage[] =
    "usage: vcmfarm pause JOB --coordinator URL --secret FILE\n"
    "\n"
    "Pauses JOB: it gets no new leases; the leases its workers hold when it is paused\n"
    "are finished and their iterations merged, as always. Paused is saved with the job\n"
    "list, so a restarted coordinator keeps it paused. `vcmfarm resume JOB` undoes it.\n\n" CONNECTION_HELP;

static const char resume_usage[] =
    "usage: vcmfarm resume JOB --coordinator URL --secret FILE\n"
    "\n"
    "Resumes a paused JOB: it is leased again, with its share of the workers by priority\n"
    "from now on (no catching up for the time it was paused).\n\n" CONNECTION_HELP;

/* `cancel JOB`, `remove JOB`, `pause JOB` and `resume JOB`: one request answered by a
 * ResultAck. */
static int job_request(int argc, char **argv, const char *cmd, const char *usage, Vcmfarm__Envelope__BodyCase body) {
  static const struct option options[] = {{"coordinator", required_argument, 0, 'c'},
                                          {"secret", required_argument, 0, 'k'},
                                          {"timeout", required_argument, 0, 'T'},
                                          {"help", no_argument, 0, 'h'},
                                          {0, 0, 0, 0}};
  connection conn = {NULL, NULL, 10.0};
  int err = VF_OK, c;
  optind = 0; /* 0: getopt starts again from scratch (glibc), forgetting the last argv */
  while ((c = vf_cli_getopt(argc, argv, "c:k:h", options)) != -1) {
    if (connection_option(&conn, c, &err)) {
      if (err != VF_OK) return vf_cli_fail(cmd, err);
      continue;
    }
    if (c == 'h') return fputs(usage, stdout), VF_EXIT_OK;
    return vf_cli_bad_option(cmd);
  }
  if (optind != argc - 1) return vf_cli_usage_error(cmd, "expected one JOB");
  uint64_t job_id;
  if ((err = parse_job_id(argv[optind], &job_id)) != VF_OK) return vf_cli_fail(cmd, err);
  Vcmfarm__CancelRequest cancel = VCMFARM__CANCEL_REQUEST__INIT;
  Vcmfarm__RemoveRequest remove = VCMFARM__REMOVE_REQUEST__INIT;
  Vcmfarm__PauseRequest pause = VCMFARM__PAUSE_REQUEST__INIT;
  Vcmfarm__ResumeRequest resume = VCMFARM__RESUME_REQUEST__INIT;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = body;
  if (body == VCMFARM__ENVELOPE__BODY_CANCEL) {
    cancel.job_id = job_id;
    q.cancel = &cancel;
  } else if (body == VCMFARM__ENVELOPE__BODY_PAUSE) {
    pause.job_id = job_id;
    q.pause = &pause;
  } else if (body == VCMFARM__ENVELOPE__BODY_RESUME) {
    resume.job_id = job_id;
    q.resume = &resume;
  } else {
    remove.job_id = job_id;
    q.remove = &remove;
  }
  if ((err = request(&conn, &q, VCMFARM__ENVELOPE__BODY_RESULT_ACK, &reply)) != VF_OK) return vf_cli_fail(cmd, err);
  /* A refusal (a job ended already, or not yet) did nothing: the request did not fit the
   * job, a mistake of the command line like a job that does not exist. */
  int accepted = reply->result_ack->accepted;
  fprintf(stderr, "vcmfarm %s: %s\n", cmd, reply->result_ack->message);
  vf_message_free(reply);
  return accepted ? VF_EXIT_OK : VF_EXIT_BAD_INPUT;
}

int vf_cmd_cancel(int argc, char **argv) {
  return job_request(argc, argv, "cancel", cancel_usage, VCMFARM__ENVELOPE__BODY_CANCEL);
}

int vf_cmd_remove(int argc, char **argv) {
  return job_request(argc, argv, "remove", remove_usage, VCMFARM__ENVELOPE__BODY_REMOVE);
}

int vf_cmd_pause(int argc, char **argv) {
  return job_request(argc, argv, "pause", pause_usage, VCMFARM__ENVELOPE__BODY_PAUSE);
}

int vf_cmd_resume(int argc, char **argv) {
  return job_request(argc, argv, "resume", resume_usage, VCMFARM__ENVELOPE__BODY_RESUME);
}

/* ---- keygen ---- */

static const char keygen_usage[] =
    "usage: vcmfarm keygen FILE [-q]\n"
    "\n"
    "Writes a new random farm key (64 hex digits) to FILE with permissions 0600;\n"
    "coordinator, workers and clients all need a copy. Never replaces an existing file.\n"
    "\n"
    "  -q, --quiet  no line saying what was written\n"
    "  -h, --help   this text\n";

int vf_cmd_keygen(int argc, char **argv) {
  static const struct option options[] = {{"quiet", no_argument, 0, 'q'}, {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
  int quiet = 0, c;
  optind = 0; /* 0: getopt starts again from scratch (glibc), forgetting the last argv */
  while ((c = vf_cli_getopt(argc, argv, "qh", options)) != -1) {
    if (c == 'q') quiet = 1;
    else if (c == 'h') return fputs(keygen_usage, stdout), VF_EXIT_OK;
    else return vf_cli_bad_option("keygen");
  }
  if (optind != argc - 1) return vf_cli_usage_error("keygen", "expected one FILE");
  int err = vf_cli_writable("FILE", argv[optind]);
  if (err == VF_OK) err = vf_wire_key_generate(argv[optind]);
  if (err != VF_OK) return vf_cli_fail("keygen", err);
  if (!quiet)
    fprintf(stderr, "wrote %s: a new farm key, readable by you only; copy it to every machine of the farm\n",
            argv[optind]);
  return VF_EXIT_OK;
}
