/* Three-component vectors for positions, directions and RGB radiance, and an orthonormal
 * frame for shading. Single precision: the renderer's geometry and per-sample radiance are
 * float; accumulation into films is double (see film.h). */
#ifndef VF_VEC3_H
#define VF_VEC3_H

#include <math.h>

typedef struct {
  float x, y, z;
} vf_vec3;

static inline vf_vec3 vf_vec3_make(float x, float y, float z) { return (vf_vec3){x, y, z}; }
static inline vf_vec3 vf_vec3_splat(float v) { return (vf_vec3){v, v, v}; }
static inline vf_vec3 vf_add(vf_vec3 a, vf_vec3 b) { return (vf_vec3){a.x + b.x, a.y + b.y, a.z + b.z}; }
static inline vf_vec3 vf_sub(vf_vec3 a, vf_vec3 b) { return (vf_vec3){a.x - b.x, a.y - b.y, a.z - b.z}; }
static inline vf_vec3 vf_mul(vf_vec3 a, vf_vec3 b) { return (vf_vec3){a.x * b.x, a.y * b.y, a.z * b.z}; }
static inline vf_vec3 vf_scale(vf_vec3 a, float s) { return (vf_vec3){a.x * s, a.y * s, a.z * s}; }
static inline vf_vec3 vf_neg(vf_vec3 a) { return (vf_vec3){-a.x, -a.y, -a.z}; }
static inline float vf_dot(vf_vec3 a, vf_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline vf_vec3 vf_cross(vf_vec3 a, vf_vec3 b) {
  return (vf_vec3){a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
static inline float vf_length_sq(vf_vec3 a) { return vf_dot(a, a); }
static inline float vf_length(vf_vec3 a) { return sqrtf(vf_dot(a, a)); }
static inline vf_vec3 vf_normalize(vf_vec3 a) { return vf_scale(a, 1.0f / vf_length(a)); }
static inline float vf_max_component(vf_vec3 a) { return fmaxf(a.x, fmaxf(a.y, a.z)); }
static inline float vf_min_component(vf_vec3 a) { return fminf(a.x, fminf(a.y, a.z)); }
static inline int vf_is_zero(vf_vec3 a) { return a.x == 0.0f && a.y == 0.0f && a.z == 0.0f; }
static inline int vf_is_finite(vf_vec3 a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }
/* Luminance with Rec. 709 primaries: used for Russian roulette and light selection. */
static inline float vf_luminance(vf_vec3 c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }
static inline float vf_vec3_get(vf_vec3 a, int i) { return i == 0 ? a.x : (i == 1 ? a.y : a.z); }

/* Orthonormal frame with n as the local z axis. */
typedef struct {
  vf_vec3 s, t, n;
} vf_frame;

/* Builds a frame around the unit vector n (Duff et al., "Building an Orthonormal Basis,
 * Revisited", JCGT 2017: continuous except on the plane n.z = 0's sign flip). */
static inline vf_frame vf_frame_from_normal(vf_vec3 n) {
  float sign = copysignf(1.0f, n.z);
  float a = -1.0f / (sign + n.z);
  float b = n.x * n.y * a;
  vf_frame f;
  f.s = (vf_vec3){1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x};
  f.t = (vf_vec3){b, sign + n.y * n.y * a, -n.y};
  f.n = n;
  return f;
}
static inline vf_vec3 vf_frame_to_local(const vf_frame *f, vf_vec3 v) {
  return (vf_vec3){vf_dot(v, f->s), vf_dot(v, f->t), vf_dot(v, f->n)};
}
static inline vf_vec3 vf_frame_to_world(const vf_frame *f, vf_vec3 v) {
  return vf_add(vf_add(vf_scale(f->s, v.x), vf_scale(f->t, v.y)), vf_scale(f->n, v.z));
}

#endif
