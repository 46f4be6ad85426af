/* `vcmfarm render`: one machine, no set-up, the farm's own code path.
 *
 * By default it starts, in this process, a coordinator (coordinator/coordinator.h) with a
 * private state directory and a fresh key, listening on an inproc:// address, and one
 * worker (worker/worker.h) on another thread; then, as a client, submits the job
 * (coordinator/submit.h), follows it through status requests (the progress line), fetches
 * its film at every checkpoint and at the end, and writes it to -o. Every iteration thus
 * goes through leases, tiles, checks and merging exactly as on a farm of many machines.
 * --direct renders on this thread with vf_render_range instead (benchmarks of the renderer
 * alone, and the independent reference the farm tests compare with). */
#include "render_cmd.h"

#include "options.h"
#include "../common/clock.h"
#include "../common/error.h"
#include "../common/farm_client.h"
#include "../common/file.h"
#include "../common/film.h"
#include "../common/film_wire.h"
#include "../common/image.h"
#include "../worker/blob_cache.h"
#include "local_render.h"
#include "../worker/render.h"
#include "../worker/worker.h"
#include "../coordinator/coordinator.h"
#include "../coordinator/job.h"
#include "submit.h"

#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <sodium.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

static const char usage[] =
    "usage: vcmfarm render SCENE [options] -o FILM.exr\n"
    "\n"
    "Renders global iterations [K, K+N) of SCENE (a built-in name or a JSON scene file,\n"
    "see docs/SCENES.md) into FILM.exr, an OpenEXR film that any viewer opens and that\n"
    "`vcmfarm merge` and `continue` extend exactly. It runs a farm's coordinator and one\n"
    "worker in this process (the farm's own code path, docs/PROTOCOL.md); --direct renders\n"
    "without them.\n"
    "\n"
    "  -a, --algorithm A        vcm (default), bpt, pt, lt, ppm, bpm or auto\n"
    "  -n, --iterations N       number of iterations (default: the scene's, else 16)\n"
    "  -t, --time S             render for S seconds instead (no new iteration after S)\n"
    "      --reference REF      reference image (a film or an RGB EXR of the same size):\n"
    "                           the convergence log records the RMSE against it\n"
    "      --target-rmse X      stop once the RMSE against the reference is <= X\n"
    "      --target-error E     stop once the estimated RMSE (no reference) is <= E\n"
    "      --checkpoint-interval S  every S seconds (default 10) append an entry to the\n"
    "                           film's convergence log and write the film, so a killed\n"
    "                           render keeps its work; 0: only at the end\n"
    "  -k, --start-iteration K  first global iteration index (default 0)\n"
    "  -s, --seed S             job seed (default: the scene's, else 1)\n"
    "  -j, --threads T          render threads (default: one per CPU)\n"
    "  -l, --max-path-length L  maximum path segments (default 10)\n"
    "  -r, --radius-factor F    initial merge radius / scene radius (default 0.003)\n"
    "      --alpha A            radius reduction exponent in (0, 1] (default 0.75)\n"
    "  -R, --resolution WxH     image size (default: the scene camera's)\n"
    "  -o, --output FILM.exr    the film to write (required)\n"
    "  -p, --preview IMAGE.png  also write a tone-mapped sRGB preview\n"
    "  -e, --exposure E         preview exposure in stops (default 0)\n"
    "      --direct             render on this thread, without coordinator and worker: a\n"
    "                           target then stops right after the iteration meeting it\n"
    "                           (through the farm, after the part of a lease meeting it)\n"
    "  -q, --quiet              no progress line or summary\n"
    "  -h, --help               this text\n"
    "\n"
    "The random numbers of an iteration depend only on (seed, iteration index, pixel), so\n"
    "renders of disjoint iteration ranges merge into exactly the render of their union.\n"
    "With a target and neither --iterations nor --time, it renders until the target is met.\n"
    "Exit status: 0 done, 1 failure while rendering, 2 bad input (nothing is written).\n";

typedef struct {
  const char *scene, *output, *preview, *reference;
  vf_cli_settings overrides;
  double target_rmse, target_error, checkpoint_interval, time_limit, exposure;
  long long iterations; /* -1: not given */
  int threads;          /* 0: one per CPU */
  uint64_t start;
  int quiet, direct;
} render_options;

static volatile sig_atomic_t interrupted;
static void on_interrupt(int sig) {
  (void)sig;
  interrupted = 1;
}

