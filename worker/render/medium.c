/* Media, one piece of a ray at a time: medium.h. */
#include "medium.h"

#include <math.h>
#include <stddef.h>

void vf_medium_prepare(vf_medium_rt *rt, const vf_medium *m) {
  rt->sigma_s = m->sigma_s;
  rt->sigma_t = vf_add(m->sigma_a, m->sigma_s);
  rt->g = m->g;
  rt->scattering = m->sigma_s.x > 0.0f || m->sigma_s.y > 0.0f || m->sigma_s.z > 0.0f;
  float albedo = 0.0f;
  const float st[3] = {rt->sigma_t.x, rt->sigma_t.y, rt->sigma_t.z};
  const float ss[3] = {rt->sigma_s.x, rt->sigma_s.y, rt->sigma_s.z};
  for (int c = 0; c < 3; c++)
    if (st[c] > 0.0f && ss[c] / st[c] > albedo) albedo = ss[c] / st[c];
  rt->continuation = albedo > 1.0f ? 1.0f : albedo;
  rt->grid = m->grid;
  rt->majorant = 0.0f;
  rt->mean_density = 1.0f;
  if (m->grid != NULL) {
    const vf_density_grid *g = m->grid;
    float max_t = fmaxf(rt->sigma_t.x, fmaxf(rt->sigma_t.y, rt->sigma_t.z));
    rt->majorant = g->max_density * max_t;
    double sum = 0.0;
    size_t n = (size_t)g->nx * g->ny * g->nz;
    for (size_t i = 0; i < n; i++) sum += g->density[i];
    rt->mean_density = n > 0 ? (float)(sum / (double)n) : 0.0f;
  }
}

float vf_grid_density(const vf_density_grid *g, vf_vec3 p) {
  if (!(p.x >= g->box_min.x && p.x <= g->box_max.x && p.y >= g->box_min.y && p.y <= g->box_max.y &&
        p.z >= g->box_min.z && p.z <= g->box_max.z))
    return 0.0f;
  /* Continuous sample coordinates: sample i sits at i + 0.5 cells from the box's minimum. */
  const float q[3] = {(p.x - g->box_min.x) / (g->box_max.x - g->box_min.x) * (float)g->nx - 0.5f,
                      (p.y - g->box_min.y) / (g->box_max.y - g->box_min.y) * (float)g->ny - 0.5f,
                      (p.z - g->box_min.z) / (g->box_max.z - g->box_min.z) * (float)g->nz - 0.5f};
  const uint32_t n[3] = {g->nx, g->ny, g->nz};
  uint32_t i0[3], i1[3];
  float f[3];
  for (int a = 0; a < 3; a++) {
    float x = q[a] < 0.0f ? 0.0f : q[a] > (float)(n[a] - 1) ? (float)(n[a] - 1) : q[a];
    float fl = floorf(x);
    i0[a] = (uint32_t)fl;
    i1[a] = i0[a] + 1 < n[a] ? i0[a] + 1 : i0[a];
    f[a] = x - fl;
  }
#define AT(x, y, z) g->density[((size_t)(z) * g->ny + (y)) * g->nx + (x)]
  float c00 = AT(i0[0], i0[1], i0[2]) * (1.0f - f[0]) + AT(i1[0], i0[1], i0[2]) * f[0];
  float c10 = AT(i0[0], i1[1], i0[2]) * (1.0f - f[0]) + AT(i1[0], i1[1], i0[2]) * f[0];
  float c01 = AT(i0[0], i0[1], i1[2]) * (1.0f - f[0]) + AT(i1[0], i0[1], i1[2]) * f[0];
  float c11 = AT(i0[0], i1[1], i1[2]) * (1.0f - f[0]) + AT(i1[0], i1[1], i1[2]) * f[0];
#undef AT
  float c0 = c00 * (1.0f - f[1]) + c10 * f[1];
  float c1 = c01 * (1.0f - f[1]) + c11 * f[1];
  return c0 * (1.0f - f[2]) + c1 * f[2];
}

