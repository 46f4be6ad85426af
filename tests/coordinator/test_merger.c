/* Merging off the loop (coordinator/merger.c, coordinator/results.c): a real coordinator
 * loop on a thread, over ipc://, with a 1920x1080 job. Flooding workers send one-iteration
 * parts of a noisy film (incompressible tiles: 48 bytes per pixel, 100 MB per part) back to
 * back, while another worker sends heartbeats and a third asks for leases, one after the
 * other. Heartbeats and leases must be answered within a bound whatever the flood (each
 * part costs the merge thread a decode of 510 tiles and an addition of 100 MB), parts must
 * be merged meanwhile, and an answer "busy" must come with a time to retry. The same for a
 * job in its pilot phase, whose parts go to its pilot film (and its pilot film's
 * checkpoints, every second here, to the merge thread too). */
#include "check.h"

#include <stdio.h>
#include "common/clock.h"
#include "common/error.h"
#include "common/farm_client.h"
#include "common/film.h"
#include "common/film_wire.h"
#include "common/rng.h"
#include "common/settings.h"
#include "coordinator/coordinator.h"

#include <pthread.h>
#include <sodium.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <unistd.h>

#define W 1920
#define H 1080
#define FLOODERS 3
#define FLOOD_SECONDS 8.0
/* The flood goes on past FLOOD_SECONDS until the merge thread has merged two parts (a
 * sanitized build on a busy machine takes seconds a merge), up to this long. */
#define FLOOD_MAX_SECONDS 60.0
#define MAX_SAMPLES 100000

static char dir[64], url[128], state[128];
static vf_wire_key key;
static char settings[512], pilot_settings[512];
static int pilot_case; /* the job has a pilot longer than the test: every part is a pilot part */
static const uint8_t scene_hash[32] = {9, 9, 9};
static Vcmfarm__Tile *tiles;
static uint32_t n_tiles;
static atomic_int flooding;
static atomic_uint parts_merged, busy_answers, refused;

static int call(vf_farm_client *c, Vcmfarm__Envelope *q, Vcmfarm__Envelope__BodyCase want, Vcmfarm__Envelope **reply) {
  return vf_farm_request(c, q, want, 30000, reply);
}

static uint64_t register_worker(vf_farm_client *c) {
  Vcmfarm__Register reg = VCMFARM__REGISTER__INIT;
  static int registered; /* distinct names: a name registering again is that worker restarted */
  char name[16];
  snprintf(name, sizeof name, "%s%d", "t", registered++);
  reg.name = name;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_REGISTER;
  q.register_ = &reg;
  if (call(c, &q, VCMFARM__ENVELOPE__BODY_REGISTERED, &reply) != VF_OK) return 0;
  uint64_t id = reply->registered->worker_id;
  vf_message_free(reply);
  return id;
}

/* A lease (retrying while the coordinator says Idle); 1 on success. */
static int lease(vf_farm_client *c, uint64_t worker, uint64_t *lease_id, uint64_t *job, uint64_t *begin,
                 uint64_t *end) {
  for (int attempt = 0; attempt < 200; attempt++) {
    Vcmfarm__LeaseRequest lr = VCMFARM__LEASE_REQUEST__INIT;
    lr.worker_id = worker;
    Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
    q.body_case = VCMFARM__ENVELOPE__BODY_LEASE_REQUEST;
    q.lease_request = &lr;
    if (vf_farm_call(c, &q, 30000, &reply) != VF_OK) return 0;
    if (reply->body_case == VCMFARM__ENVELOPE__BODY_LEASE) {
      *lease_id = reply->lease->lease_id;
      *job = reply->lease->job_id;
      *begin = reply->lease->begin;
      *end = reply->lease->end;
      vf_message_free(reply);
      return 1;
    }
    vf_message_free(reply);
    usleep(50000);
  }
  return 0;
}

