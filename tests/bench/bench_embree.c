/* The raw Embree rate on a scene, to set the renderer's rays/s against.
 *
 * Rays like the renderer's: camera rays through random pixels, cosine-distributed bounce
 * rays from the points they hit, and shadow rays between random pairs of those points.
 * Each kind is traced with vf_accel_intersect / vf_accel_occluded (one rtcIntersect1 or
 * rtcOccluded1 each) on T threads; prints rays/s per kind and for the renderer's mix:
 * the raw rate that issue 2's target is set against. For context it then traces the same
 * rays as the renderer does, in packets of VF_ACCEL_PACKET consecutive (unrelated) rays
 * (vf_accel_intersect_packet / vf_accel_occluded_packet).
 *
 *   bench_embree [SCENE] [THREADS] [RAYS_PER_KIND]      defaults: cornell 2 4000000 */
#include "common/clock.h"
#include "common/error.h"
#include "common/pool.h"
#include "common/rng.h"
#include "worker/render/accel.h"
#include "worker/render/camera.h"
#include "worker/render/sampling.h"
#include "worker/scene/scene.h"
#include "worker/scene/load.h"

#include <stdio.h>
#include <stdlib.h>

typedef struct {
  vf_vec3 org, dir;
  float tfar;
} ray;

typedef struct {
  const vf_accel *accel;
  const ray *rays;
  size_t n;
  int occlusion, packets;
  unsigned long long hits[64];
} run_ctx;

#define BATCH 65536

static void run_task(void *p, size_t task, int thread) {
  run_ctx *c = p;
  size_t begin = task * BATCH, end = begin + BATCH < c->n ? begin + BATCH : c->n;
  unsigned long long hits = 0;
  if (c->packets) {
    for (size_t i = begin; i < end; i += VF_ACCEL_PACKET) {
      int n = end - i < VF_ACCEL_PACKET ? (int)(end - i) : VF_ACCEL_PACKET;
      vf_vec3 org[VF_ACCEL_PACKET], dir[VF_ACCEL_PACKET];
      float tfar[VF_ACCEL_PACKET];
      vf_hit h[VF_ACCEL_PACKET];
      for (int k = 0; k < n; k++) {
        org[k] = c->rays[i + k].org;
        dir[k] = c->rays[i + k].dir;
        tfar[k] = c->rays[i + k].tfar;
      }
      uint32_t mask = c->occlusion ? vf_accel_occluded_packet(c->accel, org, dir, tfar, n)
                                   : vf_accel_intersect_packet(c->accel, org, dir, n, h);
      hits += (unsigned long long)__builtin_popcount(mask);
    }
    c->hits[thread] += hits;
    return;
  }
  for (size_t i = begin; i < end; i++) {
    const ray *r = &c->rays[i];
    if (c->occlusion) {
      hits += (unsigned long long)vf_accel_occluded(c->accel, r->org, r->dir, r->tfar);
    } else {
      vf_hit h;
      hits += (unsigned long long)vf_accel_intersect(c->accel, r->org, r->dir, r->tfar, &h);
    }
  }
  c->hits[thread] += hits;
}

static double rate(vf_pool *pool, const vf_accel *accel, const ray *rays, size_t n, int occlusion, int packets) {
  run_ctx c = {accel, rays, n, occlusion, packets, {0}};
  double t0 = vf_seconds_now();
  vf_pool_run(pool, (n + BATCH - 1) / BATCH, run_task, &c);
  return (double)n / (vf_seconds_now() - t0);
}

/* The rate of the renderer's mix of rays, about 15% camera, 30% bounce and 55% shadow
 * rays (vcm, cornell), from the rates of each kind. */
static double mix_rate(double camera, double bounce, double shadow) {
  return 1.0 / (0.15 / camera + 0.30 / bounce + 0.55 / shadow);
}

