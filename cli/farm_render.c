/* `vcmfarm render` through the farm's own code path, in one process.
 *
 * It starts a coordinator (coordinator/coordinator.h) with a private state directory and
 * a fresh key, listening on an inproc:// address, and one worker (worker/worker.h) on
 * another thread; then, as a client, submits the job (cli/submit.h), follows it through
 * status requests (the progress line), fetches its film at every checkpoint interval and
 * at the end, and writes it atomically to -o. Every iteration thus goes through leases,
 * checks and merging exactly as on a farm of many machines; only the parts' pixels pass as
 * films in memory (common/film_handoff.h) rather than encoded tiles, so that the process
 * holds no second copy of a part and spends no time deflating it. */
#include "farm_render.h"

#include "../common/clock.h"
#include "../common/error.h"
#include "../common/farm_client.h"
#include "../common/file.h"
#include "../common/forecast.h"
#include "../coordinator/coordinator.h"
#include "../coordinator/job.h"
#include "../worker/blob_cache.h"
#include "../worker/worker.h"
#include "fetch.h"
#include "interrupt.h"
#include "submit.h"

#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <sodium.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

/* An open-ended render is one farm job. */
_Static_assert(VF_CLI_ITERATIONS_OPEN_ENDED <= VF_JOB_MAX_ITERATIONS, "open-ended renders must fit in a job");

#define FARM_URL "inproc://vcmfarm-render"
#define POLL_MS 200
#define REQUEST_MS 30000 /* in-process: only a stuck coordinator takes this long */
/* The worker ships a part of its lease this often (or 50 times a part's cost, if more):
 * the granularity of the progress line and of the target checks. */
#define PART_SECONDS 1.0
/* In-process, a request costs no round trip: small chunks keep the copies of a chunk in
 * flight (read, sealed, received, opened, unpacked) from adding to the render's peak. */
#define FETCH_CHUNK_BYTES ((size_t)1 << 20)

/* Each thread's result is read after pthread_join; `ended` says, meanwhile, that it
 * returned (the coordinator only does so early when it could not start). */
typedef struct {
  vf_coordinator_config config;
  volatile sig_atomic_t ended;
  int err;
} coordinator_thread;

static void *coordinator_main(void *p) {
  coordinator_thread *t = p;
  t->err = vf_coordinator_run(&t->config);
  t->ended = 1;
  return NULL;
}

typedef struct {
  vf_worker_config config;
  volatile sig_atomic_t *stop;
  volatile sig_atomic_t ended;
  vf_worker_totals totals;
  int err;
} worker_thread;

static void *worker_main(void *p) {
  worker_thread *t = p;
  t->err = vf_worker_run(&t->config, t->stop, &t->totals);
  t->ended = 1;
  return NULL;
}

/* Waits until the coordinator answers (it binds its socket on its own thread). */
static int await_coordinator(vf_farm_client *client, const coordinator_thread *ct) {
  Vcmfarm__StatusRequest m = VCMFARM__STATUS_REQUEST__INIT;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_STATUS_REQUEST;
  q.status_request = &m;
  double deadline = vf_seconds_now() + REQUEST_MS / 1000.0;
  while (!ct->ended && vf_seconds_now() < deadline) {
    if (vf_farm_request(client, &q, VCMFARM__ENVELOPE__BODY_STATUS, 250, &reply) == VF_OK) {
      vf_message_free(reply);
      return VF_OK;
    }
  }
  return ct->ended ? VF_OK /* its error is reported after the join */
                   : vf_error_set(VF_ETIMEDOUT, "the in-process coordinator did not answer");
}

static void sleep_ms(int ms) {
  struct timespec ts = {ms / 1000, (long)(ms % 1000) * 1000000L};
  nanosleep(&ts, NULL); /* a signal ends it early: fine */
}

/* The job's status, from the status of every job (which leaves out the convergence log
 * that the status of one job carries); free *reply with vf_message_free. */