static int write_preview(const vf_film *film, const render_options *o) {
  if (o->preview == NULL) return VF_OK;
  vf_image img;
  int err = vf_image_alloc(&img, film->width, film->height);
  if (err != VF_OK) return err;
  vf_film_mean(film, img.rgb);
  err = vf_image_write_png(o->preview, &img, (float)o->exposure);
  vf_image_destroy(&img);
  return err;
}

/* The summary's first lines: the film's iterations, rates, and the renderer's statistics
 * over the `rendered` iterations they were gathered on. */
static void print_summary(const vf_film *film, double seconds, const vf_vcm_stats *stats, uint64_t rendered) {
  char set[256];
  if (vf_iterset_format(&film->iterations, set, sizeof set) != VF_OK) snprintf(set, sizeof set, "(long)");
  uint64_t n = vf_iterset_count(&film->iterations);
  double per = rendered ? 1000.0 / (double)rendered : 0.0;
  fprintf(stderr,
          "rendered %llu iteration(s) %s in %.2f s: %.3f it/s, %.2f Mrays/s, %llu light vertices/it\n"
          "per iteration: light sub-paths %.1f ms, grid %.1f ms, camera sub-paths %.1f ms; "
          "%llu non-finite sample(s)%s\n",
          (unsigned long long)n, set, seconds, (double)n / seconds, (double)stats->rays / seconds * 1e-6,
          (unsigned long long)(rendered ? stats->light_vertices / rendered : 0), stats->light_seconds * per,
          stats->grid_seconds * per, stats->camera_seconds * per, (unsigned long long)stats->nonfinite,
          interrupted ? " (interrupted)" : "");
}

/* --direct: the render loop on this thread, no farm. */
static int render_direct(const render_options *o) {
  int err;
  vf_scene *scene = NULL;
  vf_renderer *renderer = NULL;
  vf_film *film = NULL;
  vf_image reference = {0};
  vf_checkpointer cp = {0};
  if ((err = vf_scene_load(o->scene, &scene)) != VF_OK) return vf_cli_fail("render", err);

  /* Settings: defaults, then the scene's "render" object, then the command line. */
  vf_settings settings = scene->settings;
  if ((err = vf_cli_settings_apply(&o->overrides, &settings)) != VF_OK) goto done;
  if ((err = vf_settings_validate(&settings)) != VF_OK) goto done;
  if (o->reference && (err = vf_reference_load(o->reference, settings.width, settings.height, &reference)) != VF_OK)
    goto done;
  int open_ended = o->time_limit > 0.0 || o->target_rmse > 0.0 || o->target_error > 0.0;
  uint64_t count = o->iterations > 0 ? (uint64_t)o->iterations : (open_ended ? UINT64_MAX - o->start : 16);
  if (count > UINT64_MAX - o->start) {
    err = vf_error_set(VF_EUSAGE, "--start-iteration %llu + --iterations overflows", (unsigned long long)o->start);
    goto done;
  }

  if ((err = vf_renderer_create(scene, &settings, o->threads, &renderer)) != VF_OK) goto done;
  if ((err = vf_film_create(settings.width, settings.height, &film)) != VF_OK) goto done;
  if ((err = vf_renderer_stamp(renderer, film)) != VF_OK) goto done;
  if (!o->quiet) {
    char text[512];
    vf_settings_format(&settings, text, sizeof text);
    fprintf(stderr, "vcmfarm render: %s, %s\n", scene->source, text);
    vf_vcm_describe(vf_renderer_vcm(renderer), stderr);
  }

  int tty = !o->quiet && isatty(STDERR_FILENO);
  if ((err = vf_checkpointer_init(&cp, film, o->output, o->reference ? &reference : NULL, o->target_rmse, o->target_error,
                                  tty)) != VF_OK)
    goto done;
  vf_render_control control = {o->time_limit, NULL, NULL, &interrupted, 0.0, NULL};
  vf_checkpointer_attach(&cp, &control, o->checkpoint_interval);
  struct sigaction sa, old_int, old_term;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_interrupt;
  sigaction(SIGINT, &sa, &old_int);
  sigaction(SIGTERM, &sa, &old_term);
  vf_render_status st;
  err = vf_render_range(renderer, film, o->start, o->start + count, &control, &st);
  sigaction(SIGINT, &old_int, NULL);
  sigaction(SIGTERM, &old_term, NULL);
  if (tty) fputc('\n', stderr);
  if (err != VF_OK) goto done;
  if (st.iterations_done == 0) {
    err = vf_error_set(VF_EINVAL, "no iteration finished; nothing written");
    goto done;
  }
  /* The final checkpoint wrote the film. */
  if ((err = write_preview(film, o)) != VF_OK) goto done;
  if (!o->quiet) {
    print_summary(film, st.seconds, &st.stats, st.iterations_done);
    if (st.iterations_done >= 2 && st.seconds > st.first_seconds) {
      /* The rate a long render settles at: the first iteration also pays for the first
       * touches of the renderer's buffers (tens of thousands of page faults). */
      double s = st.seconds - st.first_seconds;
      fprintf(stderr, "after the first iteration: %.3f it/s, %.2f Mrays/s\n", (double)(st.iterations_done - 1) / s,
              (double)(st.stats.rays - st.first_rays) / s * 1e-6);
    }
    fprintf(stderr, "estimated RMSE %.4g", cp.last.estimated_rmse);
    if (o->reference) fprintf(stderr, ", RMSE %.4g against %s", cp.last.rmse, o->reference);
    fprintf(stderr, "%s\nwrote %s%s%s\n", cp.target_reached ? " (target reached)" : "", o->output,
            o->preview ? " and " : "", o->preview ? o->preview : "");
  }
done:
  vf_checkpointer_destroy(&cp);
  vf_image_destroy(&reference);
  vf_film_destroy(film);
  vf_renderer_destroy(renderer);
  vf_scene_destroy(scene);
  return err == VF_OK ? VF_EXIT_OK : vf_cli_fail("render", err);
}