static int compare(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

int main(int argc, char **argv) {
  const char *name = argc > 1 ? argv[1] : "cornell";
  int threads = argc > 2 ? atoi(argv[2]) : 2;
  size_t n = argc > 3 ? (size_t)atoll(argv[3]) : 4000000;
  vf_scene *scene;
  vf_accel *accel;
  vf_pool *pool;
  int err;
  if ((err = vf_scene_load(name, &scene)) != VF_OK || (err = vf_accel_create(scene, &accel)) != VF_OK ||
      (err = vf_pool_create(threads, &pool)) != VF_OK) {
    fprintf(stderr, "bench_embree: %s\n", vf_error_detail(err));
    return 1;
  }
  vf_camera cam;
  vf_camera_init(&cam, &scene->camera, scene->settings.width, scene->settings.height);
  ray *primary = malloc(n * sizeof *primary), *bounce = malloc(n * sizeof *bounce), *shadow = malloc(n * sizeof *shadow);
  vf_vec3 *points = malloc(n * sizeof *points), *normals = malloc(n * sizeof *normals);
  vf_rng rng = vf_rng_for_path(1, 0, 0, VF_STREAM_TEST);
  size_t m = 0;
  for (size_t i = 0; i < n; i++) {
    float x = vf_rng_float(&rng) * (float)cam.width, y = vf_rng_float(&rng) * (float)cam.height;
    primary[i] = (ray){cam.position, vf_camera_direction(&cam, x, y), INFINITY};
    vf_hit h;
    if (vf_accel_intersect(accel, primary[i].org, primary[i].dir, INFINITY, &h)) {
      vf_vec3 nn = vf_dot(h.normal, primary[i].dir) < 0.0f ? h.normal : vf_neg(h.normal);
      points[m] = vf_offset_ray_origin(h.position, nn, vf_accel_scale(accel));
      normals[m++] = nn;
    }
  }
  for (size_t i = 0; i < n; i++) {
    size_t a = (size_t)(vf_rng_float(&rng) * (float)m) % m, b = (size_t)(vf_rng_float(&rng) * (float)m) % m;
    vf_frame f = vf_frame_from_normal(normals[a]);
    vf_vec3 d = vf_frame_to_world(&f, vf_sample_cosine_hemisphere(vf_rng_float(&rng), vf_rng_float(&rng), NULL));
    bounce[i] = (ray){points[a], d, INFINITY};
    shadow[i] = (ray){points[a], vf_sub(points[b], points[a]), 1.0f};
  }
  enum { RUNS = 5 };
  double r[6][RUNS];
  for (int k = 0; k < RUNS; k++)
    for (int packets = 0; packets < 2; packets++) {
      r[3 * packets + 0][k] = rate(pool, accel, primary, n, 0, packets);
      r[3 * packets + 1][k] = rate(pool, accel, bounce, n, 0, packets);
      r[3 * packets + 2][k] = rate(pool, accel, shadow, n, 1, packets);
    }
  for (int j = 0; j < 6; j++) qsort(r[j], RUNS, sizeof(double), compare);
  printf("scene %s, %d thread(s), %zu rays per kind, median of %d runs:\n", name, threads, n, RUNS);
  printf("  camera rays   rtcIntersect1  %7.2f Mrays/s\n", r[0][RUNS / 2] * 1e-6);
  printf("  bounce rays   rtcIntersect1  %7.2f Mrays/s\n", r[1][RUNS / 2] * 1e-6);
  printf("  shadow rays   rtcOccluded1   %7.2f Mrays/s\n", r[2][RUNS / 2] * 1e-6);
  double mix = mix_rate(r[0][RUNS / 2], r[1][RUNS / 2], r[2][RUNS / 2]);
  printf("  mix 15%% camera, 30%% bounce, 55%% shadow: %.2f Mrays/s\n", mix * 1e-6);
  printf("the same rays in packets of %d, as the renderer traces them (Embree's %s kernels, 8 wide):\n",
         VF_ACCEL_PACKET, vf_accel_kernels());
  printf("  camera rays   packets        %7.2f Mrays/s\n", r[3][RUNS / 2] * 1e-6);
  printf("  bounce rays   packets        %7.2f Mrays/s\n", r[4][RUNS / 2] * 1e-6);
  printf("  shadow rays   packets        %7.2f Mrays/s\n", r[5][RUNS / 2] * 1e-6);
  double packet_mix = mix_rate(r[3][RUNS / 2], r[4][RUNS / 2], r[5][RUNS / 2]);
  printf("  packet mix: %.2f Mrays/s\n", packet_mix * 1e-6);
  free(primary);
  free(bounce);
  free(shadow);
  free(points);
  free(normals);
  vf_pool_destroy(pool);
  vf_accel_destroy(accel);
  vf_scene_destroy(scene);
  return 0;
}