static double heartbeat(vf_farm_client *c, uint64_t worker, uint64_t lease_id, uint64_t done, double seconds) {
  Vcmfarm__Heartbeat m = VCMFARM__HEARTBEAT__INIT;
  m.worker_id = worker;
  m.lease_id = lease_id;
  m.iterations_done = done;
  m.seconds = seconds;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_HEARTBEAT;
  q.heartbeat = &m;
  double t0 = vf_seconds_now();
  if (call(c, &q, VCMFARM__ENVELOPE__BODY_HEARTBEAT_ACK, &reply) != VF_OK) return 1e9;
  double dt = vf_seconds_now() - t0;
  vf_message_free(reply);
  return dt;
}

static void *flood(void *arg) {
  (void)arg;
  vf_farm_client *c;
  if (vf_farm_client_open(url, &key, &c) != VF_OK) return NULL;
  uint64_t worker = register_worker(c), lid, job, begin, end;
  if (!lease(c, worker, &lid, &job, &begin, &end)) goto close;
  heartbeat(c, worker, lid, 1, 0.001); /* a fast worker: its next leases are long */
  while (atomic_load(&flooding) && begin < end) {
    Vcmfarm__LeaseResult m = VCMFARM__LEASE_RESULT__INIT;
    m.worker_id = worker;
    m.lease_id = lid;
    m.job_id = job;
    m.begin = begin;
    m.end = begin + 1;
    m.width = W;
    m.height = H;
    m.scene_hash.data = (uint8_t *)scene_hash;
    m.scene_hash.len = 32;
    m.settings = pilot_case ? pilot_settings : settings;
    m.tiles_total = n_tiles;
    m.render_seconds = 1.0;
    m.pilot = pilot_case;
    Vcmfarm__Tile *ptrs[VF_FILM_TILES_PER_MESSAGE];
    int merged = 0;
    for (uint32_t at = 0; at < n_tiles && atomic_load(&flooding);) {
      uint32_t n = n_tiles - at < VF_FILM_TILES_PER_MESSAGE ? n_tiles - at : VF_FILM_TILES_PER_MESSAGE;
      for (uint32_t i = 0; i < n; i++) ptrs[i] = &tiles[at + i];
      m.tiles = ptrs;
      m.n_tiles = n;
      Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
      q.body_case = VCMFARM__ENVELOPE__BODY_RESULT;
      q.result = &m;
      if (call(c, &q, VCMFARM__ENVELOPE__BODY_RESULT_ACK, &reply) != VF_OK) goto close;
      Vcmfarm__ResultAck *ack = reply->result_ack;
      if (!ack->accepted) {
        if (ack->retry_ms == 0) {
          atomic_fetch_add(&refused, 1);
          fprintf(stderr, "  refused: %s\n", ack->message);
          vf_message_free(reply);
          goto close;
        }
        atomic_fetch_add(&busy_answers, 1);
        usleep(1000u * (ack->retry_ms > 200 ? 200 : ack->retry_ms));
        vf_message_free(reply);
        continue;
      }
      merged = strcmp(ack->message, "merged") == 0;
      vf_message_free(reply);
      at += n;
    }
    if (merged) atomic_fetch_add(&parts_merged, 1);
    begin++;
  }
close:
  vf_farm_client_close(c);
  return NULL;
}