/* ---- through an in-process farm ---------------------------------------------------- */

#define FARM_URL "inproc://vcmfarm-render"
#define POLL_MS 200
#define REQUEST_MS 30000 /* in-process: only a stuck coordinator takes this long */
/* The worker ships a part of its lease this often (or 50 times a part's cost, if more):
 * the granularity of the progress line and of the target checks. */
#define PART_SECONDS 1.0

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

/* Fetches the film as the coordinator holds it now and writes it atomically to the
 * output; *film (may be NULL) receives it decoded. */
static int checkpoint(vf_farm_client *client, uint64_t job_id, const char *output, vf_film **film) {
  Vcmfarm__FetchRequest m = VCMFARM__FETCH_REQUEST__INIT;
  m.job_id = job_id;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_FETCH;
  q.fetch = &m;
  int err = vf_farm_request(client, &q, VCMFARM__ENVELOPE__BODY_FILM, REQUEST_MS, &reply);
  if (err != VF_OK) return err;
  const ProtobufCBinaryData *exr = &reply->film->film_exr;
  if (film) err = vf_film_from_bytes(exr->data, exr->len, "the fetched film", film);
  if (err == VF_OK) err = vf_file_write_atomic(output, exr->data, exr->len, 0644);
  vf_message_free(reply);
  return err;
}

/* Iterations as the worker renders them (the job's count grows by merged parts). */
static void progress_line(const Vcmfarm__JobStatus *j, uint64_t rendered, double elapsed, int reference) {
  char error[96] = "";
  if (isfinite(j->estimated_rmse)) {
    int n = snprintf(error, sizeof error, "  est. RMSE %.3g", j->estimated_rmse);
    if (reference && isfinite(j->rmse) && n > 0 && (size_t)n < sizeof error)
      snprintf(error + n, sizeof error - (size_t)n, "  RMSE %.3g", j->rmse);
  }
  char eta[32] = "";
  if (j->eta_seconds >= 0.0) snprintf(eta, sizeof eta, "  ETA %.1f s", j->eta_seconds);
  char total[32] = "";
  if (j->iterations_total < VF_JOB_MAX_ITERATIONS)
    snprintf(total, sizeof total, "/%llu", (unsigned long long)j->iterations_total);
  double rate = elapsed > 0.0 ? (double)rendered / elapsed : 0.0;
  fprintf(stderr, "\r  iteration %llu%s (%llu merged)  %.2f it/s%s  elapsed %.1f s%s   ", (unsigned long long)rendered,
          total, (unsigned long long)j->iterations_done, rate, error, elapsed, eta);
}

