/* Ray queries and the ray-origin offset: without an offset, rays leaving a surface hit it
 * again (acne), worst far from the origin where float spacing is coarse; with the offset,
 * never, at any scale; and no ray leaving the inside of a closed box escapes it. Packets
 * of rays answer as single rays do. */
#include "check.h"
#include "common/error.h"
#include "common/rng.h"
#include "worker/render/accel.h"
#include "worker/render/sampling.h"
#include "worker/scene/scene.h"
#include "worker/scene/json.h"
#include "worker/scene/load.h"
#include "worker/scene/builtin.h"

#include <stdio.h>
#include <string.h>

/* A closed cube of 12 inward-facing triangles, edge 2 * size, centred at c. */
static vf_scene *cube(double c, double size) {
  char text[2048];
  double a = c - size, b = c + size;
  snprintf(text, sizeof text,
           "{\"camera\": {\"position\": [%.17g, %.17g, %.17g], \"forward\": [0, 0, -1], \"fov\": 60},"
           " \"materials\": {\"m\": {\"diffuse\": [0.5, 0.5, 0.5]}},"
           " \"shapes\": [{\"type\": \"mesh\", \"material\": \"m\", \"emission\": [1, 1, 1],"
           "  \"positions\": [%.17g,%.17g,%.17g, %.17g,%.17g,%.17g, %.17g,%.17g,%.17g, %.17g,%.17g,%.17g,"
           "                 %.17g,%.17g,%.17g, %.17g,%.17g,%.17g, %.17g,%.17g,%.17g, %.17g,%.17g,%.17g],"
           "  \"indices\": [0,1,2, 0,2,3, 4,6,5, 4,7,6, 0,4,5, 0,5,1, 3,2,6, 3,6,7, 0,3,7, 0,7,4, 1,5,6, 1,6,2]}]}",
           c, c, c, a, a, a, b, a, a, b, b, a, a, b, a, a, a, b, b, a, b, b, b, b, a, b, b);
  vf_scene *s = NULL;
  CHECK_INT_EQ(vf_scene_parse(text, strlen(text), "cube", ".", NULL, 0, &s), VF_OK);
  return s;
}

typedef struct {
  int self_hits, escapes, rays;
} counts;

/* From random points on the cube's walls, rays into the cube: a hit on the starting
 * triangle is acne; no hit at all is a leak. */
static counts shoot(const vf_scene *s, const vf_accel *a, int use_offset, int rays) {
  counts result = {0, 0, rays};
  vf_rng rng = vf_rng_for_path(9, 0, 0, VF_STREAM_TEST);
  const vf_shape *sh = &s->shapes[0];
  for (int i = 0; i < rays; i++) {
    uint32_t t = vf_rng_next(&rng) % sh->num_triangles;
    const uint32_t *idx = &sh->indices[3 * t];
    vf_vec3 p[3];
    for (int k = 0; k < 3; k++)
      p[k] = vf_vec3_make(sh->positions[3 * idx[k]], sh->positions[3 * idx[k] + 1], sh->positions[3 * idx[k] + 2]);
    float u, v;
    vf_sample_triangle(vf_rng_float(&rng), vf_rng_float(&rng), &u, &v);
    vf_vec3 x = vf_add(vf_add(vf_scale(p[0], 1.0f - u - v), vf_scale(p[1], u)), vf_scale(p[2], v));
    vf_vec3 n = vf_normalize(vf_cross(vf_sub(p[1], p[0]), vf_sub(p[2], p[0]))); /* inward */
    vf_frame f = vf_frame_from_normal(n);
    vf_vec3 d = vf_frame_to_world(&f, vf_sample_cosine_hemisphere(vf_rng_float(&rng), vf_rng_float(&rng), NULL));
    vf_vec3 o = use_offset ? vf_offset_ray_origin(x, n, vf_accel_scale(a)) : x;
    vf_hit h;
    if (!vf_accel_intersect(a, o, d, INFINITY, &h)) result.escapes++;
    else if (h.primitive == t) result.self_hits++;
  }
  return result;
}