static int cmp(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

static void *run_coordinator(void *arg) {
  vf_coordinator_config cc = {.listen_url = url, .state_dir = state, .key = &key, .worker_timeout = 60.0,
                              .lease_seconds = 20.0, .checkpoint_interval = pilot_case ? 1.0 : 1000.0, .stop = arg,
                              .quiet = 1};
  intptr_t err = vf_coordinator_run(&cc);
  return (void *)err;
}

/* What the merge thread does for one part, timed here on this thread: decode its 510
 * tiles, store them in a staged film, validate it, add its pixels to the job's film. The
 * latencies below are judged against this, measured on the same machine in the same build
 * (a sanitized build is several times slower throughout): a loop that merged would keep a
 * request waiting for up to a whole merge. */
static double one_merge_seconds(void) {
  Vcmfarm__LeaseResult m = VCMFARM__LEASE_RESULT__INIT;
  m.begin = 0;
  m.end = 1;
  m.width = W;
  m.height = H;
  Vcmfarm__Tile **ptrs = malloc(n_tiles * sizeof *ptrs);
  vf_film *staged = NULL, *job = NULL;
  double best = 1e9;
  if (ptrs == NULL || vf_film_create(W, H, &staged) != VF_OK || vf_film_create(W, H, &job) != VF_OK ||
      vf_iterset_add(&staged->iterations, 0, 1) != VF_OK)
    goto done;
  for (uint32_t i = 0; i < n_tiles; i++) ptrs[i] = &tiles[i];
  m.tiles = ptrs;
  m.n_tiles = n_tiles;
  for (int round = 0; round < 3; round++) {
    double t0 = vf_seconds_now();
    vf_film_tile *decoded;
    if (vf_film_tiles_decode(&m, W, H, &decoded) != VF_OK) goto done;
    for (uint32_t i = 0; i < n_tiles; i++) vf_film_tile_store(staged, &decoded[i]);
    vf_film_tiles_free(decoded, n_tiles);
    if (vf_film_validate(staged, "part") != VF_OK) goto done;
    vf_film_add_pixels(job, staged);
    double t = vf_seconds_now() - t0;
    if (t < best) best = t;
  }
done:
  vf_film_destroy(staged);
  vf_film_destroy(job);
  free(ptrs);
  return best;
}

static void flood_case(void) {
  double merge = one_merge_seconds();
  atomic_store(&parts_merged, 0);
  atomic_store(&busy_answers, 0);
  atomic_store(&refused, 0);
  snprintf(url, sizeof url, "ipc://%s/c%d.sock", dir, pilot_case);
  snprintf(state, sizeof state, "%s/state%d", dir, pilot_case);
  volatile sig_atomic_t stop = 0;
  pthread_t coordinator;
  pthread_create(&coordinator, NULL, run_coordinator, (void *)&stop);
  vf_farm_client *c;
  CHECK(vf_farm_client_open(url, &key, &c) == VF_OK);
  Vcmfarm__Scene scene = VCMFARM__SCENE__INIT;
  scene.source_case = VCMFARM__SCENE__SOURCE_BUILTIN;
  scene.builtin = "cornell";
  Vcmfarm__SubmitJob sm = VCMFARM__SUBMIT_JOB__INIT;
  sm.name = "flood";
  sm.scene = &scene;
  sm.scene_hash.data = (uint8_t *)scene_hash;
  sm.scene_hash.len = 32;
  sm.settings = pilot_case ? pilot_settings : settings;
  sm.iterations = 1000000000;
  sm.priority = 1;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_SUBMIT;
  q.submit = &sm;
  CHECK(call(c, &q, VCMFARM__ENVELOPE__BODY_SUBMITTED, &reply) == VF_OK);
  if (check_failed_in_case) return;
  vf_message_free(reply);
  /* The watcher holds a lease and beats; the asker asks for leases one after another. */
  uint64_t watcher = register_worker(c), lid, job, begin, end;
  CHECK(lease(c, watcher, &lid, &job, &begin, &end));
  heartbeat(c, watcher, lid, 1, 0.001);
  vf_farm_client *asker_client;
  CHECK(vf_farm_client_open(url, &key, &asker_client) == VF_OK);
  uint64_t asker = register_worker(asker_client);
  atomic_store(&flooding, 1);
  pthread_t flooders[FLOODERS];
  for (int i = 0; i < FLOODERS; i++) pthread_create(&flooders[i], NULL, flood, NULL);
  static double beats[MAX_SAMPLES], leases[MAX_SAMPLES];
  size_t nb = 0, nl = 0;
  double t0 = vf_seconds_now();
  usleep(500000); /* the flood under way */
  for (double t = 0.0; (t < FLOOD_SECONDS || atomic_load(&parts_merged) < 2) && t < FLOOD_MAX_SECONDS &&
                      nb < MAX_SAMPLES;
       t = vf_seconds_now() - t0) {
    beats[nb++] = heartbeat(c, watcher, lid, 1, 0.001);
    uint64_t l2, j2, b2, e2;
    double l0 = vf_seconds_now();
    if (lease(asker_client, asker, &l2, &j2, &b2, &e2)) leases[nl++] = vf_seconds_now() - l0;
    usleep(5000);
  }
  atomic_store(&flooding, 0);
  for (int i = 0; i < FLOODERS; i++) pthread_join(flooders[i], NULL);
  qsort(beats, nb, sizeof *beats, cmp);
  qsort(leases, nl, sizeof *leases, cmp);
  double b50 = beats[nb / 2], b99 = beats[(size_t)(0.99 * (double)(nb - 1))], bmax = beats[nb - 1];
  double l99 = nl ? leases[(size_t)(0.99 * (double)(nl - 1))] : 1e9;
  printf("  a part's merge alone: %.0f ms; %zu heartbeats: median %.1f ms, p99 %.1f ms, max %.1f ms; %zu lease "
         "requests, p99 %.1f ms; %u parts merged, %u busy answers\n",
         1e3 * merge, nb, 1e3 * b50, 1e3 * b99, 1e3 * bmax, nl, 1e3 * l99, atomic_load(&parts_merged),
         atomic_load(&busy_answers));
  CHECK(atomic_load(&parts_merged) >= 2);         /* the merge thread merged meanwhile */
  CHECK_INT_EQ(atomic_load(&refused), 0);
  CHECK(nb > 100);
  CHECK(merge < 1e9);
  /* Were merges on the loop, back to back as here, a request would wait for the rest of
   * the merge under way: half a merge at the median, nearly a whole one at p99. This loop
   * answers between the messages it decrypts, whatever the merge thread is doing. */
  CHECK(b99 < 0.5 * merge);
  CHECK(l99 < 0.5 * merge);
  CHECK(bmax < merge);
  stop = 1;
  void *err;
  pthread_join(coordinator, &err);
  CHECK_INT_EQ((intptr_t)err, VF_OK);
  if (pilot_case) { /* its checkpoints wrote the pilot film (and the last one, on stopping) */
    char pilot_file[256];
    snprintf(pilot_file, sizeof pilot_file, "%s/job-1.pilot.exr", state);
    CHECK(access(pilot_file, R_OK) == 0);
  }
  vf_farm_client_close(asker_client);
  vf_farm_client_close(c);
}

static void test_heartbeats_and_leases_answered_under_a_flood_of_parts(void) {
  pilot_case = 0;
  flood_case();
}

static void test_heartbeats_and_leases_answered_under_a_flood_of_pilot_parts(void) {
  pilot_case = 1;
  flood_case();
}

int main(void) {
  snprintf(dir, sizeof dir, "/tmp/vf-test-merger-XXXXXX");
  if (mkdtemp(dir) == NULL || sodium_init() < 0) return 1;
  randombytes_buf(key.bytes, sizeof key.bytes);
  vf_settings s;
  vf_settings_default(&s);
  s.width = W;
  s.height = H;
  vf_settings_format(&s, settings, sizeof settings);
  s.pilot = VF_MAX_PILOT;
  vf_settings_format(&s, pilot_settings, sizeof pilot_settings);
  /* A noisy one-iteration film: its tiles do not compress. */
  vf_film *film;
  if (vf_film_create(W, H, &film) != VF_OK) return 1;
  size_t n = 3 * (size_t)W * H;
  float *cam = malloc(n * sizeof *cam), *light = malloc(n * sizeof *light);
  vf_rng rng = vf_rng_for_path(1, 0, 0, VF_STREAM_TEST);
  for (size_t i = 0; i < n; i++) {
    cam[i] = vf_rng_float(&rng);
    light[i] = 0.1f * vf_rng_float(&rng);
  }
  if (vf_film_add_iteration(film, 0, cam, light, NULL) != VF_OK) return 1;
  free(cam);
  free(light);
  n_tiles = vf_film_tile_count(W, H);
  tiles = calloc(n_tiles, sizeof *tiles);
  uint32_t across = vf_film_tiles_across(W);
  for (uint32_t i = 0; i < n_tiles; i++) {
    uint8_t *storage; /* kept: the tile points into it until the end */
    if (vf_film_tile_encode(film, i % across, i / across, &tiles[i], &storage) != VF_OK) return 1;
  }
  vf_film_destroy(film);
  RUN(test_heartbeats_and_leases_answered_under_a_flood_of_parts);
  RUN(test_heartbeats_and_leases_answered_under_a_flood_of_pilot_parts);
  char cmd[128];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
  if (system(cmd) != 0) return 1;
  return check_finish();
}
