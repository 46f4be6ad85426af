/* bench_farm simulate VCMFARM --film FILM.exr WORKERS SECONDS ITERATION_SECONDS ENCODE_SECONDS
 *
 * A farm of WORKERS simulated workers against a real coordinator process (VCMFARM
 * coordinator over ipc://, default settings; over tcp:// on loopback, through the
 * coordinator's gate, with SIM_TRANSPORT=tcp in the environment), for docs/BENCHMARKS.md ("A coordinator for
 * 1000 workers"). The job is FILM's (its size, scene hash and settings); every part a
 * worker ships is FILM's tiles as a worker encodes them (precomputed once: real compressed
 * chunks), so the coordinator decodes, checks and merges what a real farm sends it.
 *
 * A simulated worker registers, asks for leases, and "renders" each iteration by sleeping
 * ITERATION_SECONDS (measured on the real renderer), sending heartbeats meanwhile as the
 * worker's heartbeat thread does; it ships a part when the coordinator's ship interval
 * (from its Lease and HeartbeatAck) has passed and at the end of each lease, after
 * sleeping ENCODE_SECONDS (the worker's measured cost of encoding a part, which holds its
 * render threads), and honours "busy" answers (retry_ms). Its time alive runs from its
 * registration to the end; its time rendering is the iterations' sleep.
 *
 * The workers register first and start together once all have (a farm already running
 * when the job arrives), and the time runs from then. Steady state from the start: a real farm's workers ship at moments spread over the
 * interval. Here they all start together, so each worker's first lease is cut at a uniform
 * random fraction of its duration (the rest handed back), as if it had started earlier:
 * the coordinator sees from the first minute the rate of parts of a long-running farm.
 *
 * Workers are threads of child processes, at most 200 per process (nanomsg allows 512
 * sockets per process); statistics come back through shared memory. Prints worker
 * efficiency (time rendering / time alive), p50/p99 request latency (heartbeats and lease
 * requests; result messages), parts merged, the coordinator's CPU (from /proc) and its
 * peak memory (VmHWM), and the ship interval it chose. */
#include "farm_sim.h"

#include "common/clock.h"
#include "common/error.h"
#include "common/farm_client.h"
#include "common/film.h"
#include "common/film_wire.h"

#include <arpa/inet.h>
#include <math.h>
#include <netinet/in.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#define PER_PROCESS 200
#define TILES_PER_MESSAGE VF_FILM_TILES_PER_MESSAGE
#define MAX_SAMPLES (1u << 21)

typedef struct {
  double render, alive, waiting_ship, waiting_idle;
  unsigned parts, busy_answers, refused;
} worker_stats;

/* In shared memory: written by the children, read by the parent at the end. */
typedef struct {
  atomic_int start;
  atomic_int registered; /* workers registered: they start leasing when all are */
  double deadline;         /* vf_seconds_now() (CLOCK_MONOTONIC: one clock for all processes) */
  atomic_uint n_control, n_result;
  atomic_uint ship_ms_last;
  float control[MAX_SAMPLES], result[MAX_SAMPLES]; /* seconds */
  worker_stats workers[];
} shared;

typedef struct {
  const char *url;
  const vf_wire_key *key;
  const vf_film *film;
  Vcmfarm__Tile *tiles; /* the film's, precomputed */
  uint32_t n_tiles;
  double iteration_seconds, encode_seconds;
  shared *sh;
  int index, workers;
} sim_worker;

static void sleep_s(double s) {
  if (s <= 0.0) return;
  struct timespec ts = {(time_t)s, (long)((s - (double)(time_t)s) * 1e9)};
  while (nanosleep(&ts, &ts) != 0) {
  }
}

static void record(shared *sh, int result, double seconds) {
  atomic_uint *n = result ? &sh->n_result : &sh->n_control;
  unsigned i = atomic_fetch_add(n, 1);
  if (i < MAX_SAMPLES) (result ? sh->result : sh->control)[i] = (float)seconds;
}