static int job_status(vf_farm_client *client, uint64_t job_id, Vcmfarm__Envelope **reply,
                      const Vcmfarm__JobStatus **job) {
  Vcmfarm__StatusRequest m = VCMFARM__STATUS_REQUEST__INIT;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_STATUS_REQUEST;
  q.status_request = &m;
  int err = vf_farm_request(client, &q, VCMFARM__ENVELOPE__BODY_STATUS, REQUEST_MS, reply);
  if (err != VF_OK) return err;
  for (size_t i = 0; i < (*reply)->status->n_jobs; i++)
    if ((*reply)->status->jobs[i]->job_id == job_id) {
      *job = (*reply)->status->jobs[i];
      return VF_OK;
    }
  vf_message_free(*reply);
  return vf_error_set(VF_EPROTO, "the coordinator's status lacks job %llu", (unsigned long long)job_id);
}

/* Iterations as the worker renders them (the job's count grows by merged parts); progress
 * and ETA towards the condition that will end the render (common/forecast.h): the
 * iteration count and --time are this command's (it stops the worker itself when the time
 * is up, so that every rendered iteration counts), a target the coordinator's forecast
 * (it holds the job's convergence log). */
static void progress_line(const vf_render_job *o, const Vcmfarm__JobStatus *j, uint64_t rendered, double elapsed) {
  char error[96] = "";
  if (isfinite(j->estimated_rmse)) {
    int n = snprintf(error, sizeof error, "  est. RMSE %.3g", j->estimated_rmse);
    if (o->stop.reference && isfinite(j->rmse) && n > 0 && (size_t)n < sizeof error)
      snprintf(error + n, sizeof error - (size_t)n, "  RMSE %.3g", j->rmse);
  }
  double rate = elapsed > 0.0 ? (double)rendered / elapsed : 0.0;
  uint64_t limit = vf_cli_stop_open_ended(&o->stop) ? (uint64_t)o->stop.iterations : vf_cli_stop_iterations(&o->stop);
  vf_forecast_input in = {.done = rendered, .iterations = limit, .seconds = elapsed,
                          .time_limit = o->stop.time_limit, .rate = rate};
  vf_forecast f;
  vf_forecast_compute(&in, &f);
  int target = vf_stop_reason_parse(j->progress_by);
  if ((target == VF_STOP_TARGET_RMSE || target == VF_STOP_TARGET_ERROR) && j->eta_seconds >= 0.0 &&
      (f.by == VF_STOP_NONE || f.eta < 0.0 || j->eta_seconds < f.eta))
    f = (vf_forecast){(vf_stop_reason)target, j->progress, j->eta_seconds, j->error_slope};
  char eta[64] = "", total[32] = "";
  if (f.by != VF_STOP_NONE && f.eta >= 0.0)
    snprintf(eta, sizeof eta, "  %.0f%% (%s)  ETA %.1f s", 100.0 * f.progress, vf_stop_reason_name(f.by), f.eta);
  if (limit > 0) snprintf(total, sizeof total, "/%llu", (unsigned long long)limit);
  fprintf(stderr, "\r  iteration %llu%s (%llu merged)  %.2f it/s%s  elapsed %.1f s%s   ", (unsigned long long)rendered,
          total, (unsigned long long)j->iterations_done, rate, error, elapsed, eta);
}