static int render_farm(const render_options *o) {
  const char *cmd = "render";
  int open_ended = o->time_limit > 0.0 || o->target_rmse > 0.0 || o->target_error > 0.0;
  uint64_t count = o->iterations > 0 ? (uint64_t)o->iterations : (open_ended ? VF_JOB_MAX_ITERATIONS : 16);
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

  volatile sig_atomic_t coordinator_stop = 0, worker_stop = 0;
  atomic_ullong rendered = 0;
  coordinator_thread ct = {.config = {.listen_url = FARM_URL, .state_dir = state, .key = &key,
                                      .worker_timeout = 60.0, .lease_seconds = 20.0,
                                      /* the fetches below log and write; the coordinator's own
                                       * checkpoints would only write a copy nobody reads */
                                      .checkpoint_interval = 1e9, .stop = &coordinator_stop, .quiet = 1}};
  worker_thread wt = {.config = {.url = FARM_URL, .key = key, .threads = o->threads, .name = "render",
                                 .cache_dir = cache, .ship_interval = PART_SECONDS, .quiet = 1,
                                 .describe = o->quiet ? NULL : stderr, .rendered = &rendered},
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
  struct sigaction sa, old_int, old_term;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_interrupt;
  sigaction(SIGINT, &sa, &old_int);
  sigaction(SIGTERM, &sa, &old_term);

  vf_farm_client *client = NULL;
  Vcmfarm__Envelope *reply = NULL;
  const Vcmfarm__JobStatus *job = NULL;
  vf_film *film = NULL;
  vf_submitted_job submitted;
  uint64_t job_id = 0;
  double start = 0.0, last_checkpoint = 0.0;
  int tty = !o->quiet && isatty(STDERR_FILENO), finished = 0;
  if (!coordinator_started) {
    err = vf_error_set(VF_ENOMEM, "cannot start the coordinator's thread");
    goto stop;
  }
  if ((err = vf_farm_client_open(FARM_URL, &key, &client)) != VF_OK ||
      (err = await_coordinator(client, &ct)) != VF_OK || ct.ended)
    goto stop;
  vf_submit_job sj = {o->scene, "render", &o->overrides, o->start, count, 1, 0.0, o->target_rmse,
                      o->target_error, o->reference, NULL};
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
  start = last_checkpoint = vf_seconds_now();
  int poll_ms = 10; /* short jobs end early: polls at 10, 20, 40... ms, then every POLL_MS */
  while (!finished) {
    double left = o->time_limit > 0.0 ? o->time_limit - (vf_seconds_now() - start) : 1.0;
    sleep_ms(left * 1000.0 < poll_ms ? (left > 0.0 ? (int)(left * 1000.0) + 1 : 0) : poll_ms);
    poll_ms = 2 * poll_ms < POLL_MS ? 2 * poll_ms : POLL_MS;
    double now = vf_seconds_now();
    if (interrupted || (o->time_limit > 0.0 && now - start >= o->time_limit)) break;
    if (wt.ended || ct.ended) break; /* a thread gave up: its error is reported below */
    vf_message_free(reply);
    reply = NULL;
    if ((err = job_status(client, job_id, &reply, &job)) != VF_OK) goto stop;
    if (tty) progress_line(job, atomic_load(&rendered), now - start, o->reference != NULL);
    finished = strcmp(job->state, "queued") != 0 && strcmp(job->state, "running") != 0;
    if (!finished && o->checkpoint_interval > 0.0 && now - last_checkpoint >= o->checkpoint_interval) {
      if ((err = checkpoint(client, job_id, o->output, NULL)) != VF_OK) goto stop;
      last_checkpoint = vf_seconds_now();
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
  if ((err = checkpoint(client, job_id, o->output, &film)) != VF_OK) goto stop;
  if ((err = write_preview(film, o)) != VF_OK) goto stop;
  if (!o->quiet) {
    const vf_worker_totals *t = &wt.totals;
    uint64_t n = vf_iterset_count(&film->iterations);
    print_summary(film, seconds, &t->stats, t->iterations);
    if (t->iterations > n)
      fprintf(stderr, "the worker rendered %llu iteration(s) past the stop, not counted\n",
              (unsigned long long)(t->iterations - n));
    fprintf(stderr, "estimated RMSE %.4g", job->estimated_rmse);
    if (o->reference) fprintf(stderr, ", RMSE %.4g against %s", job->rmse, o->reference);
    fprintf(stderr, "%s%s%s\nwrote %s%s%s\n", job->stop_reason[0] ? " (" : "", job->stop_reason,
            job->stop_reason[0] ? ")" : "", o->output, o->preview ? " and " : "", o->preview ? o->preview : "");
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
  sigaction(SIGINT, &old_int, NULL);
  sigaction(SIGTERM, &old_term, NULL);
  vf_file_remove_tree(dir);
  return err == VF_OK ? VF_EXIT_OK : vf_cli_fail(cmd, err);
}

int vf_cmd_render(int argc, char **argv) {
  static const struct option options[] = {
      {"algorithm", required_argument, 0, 'a'},   {"iterations", required_argument, 0, 'n'},
      {"time", required_argument, 0, 't'},        {"start-iteration", required_argument, 0, 'k'},
      {"seed", required_argument, 0, 's'},        {"threads", required_argument, 0, 'j'},
      {"max-path-length", required_argument, 0, 'l'}, {"radius-factor", required_argument, 0, 'r'},
      {"alpha", required_argument, 0, 'A'},       {"resolution", required_argument, 0, 'R'},
      {"output", required_argument, 0, 'o'},      {"preview", required_argument, 0, 'p'},
      {"exposure", required_argument, 0, 'e'},    {"quiet", no_argument, 0, 'q'},
      {"help", no_argument, 0, 'h'},              {"reference", required_argument, 0, 'F'},
      {"target-rmse", required_argument, 0, 'X'}, {"target-error", required_argument, 0, 'E'},
      {"checkpoint-interval", required_argument, 0, 'C'}, {"direct", no_argument, 0, 'D'},
      {0, 0, 0, 0}};
  const char *cmd = "render";
  render_options o = {.iterations = -1, .checkpoint_interval = 10.0};
  long long threads = 0;
  int err = VF_OK, c;
  vf_cli_settings_init(&o.overrides);
  optind = 1;
  opterr = 0;
  while ((c = getopt_long(argc, argv, "a:n:t:k:s:j:l:r:R:o:p:e:qh", options, NULL)) != -1) {
    if (vf_cli_settings_option(&o.overrides, c, optarg, &err)) {
      if (err != VF_OK) return vf_cli_fail(cmd, err);
      continue;
    }
    switch (c) {
    case 'n': err = vf_cli_int("--iterations", optarg, 1, 1000000000LL, &o.iterations); break;
    case 't': err = vf_cli_double("--time", optarg, 1e-3, 1e9, &o.time_limit); break;
    case 'k': err = vf_cli_u64("--start-iteration", optarg, &o.start); break;
    case 'j': err = vf_cli_int("--threads", optarg, 1, 1024, &threads); break;
    case 'o': o.output = optarg; break;
    case 'p': o.preview = optarg; break;
    case 'e': err = vf_cli_double("--exposure", optarg, -64.0, 64.0, &o.exposure); break;
    case 'q': o.quiet = 1; break;
    case 'D': o.direct = 1; break;
    case 'F': o.reference = optarg; break;
    case 'X': err = vf_cli_double("--target-rmse", optarg, 1e-300, 1e300, &o.target_rmse); break;
    case 'E': err = vf_cli_double("--target-error", optarg, 1e-300, 1e300, &o.target_error); break;
    case 'C': err = vf_cli_double("--checkpoint-interval", optarg, 0.0, 1e9, &o.checkpoint_interval); break;
    case 'h': fputs(usage, stdout); return VF_EXIT_OK;
    default:
      return vf_cli_bad_option("render", argv, usage);
    }
    if (err != VF_OK) return vf_cli_fail(cmd, err);
  }
  if (optind != argc - 1) {
    fprintf(stderr, "vcmfarm render: expected exactly one SCENE\n%s", usage);
    return VF_EXIT_BAD_INPUT;
  }
  if (o.output == NULL) {
    fprintf(stderr, "vcmfarm render: missing -o FILM.exr\n");
    return VF_EXIT_BAD_INPUT;
  }
  if (o.iterations > 0 && o.time_limit > 0.0) {
    fprintf(stderr, "vcmfarm render: give --iterations or --time, not both\n");
    return VF_EXIT_BAD_INPUT;
  }
  if (o.target_rmse > 0.0 && o.reference == NULL) {
    fprintf(stderr, "vcmfarm render: --target-rmse needs --reference\n");
    return VF_EXIT_BAD_INPUT;
  }
  if ((err = vf_cli_writable("-o", o.output)) != VF_OK ||
      (o.preview && (err = vf_cli_writable("--preview", o.preview)) != VF_OK))
    return vf_cli_fail(cmd, err);
  o.scene = argv[optind];
  o.threads = (int)threads;
  return o.direct ? render_direct(&o) : render_farm(&o);
}