/* One timed request; the reply (caller frees) on VF_OK. */
static int call(sim_worker *s, vf_farm_client *c, Vcmfarm__Envelope *q, int result, Vcmfarm__Envelope **reply) {
  double t0 = vf_seconds_now();
  int err = vf_farm_call(c, q, 60000, reply);
  if (err == VF_OK) record(s->sh, result, vf_seconds_now() - t0);
  return err;
}

typedef struct {
  uint64_t worker_id, lease_id, job_id;
  double ship_seconds, ship_cost;
  int valid;
} lease_state;

static void heartbeat(sim_worker *s, vf_farm_client *c, lease_state *ls, uint64_t done, double seconds) {
  Vcmfarm__Heartbeat m = VCMFARM__HEARTBEAT__INIT;
  m.worker_id = ls->worker_id;
  m.lease_id = ls->lease_id;
  m.iterations_done = done;
  m.seconds = seconds;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_HEARTBEAT;
  q.heartbeat = &m;
  if (call(s, c, &q, 0, &reply) != VF_OK) return;
  if (reply->body_case == VCMFARM__ENVELOPE__BODY_HEARTBEAT_ACK) {
    if (!reply->heartbeat_ack->lease_valid) ls->valid = 0;
    if (reply->heartbeat_ack->ship_interval_ms > 0) {
      ls->ship_seconds = reply->heartbeat_ack->ship_interval_ms / 1000.0;
      atomic_store(&s->sh->ship_ms_last, reply->heartbeat_ack->ship_interval_ms);
    }
  }
  vf_message_free(reply);
}

/* Ships [begin, end) as the film's tiles; 1 merged, 0 not. */
static int ship(sim_worker *s, vf_farm_client *c, lease_state *ls, uint64_t begin, uint64_t end) {
  worker_stats *st = &s->sh->workers[s->index];
  double t0 = vf_seconds_now();
  sleep_s(s->encode_seconds);
  Vcmfarm__LeaseResult m = VCMFARM__LEASE_RESULT__INIT;
  m.worker_id = ls->worker_id;
  m.lease_id = ls->lease_id;
  m.job_id = ls->job_id;
  m.begin = begin;
  m.end = end;
  m.width = (uint32_t)s->film->width;
  m.height = (uint32_t)s->film->height;
  m.scene_hash.data = (uint8_t *)s->film->scene_hash;
  m.scene_hash.len = 32;
  m.settings = (char *)s->film->settings_text;
  m.tiles_total = s->n_tiles;
  m.render_seconds = (double)(end - begin) * s->iteration_seconds;
  m.cpu_seconds = 2.0 * m.render_seconds;
  Vcmfarm__Tile *ptrs[TILES_PER_MESSAGE];
  int merged = 0;
  for (uint32_t at = 0; at < s->n_tiles;) {
    uint32_t n = s->n_tiles - at < TILES_PER_MESSAGE ? s->n_tiles - at : TILES_PER_MESSAGE;
    for (uint32_t i = 0; i < n; i++) ptrs[i] = &s->tiles[at + i];
    m.tiles = ptrs;
    m.n_tiles = n;
    Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
    q.body_case = VCMFARM__ENVELOPE__BODY_RESULT;
    q.result = &m;
    if (call(s, c, &q, 1, &reply) != VF_OK) break;
    if (reply->body_case != VCMFARM__ENVELOPE__BODY_RESULT_ACK) {
      vf_message_free(reply);
      break;
    }
    Vcmfarm__ResultAck *ack = reply->result_ack;
    if (!ack->accepted && ack->retry_ms > 0) {
      st->busy_answers++;
      double ms = ack->retry_ms;
      vf_message_free(reply);
      sleep_s((ms / 2 + (double)(rand() % ((int)ms + 1))) / 1000.0);
      continue;
    }
    int accepted = ack->accepted;
    merged = accepted && strcmp(ack->message, "merged") == 0;
    if (!accepted) {
      st->refused++;
      fprintf(stderr, "sim worker %d: refused: %s\n", s->index, ack->message);
    }
    vf_message_free(reply);
    if (!accepted) break;
    at += n;
  }
  ls->ship_cost = vf_seconds_now() - t0;
  st->waiting_ship += ls->ship_cost;
  if (merged) st->parts++;
  else ls->valid = 0;
  return merged;
}