int vf_grid_clip(const vf_density_grid *g, vf_vec3 o, vf_vec3 d, float tmax, float *t0, float *t1) {
  float lo = 0.0f, hi = tmax;
  const float oo[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
  const float bmin[3] = {g->box_min.x, g->box_min.y, g->box_min.z};
  const float bmax[3] = {g->box_max.x, g->box_max.y, g->box_max.z};
  for (int a = 0; a < 3; a++) {
    if (dd[a] == 0.0f) {
      if (oo[a] < bmin[a] || oo[a] > bmax[a]) return 0;
      continue;
    }
    float inv = 1.0f / dd[a];
    float ta = (bmin[a] - oo[a]) * inv, tb = (bmax[a] - oo[a]) * inv;
    if (ta > tb) {
      float s = ta;
      ta = tb;
      tb = s;
    }
    lo = ta > lo ? ta : lo;
    hi = tb < hi ? tb : hi;
    if (!(lo <= hi)) return 0;
  }
  *t0 = lo;
  *t1 = hi;
  return 1;
}

/* The number of tentative collisions a tracked piece may take before it is cut short (a
 * piece that long has transmittance below any float's resolution). */
#define TRACKING_STEPS_MAX 100000

int vf_medium_sample_piece(const vf_medium_rt *m, vf_vec3 o, vf_vec3 dir, float d, float u, vf_rng *rng, float *t,
                           vf_vec3 *weight) {
  if (!m->scattering) {
    *weight = m->grid ? vf_medium_transmittance_piece(m, o, dir, d, rng)
                      : vf_medium_transmittance_homogeneous(m->sigma_t, d);
    return VF_PIECE_PASSED;
  }
  if (m->grid == NULL) {
    /* One number picks the channel and, rescaled, the distance. */
    float x = 3.0f * u;
    int c = x < 1.0f ? 0 : x < 2.0f ? 1 : 2;
    float v = x - (float)c;
    float st = c == 0 ? m->sigma_t.x : c == 1 ? m->sigma_t.y : m->sigma_t.z;
    float s = st > 0.0f ? -log1pf(-v) / st : INFINITY;
    if (s < d) {
      vf_vec3 tr = vf_medium_transmittance_homogeneous(m->sigma_t, s);
      float pdf = vf_mean3(vf_mul(m->sigma_t, tr));
      if (!(pdf > 0.0f)) return VF_PIECE_ABSORBED;
      *t = s;
      *weight = vf_scale(tr, 1.0f / pdf);
      return VF_PIECE_SCATTERED;
    }
    vf_vec3 tr = vf_medium_transmittance_homogeneous(m->sigma_t, d);
    float pass = vf_mean3(tr);
    if (!(pass > 0.0f)) return VF_PIECE_ABSORBED;
    *weight = vf_scale(tr, 1.0f / pass);
    return VF_PIECE_PASSED;
  }
  /* Delta tracking against the majorant, with spectral weights (medium.h). */
  vf_vec3 w = vf_vec3_splat(1.0f);
  float t0, t1;
  if (!(m->majorant > 0.0f) || !vf_grid_clip(m->grid, o, dir, d, &t0, &t1)) {
    *weight = w;
    return VF_PIECE_PASSED;
  }
  float s = t0;
  vf_vec3 sa = vf_sub(m->sigma_t, m->sigma_s);
  for (int step = 0; step < TRACKING_STEPS_MAX; step++) {
    s += -log1pf(-u) / m->majorant;
    u = vf_rng_float(rng);
    if (!(s < t1)) {
      *weight = w;
      return VF_PIECE_PASSED;
    }
    float rho = vf_grid_density(m->grid, vf_add(o, vf_scale(dir, s)));
    float mean_s = rho * vf_mean3(m->sigma_s), mean_a = rho * vf_mean3(sa);
    float mean_n = m->majorant - rho * vf_mean3(m->sigma_t);
    float pick = u * m->majorant;
    u = vf_rng_float(rng);
    if (pick < mean_s) {
      *t = s;
      *weight = vf_scale(w, 1.0f / mean_s);
      return VF_PIECE_SCATTERED;
    }
    if (pick < mean_s + mean_a || !(mean_n > 0.0f)) return VF_PIECE_ABSORBED;
    w = vf_mul(w, vf_scale(vf_sub(vf_vec3_splat(m->majorant), vf_scale(m->sigma_t, rho)), 1.0f / mean_n));
  }
  return VF_PIECE_ABSORBED;
}

vf_vec3 vf_medium_transmittance_piece(const vf_medium_rt *m, vf_vec3 o, vf_vec3 dir, float d, vf_rng *rng) {
  if (m->grid == NULL) return vf_medium_transmittance_homogeneous(m->sigma_t, d);
  vf_vec3 tr = vf_vec3_splat(1.0f);
  float t0, t1;
  if (!(m->majorant > 0.0f) || !vf_grid_clip(m->grid, o, dir, d, &t0, &t1)) return tr;
  /* Ratio tracking. */
  float s = t0;
  for (int step = 0; step < TRACKING_STEPS_MAX; step++) {
    s += -log1pf(-vf_rng_float(rng)) / m->majorant;
    if (!(s < t1)) return tr;
    float rho = vf_grid_density(m->grid, vf_add(o, vf_scale(dir, s)));
    tr = vf_mul(tr, vf_scale(vf_sub(vf_vec3_splat(m->majorant), vf_scale(m->sigma_t, rho)), 1.0f / m->majorant));
    if (vf_is_zero(tr)) return tr;
  }
  return vf_vec3_splat(0.0f);
}
