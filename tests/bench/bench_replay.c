/* The renderer's rays/s against Embree's rate on the very same rays.
 *
 * bench_embree's raw rate is a fixed mix of synthetic rays (15% camera, 30% bounce, 55%
 * shadow rays between random points: the proportions of vcm on `cornell`). An algorithm
 * whose rays differ (pt has fewer shadow rays, and on a scene with a sun most of them run
 * to infinity) is then set against rays cheaper or dearer than its own. This benchmark
 * records the rays one iteration of the renderer traces and traces them again through
 * the same calls, in the same groups, with nothing else to do: the rate Embree alone
 * reaches on them. The renderer's rate against it is the share of its time spent in
 * Embree, whatever the mix.
 *
 * The renderer's four calls into Embree are wrapped at link time (-Wl,--wrap, see
 * tests/CMakeLists.txt): the wrappers pass through, and while recording they append each
 * call's rays and what it found to a log of the calling thread.
 *
 *   bench_replay SCENE ALGORITHM WxH [THREADS] [ITERATIONS] [ROUNDS]
 *   defaults: 2 threads, 3 timed iterations, 3 rounds; maximum path length 10
 *
 * Per round: ITERATIONS iterations timed after one untimed one (the renderer's steady
 * rate, as `render` prints it), one more iteration recorded, then its rays replayed three
 * times on THREADS threads (the median kept); the ratio is the round's render rate over
 * its replay rate. Prints each round and the medians. */
#include "common/clock.h"
#include "common/error.h"
#include "common/pool.h"
#include "common/settings.h"
#include "worker/render/accel.h"
#include "worker/scene/scene.h"
#include "worker/scene/load.h"
#include "worker/render/vcm.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

uint32_t __real_vf_accel_intersect_packet(const vf_accel *accel, const vf_vec3 *org, const vf_vec3 *dir, int n,
                                          vf_hit *hits);
uint32_t __real_vf_accel_occluded_packet(const vf_accel *accel, const vf_vec3 *org, const vf_vec3 *dir,
                                         const float *tfar, int n);
int __real_vf_accel_intersect(const vf_accel *accel, vf_vec3 org, vf_vec3 dir, float tfar, vf_hit *hit);
int __real_vf_accel_occluded(const vf_accel *accel, vf_vec3 org, vf_vec3 dir, float tfar);

/* One call as recorded: its kind, its rays (rays[first] on) and the mask of what it found. */
enum { CALL_INTERSECT, CALL_OCCLUDED, CALL_INTERSECT_PACKET, CALL_OCCLUDED_PACKET, CALL_KINDS };
typedef struct {
  uint8_t kind, n;
  uint32_t found;
  size_t first;
} call;

typedef struct {
  vf_vec3 org, dir;
  float tfar;
} ray;

typedef struct {
  call *calls;
  size_t num_calls, call_cap;
  ray *rays;
  size_t num_rays, ray_cap;
  int failed;
} ray_log;

#define MAX_LOGS 64
static ray_log logs[MAX_LOGS];
static int num_logs;
static int recording;
static pthread_mutex_t logs_lock = PTHREAD_MUTEX_INITIALIZER;
static _Thread_local ray_log *my_log;

static int grow(void **p, size_t *cap, size_t need, size_t elem) {
  if (need <= *cap) return 1;
  size_t cap2 = *cap ? *cap : 4096;
  while (cap2 < need) cap2 *= 2;
  void *q = realloc(*p, cap2 * elem);
  if (q == NULL) return 0;
  *p = q;
  *cap = cap2;
  return 1;
}

static void record(int kind, const vf_vec3 *org, const vf_vec3 *dir, const float *tfar, int n, uint32_t found) {
  if (my_log == NULL) {
    pthread_mutex_lock(&logs_lock);
    if (num_logs < MAX_LOGS) my_log = &logs[num_logs++];
    pthread_mutex_unlock(&logs_lock);
    if (my_log == NULL) return;
  }
  ray_log *l = my_log;
  if (l->failed || !grow((void **)&l->calls, &l->call_cap, l->num_calls + 1, sizeof *l->calls) ||
      !grow((void **)&l->rays, &l->ray_cap, l->num_rays + (size_t)n, sizeof *l->rays)) {
    l->failed = 1;
    return;
  }
  l->calls[l->num_calls++] = (call){(uint8_t)kind, (uint8_t)n, found, l->num_rays};
  for (int i = 0; i < n; i++) l->rays[l->num_rays++] = (ray){org[i], dir[i], tfar ? tfar[i] : INFINITY};
}