static void release(sim_worker *s, vf_farm_client *c, lease_state *ls) {
  Vcmfarm__LeaseRelease m = VCMFARM__LEASE_RELEASE__INIT;
  m.worker_id = ls->worker_id;
  m.lease_id = ls->lease_id;
  m.failure = "";
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_RELEASE;
  q.release = &m;
  if (call(s, c, &q, 0, &reply) == VF_OK) vf_message_free(reply);
}

/* Renders a lease (the first one cut at a random fraction), shipping as the worker does. */
static void run_lease(sim_worker *s, vf_farm_client *c, lease_state *ls, uint64_t begin, uint64_t end, int first,
                      int heartbeat_ms, double seconds) {
  worker_stats *st = &s->sh->workers[s->index];
  uint64_t limit = end;
  double started = vf_seconds_now(), shipped_at = started, next_beat = started + heartbeat_ms / 1000.0;
  /* The lease's time bound (its rate unknown), else its range's duration. */
  double duration = seconds > 0.0 ? seconds : (double)(end - begin) * s->iteration_seconds;
  if (first) duration *= (double)rand() / RAND_MAX; /* as if started earlier: steady state at once */
  uint64_t part = begin, done = begin;
  while (done < limit && ls->valid && vf_seconds_now() < s->sh->deadline &&
         (done == begin || vf_seconds_now() - started < duration)) {
    /* one iteration, heartbeats meanwhile */
    double t0 = vf_seconds_now(), end_at = t0 + s->iteration_seconds;
    for (double now = t0; now < end_at; now = vf_seconds_now()) {
      double wake = next_beat < end_at ? next_beat : end_at;
      sleep_s(wake - now);
      if (vf_seconds_now() >= next_beat) {
        heartbeat(s, c, ls, done - begin, vf_seconds_now() - started);
        next_beat += heartbeat_ms / 1000.0;
      }
    }
    double now = vf_seconds_now();
    st->render += (now < s->sh->deadline ? now : s->sh->deadline) - t0; /* alive ends at the deadline */
    done++;
    double interval = ls->ship_seconds > 50.0 * ls->ship_cost ? ls->ship_seconds : 50.0 * ls->ship_cost;
    if (done < limit && vf_seconds_now() - shipped_at >= interval && ls->valid) {
      if (!ship(s, c, ls, part, done)) return;
      part = done;
      shipped_at = vf_seconds_now();
    }
  }
  if (vf_seconds_now() >= s->sh->deadline || !ls->valid) return; /* the end: what is unshipped is not counted */
  if (done > part && !ship(s, c, ls, part, done)) return;
  if (done < end) release(s, c, ls);
}

