/* Ray queries against the scene through Embree 3, and the ray-origin offset that keeps
 * secondary rays from re-hitting the surface they leave.
 *
 * Geometry IDs equal shape indices in the vf_scene. Triangle meshes are Embree triangle
 * geometry; spheres are Embree's own sphere-point geometry (a scene's few spheres in an
 * Embree scene of their own, which only the rays that may reach one see: accel.c). A mesh whose material has an
 * alpha cut-out gets Embree filter functions that pass through its holes
 * (vf_surface_covered), for closest hits and occlusion alike, single rays and packets. */
#ifndef VF_ACCEL_H
#define VF_ACCEL_H

#include "../../common/vec3.h"
#include "../scene/scene.h"

#include <math.h>
#include <stdint.h>
#include <string.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

typedef struct vf_accel vf_accel;

typedef struct {
  float t;
  uint32_t shape;     /* index into vf_scene.shapes */
  uint32_t primitive; /* triangle index within the shape (0 for spheres) */
  vf_vec3 position;   /* recomputed from the primitive, not org + t dir, for precision */
  vf_vec3 normal;     /* unit geometric normal (triangle winding / sphere outward) */
  float u, v;         /* triangles: barycentrics, the weights of vertices 1 and 2 */
} vf_hit;

/* Builds the Embree device and scene. VF_EEMBREE with a detail on failure. */
int vf_accel_create(const vf_scene *scene, vf_accel **out);
void vf_accel_destroy(vf_accel *accel);

/* Closest hit along org + t dir for t in (0, tfar). Returns 1 and fills *hit on a hit. */
int vf_accel_intersect(const vf_accel *accel, vf_vec3 org, vf_vec3 dir, float tfar, vf_hit *hit);

/* 1 if anything blocks org + t dir for t in (0, tfar). dir need not be unit. */
int vf_accel_occluded(const vf_accel *accel, vf_vec3 org, vf_vec3 dir, float tfar);

/* Occlusion of up to VF_ACCEL_PACKET segments at once, as Embree ray packets: bit i of
 * the result is set when anything blocks org[i] + t dir[i] for t in (0, tfar[i]). The
 * answers are vf_accel_occluded's for each segment (tests/worker/render/test_accel.c); Embree traces a
 * packet of 8 rays (two for more than 8) faster per ray than single rays, even unrelated
 * ones. */
#define VF_ACCEL_PACKET 16
uint32_t vf_accel_occluded_packet(const vf_accel *accel, const vf_vec3 *org, const vf_vec3 *dir, const float *tfar,
                                  int n);

/* Closest hits of up to VF_ACCEL_PACKET rays to infinity at once, as Embree packets: bit i
 * of the result is set when ray i hit something, and hits[i] is then filled as
 * vf_accel_intersect would, bit for bit (sphere distances are solved again in double, as
 * Embree's packet and single-ray kernels differ in their last bits). */
uint32_t vf_accel_intersect_packet(const vf_accel *accel, const vf_vec3 *org, const vf_vec3 *dir, int n,
                                   vf_hit *hits);

/* The instruction set of the Embree kernels that trace here: "AVX2" on every x86 machine
 * that has it (vf_accel_create caps Embree there, so that machines with AVX-512 find the
 * same hits), else a description saying that hits differ from those of AVX2 machines. */
const char *vf_accel_kernels(void);

/* One coordinate of vf_offset_ray_origin: p moved by 256 n units in its last place, or by
 * float_scale n when |p| < origin. */
static inline float vf_offset_coordinate(float p, float n, float origin, float float_scale) {
  int32_t delta = (int32_t)(256.0f * n), bits;
  memcpy(&bits, &p, sizeof bits);
  bits += p < 0.0f ? -delta : delta;
  float moved;
  memcpy(&moved, &bits, sizeof moved);
  return fabsf(p) < origin ? p + float_scale * n : moved;
}

/* Moves p off its surface towards the side n points to, by a few units in the last place of
 * p's coordinates (Waechter and Binder, "A Fast and Robust Method for Avoiding
 * Self-Intersection", Ray Tracing Gems, 2019). Near the origin, where the ulps of p are too
 * fine, it moves by a small fraction of `scale` (the scene's size) instead; the paper's
 * constants assume scale 1. Both regimes scale with the scene, unlike a fixed epsilon.
 * Inline: every ray origin and shadow-ray end of the renderer passes here, and as a call
 * into another file its vectors went through the stack. */
static inline vf_vec3 vf_offset_ray_origin(vf_vec3 p, vf_vec3 n, float scale) {
  /* Constants of the paper, for a scene of size 1: below |p| = origin the float spacing is
   * too fine for an ulp offset, so a small offset along n is used there instead. */
  const float origin = scale * (1.0f / 32.0f), float_scale = scale * (1.0f / 65536.0f);
#ifdef __SSE2__
  /* The same three coordinates at once, operation for operation (so bit for bit): every
   * ray origin and shadow-ray end passes here. */
  __m128 vp = _mm_setr_ps(p.x, p.y, p.z, 0.0f), vn = _mm_setr_ps(n.x, n.y, n.z, 0.0f);
  __m128i delta = _mm_cvttps_epi32(_mm_mul_ps(_mm_set1_ps(256.0f), vn));
  __m128i negative = _mm_castps_si128(_mm_cmplt_ps(vp, _mm_setzero_ps()));
  delta = _mm_sub_epi32(_mm_xor_si128(delta, negative), negative); /* -delta where p < 0 */
  __m128 moved = _mm_castsi128_ps(_mm_add_epi32(_mm_castps_si128(vp), delta));
  __m128 abs_p = _mm_andnot_ps(_mm_set1_ps(-0.0f), vp);
  __m128 near = _mm_cmplt_ps(abs_p, _mm_set1_ps(origin));
  __m128 along = _mm_add_ps(vp, _mm_mul_ps(_mm_set1_ps(float_scale), vn));
  __m128 r = _mm_or_ps(_mm_and_ps(near, along), _mm_andnot_ps(near, moved));
  float out[4];
  _mm_storeu_ps(out, r);
  return vf_vec3_make(out[0], out[1], out[2]);
#else
  return vf_vec3_make(vf_offset_coordinate(p.x, n.x, origin, float_scale),
                      vf_offset_coordinate(p.y, n.y, origin, float_scale),
                      vf_offset_coordinate(p.z, n.z, origin, float_scale));
#endif
}

/* The scene size that ray offsets are relative to: its bounding-sphere radius. */
float vf_accel_scale(const vf_accel *accel);

#endif