uint32_t __wrap_vf_accel_intersect_packet(const vf_accel *accel, const vf_vec3 *org, const vf_vec3 *dir, int n,
                                          vf_hit *hits);
uint32_t __wrap_vf_accel_intersect_packet(const vf_accel *accel, const vf_vec3 *org, const vf_vec3 *dir, int n,
                                          vf_hit *hits) {
  uint32_t found = __real_vf_accel_intersect_packet(accel, org, dir, n, hits);
  if (recording) record(CALL_INTERSECT_PACKET, org, dir, NULL, n, found);
  return found;
}

uint32_t __wrap_vf_accel_occluded_packet(const vf_accel *accel, const vf_vec3 *org, const vf_vec3 *dir,
                                         const float *tfar, int n);
uint32_t __wrap_vf_accel_occluded_packet(const vf_accel *accel, const vf_vec3 *org, const vf_vec3 *dir,
                                         const float *tfar, int n) {
  uint32_t found = __real_vf_accel_occluded_packet(accel, org, dir, tfar, n);
  if (recording) record(CALL_OCCLUDED_PACKET, org, dir, tfar, n, found);
  return found;
}

int __wrap_vf_accel_intersect(const vf_accel *accel, vf_vec3 org, vf_vec3 dir, float tfar, vf_hit *hit);
int __wrap_vf_accel_intersect(const vf_accel *accel, vf_vec3 org, vf_vec3 dir, float tfar, vf_hit *hit) {
  int found = __real_vf_accel_intersect(accel, org, dir, tfar, hit);
  if (recording) record(CALL_INTERSECT, &org, &dir, &tfar, 1, (uint32_t)found);
  return found;
}

int __wrap_vf_accel_occluded(const vf_accel *accel, vf_vec3 org, vf_vec3 dir, float tfar);
int __wrap_vf_accel_occluded(const vf_accel *accel, vf_vec3 org, vf_vec3 dir, float tfar) {
  int found = __real_vf_accel_occluded(accel, org, dir, tfar);
  if (recording) record(CALL_OCCLUDED, &org, &dir, &tfar, 1, (uint32_t)found);
  return found;
}

/* ---- replay ------------------------------------------------------------------------- */

/* The recorded calls of all threads, in tasks of about REPLAY_TASK rays each. */
#define REPLAY_TASK 65536
typedef struct {
  const vf_accel *accel;
  size_t (*bounds)[3]; /* per task: log, first call, end call */
  unsigned long long mismatches[MAX_LOGS];
} replay_ctx;

static void replay_task(void *p, size_t task, int thread) {
  replay_ctx *c = p;
  const ray_log *l = &logs[c->bounds[task][0]];
  unsigned long long mismatches = 0;
  for (size_t k = c->bounds[task][1]; k < c->bounds[task][2]; k++) {
    const call *cl = &l->calls[k];
    const ray *r = &l->rays[cl->first];
    vf_vec3 org[VF_ACCEL_PACKET], dir[VF_ACCEL_PACKET];
    float tfar[VF_ACCEL_PACKET];
    vf_hit hits[VF_ACCEL_PACKET];
    uint32_t found = 0;
    switch (cl->kind) {
    case CALL_INTERSECT: found = (uint32_t)__real_vf_accel_intersect(c->accel, r->org, r->dir, r->tfar, hits); break;
    case CALL_OCCLUDED: found = (uint32_t)__real_vf_accel_occluded(c->accel, r->org, r->dir, r->tfar); break;
    default:
      for (int i = 0; i < cl->n; i++) {
        org[i] = r[i].org;
        dir[i] = r[i].dir;
        tfar[i] = r[i].tfar;
      }
      found = cl->kind == CALL_INTERSECT_PACKET ? __real_vf_accel_intersect_packet(c->accel, org, dir, cl->n, hits)
                                                : __real_vf_accel_occluded_packet(c->accel, org, dir, tfar, cl->n);
    }
    mismatches += found != cl->found;
  }
  c->mismatches[thread] += mismatches;
}