static void *sim_thread(void *arg) {
  sim_worker *s = arg;
  worker_stats *st = &s->sh->workers[s->index];
  vf_farm_client *c;
  if (vf_farm_client_open(s->url, s->key, &c) != VF_OK) return NULL;
  Vcmfarm__Register reg = VCMFARM__REGISTER__INIT;
  char name[32];
  snprintf(name, sizeof name, "sim%d", s->index);
  reg.name = name;
  reg.host = "sim";
  reg.threads = reg.cores = 2;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_REGISTER;
  q.register_ = &reg;
  if (vf_farm_request(c, &q, VCMFARM__ENVELOPE__BODY_REGISTERED, 60000, &reply) != VF_OK) goto close;
  uint64_t worker = reply->registered->worker_id;
  int heartbeat_ms = (int)reply->registered->heartbeat_ms;
  vf_message_free(reply);
  /* A farm whose workers are there when the job comes: they all registered before. */
  atomic_fetch_add(&s->sh->registered, 1);
  while (atomic_load(&s->sh->registered) < s->workers) sleep_s(0.01);
  double born = vf_seconds_now();
  int first = 1;
  while (vf_seconds_now() < s->sh->deadline) {
    Vcmfarm__LeaseRequest lr = VCMFARM__LEASE_REQUEST__INIT;
    lr.worker_id = worker;
    q.body_case = VCMFARM__ENVELOPE__BODY_LEASE_REQUEST;
    q.lease_request = &lr;
    if (call(s, c, &q, 0, &reply) != VF_OK) continue;
    if (reply->body_case == VCMFARM__ENVELOPE__BODY_IDLE) {
      double wait = reply->idle->retry_ms / 1000.0, t0 = vf_seconds_now();
      vf_message_free(reply);
      sleep_s(wait);
      st->waiting_idle += vf_seconds_now() - t0;
      continue;
    }
    if (reply->body_case != VCMFARM__ENVELOPE__BODY_LEASE) {
      vf_message_free(reply);
      sleep_s(0.5);
      continue;
    }
    lease_state ls = {worker, reply->lease->lease_id, reply->lease->job_id, reply->lease->ship_interval_ms / 1000.0,
                      0.0, 1};
    uint64_t b = reply->lease->begin, e = reply->lease->end;
    double seconds = reply->lease->seconds_ms / 1000.0;
    vf_message_free(reply);
    run_lease(s, c, &ls, b, e, first, heartbeat_ms, seconds);
    first = 0;
  }
  st->alive = s->sh->deadline - born;
close:
  vf_farm_client_close(c);
  return NULL;
}

static void child(sim_worker *proto, int from, int to) {
  while (!atomic_load(&proto->sh->start)) sleep_s(0.01);
  srand((unsigned)(getpid() * 7919));
  int n = to - from;
  sim_worker *w = calloc((size_t)n, sizeof *w);
  pthread_t *t = calloc((size_t)n, sizeof *t);
  for (int i = 0; i < n; i++) {
    w[i] = *proto;
    w[i].index = from + i;
    pthread_attr_t attr;
    pthread_attr_init(&attr);
    pthread_attr_setstacksize(&attr, 256 << 10);
    pthread_create(&t[i], &attr, sim_thread, &w[i]);
    pthread_attr_destroy(&attr);
    sleep_s(0.002); /* registrations spread over a moment, as a farm's boots are */
  }
  for (int i = 0; i < n; i++) pthread_join(t[i], NULL);
  _exit(0);
}

/* A loopback port nobody listens on now (the kernel's pick for port 0). */
static int free_port(void) {
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  struct sockaddr_in a = {.sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK)};
  socklen_t len = sizeof a;
  int port = -1;
  if (fd >= 0 && bind(fd, (struct sockaddr *)&a, sizeof a) == 0 && getsockname(fd, (struct sockaddr *)&a, &len) == 0)
    port = ntohs(a.sin_port);
  if (fd >= 0) close(fd);
  return port;
}

static double proc_field(pid_t pid, const char *file, const char *key) {
  char path[64], line[256];
  snprintf(path, sizeof path, "/proc/%d/%s", (int)pid, file);
  FILE *f = fopen(path, "r");
  if (!f) return 0.0;
  double v = 0.0;
  size_t klen = strlen(key);
  while (fgets(line, sizeof line, f))
    if (strncmp(line, key, klen) == 0) v = atof(line + klen);
  fclose(f);
  return v;
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
  if (p) sscanf(p + 2, "%*c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %lu %lu", &utime, &stime);
  return (double)(utime + stime) / (double)sysconf(_SC_CLK_TCK);
}