int vf_farm_render(const vf_render_job *o) {
  const char *cmd = "render";
  uint64_t count = vf_cli_stop_iterations(&o->stop);
  if (o->start > VF_JOB_MAX_FIRST)
    return vf_cli_fail(cmd, vf_error_set(VF_EUSAGE, "--start-iteration %llu: through the farm at most 2^53 "
                                         "(--direct takes any)", (unsigned long long)o->start));
  char dir[4096], state[4200], cache[4200];
  int err = vf_file_temp_dir("vcmfarm-render", dir, sizeof dir);
  if (err != VF_OK) return vf_cli_fail(cmd, err);
  snprintf(state, sizeof state, "%s/state", dir);
  snprintf(cache, sizeof cache, "%s/cache", dir);
  vf_wire_key key;
  if (sodium_init() < 0) err = vf_error_set(VF_EINVAL, "libsodium cannot start");
  if (err == VF_OK) {
    randombytes_buf(key.bytes, sizeof key.bytes);
    err = vf_blob_cache_open(cache);
  }
  if (err != VF_OK) {
    vf_file_remove_tree(dir);
    return vf_cli_fail(cmd, err);
  }

  /* The worker's parts reach the coordinator as films in memory, not encoded tiles. */
  vf_film_handoff *handoff = NULL;
  if ((err = vf_film_handoff_create(&handoff)) != VF_OK) {
    vf_file_remove_tree(dir);
    return vf_cli_fail(cmd, err);
  }
  volatile sig_atomic_t coordinator_stop = 0, worker_stop = 0;
  atomic_ullong rendered = 0;
  coordinator_thread ct = {.config = {.listen_url = FARM_URL, .state_dir = state, .key = &key,
                                      .worker_timeout = 60.0, .lease_seconds = 20.0,
                                      /* each fetch below logs and checkpoints the film; the
                                       * coordinator's own checkpoints would only write copies
                                       * nobody reads */
                                      .checkpoint_interval = 1e9, .stop = &coordinator_stop, .quiet = 1,
                                      .handoff = handoff}};
  worker_thread wt = {.config = {.url = FARM_URL, .key = key, .threads = o->threads, .name = "render",
                                 .cache_dir = cache, .ship_interval = PART_SECONDS, .quiet = 1,
                                 .describe = o->quiet ? NULL : stderr, .rendered = &rendered,
                                 .handoff = handoff},
                      .stop = &worker_stop};
  /* The threads leave SIGINT and SIGTERM to this one. */
  sigset_t block, old_mask;
  sigemptyset(&block);
  sigaddset(&block, SIGINT);
  sigaddset(&block, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &block, &old_mask);
  pthread_t coordinator_tid, worker_tid;
  int coordinator_started = pthread_create(&coordinator_tid, NULL, coordinator_main, &ct) == 0, worker_started = 0;
  pthread_sigmask(SIG_SETMASK, &old_mask, NULL);
  vf_interrupt_saved saved;
  vf_interrupt_catch(&saved);

  vf_farm_client *client = NULL;
  Vcmfarm__Envelope *reply = NULL;
  const Vcmfarm__JobStatus *job = NULL;
  vf_film *film = NULL;
  vf_submitted_job submitted;
  uint64_t job_id = 0;
  double start = 0.0, last_fetch = 0.0, fetch_interval = vf_cli_checkpoint_next(&o->checkpoint, 0.0);
  int tty = !o->quiet && isatty(STDERR_FILENO), finished = 0;
  if (!coordinator_started) {
    err = vf_error_set(VF_ENOMEM, "cannot start the coordinator's thread");
    goto stop;
  }
  if ((err = vf_farm_client_open(FARM_URL, &key, &client)) != VF_OK ||
      (err = await_coordinator(client, &ct)) != VF_OK || ct.ended)
    goto stop;
  vf_submit_job sj = {o->scene, o->camera, "render", &o->overrides, o->start, count, 1, 0.0, o->stop.target_rmse,
                      o->stop.target_error, o->stop.reference, NULL};
  if ((err = vf_submit(client, REQUEST_MS, &sj, &submitted)) != VF_OK) goto stop;
  job_id = submitted.job_id;
  /* The worker starts once the job is there: its first lease request gets it. */
  pthread_sigmask(SIG_BLOCK, &block, NULL);
  worker_started = pthread_create(&worker_tid, NULL, worker_main, &wt) == 0;
  pthread_sigmask(SIG_SETMASK, &old_mask, NULL);
  if (!worker_started) {
    err = vf_error_set(VF_ENOMEM, "cannot start the worker's thread");
    goto stop;
  }
  if (!o->quiet)
    fprintf(stderr, "vcmfarm render: %s, %s\nthrough an in-process coordinator and worker (--direct: without)\n",
            submitted.scene_source, submitted.settings_text);
  start = last_fetch = vf_seconds_now();
  int poll_ms = 10; /* short jobs end early: polls at 10, 20, 40... ms, then every POLL_MS */
  while (!finished) {
    double left = o->stop.time_limit > 0.0 ? o->stop.time_limit - (vf_seconds_now() - start) : 1.0;
    sleep_ms(left * 1000.0 < poll_ms ? (left > 0.0 ? (int)(left * 1000.0) + 1 : 0) : poll_ms);
    poll_ms = 2 * poll_ms < POLL_MS ? 2 * poll_ms : POLL_MS;
    double now = vf_seconds_now();
    if (vf_interrupted || (o->stop.time_limit > 0.0 && now - start >= o->stop.time_limit)) break;
    if (wt.ended || ct.ended) break; /* a thread gave up: its error is reported below */
    vf_message_free(reply);
    reply = NULL;
    if ((err = job_status(client, job_id, &reply, &job)) != VF_OK) goto stop;
    if (tty) progress_line(o, job, atomic_load(&rendered), now - start);
    finished = strcmp(job->state, "queued") != 0 && strcmp(job->state, "running") != 0;
    if (!finished && fetch_interval > 0.0 && now - last_fetch >= fetch_interval) {
      if ((err = vf_fetch_film(client, job_id, o->output, REQUEST_MS, FETCH_CHUNK_BYTES, NULL)) != VF_OK) goto stop;
      last_fetch = vf_seconds_now();
      /* The coordinator's checkpoint and the copy take CPU from the render threads. */
      fetch_interval = vf_cli_checkpoint_next(&o->checkpoint, last_fetch - now);
    }
  }
  /* The worker finishes its iteration, ships what it rendered and hands back the rest. */
  worker_stop = 1;
  pthread_join(worker_tid, NULL);
  worker_started = 0;
  double seconds = vf_seconds_now() - start;
  if (tty) fputc('\n', stderr);
  if ((err = wt.err) != VF_OK || ct.ended) goto stop; /* the coordinator's error: after its join */
  vf_message_free(reply);
  reply = NULL;
  if ((err = job_status(client, job_id, &reply, &job)) != VF_OK) goto stop;
  if (strcmp(job->state, "failed") == 0) {
    err = vf_error_set(VF_EINVAL, "the job failed: %s", job->message);
    goto stop;
  }
  if (job->iterations_done == 0) {
    err = vf_error_set(VF_EINVAL, "no iteration finished; nothing written");
    goto stop;
  }
  if ((err = vf_fetch_film(client, job_id, o->output, REQUEST_MS, FETCH_CHUNK_BYTES, &film)) != VF_OK) goto stop;
  if ((err = vf_render_job_write_preview(o, film)) != VF_OK) goto stop;
  if (!o->quiet) {
    const vf_worker_totals *t = &wt.totals;
    uint64_t n = vf_iterset_count(&film->iterations);
    vf_render_job_print_summary(film, seconds, &t->stats, t->iterations, vf_interrupted);
    if (t->iterations > n)
      fprintf(stderr, "the worker rendered %llu iteration(s) past the stop, not counted\n",
              (unsigned long long)(t->iterations - n));
    vf_render_job_print_result(o, job->estimated_rmse, job->rmse, job->stop_reason);
  }
stop:
  vf_message_free(reply);
  vf_film_destroy(film);
  vf_farm_client_close(client);
  worker_stop = 1;
  if (worker_started) pthread_join(worker_tid, NULL);
  coordinator_stop = 1;
  if (coordinator_started) {
    pthread_join(coordinator_tid, NULL);
    if (err == VF_OK) err = ct.err; /* it could not start, or not write its final checkpoint */
  }
  vf_interrupt_restore(&saved);
  vf_film_handoff_destroy(handoff);
  vf_file_remove_tree(dir);
  return err == VF_OK ? VF_EXIT_OK : vf_cli_fail(cmd, err);
}