static int compare(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

static double median(double *v, int n) {
  qsort(v, (size_t)n, sizeof *v, compare);
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static void clear_logs(void) {
  for (int i = 0; i < num_logs; i++) logs[i].num_calls = logs[i].num_rays = 0, logs[i].failed = 0;
}

int main(int argc, char **argv) {
  if (argc < 4) {
    fprintf(stderr, "usage: bench_replay SCENE ALGORITHM WxH [THREADS] [ITERATIONS] [ROUNDS]\n");
    return 2;
  }
  int threads = argc > 4 ? atoi(argv[4]) : 2, iterations = argc > 5 ? atoi(argv[5]) : 3;
  int rounds = argc > 6 ? atoi(argv[6]) : 3;
  vf_scene *scene;
  vf_accel *accel;
  vf_pool *pool;
  vf_vcm *vcm;
  int err;
  if ((err = vf_scene_load(argv[1], &scene)) != VF_OK) {
    fprintf(stderr, "bench_replay: %s\n", vf_error_detail(err));
    return 1;
  }
  vf_settings settings = scene->settings;
  settings.max_path_length = 10;
  if ((err = vf_algorithm_parse(argv[2], &settings.algorithm)) != VF_OK ||
      sscanf(argv[3], "%dx%d", &settings.width, &settings.height) != 2 || threads < 1 || iterations < 1 ||
      rounds < 1 || (err = vf_settings_validate(&settings)) != VF_OK) {
    fprintf(stderr, "bench_replay: bad arguments%s%s\n", err ? ": " : "", err ? vf_error_detail(err) : "");
    return 2;
  }
  if ((err = vf_accel_create(scene, &accel)) != VF_OK || (err = vf_pool_create(threads, &pool)) != VF_OK ||
      (err = vf_vcm_create(scene, accel, &settings, pool, &vcm)) != VF_OK) {
    fprintf(stderr, "bench_replay: %s\n", vf_error_detail(err));
    return 1;
  }
  size_t pixels = (size_t)settings.width * (size_t)settings.height;
  float *camera_rgb = malloc(3 * pixels * sizeof(float)), *light_rgb = malloc(3 * pixels * sizeof(float));
  if (camera_rgb == NULL || light_rgb == NULL) return 1;
  printf("scene %s, %s, %dx%d, max path length 10, %d thread(s), Embree's %s kernels; per round %d timed "
         "iteration(s) after one, then one recorded and replayed 3 times\n\n",
         argv[1], argv[2], settings.width, settings.height, threads, vf_accel_kernels(), iterations);
  printf("| round | render Mrays/s | replay Mrays/s | render of replay | rays per iteration | intersect %% | occluded %% | to infinity %% |\n");
  printf("|---|---|---|---|---|---|---|---|\n");
  double *ratios = malloc((size_t)rounds * sizeof *ratios), *render_rates = malloc((size_t)rounds * sizeof(double));
  double *replay_rates = malloc((size_t)rounds * sizeof(double));
  if (ratios == NULL || render_rates == NULL || replay_rates == NULL) return 1;
  uint64_t next = 0;
  for (int round = 0; round < rounds; round++) {
    vf_vcm_stats st = {0};
    if ((err = vf_vcm_iteration(vcm, next++, camera_rgb, light_rgb, &st)) != VF_OK) break;
    memset(&st, 0, sizeof st);
    double t0 = vf_seconds_now();
    for (int i = 0; i < iterations && err == VF_OK; i++) err = vf_vcm_iteration(vcm, next++, camera_rgb, light_rgb, &st);
    double render_rate = (double)st.rays / (vf_seconds_now() - t0);
    clear_logs();
    memset(&st, 0, sizeof st);
    recording = 1;
    if (err == VF_OK) err = vf_vcm_iteration(vcm, next++, camera_rgb, light_rgb, &st);
    recording = 0;
    if (err != VF_OK) break;
    /* The log must hold every ray the iteration counted, no more. */
    size_t rays = 0, calls = 0, intersect = 0, infinite = 0;
    for (int i = 0; i < num_logs; i++) {
      if (logs[i].failed) {
        fprintf(stderr, "bench_replay: out of memory for the log\n");
        return 1;
      }
      rays += logs[i].num_rays;
      calls += logs[i].num_calls;
      for (size_t k = 0; k < logs[i].num_calls; k++)
        if (logs[i].calls[k].kind == CALL_INTERSECT || logs[i].calls[k].kind == CALL_INTERSECT_PACKET)
          intersect += logs[i].calls[k].n;
      for (size_t k = 0; k < logs[i].num_calls; k++)
        if (logs[i].calls[k].kind == CALL_OCCLUDED || logs[i].calls[k].kind == CALL_OCCLUDED_PACKET)
          for (int j = 0; j < logs[i].calls[k].n; j++) infinite += isinf(logs[i].rays[logs[i].calls[k].first + (size_t)j].tfar) != 0;
    }
    if (rays != st.rays) {
      fprintf(stderr, "bench_replay: recorded %zu rays, the iteration counted %llu\n", rays,
              (unsigned long long)st.rays);
      return 1;
    }
    /* Tasks of whole calls, each within one thread's log. */
    size_t (*bounds)[3] = malloc((calls + (size_t)num_logs) * sizeof *bounds), tasks = 0;
    if (bounds == NULL) return 1;
    for (int i = 0; i < num_logs; i++)
      for (size_t k = 0; k < logs[i].num_calls;) {
        size_t end = k, n = 0;
        while (end < logs[i].num_calls && n < REPLAY_TASK) n += logs[i].calls[end++].n;
        bounds[tasks][0] = (size_t)i, bounds[tasks][1] = k, bounds[tasks][2] = end;
        tasks++;
        k = end;
      }
    double replays[3];
    for (int r = 0; r < 3; r++) {
      replay_ctx c = {accel, bounds, {0}};
      double t1 = vf_seconds_now();
      vf_pool_run(pool, tasks, replay_task, &c);
      replays[r] = (double)rays / (vf_seconds_now() - t1);
      unsigned long long mismatches = 0;
      for (int t = 0; t < threads && t < MAX_LOGS; t++) mismatches += c.mismatches[t];
      if (mismatches != 0) {
        fprintf(stderr, "bench_replay: %llu replayed calls found other hits than the render's\n", mismatches);
        return 1;
      }
    }
    free(bounds);
    double replay_rate = median(replays, 3);
    render_rates[round] = render_rate;
    replay_rates[round] = replay_rate;
    ratios[round] = render_rate / replay_rate;
    printf("| %d | %.3f | %.3f | %.1f%% | %zu | %.1f | %.1f | %.1f |\n", round + 1, render_rate * 1e-6,
           replay_rate * 1e-6, 100.0 * ratios[round], rays, 100.0 * (double)intersect / (double)rays,
           100.0 * (double)(rays - intersect) / (double)rays, 100.0 * (double)infinite / (double)rays);
    fflush(stdout);
  }
  if (err != VF_OK) {
    fprintf(stderr, "bench_replay: %s\n", vf_error_detail(err));
    return 1;
  }
  printf("\nmedians: render %.3f Mrays/s, replay %.3f Mrays/s, render of replay %.1f%%\n",
         median(render_rates, rounds) * 1e-6, median(replay_rates, rounds) * 1e-6, 100.0 * median(ratios, rounds));
  for (int i = 0; i < num_logs; i++) free(logs[i].calls), free(logs[i].rays);
  free(ratios), free(render_rates), free(replay_rates), free(camera_rgb), free(light_rgb);
  vf_vcm_destroy(vcm);
  vf_pool_destroy(pool);
  vf_accel_destroy(accel);
  vf_scene_destroy(scene);
  return 0;
}