static int cmp_float(const void *a, const void *b) {
  float x = *(const float *)a, y = *(const float *)b;
  return (x > y) - (x < y);
}

static double pct(float *v, unsigned n, double p) {
  if (n == 0) return 0.0;
  qsort(v, n, sizeof *v, cmp_float);
  return v[(size_t)(p * (double)(n - 1) + 0.5)];
}

int vf_bench_farm_simulate(const char *vcmfarm, const char *film_path, int workers, double seconds,
                           double iteration_seconds, double encode_seconds) {
  vf_film *film;
  int err = vf_film_read(film_path, &film);
  if (err != VF_OK) {
    fprintf(stderr, "%s: %s\n", film_path, vf_error_detail(err));
    return 1;
  }
  uint32_t n_tiles = vf_film_tile_count(film->width, film->height), across = vf_film_tiles_across(film->width);
  Vcmfarm__Tile *tiles = calloc(n_tiles, sizeof *tiles);
  size_t part_bytes = 0;
  for (uint32_t i = 0; i < n_tiles; i++) {
    uint8_t *storage;
    if (vf_film_tile_encode(film, i % across, i / across, &tiles[i], &storage) != VF_OK) return 1;
    part_bytes += tiles[i].chunk.len; /* storage stays: the tiles point into it */
  }
  struct rlimit rl;
  if (getrlimit(RLIMIT_NOFILE, &rl) == 0 && rl.rlim_cur < rl.rlim_max) {
    rl.rlim_cur = rl.rlim_max; /* the coordinator inherits it: a descriptor per worker */
    setrlimit(RLIMIT_NOFILE, &rl);
  }
  size_t shared_bytes = sizeof(shared) + (size_t)workers * sizeof(worker_stats);
  shared *sh = mmap(NULL, shared_bytes, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  if (sh == MAP_FAILED) return 1;
  char dir[] = "/tmp/vf-bench-sim-XXXXXX", key_path[256], url[300], state[300];
  if (mkdtemp(dir) == NULL) return 1;
  snprintf(key_path, sizeof key_path, "%s/farm.key", dir);
  snprintf(url, sizeof url, "ipc://%s/coordinator.sock", dir);
  const char *transport = getenv("SIM_TRANSPORT");
  if (transport != NULL && strcmp(transport, "tcp") == 0) {
    int port = free_port();
    if (port <= 0) return 1;
    snprintf(url, sizeof url, "tcp://127.0.0.1:%d", port);
  }
  printf("transport: %s\n", url);
  snprintf(state, sizeof state, "%s/state", dir);
  vf_wire_key key;
  if (vf_wire_key_generate(key_path) != VF_OK || vf_wire_key_load(key_path, &key) != VF_OK) return 1;
  /* Children first, before this process touches nanomsg (its threads do not survive a fork). */
  sim_worker proto = {url, &key, film, tiles, n_tiles, iteration_seconds, encode_seconds, sh, 0, workers};
  int processes = (workers + PER_PROCESS - 1) / PER_PROCESS;
  pid_t *kids = calloc((size_t)processes, sizeof *kids);
  for (int p = 0; p < processes; p++) {
    int from = p * workers / processes, to = (p + 1) * workers / processes;
    if ((kids[p] = fork()) == 0) child(&proto, from, to);
  }
  pid_t coordinator = fork();
  if (coordinator == 0) {
    char log[300];
    snprintf(log, sizeof log, "%s/coordinator.log", dir);
    if (freopen(log, "w", stderr) == NULL) _exit(127);
    setenv("TMPDIR", dir, 1); /* the private socket behind the TCP gate, removed with dir */
    execl(vcmfarm, vcmfarm, "coordinator", "--listen", url, "--state", state, "--secret", key_path, (char *)NULL);
    _exit(127);
  }
  vf_farm_client *c;
  vf_farm_client_open(url, &key, &c);
  Vcmfarm__Scene scene = VCMFARM__SCENE__INIT;
  scene.source_case = VCMFARM__SCENE__SOURCE_BUILTIN;
  scene.builtin = "cornell";
  Vcmfarm__SubmitJob sm = VCMFARM__SUBMIT_JOB__INIT;
  sm.name = "simulated";
  sm.scene = &scene;
  sm.scene_hash.data = film->scene_hash;
  sm.scene_hash.len = 32;
  sm.settings = film->settings_text;
  sm.iterations = 1000000000;
  sm.priority = 1;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_SUBMIT;
  q.submit = &sm;
  if ((err = vf_farm_request(c, &q, VCMFARM__ENVELOPE__BODY_SUBMITTED, 10000, &reply)) != VF_OK) {
    fprintf(stderr, "submit: %s\n", vf_error_detail(err));
    kill(coordinator, SIGKILL);
    for (int p = 0; p < processes; p++) kill(kids[p], SIGKILL);
    return 1;
  }
  vf_message_free(reply);
  double t0 = vf_seconds_now(), cpu0 = proc_cpu(coordinator);
  sh->deadline = t0 + seconds;
  atomic_store(&sh->start, 1);
  for (int p = 0; p < processes; p++) waitpid(kids[p], NULL, 0);
  double wall = vf_seconds_now() - t0, cpu = proc_cpu(coordinator) - cpu0;
  double hwm = proc_field(coordinator, "status", "VmHWM:") / 1024.0;
  kill(coordinator, SIGTERM);
  waitpid(coordinator, NULL, 0);
  vf_farm_client_close(c);
  double render = 0, alive = 0, ship = 0, idle = 0;
  unsigned parts = 0, busy = 0, refused = 0;
  for (int i = 0; i < workers; i++) {
    worker_stats *w = &sh->workers[i];
    render += w->render;
    alive += w->alive;
    ship += w->waiting_ship;
    idle += w->waiting_idle;
    parts += w->parts;
    busy += w->busy_answers;
    refused += w->refused;
  }
  unsigned nc = atomic_load(&sh->n_control), nr = atomic_load(&sh->n_result);
  if (nc > MAX_SAMPLES) nc = MAX_SAMPLES;
  if (nr > MAX_SAMPLES) nr = MAX_SAMPLES;
  printf("%d simulated workers, %dx%d film (parts of %.1f MB), %.2f s per iteration, %.2f s to encode a part, "
         "%.0f s:\n",
         workers, film->width, film->height, (double)part_bytes / 1e6, iteration_seconds, encode_seconds, wall);
  printf("  worker efficiency %.2f%% (rendering %.0f of %.0f worker-seconds alive; shipping %.2f%%, idle %.2f%%)\n",
         100.0 * render / alive, render, alive, 100.0 * ship / alive, 100.0 * idle / alive);
  printf("  heartbeats and leases: %u requests, p50 %.2f ms, p99 %.2f ms, max %.2f ms\n", nc,
         1e3 * pct(sh->control, nc, 0.5), 1e3 * pct(sh->control, nc, 0.99), 1e3 * pct(sh->control, nc, 1.0));
  printf("  result messages: %u, p50 %.2f ms, p99 %.2f ms; %u parts merged, %u busy answers, %u refused\n", nr,
         1e3 * pct(sh->result, nr, 0.5), 1e3 * pct(sh->result, nr, 0.99), parts, busy, refused);
  printf("  coordinator: CPU %.1f s = %.0f%% of a core, peak RSS %.0f MiB; ship interval %.0f s at the end\n", cpu,
         100.0 * cpu / wall, hwm, atomic_load(&sh->ship_ms_last) / 1000.0);
  char cmd[400];
  snprintf(cmd, sizeof cmd, "grep -c 'merged job' '%s/coordinator.log' >/dev/null; rm -rf '%s'", dir, dir);
  return system(cmd) == 0 ? 0 : 1;
}
