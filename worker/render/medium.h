/* Light in participating media, one medium at a time: the Henyey-Greenstein phase function,
 * free-flight distance sampling and transmittance along a piece of a ray that lies in one
 * medium, and the distance densities the MIS quantities need (worker/scene/medium.h has the
 * model). worker/render/segment.h walks a whole segment between two vertices, piece by
 * piece through index-matched boundaries.
 *
 * Conventions:
 * - A medium vertex scatters with "BSDF" sigma_s(x) p(fix, gen): sigma_s is part of the
 *   vertex, as the BSDF's albedo is part of a surface vertex, so that connections and
 *   merges at a medium vertex evaluate one function. Its cosine is 1.
 * - Distances of a homogeneous scattering medium are sampled by one channel chosen
 *   uniformly, the density being the mean of the three channels' (spectral MIS, one sample):
 *     p(scatter at t) = mean_c sigma_t,c exp(-sigma_t,c t),  P(pass d) = mean_c exp(-sigma_t,c d).
 *   The path's throughput takes T(t) / p (a vector): exact, whichever channel was drawn.
 * - A medium that only absorbs (sigma_s = 0 in every channel) is never sampled: its
 *   transmittance multiplies the throughput, and the densities of passing it are 1 for
 *   every technique.
 * - A heterogeneous medium (a density grid rho scaling sigma_a and sigma_s) is tracked
 *   against the majorant rho_max max_c sigma_t,c: tentative collisions at that rate, each
 *   a scattering with probability mean_c sigma_s,c(x) / majorant, an absorption with
 *   mean_c sigma_a,c(x) / majorant (the path ends) or else a null collision whose weight
 *   per channel is (majorant - sigma_t,c(x)) / (majorant - mean_c sigma_t,c(x)) (delta
 *   tracking with spectral weights); transmittance by ratio tracking. Both are unbiased
 *   estimates of what the homogeneous formulas give exactly. Their densities have no
 *   closed form, so the MIS weights take a surrogate instead, the homogeneous densities of
 *   the medium at the grid's mean density (scaled at a medium vertex by the vertex's
 *   density): the weights are then any deterministic functions of the path that every
 *   technique computes alike, so they still sum to one (Veach's thesis, sec. 9.2) and the
 *   estimate stays unbiased; only their efficiency is approximate.
 * Pure functions over a prepared medium (vf_medium_rt), numbers passed in: the test
 * suite drives them directly (tests/worker/render/test_medium.c). */
#ifndef VF_RENDER_MEDIUM_H
#define VF_RENDER_MEDIUM_H

#include "../../common/rng.h"
#include "../../common/vec3.h"
#include "../scene/medium.h"
#include "sampling.h"

#include <math.h>
#include <stdint.h>

/* What the renderer keeps of a medium. */
typedef struct {
  vf_vec3 sigma_t, sigma_s; /* per unit length; heterogeneous: per unit density */
  float g;
  float continuation;       /* Russian-roulette survival at its vertices: its largest albedo */
  int scattering;           /* sigma_s > 0 in some channel: distances are sampled, vertices made */
  const vf_density_grid *grid; /* NULL: homogeneous */
  float majorant;           /* grid: rho_max max_c sigma_t,c */
  float mean_density;       /* grid: the mean of its samples (the MIS surrogate's) */
} vf_medium_rt;

/* Prepares medium m for rendering. */
void vf_medium_prepare(vf_medium_rt *rt, const vf_medium *m);

/* The grid's density at world point p: trilinear between sample centres, clamped to the
 * outer samples inside the box, zero outside it. */
float vf_grid_density(const vf_density_grid *g, vf_vec3 p);

/* The parametric range [*t0, *t1] of the ray o + t d (t in [0, tmax]) inside the grid's
 * box; 0 when it misses. */
int vf_grid_clip(const vf_density_grid *g, vf_vec3 o, vf_vec3 d, float tmax, float *t0, float *t1);

/* What a path sampling distances does on a piece of ray in one medium. */
enum { VF_PIECE_PASSED, VF_PIECE_SCATTERED, VF_PIECE_ABSORBED };

/* Where a path travelling the piece o + t dir, t in [0, d) (d may be infinite), in medium
 * m scatters: VF_PIECE_SCATTERED with *t, or VF_PIECE_PASSED when it crosses the piece
 * whole, or VF_PIECE_ABSORBED when it ends there (a heterogeneous medium's absorption, or
 * a piece it cannot cross). *weight multiplies the throughput: transmittance over the
 * probability density (or probability) of what happened, up to the scattering vertex's
 * sigma_s which its "BSDF" holds. u is the piece's number (a homogeneous medium needs no
 * other); tracking draws the rest from rng. */