static void test_offset_prevents_acne_and_leaks_at_every_scale(void) {
  /* Centres in units of the cube's size: at the origin, and 100 and 3000 sizes away, where
   * float spacing is 2^-17 and 2^-12 of the size. */
  const double centres[] = {0.0, 1e2, -3e3};
  const double sizes[] = {1e-4, 1.0, 1e3};
  for (int c = 0; c < 3; c++)
    for (int z = 0; z < 3; z++) {
      vf_scene *s = cube(centres[c] * sizes[z], sizes[z]);
      vf_accel *a = NULL;
      if (s == NULL) return;
      CHECK_INT_EQ(vf_accel_create(s, &a), VF_OK);
      if (a == NULL) return;
      counts with = shoot(s, a, 1, 20000), without = shoot(s, a, 0, 20000);
      printf("  cube at %-7g size %-6g: offset %d self-hits %d escapes; none %5d self-hits %d escapes\n", centres[c] * sizes[z],
             sizes[z], with.self_hits, with.escapes, without.self_hits, without.escapes);
      CHECK_INT_EQ(with.self_hits, 0);
      CHECK_INT_EQ(with.escapes, 0);
      vf_accel_destroy(a);
      vf_scene_destroy(s);
    }
}

/* The problem the offset solves is real: far from the origin, where a float's spacing is
 * large against the cube, rays started on the surface itself hit it again. */
static void test_without_offset_rays_hit_their_own_surface(void) {
  vf_scene *s = cube(1e4, 1.0);
  vf_accel *a = NULL;
  if (s == NULL) return;
  CHECK_INT_EQ(vf_accel_create(s, &a), VF_OK);
  counts without = shoot(s, a, 0, 20000);
  printf("  without an offset: %d of %d rays hit their own triangle\n", without.self_hits, without.rays);
  CHECK(without.self_hits > without.rays / 100);
  vf_accel_destroy(a);
  vf_scene_destroy(s);
}

/* The packet tests' scene: `cornell` (triangles and spheres). 0 when it cannot be loaded
 * (the failed check is recorded). */
typedef struct {
  vf_scene *scene;
  vf_accel *accel;
  vf_vec3 center;
  float radius;
} packet_scene;

static int open_packet_scene(packet_scene *ps) {
  ps->scene = NULL;
  ps->accel = NULL;
  CHECK_INT_EQ(vf_scene_load("cornell", &ps->scene), VF_OK);
  if (ps->scene == NULL) return 0;
  CHECK_INT_EQ(vf_accel_create(ps->scene, &ps->accel), VF_OK);
  if (ps->accel == NULL) {
    vf_scene_destroy(ps->scene);
    return 0;
  }
  printf("  packets of up to %d rays, Embree's %s kernels\n", VF_ACCEL_PACKET, vf_accel_kernels());
  vf_scene_bounding_sphere(ps->scene, &ps->center, &ps->radius);
  return 1;
}

static void close_packet_scene(packet_scene *ps) {
  vf_accel_destroy(ps->accel);
  vf_scene_destroy(ps->scene);
}

/* A random point of the cube of half-size `scale` times the bounding radius around the
 * scene's centre. */
static vf_vec3 random_point(const packet_scene *ps, float scale, vf_rng *rng) {
  vf_vec3 u = vf_vec3_make(2.0f * vf_rng_float(rng) - 1.0f, 2.0f * vf_rng_float(rng) - 1.0f,
                           2.0f * vf_rng_float(rng) - 1.0f);
  return vf_add(ps->center, vf_scale(u, scale * ps->radius));
}

/* Packets of shadow rays answer as the rays one by one: on `cornell`, segments between
 * random points of the box and rays to infinity, in packets of every fill from one ray to
 * VF_ACCEL_PACKET. */
