/* The coordinator's costs, for docs/BENCHMARKS.md ("Farm").
 *
 *   bench_farm merge [RUNS [WxH]]
 *       CPU and wall time of the coordinator's handlers for the LeaseResult messages of
 *       one result (check the tiles, stage them, merge) of a 64x64 film (one tile) and of
 *       a 1920x1080 film (510 tiles), one iteration each, in process (coordinator/farm.h);
 *       median of RUNS (default 9 and 5), and the checkpoint write of the job film; with
 *       WxH, that size only. The messages are framed and opened as on the wire.
 *   bench_farm simulate VCMFARM WORKERS THINK_MS RESULTS
 *       A real coordinator process (VCMFARM coordinator over ipc://) and WORKERS fake
 *       workers (threads of this process, one REQ socket each) that take leases and,
 *       after THINK_MS of pretend rendering, send precomputed 64x64 one-iteration films
 *       (one tile each),
 *       until RESULTS results are merged. Prints the round trip of results (median, 90th,
 *       99th percentile), the results merged per second and the coordinator's CPU time
 *       per result (from /proc).
 *   bench_farm simulate VCMFARM --film FILM.exr WORKERS SECONDS ITERATION_SECONDS ENCODE_SECONDS
 *       A farm of WORKERS simulated workers rendering FILM's job for SECONDS, each
 *       iteration taking ITERATION_SECONDS and encoding a part ENCODE_SECONDS, shipping
 *       FILM's real tiles as often as the coordinator says (tests/bench/farm_sim.c).
 * Built, never run by ctest. */
#include "common/clock.h"
#include "common/error.h"
#include "common/farm_client.h"
#include "common/film.h"
#include "common/film_wire.h"
#include "common/rng.h"
#include "common/settings.h"
#include "coordinator/farm.h"
#include "tests/bench/farm_sim.h"

#include <pthread.h>
#include <signal.h>
#include <sodium.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