int vf_medium_sample_piece(const vf_medium_rt *m, vf_vec3 o, vf_vec3 dir, float d, float u, vf_rng *rng, float *t,
                           vf_vec3 *weight);

/* The transmittance of the piece o + t dir, t in [0, d): exact for a homogeneous medium,
 * ratio tracking's unbiased estimate (numbers from rng) for a grid. */
vf_vec3 vf_medium_transmittance_piece(const vf_medium_rt *m, vf_vec3 o, vf_vec3 dir, float d, vf_rng *rng);

/* The density scale at p: the grid's density, 1 for a homogeneous medium. */
static inline float vf_medium_density_at(const vf_medium_rt *m, vf_vec3 p) {
  return m->grid ? vf_grid_density(m->grid, p) : 1.0f;
}

/* Henyey-Greenstein: the density of scattering by angle theta (cos_theta between the
 * direction of travel before and after), over the sphere of directions. */
static inline float vf_hg(float cos_theta, float g) {
  float denom = 1.0f + g * g - 2.0f * g * cos_theta;
  denom = denom > 1e-12f ? denom : 1e-12f;
  return (1.0f - g * g) / (4.0f * VF_PI * denom * sqrtf(denom));
}

/* A direction of travel after scattering a path that travelled along `in` (unit), drawn
 * from HG with u1, u2; exact inverse of its cdf in cos_theta. Returns the cosine too. */
static inline vf_vec3 vf_hg_sample(vf_vec3 in, float g, float u1, float u2, float *cos_theta) {
  float c;
  if (fabsf(g) < 1e-3f) {
    c = 1.0f - 2.0f * u1;
  } else {
    float sq = (1.0f - g * g) / (1.0f + g - 2.0f * g * u1);
    c = (1.0f + g * g - sq * sq) / (2.0f * g);
  }
  c = c < -1.0f ? -1.0f : c > 1.0f ? 1.0f : c;
  float s = sqrtf(vf_fmaxf_zero(1.0f - c * c));
  float phi = 2.0f * VF_PI * u2;
  vf_frame f = vf_frame_from_normal(in);
  *cos_theta = c;
  return vf_normalize(vf_frame_to_world(&f, vf_vec3_make(s * cosf(phi), s * sinf(phi), c)));
}

static inline float vf_mean3(vf_vec3 v) { return (v.x + v.y + v.z) * (1.0f / 3.0f); }
static inline vf_vec3 vf_exp3(vf_vec3 v) { return vf_vec3_make(expf(v.x), expf(v.y), expf(v.z)); }

/* Transmittance of a homogeneous medium (or a grid's surrogate) over distance d. */
static inline vf_vec3 vf_medium_transmittance_homogeneous(vf_vec3 sigma_t, float d) {
  if (isinf(d)) return vf_vec3_make(sigma_t.x > 0.0f ? 0.0f : 1.0f, sigma_t.y > 0.0f ? 0.0f : 1.0f,
                                    sigma_t.z > 0.0f ? 0.0f : 1.0f);
  return vf_exp3(vf_scale(sigma_t, -d));
}

/* The sigma_t the MIS surrogate uses for m: its own, or a grid's at its mean density. */
static inline vf_vec3 vf_medium_surrogate_sigma(const vf_medium_rt *m) {
  return m->grid ? vf_scale(m->sigma_t, m->mean_density) : m->sigma_t;
}

/* The densities of a piece of length d in medium m (see the top): *pass, the probability
 * that a path sampling distances crosses it whole; *scatter, the density of its scattering
 * at its far end (at a vertex of density `rho` there: 1 for homogeneous media). A medium
 * that does not scatter has pass = 1, scatter = 0. */
static inline void vf_medium_piece_pdf(const vf_medium_rt *m, float d, float rho, float *pass, float *scatter) {
  if (!m->scattering) {
    *pass = 1.0f;
    *scatter = 0.0f;
    return;
  }
  vf_vec3 st = vf_medium_surrogate_sigma(m);
  vf_vec3 tr = vf_medium_transmittance_homogeneous(st, d);
  *pass = vf_mean3(tr);
  vf_vec3 at = m->grid ? vf_scale(m->sigma_t, rho) : st;
  *scatter = vf_mean3(vf_mul(at, tr));
}

#endif