static void test_packets_answer_as_single_rays(void) {
  packet_scene ps;
  if (!open_packet_scene(&ps)) return;
  vf_accel *a = ps.accel;
  vf_rng rng = vf_rng_for_path(11, 0, 0, VF_STREAM_TEST);
  int rays = 0, blocked = 0, mismatches = 0;
  for (int round = 0; round < 4000; round++) {
    int n = 1 + round % VF_ACCEL_PACKET;
    vf_vec3 org[VF_ACCEL_PACKET], dir[VF_ACCEL_PACKET];
    float tfar[VF_ACCEL_PACKET];
    for (int i = 0; i < n; i++) {
      org[i] = random_point(&ps, 0.7f, &rng);
      dir[i] = vf_sub(random_point(&ps, 0.7f, &rng), org[i]);
      tfar[i] = (round + i) % 3 == 0 ? INFINITY : 1.0f;
    }
    uint32_t mask = vf_accel_occluded_packet(a, org, dir, tfar, n);
    for (int i = 0; i < n; i++) {
      int single = vf_accel_occluded(a, org[i], dir[i], tfar[i]);
      mismatches += single != (int)(mask >> i & 1u);
      blocked += single;
      rays++;
    }
    CHECK_INT_EQ((int)(mask >> n), 0); /* lanes past n answer nothing */
  }
  printf("  %d rays in packets, %d blocked, %d answered differently one by one\n", rays, blocked, mismatches);
  CHECK_INT_EQ(mismatches, 0);
  CHECK(blocked > rays / 10 && blocked < rays - rays / 10); /* both answers are exercised */
  close_packet_scene(&ps);
}

/* Packets of closest-hit rays find the hits of single rays, bit for bit (sphere distances
 * are solved again in double either way, since Embree's kernels differ in the last bits):
 * on `cornell`, rays in random directions from random points of the box. */
static void test_intersect_packets_find_single_ray_hits(void) {
  packet_scene ps;
  if (!open_packet_scene(&ps)) return;
  vf_accel *a = ps.accel;
  vf_rng rng = vf_rng_for_path(12, 0, 0, VF_STREAM_TEST);
  int rays = 0, found = 0, spheres = 0, mismatches = 0;
  for (int round = 0; round < 4000; round++) {
    int n = 1 + round % VF_ACCEL_PACKET;
    vf_vec3 org[VF_ACCEL_PACKET], dir[VF_ACCEL_PACKET];
    vf_hit hits[VF_ACCEL_PACKET];
    for (int i = 0; i < n; i++) {
      org[i] = random_point(&ps, 0.5f, &rng);
      dir[i] = vf_sample_uniform_sphere(vf_rng_float(&rng), vf_rng_float(&rng));
    }
    uint32_t mask = vf_accel_intersect_packet(a, org, dir, n, hits);
    CHECK_INT_EQ((int)(mask >> n), 0);
    for (int i = 0; i < n; i++) {
      vf_hit h;
      int single = vf_accel_intersect(a, org[i], dir[i], INFINITY, &h);
      int packet = (int)(mask >> i & 1u);
      rays++;
      if (single != packet) {
        mismatches++;
        continue;
      }
      if (!single) continue;
      found++;
      spheres += ps.scene->shapes[h.shape].kind == VF_SHAPE_SPHERE;
      mismatches += h.t != hits[i].t || h.shape != hits[i].shape || h.primitive != hits[i].primitive ||
                     memcmp(&h.position, &hits[i].position, sizeof h.position) != 0 ||
                     memcmp(&h.normal, &hits[i].normal, sizeof h.normal) != 0;
    }
  }
  printf("  %d rays in packets, %d hits (%d on spheres), %d differ from single rays\n", rays, found, spheres,
         mismatches);
  CHECK_INT_EQ(mismatches, 0);
  CHECK(spheres > found / 50); /* the spheres, where Embree's kernels differ, are exercised */
  close_packet_scene(&ps);
}

int main(void) {
  RUN(test_packets_answer_as_single_rays);
  RUN(test_intersect_packets_find_single_ray_hits);
  RUN(test_offset_prevents_acne_and_leaks_at_every_scale);
  RUN(test_without_offset_rays_hit_their_own_surface);
  return check_finish();
}