static int compare(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

static double percentile(double *v, size_t n, double p) {
  qsort(v, n, sizeof *v, compare);
  size_t i = (size_t)(p * (double)(n - 1) + 0.5);
  return n ? v[i] : 0.0;
}

static double cpu_now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static const uint8_t scene_hash[32] = {1, 2, 3};

static void settings_text(int width, int height, char *buf, size_t n) {
  vf_settings s;
  vf_settings_default(&s);
  s.width = width;
  s.height = height;
  vf_settings_format(&s, buf, n);
}

/* A film holding iteration k only, with noisy pixels like a render's. */
static int noisy_film(int width, int height, const char *settings, uint64_t k, vf_film **out) {
  vf_film *f;
  int err = vf_film_create(width, height, &f);
  if (err != VF_OK) return err;
  size_t n = 3 * (size_t)width * (size_t)height;
  float *cam = malloc(n * sizeof *cam), *light = malloc(n * sizeof *light);
  vf_rng rng = vf_rng_for_path(1, k, 0, VF_STREAM_TEST);
  for (size_t i = 0; i < n; i++) {
    cam[i] = vf_rng_float(&rng);
    light[i] = 0.1f * vf_rng_float(&rng);
  }
  memcpy(f->scene_hash, scene_hash, 32);
  snprintf(f->settings_text, sizeof f->settings_text, "%s", settings);
  f->render_seconds = 1000.0; /* a slow worker: every lease is one iteration */
  err = vf_film_add_iteration(f, k, cam, light, NULL);
  free(cam);
  free(light);
  if (err == VF_OK) *out = f;
  else vf_film_destroy(f);
  return err;
}

static Vcmfarm__Envelope submit_envelope(Vcmfarm__SubmitJob *m, Vcmfarm__Scene *scene, const char *settings) {
  vcmfarm__scene__init(scene);
  scene->source_case = VCMFARM__SCENE__SOURCE_BUILTIN;
  scene->builtin = "cornell";
  vcmfarm__submit_job__init(m);
  m->name = "bench";
  m->scene = scene;
  m->scene_hash.data = (uint8_t *)scene_hash;
  m->scene_hash.len = 32;
  m->settings = (char *)settings;
  m->iterations = 1000000000;
  m->priority = 1;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_SUBMIT;
  q.submit = m;
  return q;
}

/* ---- merge ---- */

typedef struct {
  vf_farm *farm;
  vf_wire_key key;
  double cpu, wall; /* the coordinator's: opening the frame, decoding, handling */
  size_t bytes;
} in_process;

/* One message of tiles framed as a worker does, then opened and handled as the
 * coordinator does; the coordinator's part timed. */
static int handle_tiles(void *ctx, Vcmfarm__LeaseResult *m) {
  in_process *ip = ctx;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *request;
  q.body_case = VCMFARM__ENVELOPE__BODY_RESULT;
  q.result = m;
  uint8_t *frame;
  size_t len;
  if (vf_message_pack(&ip->key, NULL, &q, &frame, &len, NULL) != VF_OK) return -1;
  ip->bytes += len;
  vf_farm_reply r;
  double c0 = cpu_now(), w0 = vf_seconds_now();
  if (vf_message_unpack(&ip->key, NULL, frame, len, &request, NULL) != VF_OK) {
    free(frame);
    return -1;
  }
  vf_farm_handle(ip->farm, request, vf_seconds_now(), &r);
  vf_message_free(request);
  ip->cpu += cpu_now() - c0;
  ip->wall += vf_seconds_now() - w0;
  free(frame);
  int accepted = r.result_ack.accepted;
  if (!accepted) fprintf(stderr, "result refused: %s\n", r.result_ack.message);
  vf_farm_reply_release(&r);
  return accepted;
}

static void bench_merge(int width, int height, int runs, const char *dir) {
  char settings[512];
  settings_text(width, height, settings, sizeof settings);
  vf_farm_config config = {dir, 1e9, 20.0, 0.0};
  vf_farm farm;
  vf_farm_init(&farm, &config);
  vf_farm_reply r;
  Vcmfarm__SubmitJob sm;
  Vcmfarm__Scene sc;
  Vcmfarm__Envelope q = submit_envelope(&sm, &sc, settings);
  vf_farm_handle(&farm, &q, vf_seconds_now(), &r);
  if (r.env.body_case != VCMFARM__ENVELOPE__BODY_SUBMITTED) {
    fprintf(stderr, "submit refused: %s\n", r.env.error ? r.env.error->message : "?");
    exit(1);
  }
  vf_farm_reply_release(&r);
  Vcmfarm__Register reg = VCMFARM__REGISTER__INIT;
  reg.name = "bench";
  q = (Vcmfarm__Envelope)VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_REGISTER;
  q.register_ = &reg;
  vf_farm_handle(&farm, &q, vf_seconds_now(), &r);
  uint64_t worker = r.registered.worker_id;
  vf_farm_reply_release(&r);
  double *cpu = calloc((size_t)runs, sizeof *cpu), *wall = calloc((size_t)runs, sizeof *wall);
  double *encode = calloc((size_t)runs, sizeof *encode);
  size_t bytes = 0;
  for (int i = 0; i < runs; i++) {
    Vcmfarm__LeaseRequest lr = VCMFARM__LEASE_REQUEST__INIT;
    lr.worker_id = worker;
    q = (Vcmfarm__Envelope)VCMFARM__ENVELOPE__INIT;
    q.body_case = VCMFARM__ENVELOPE__BODY_LEASE_REQUEST;
    q.lease_request = &lr;
    vf_farm_handle(&farm, &q, vf_seconds_now(), &r);
    Vcmfarm__LeaseResult m = VCMFARM__LEASE_RESULT__INIT;
    m.worker_id = worker;
    m.lease_id = r.lease.lease_id;
    m.job_id = r.lease.job_id;
    m.begin = r.lease.begin;
    m.end = m.begin + 1; /* a part of one iteration (the lease, its rate unknown, is longer) */
    int leased = r.env.body_case == VCMFARM__ENVELOPE__BODY_LEASE;
    vf_farm_reply_release(&r);
    vf_film *film;
    if (!leased || noisy_film(width, height, settings, m.begin, &film) != VF_OK) {
      fprintf(stderr, "unexpected lease or film failure\n");
      exit(1);
    }
    in_process ip = {&farm, {{0}}, 0.0, 0.0, 0};
    randombytes_buf(ip.key.bytes, sizeof ip.key.bytes);
    double t0 = vf_seconds_now();
    if (vf_film_send_tiles(film, &m, 10, handle_tiles, &ip) != 1) exit(1);
    encode[i] = vf_seconds_now() - t0 - ip.wall; /* encoding the tiles and framing them */
    vf_film_destroy(film);
    bytes = ip.bytes;
    cpu[i] = ip.cpu;
    wall[i] = ip.wall;
  }
  double w0 = vf_seconds_now();
  vf_farm_checkpoint(&farm, 1);
  double checkpoint = vf_seconds_now() - w0;
  printf("%dx%d: result of %.2f MB, coordinator CPU %.2f ms, wall %.2f ms; worker (encode, frame) %.2f ms (median "
         "of %d); checkpoint write %.1f ms\n",
         width, height, (double)bytes / 1e6, 1e3 * percentile(cpu, (size_t)runs, 0.5),
         1e3 * percentile(wall, (size_t)runs, 0.5), 1e3 * percentile(encode, (size_t)runs, 0.5), runs,
         1e3 * checkpoint);
  free(encode);
  free(cpu);
  free(wall);
  vf_farm_destroy(&farm);
}

/* ---- simulate ---- */

typedef struct {
  const char *url;
  const vf_wire_key *key;
  int think_ms, index;
  vf_film **films; /* [k]: film of iteration k */
  unsigned results;
  atomic_uint *merged;
  double *latency; /* shared array, RESULTS long */
  atomic_uint *latency_count;
} fake_worker;

static int send_tiles(void *ctx, Vcmfarm__LeaseResult *m) {
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_RESULT;
  q.result = m;
  if (vf_farm_request(ctx, &q, VCMFARM__ENVELOPE__BODY_RESULT_ACK, 30000, &reply) != VF_OK) return -1;
  int accepted = reply->result_ack->accepted;
  vf_message_free(reply);
  return accepted;
}

static void *fake(void *arg) {
  fake_worker *f = arg;
  vf_farm_client *c;
  if (vf_farm_client_open(f->url, f->key, &c) != VF_OK) return NULL;
  Vcmfarm__Register reg = VCMFARM__REGISTER__INIT;
  char name[32];
  snprintf(name, sizeof name, "fake%d", f->index);
  reg.name = name;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_REGISTER;
  q.register_ = &reg;
  if (vf_farm_request(c, &q, VCMFARM__ENVELOPE__BODY_REGISTERED, 30000, &reply) != VF_OK) goto close;
  uint64_t worker = reply->registered->worker_id;
  vf_message_free(reply);
  while (atomic_load(f->merged) < f->results) {
    Vcmfarm__LeaseRequest lr = VCMFARM__LEASE_REQUEST__INIT;
    lr.worker_id = worker;
    q.body_case = VCMFARM__ENVELOPE__BODY_LEASE_REQUEST;
    q.lease_request = &lr;
    if (vf_farm_call(c, &q, 30000, &reply) != VF_OK) break;
    if (reply->body_case != VCMFARM__ENVELOPE__BODY_LEASE ||
        reply->lease->begin >= f->results) {
      vf_message_free(reply);
      break;
    }
    Vcmfarm__LeaseResult m = VCMFARM__LEASE_RESULT__INIT;
    m.worker_id = worker;
    m.lease_id = reply->lease->lease_id;
    m.job_id = reply->lease->job_id;
    m.begin = reply->lease->begin;
    vf_message_free(reply);
    if (f->think_ms > 0) {
      struct timespec ts = {f->think_ms / 1000, (long)(f->think_ms % 1000) * 1000000L};
      nanosleep(&ts, NULL);
    }
    double t0 = vf_seconds_now();
    int rc = vf_film_send_tiles(f->films[m.begin], &m, 10, send_tiles, c);
    double dt = vf_seconds_now() - t0;
    if (rc < 0) break;
    if (rc == 1) {
      unsigned i = atomic_fetch_add(f->latency_count, 1);
      if (i < f->results) f->latency[i] = dt;
      atomic_fetch_add(f->merged, 1);
    }
  }
close:
  vf_farm_client_close(c);
  return NULL;
}

static double proc_cpu(pid_t pid) {
  char path[64], buf[1024];
  snprintf(path, sizeof path, "/proc/%d/stat", (int)pid);
  FILE *f = fopen(path, "r");
  if (!f) return 0.0;
  size_t n = fread(buf, 1, sizeof buf - 1, f);
  fclose(f);
  buf[n] = '\0';
  char *p = strrchr(buf, ')');
  unsigned long utime = 0, stime = 0;
  /* fields after the command: state(3) ... utime(14) stime(15) */
  if (p) sscanf(p + 2, "%*c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %lu %lu", &utime, &stime);
  return (double)(utime + stime) / (double)sysconf(_SC_CLK_TCK);
}

static int simulate(const char *vcmfarm, int workers, int think_ms, unsigned results) {
  char dir[] = "/tmp/vf-bench-farm-XXXXXX", key_path[256], url[300], state[300];
  if (mkdtemp(dir) == NULL) return 1;
  snprintf(key_path, sizeof key_path, "%s/farm.key", dir);
  snprintf(url, sizeof url, "ipc://%s/coordinator.sock", dir);
  snprintf(state, sizeof state, "%s/state", dir);
  vf_wire_key key;
  if (vf_wire_key_generate(key_path) != VF_OK || vf_wire_key_load(key_path, &key) != VF_OK) return 1;
  char settings[512];
  settings_text(64, 64, settings, sizeof settings);
  fprintf(stderr, "precomputing %u films...\n", results);
  vf_film **films = calloc(results, sizeof *films);
  for (unsigned k = 0; k < results; k++)
    if (noisy_film(64, 64, settings, k, &films[k]) != VF_OK) return 1;
  pid_t pid = fork();
  if (pid == 0) {
    char log[300];
    snprintf(log, sizeof log, "%s/coordinator.log", dir);
    if (freopen(log, "w", stderr) == NULL) _exit(127);
    execl(vcmfarm, vcmfarm, "coordinator", "--listen", url, "--state", state, "--secret", key_path,
          "--lease-seconds", "1", "--worker-timeout", "60", (char *)NULL);
    _exit(127);
  }
  vf_farm_client *c;
  vf_farm_client_open(url, &key, &c);
  Vcmfarm__SubmitJob sm;
  Vcmfarm__Scene sc;
  Vcmfarm__Envelope q = submit_envelope(&sm, &sc, settings), *reply;
  int err = vf_farm_request(c, &q, VCMFARM__ENVELOPE__BODY_SUBMITTED, 10000, &reply);
  if (err != VF_OK) {
    fprintf(stderr, "submit: %s\n", vf_error_detail(err));
    kill(pid, SIGKILL);
    waitpid(pid, NULL, 0);
    return 1;
  }
  vf_message_free(reply);
  atomic_uint merged = 0, latency_count = 0;
  double *latency = calloc(results, sizeof *latency);
  fake_worker *fw = calloc((size_t)workers, sizeof *fw);
  pthread_t *threads = calloc((size_t)workers, sizeof *threads);
  double cpu0 = proc_cpu(pid), t0 = vf_seconds_now();
  for (int i = 0; i < workers; i++) {
    fw[i] = (fake_worker){url, &key, think_ms, i, films, results, &merged, latency, &latency_count};
    pthread_create(&threads[i], NULL, fake, &fw[i]);
  }
  for (int i = 0; i < workers; i++) pthread_join(threads[i], NULL);
  double seconds = vf_seconds_now() - t0, cpu = proc_cpu(pid) - cpu0;
  unsigned n = atomic_load(&latency_count);
  if (n > results) n = results;
  printf("%d fake workers, think %d ms: %u results in %.2f s = %.1f results/s; result round trip median %.2f ms, "
         "p90 %.2f ms, p99 %.2f ms; coordinator CPU %.2f ms per result (%.0f%% of a core)\n",
         workers, think_ms, n, seconds, n / seconds, 1e3 * percentile(latency, n, 0.5),
         1e3 * percentile(latency, n, 0.9), 1e3 * percentile(latency, n, 0.99), n ? 1e3 * cpu / n : 0.0,
         100.0 * cpu / seconds);
  kill(pid, SIGTERM);
  waitpid(pid, NULL, 0);
  vf_farm_client_close(c);
  for (unsigned k = 0; k < results; k++) vf_film_destroy(films[k]);
  free(films);
  free(latency);
  free(fw);
  free(threads);
  char cmd[400];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
  return system(cmd) == 0 ? 0 : 1;
}

int main(int argc, char **argv) {
  if (sodium_init() < 0) return 1;
  if (argc >= 2 && strcmp(argv[1], "merge") == 0) {
    int runs = argc >= 3 ? atoi(argv[2]) : 0;
    char dir[] = "/tmp/vf-bench-merge-XXXXXX";
    if (mkdtemp(dir) == NULL) return 1;
    int width = 0, height = 0;
    if (argc >= 4 && sscanf(argv[3], "%dx%d", &width, &height) == 2 && width > 0 && height > 0) {
      bench_merge(width, height, runs > 0 ? runs : 5, dir);
    } else {
      bench_merge(64, 64, runs > 0 ? runs : 9, dir);
      bench_merge(1920, 1080, runs > 0 ? runs : 5, dir);
    }
    char cmd[200];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : 1;
  }
  if (argc == 9 && strcmp(argv[1], "simulate") == 0 && strcmp(argv[3], "--film") == 0)
    return vf_bench_farm_simulate(argv[2], argv[4], atoi(argv[5]), atof(argv[6]), atof(argv[7]), atof(argv[8]));
  if (argc == 6 && strcmp(argv[1], "simulate") == 0)
    return simulate(argv[2], atoi(argv[3]), atoi(argv[4]), (unsigned)atoi(argv[5]));
  fprintf(stderr, "usage: bench_farm merge [RUNS]\n       bench_farm simulate VCMFARM WORKERS THINK_MS RESULTS\n"
                  "       bench_farm simulate VCMFARM --film FILM.exr WORKERS SECONDS ITERATION_SECONDS ENCODE_SECONDS\n");
  return 2;
}
