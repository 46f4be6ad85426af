/* The MIS identity: for a full path x_0 .. x_k (x_0 on the light, x_k on the camera's lens),
 * the recursive weights of worker/render/mis.h, driven exactly as the renderer's passes drive them
 * (worker/render/light_pass.c, camera_pass.c), must
 * (1) sum to 1 over every technique the renderer uses to sample that path, and
 * (2) each equal a direct evaluation of the balance heuristic, tech. rep. eq. (12), from
 *     the path's vertex densities computed one by one in double precision (eq. 2-8, 10),
 *     and of the power heuristic with beta 2 and 3 (paper eq. 10).
 *
 * Paths come from random walks in the built-in "cornell" (an area light and a pinhole),
 * "cornell-dof" (a thin lens: x_k is a point sampled on the lens), "cornell-ortho" (an
 * orthographic camera: x_k is x_{k-1}'s foot on the view plane, and the camera's density
 * of x_{k-1} has no distance in it, tech. rep. sec. 5.2) and "cornell-spot" (a
 * spot light, a delta in position: eq. 48-50, no emission hits): from the light, closed by
 * a connection to the camera, and from the camera, closed by a light sample or by hitting
 * the light. The first family has no specular vertex; the second has exactly one (a
 * reflection off the mirror or glass ball), where eq. (51) removes three techniques and
 * the rest must still sum to 1. In "cornell-rough" the balls are rough gold and rough glass
 * and the floor a glTF material (worker/render/bsdf.h): no vertex is specular, and the paths
 * reflect off and refract through GGX lobes. The "features" scene (tests/worker/render/feature_scene.h)
 * has smooth-normal balls, textured diffuse and glTF materials, a normal-mapped wall, an
 * emission-textured light and a cut-out grating: its BSDFs are set up as the renderer's
 * (worker/render/surface.h), with shading normals.
 *
 * Which techniques exist (mirrors choose_techniques() of worker/render/vcm.c and the guards of
 * worker/render/light_pass.c and camera_pass.c):
 *   VC, s = 0 (t = k + 1): emission hit; a path of one segment has only this technique.
 *   VC, s = 1 (t = k):     light sampling from x_1, unless x_1 is specular.
 *   VC, 2 <= s <= k - 1:   connection of x_{s-1} and x_s, both non-specular.
 *   VC, s = k (t = 1):     x_{k-1} projected onto the camera, one per light sub-path,
 *                          so n = n_light; the light's own point x_0 is never projected
 *                          (s = 1, t = 1 exists only in pure light tracing, unweighted).
 *   VM, 2 <= s <= k:       merging at x_{s-1} (t = k + 2 - s), non-specular; n = n_light.
 * BPT drops VM, BPM drops VC (its emission hits count only along purely specular camera
 * paths, unweighted), PT keeps s = 0 and s = 1. */
#include "check.h"
#include "feature_scene.h"

#include "common/error.h"
#include "common/sampler.h"
#include "worker/render/accel.h"
#include "worker/render/bsdf.h"
#include "worker/render/camera.h"
#include "worker/render/light.h"
#include "worker/render/mis.h"
#include "worker/render/sampling.h"
#include "worker/scene/scene.h"
#include "worker/scene/load.h"
#include "worker/render/surface.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { MAX_SEGMENTS = 6, MAX_VERTICES = MAX_SEGMENTS + 1, MAX_PATHS = 3000, WALKS = 6000 };

/* A full path: position[0] on the light, position[k] on the lens (the pinhole's position). */
typedef struct {
  int k;
  vf_vec3 position[MAX_VERTICES];
  vf_vec3 normal[MAX_VERTICES];              /* geometric; [0] the light's, [k] unused */
  const vf_material *material[MAX_VERTICES]; /* interior vertices 1 .. k-1 */
  uint32_t shape[MAX_VERTICES], primitive[MAX_VERTICES]; /* interior vertices: the hit's */
  float bu[MAX_VERTICES], bv[MAX_VERTICES];              /* barycentrics, for interpolated shapes */
  int specular[MAX_VERTICES];                /* interior vertex with only delta lobes */
} full_path;

typedef struct {
  full_path paths[MAX_PATHS];
  int count;
} path_set;

typedef struct {
  vf_scene *scene;
  vf_accel *accel;
  vf_lights *lights;
  const vf_light *light; /* the scene's one light: an area mesh or a spot */
  const vf_point_light_desc *spot; /* its description when a spot, else NULL */
  vf_camera camera;
  double n_light;        /* light sub-paths per iteration: one per pixel (or per block of pixels) */
  vf_bsdf_lobes *lobes;  /* per material, as the renderer's */
} test_scene;

/* ---------------------------------------------------------------------------------------- */
/* Geometry helpers                                                                          */

static vf_vec3 direction_between(vf_vec3 from, vf_vec3 to, float *dist) {
  vf_vec3 d = vf_sub(to, from);
  *dist = vf_length(d);
  return vf_scale(d, 1.0f / *dist);
}

static double dist_sq_d(vf_vec3 a, vf_vec3 b) {
  double dx = (double)a.x - b.x, dy = (double)a.y - b.y, dz = (double)a.z - b.z;
  return dx * dx + dy * dy + dz * dz;
}

/* |cos| at p (normal n) of the direction towards q, in double. */
static double abs_cos_d(vf_vec3 p, vf_vec3 n, vf_vec3 q) {
  double dx = (double)q.x - p.x, dy = (double)q.y - p.y, dz = (double)q.z - p.z;
  return fabs((dx * n.x + dy * n.y + dz * n.z) / sqrt(dx * dx + dy * dy + dz * dz));
}

/* As the renderer's shadow segments (queue_segment, worker/render/wavefront.h): both ends moved off
 * their surfaces (nq zero: a point). */
static int occluded(const test_scene *ts, vf_vec3 p, vf_vec3 n, vf_vec3 q, vf_vec3 nq) {
  vf_vec3 d = vf_sub(q, p);
  vf_vec3 o = vf_offset_ray_origin(p, vf_dot(n, d) > 0.0f ? n : vf_neg(n), vf_accel_scale(ts->accel));
  vf_vec3 e = vf_is_zero(nq) ? q : vf_offset_ray_origin(q, vf_dot(nq, d) < 0.0f ? nq : vf_neg(nq), vf_accel_scale(ts->accel));
  return vf_accel_occluded(ts->accel, o, vf_sub(e, o), 1.0f);
}

/* The BSDF at hit h for a path arriving from fix, as the renderer sets it up (bsdf_at of
 * worker/render/wavefront.h): through the shading normal and textures of an interpolated shape. */
static int bsdf_at_hit(const test_scene *ts, uint32_t shape, uint32_t prim, float u, float v, vf_vec3 normal,
                       vf_vec3 fix, vf_bsdf *b) {
  const vf_shape *sh = &ts->scene->shapes[shape];
  if (vf_surface_interpolated(ts->scene, sh))
    return vf_surface_bsdf(b, ts->scene, ts->lobes, shape, prim, u, v, normal, fix);
  return vf_bsdf_init(b, &ts->scene->materials[sh->material], normal, fix);
}

/* The same at interior vertex i of x. */
static int bsdf_at_vertex(const test_scene *ts, const full_path *x, int i, vf_vec3 fix, vf_bsdf *b) {
  return bsdf_at_hit(ts, x->shape[i], x->primitive[i], x->bu[i], x->bv[i], x->normal[i], fix, b);
}

/* Copies interior vertex j of `from` to vertex i of `to`. */
static void copy_vertex(full_path *to, int i, const full_path *from, int j) {
  to->position[i] = from->position[j];
  to->normal[i] = from->normal[j];
  to->material[i] = from->material[j];
  to->specular[i] = from->specular[j];
  to->shape[i] = from->shape[j];
  to->primitive[i] = from->primitive[j];
  to->bu[i] = from->bu[j];
  to->bv[i] = from->bv[j];
}

/* Density of the specular reflection of fix (tech. rep. eq. 52: the probability of
 * picking that delta component), with the continuation, as vf_bsdf_sample() reports it.
 * Mirror and dielectric reflection give the same direction, so both choices count. The
 * paths here never refract: past a refraction the next vertex is inside the glass ball. */
static float specular_reflection_pdf(const vf_bsdf *b) {
  return (b->lobe_probability[VF_LOBE_MIRROR] + b->lobe_probability[VF_LOBE_DIELECTRIC] * b->fresnel) *
         b->continuation;
}

/* ---------------------------------------------------------------------------------------- */
/* Per-path data: the BSDFs in both walking directions and the vertex densities             */

typedef struct {
  vf_bsdf from_light[MAX_VERTICES];  /* at x_i, fix towards x_{i-1} (light sub-path) */
  vf_bsdf from_camera[MAX_VERTICES]; /* at x_i, fix towards x_{i+1} (camera sub-path) */
  double cos_light;                  /* at x_0 towards x_1; 1 for a spot, which has no surface */
  double emission_pdf_w;             /* of the light emitting towards x_1, in solid angle */
  double p_light[MAX_VERTICES];      /* pL(x_i): area density of the light walk sampling x_i */
  double p_camera[MAX_VERTICES];     /* pC(x_i): the same for the camera walk */
} path_data;

/* Builds the BSDFs and densities; 0 when the path cannot carry light (a vertex that cannot
 * scatter, a zero density, a specular vertex that is not a reflection, a grazing angle). */
static int prepare_path(const test_scene *ts, const full_path *x, path_data *pd) {
  const int k = x->k;
  const double min_cos = 1e-3; /* keeps float round-off of cos far below the tolerance */
  pd->cos_light = (double)vf_dot(x->normal[0], vf_sub(x->position[1], x->position[0])) /
                  sqrt(dist_sq_d(x->position[0], x->position[1]));
  pd->emission_pdf_w = pd->cos_light / M_PI;
  if (ts->spot) { /* emits uniformly into its outer cone */
    pd->cos_light = (double)vf_dot(ts->spot->direction, vf_sub(x->position[1], x->position[0])) /
                    sqrt(dist_sq_d(x->position[0], x->position[1]));
    if (!(pd->cos_light > cos(ts->spot->outer_cone_angle))) return 0;
    pd->emission_pdf_w = 1.0 / (2.0 * M_PI * (1.0 - cos(ts->spot->outer_cone_angle)));
    pd->cos_light = 1.0;
  }
  if (!(pd->cos_light > min_cos)) return 0;
  for (int i = 1; i < k; i++) {
    float d;
    vf_vec3 to_prev = direction_between(x->position[i], x->position[i - 1], &d);
    vf_vec3 to_next = direction_between(x->position[i], x->position[i + 1], &d);
    if (!bsdf_at_vertex(ts, x, i, to_prev, &pd->from_light[i])) return 0;
    if (!bsdf_at_vertex(ts, x, i, to_next, &pd->from_camera[i])) return 0;
    if (pd->from_light[i].is_delta != x->specular[i]) return 0;
    if (abs_cos_d(x->position[i], x->normal[i], x->position[i - 1]) < min_cos ||
        abs_cos_d(x->position[i], x->normal[i], x->position[i + 1]) < min_cos)
      return 0;
    if (x->specular[i]) {
      /* A reflection, and one that float positions resolve: where a ball touches the floor
       * the segment after it is short and its direction known to ~1e-4 rad only, which at
       * grazing angles shows up as a cosine and Fresnel mismatch between the two walking
       * directions (weights off by ~3e-4), not as an error of the weights. */
      double cos_prev = abs_cos_d(x->position[i], x->normal[i], x->position[i - 1]);
      double cos_next = abs_cos_d(x->position[i], x->normal[i], x->position[i + 1]);
      vf_vec3 mirrored = vf_frame_to_world(&pd->from_light[i].frame,
                                           vf_vec3_make(-pd->from_light[i].local_fix.x,
                                                        -pd->from_light[i].local_fix.y, pd->from_light[i].local_fix.z));
      if (!(vf_dot(mirrored, to_next) > 0.9999f) || !(fabs(cos_prev - cos_next) <= 1e-4 * cos_prev)) return 0;
    } else {
      float c, p, r;
      if (vf_is_zero(vf_bsdf_evaluate(&pd->from_light[i], to_next, &c, &p, &r)) || !(p > 0.0f) || !(r > 0.0f))
        return 0;
    }
  }

  /* Light side (eq. 2-4): x_0 by area (a spot's position is a delta: only its selection
   * counts, the same in every technique), x_1 by emission, then BSDF sampling. */
  pd->p_light[0] = (double)ts->light->pick_probability / (ts->spot ? 1.0 : (double)ts->light->area);
  pd->p_light[1] = pd->emission_pdf_w * (k > 1 ? abs_cos_d(x->position[1], x->normal[1], x->position[0]) : 1.0) /
                   dist_sq_d(x->position[0], x->position[1]);
  for (int i = 2; i <= k; i++) {
    const vf_bsdf *b = &pd->from_light[i - 1];
    float c, pdf_w, rev;
    if (x->specular[i - 1]) {
      pdf_w = specular_reflection_pdf(b);
    } else {
      float d;
      vf_bsdf_evaluate(b, direction_between(x->position[i - 1], x->position[i], &d), &c, &pdf_w, &rev);
    }
    double cos_i = i < k ? abs_cos_d(x->position[i], x->normal[i], x->position[i - 1]) : 1.0;
    pd->p_light[i] = (double)pdf_w * cos_i / dist_sq_d(x->position[i - 1], x->position[i]);
  }

  /* Camera side (eq. 6-8 read from the eye): x_k on the lens (the pinhole is deterministic;
   * a thin lens's point has the density 1 / (pi r^2) whether traced from or connected to,
   * a factor of every technique), x_{k-1} through the image from x_k, then BSDF sampling;
   * at x_0 the light's emitting cosine converts the measure. */
  pd->p_camera[k] = 1.0;
  float d;
  vf_vec3 view = direction_between(x->position[k], x->position[k - 1], &d);
  double cos_k1 = k > 1 ? abs_cos_d(x->position[k - 1], x->normal[k - 1], x->position[k]) : pd->cos_light;
  if (ts->scene->camera.view_width > 0.0f) {
    /* Orthographic: uniform on the pixel's square of the view plane, projected along the
     * view: one over the pixel's area, times the cosine at x_{k-1}. */
    double pixel = (double)ts->scene->camera.view_width / ts->scene->settings.width;
    pd->p_camera[k - 1] = cos_k1 / (pixel * pixel);
  } else {
    pd->p_camera[k - 1] =
        (double)vf_camera_pdf_w(&ts->camera, view) * cos_k1 / dist_sq_d(x->position[k], x->position[k - 1]);
  }
  for (int i = k - 2; i >= 0; i--) {
    const vf_bsdf *b = &pd->from_camera[i + 1];
    float c, pdf_w, rev;
    if (x->specular[i + 1]) {
      pdf_w = specular_reflection_pdf(b);
    } else {
      vf_bsdf_evaluate(b, direction_between(x->position[i + 1], x->position[i], &d), &c, &pdf_w, &rev);
    }
    double cos_i = i > 0 ? abs_cos_d(x->position[i], x->normal[i], x->position[i + 1]) : pd->cos_light;
    pd->p_camera[i] = (double)pdf_w * cos_i / dist_sq_d(x->position[i + 1], x->position[i]);
  }
  if (ts->spot) pd->p_camera[0] = 0.0; /* no ray hits a point */
  for (int i = 0; i <= k; i++)
    if (!(pd->p_light[i] > 0.0) || !(pd->p_camera[i] > 0.0 || (i == 0 && ts->spot))) return 0;
  return 1;
}

/* ---------------------------------------------------------------------------------------- */
/* Techniques and configurations                                                             */

typedef struct {
  int vc[MAX_VERTICES + 1]; /* VC with s light vertices, s = 0 .. k */
  int vm[MAX_VERTICES + 1]; /* VM with s light vertices, s = 2 .. k */
  int emission_unweighted;  /* BPM: s = 0 along a purely specular camera path, weight 1 */
} technique_set;

/* The techniques the renderer uses for this path under algorithm a (see the top of the file);
 * delta_light: the light cannot be hit, s = 0 does not exist. */
static void implemented_techniques(const full_path *x, vf_algorithm a, int delta_light, technique_set *t) {
  const int k = x->k;
  memset(t, 0, sizeof *t);
  int vc = a == VF_ALGO_VCM || a == VF_ALGO_UPG || a == VF_ALGO_BPT;
  int vm = a == VF_ALGO_VCM || a == VF_ALGO_UPG || a == VF_ALGO_BPM;
  int all_specular = 1;
  for (int i = 1; i < k; i++) all_specular &= x->specular[i];
  if (k == 1) {
    t->vc[0] = 1; /* seen directly: emission_weighted() returns it unweighted */
    t->emission_unweighted = 1;
    return;
  }
  if (a == VF_ALGO_BPM) {
    t->vc[0] = t->emission_unweighted = all_specular;
  } else {
    t->vc[0] = 1;
    t->vc[1] = !x->specular[1];
  }
  if (vc) {
    for (int s = 2; s <= k - 1; s++) t->vc[s] = !x->specular[s - 1] && !x->specular[s];
    t->vc[k] = !x->specular[k - 1];
  }
  if (vm)
    for (int s = 2; s <= k; s++) t->vm[s] = !x->specular[s - 1];
  if (delta_light) t->vc[0] = t->emission_unweighted = 0;
}

/* The heuristic's exponent of the checks: 1 the balance heuristic, else the power one. */
static double g_beta = 1.0;

/* vf_mis_config as setup_iteration() builds it for eta = pi r^2 n_light. */
static vf_mis_config config_for(vf_algorithm a, double eta, double n_light) {
  vf_mis_config c;
  int vc_in_weights = a == VF_ALGO_VCM || a == VF_ALGO_UPG || a == VF_ALGO_BPT;
  int vm_in_weights = a == VF_ALGO_VCM || a == VF_ALGO_UPG || a == VF_ALGO_BPM;
  c.beta = (float)g_beta;
  c.vm_weight = vm_in_weights ? vf_mis_h(&c, (float)eta) : 0.0f;
  c.vc_weight = vc_in_weights ? vf_mis_h(&c, (float)(1.0 / eta)) : 0.0f;
  c.light_paths = (float)n_light;
  c.pt = a == VF_ALGO_PT;
  return c;
}

/* ---------------------------------------------------------------------------------------- */
/* Direct evaluation of eq. (12), w_i = (n_i p_i)^beta / sum_j (n_j p_j)^beta, in double  */

static void direct_weights(const full_path *x, const path_data *pd, const technique_set *t, double eta,
                           double n_light, double w_vc[], double w_vm[]) {
  const int k = x->k;
  double p_vc[MAX_VERTICES + 1] = {0}, p_vm[MAX_VERTICES + 1] = {0}, total = 0.0;
  for (int s = 0; s <= k; s++) {
    double p = 1.0;
    for (int i = 0; i < s; i++) p *= pd->p_light[i];
    for (int i = s; i <= k; i++) p *= pd->p_camera[i];
    /* n_VC = 1, except the camera connection: every light sub-path projects onto the image. */
    p_vc[s] = (s == k && k > 1 ? n_light : 1.0) * p; /* eq. (10) */
    if (s >= 2) {
      double q = pd->p_camera[s - 1];
      for (int i = 0; i < s; i++) q *= pd->p_light[i];
      for (int i = s; i <= k; i++) q *= pd->p_camera[i];
      /* n_VM pi r^2 = eta_VCM with n_VC = 1 (eq. 10, 20). */
      p_vm[s] = eta * q;
    }
  }
  for (int s = 0; s <= k; s++) {
    p_vc[s] = pow(p_vc[s], g_beta);
    p_vm[s] = pow(p_vm[s], g_beta);
    total += (t->vc[s] ? p_vc[s] : 0.0) + (t->vm[s] ? p_vm[s] : 0.0);
  }
  for (int s = 0; s <= k; s++) {
    w_vc[s] = t->vc[s] ? p_vc[s] / total : 0.0;
    w_vm[s] = t->vm[s] ? p_vm[s] / total : 0.0;
  }
  if (t->emission_unweighted) w_vc[0] = 1.0;
}

/* ---------------------------------------------------------------------------------------- */
/* The recursive weights, with the call sequence of the renderer's passes                  */

/* As connect_to_camera() of worker/render/light_pass.c: the camera's area density of generating p
 * linked to lens point `lens` (worker/render/camera.h), whose |cos| towards it is cos_at_p; 0
 * off the image. */
static float camera_pdf_a(const vf_camera *cam, vf_vec3 lens, vf_vec3 p, float cos_at_p) {
  vf_camera_link link;
  if (!vf_camera_link_point(cam, lens, p, &link)) return 0.0f;
  return vf_camera_link_pdf_a(&link, cos_at_p);
}

/* What vf_light_emit and vf_light_illuminate report for x_0 seen from x_1, before the
 * selection probability: the area light's from its formulas, the spot's from illuminate
 * itself (its point is deterministic). */
typedef struct {
  float direct_pdf_a, emission_pdf_w, direct_pdf_w, cos_at_light;
} light_report;

static light_report light_densities(const test_scene *ts, const full_path *x, float cos0) {
  float dist;
  direction_between(x->position[1], x->position[0], &dist);
  const float inv_area = ts->light->inv_area;
  light_report r = {inv_area, inv_area * cos0 * VF_INV_PI, inv_area * dist * dist / cos0, cos0};
  if (ts->spot) {
    const float rnd[2] = {0.5f, 0.5f};
    vf_vec3 d, lp, ln;
    float distance;
    r.direct_pdf_a = 1.0f;
    vf_light_illuminate(ts->lights, ts->light, x->position[1], rnd, &d, &distance, &lp, &ln, &r.direct_pdf_w,
                        &r.emission_pdf_w, &r.cos_at_light);
  }
  return r;
}

/* The sub-path quantities at every vertex: light[i] at y_i = x_i after its hit (i >= 1),
 * camera[j] at z_j = x_{k-j} after its hit (j >= 1). */
static void trace_quantities(const test_scene *ts, const full_path *x, const path_data *pd, const vf_mis_config *c_light,
                             const vf_mis_config *c, vf_mis light[], vf_mis camera[]) {
  const int k = x->k;
  const float pick = ts->light->pick_probability;
  float cos0 = (float)pd->cos_light;
  light_report r = light_densities(ts, x, cos0);
  vf_mis m;
  /* light_start(): densities times the pick probability (eq. 31-33, 48-50), then hit and scatter. */
  vf_mis_light_start(&m, c_light, r.direct_pdf_a * pick, r.emission_pdf_w * pick, cos0, ts->light->is_delta,
                     ts->light->is_finite);
  for (int i = 1; i < k; i++) {
    const vf_bsdf *b = &pd->from_light[i];
    float dist;
    direction_between(x->position[i - 1], x->position[i], &dist);
    /* the geometric cosine, as light_bounce() (local_fix.z is the shading one) */
    vf_mis_hit(&m, c_light, dist, fabsf(vf_dot(x->normal[i], direction_between(x->position[i], x->position[i - 1], &dist))), 1);
    light[i] = m;
    if (i == k - 1) break;
    vf_vec3 gen = direction_between(x->position[i], x->position[i + 1], &dist);
    float cos_gen, pdf, rev;
    if (x->specular[i]) {
      cos_gen = fabsf(vf_dot(x->normal[i], gen)); /* geometric, as vf_bsdf_sample reports it */
      pdf = rev = specular_reflection_pdf(b);
    } else {
      vf_bsdf_evaluate(b, gen, &cos_gen, &pdf, &rev);
    }
    vf_mis_scatter(&m, c_light, cos_gen, pdf, rev, x->specular[i]);
  }
  /* camera_start(): the density of the first direction from the lens point (eq. 31-33; an
   * orthographic camera's of its point on the view plane, sec. 5.2), then the same. */
  float dist;
  vf_mis_camera_start(&m, c, vf_camera_start_density(&ts->camera, direction_between(x->position[k], x->position[k - 1], &dist)));
  const int orthographic = ts->camera.pixel_size > 0.0f;
  for (int j = 1; j <= k; j++) {
    int i = k - j;
    vf_vec3 dir = direction_between(x->position[i + 1], x->position[i], &dist);
    vf_mis_hit(&m, c, dist, fabsf(vf_dot(x->normal[i], dir)), !(j == 1 && orthographic));
    camera[j] = m;
    if (j == k) break;
    const vf_bsdf *b = &pd->from_camera[i];
    vf_vec3 gen = direction_between(x->position[i], x->position[i - 1], &dist);
    float cos_gen, pdf, rev;
    if (x->specular[i]) {
      cos_gen = fabsf(vf_dot(x->normal[i], gen)); /* geometric, as vf_bsdf_sample reports it */
      pdf = rev = specular_reflection_pdf(b);
    } else {
      vf_bsdf_evaluate(b, gen, &cos_gen, &pdf, &rev);
    }
    vf_mis_scatter(&m, c, cos_gen, pdf, rev, x->specular[i]);
  }
}

/* Whether the checks run upg (1: preferring the light's side, 2: the camera's): its VM
 * techniques are then weighted as gathering_pass.c weighs a gathering, from the side its
 * rule picks: the light's (vf_mis_weight_gather: the light vertex's predecessor's quantities
 * scattered towards the camera vertex) where that predecessor's choice was not specular,
 * the camera's (vf_mis_weight_gather_camera) where the camera vertex's predecessor is a
 * surface vertex whose choice was not specular. */
static int g_upg = 0;

/* Each used technique's weight as emission_weighted(), light_sample(), connect_vertices(),
 * connect_to_camera() and merge_vertices() (or for upg the gathering) compute it. */
static void recursive_weights(const test_scene *ts, const full_path *x, const path_data *pd, const vf_mis_config *c_light,
                              const vf_mis_config *c, const technique_set *t, double w_vc[], double w_vm[]) {
  const int k = x->k;
  const float pick = ts->light->pick_probability, inv_area = ts->light->inv_area;
  const float cos0 = (float)pd->cos_light;
  const light_report r = light_densities(ts, x, cos0);
  vf_mis light[MAX_VERTICES], camera[MAX_VERTICES + 1];
  trace_quantities(ts, x, pd, c_light, c, light, camera);
  for (int s = 0; s <= k; s++) w_vc[s] = w_vm[s] = 0.0;

  if (t->vc[0]) /* s = 0 */
    w_vc[0] = t->emission_unweighted
                  ? 1.0
                  : vf_mis_weight_emission(&camera[k], c, inv_area * pick, cos0 * VF_INV_PI * inv_area * pick);
  if (t->vc[1]) { /* s = 1: x_1 sees x_0 as a light sample */
    float dist, cos_to_light, bsdf_pdf, bsdf_rev_pdf;
    vf_vec3 dir = direction_between(x->position[1], x->position[0], &dist);
    vf_bsdf_evaluate(&pd->from_camera[1], dir, &cos_to_light, &bsdf_pdf, &bsdf_rev_pdf);
    if (ts->light->is_delta) bsdf_pdf = 0.0f; /* eq. (44): a delta light cannot be hit */
    w_vc[1] = vf_mis_weight_light_sample(&camera[k - 1], c, bsdf_pdf, bsdf_rev_pdf, r.direct_pdf_w * pick,
                                         r.emission_pdf_w * pick, cos_to_light, r.cos_at_light);
  }
  for (int s = 2; s <= k - 1; s++) { /* light vertex x_{s-1}, camera vertex x_s = z_{k-s} */
    if (!t->vc[s]) continue;
    float dist;
    vf_vec3 d = direction_between(x->position[s], x->position[s - 1], &dist);
    float dist2 = dist * dist;
    float cos_camera, camera_pdf, camera_rev_pdf, cos_light, light_pdf, light_rev_pdf;
    vf_bsdf_evaluate(&pd->from_camera[s], d, &cos_camera, &camera_pdf, &camera_rev_pdf);
    vf_bsdf_evaluate(&pd->from_light[s - 1], vf_neg(d), &cos_light, &light_pdf, &light_rev_pdf);
    w_vc[s] = vf_mis_weight_connection(&light[s - 1], &camera[k - s], c, camera_pdf * cos_light / dist2,
                                       light_pdf * cos_camera / dist2, light_rev_pdf, camera_rev_pdf);
  }
  if (k > 1 && t->vc[k]) { /* t = 1 */
    float dist, cos_to_camera, dir_pdf, rev_pdf;
    vf_vec3 to_camera = direction_between(x->position[k - 1], x->position[k], &dist);
    vf_bsdf_evaluate(&pd->from_light[k - 1], to_camera, &cos_to_camera, &dir_pdf, &rev_pdf);
    float pdf_a = camera_pdf_a(&ts->camera, x->position[k], x->position[k - 1], cos_to_camera);
    w_vc[k] = vf_mis_weight_camera_connection(&light[k - 1], c, pdf_a, rev_pdf);
  }
  for (int s = 2; s <= k; s++) { /* merging y_{s-1} into z_{k+1-s}, both at x_{s-1} */
    if (!t->vm[s]) continue;
    const vf_bsdf *lb = &pd->from_light[s - 1], *cb = &pd->from_camera[s - 1];
    vf_vec3 light_dir = vf_frame_to_world(&lb->frame, lb->local_fix);
    float cos_camera, camera_pdf, camera_rev_pdf;
    vf_bsdf_evaluate(cb, light_dir, &cos_camera, &camera_pdf, &camera_rev_pdf);
    camera_rev_pdf *= lb->continuation / cb->continuation;
    w_vm[s] = vf_mis_weight_merge(&light[s - 1], &camera[k + 1 - s], c, camera_pdf, camera_rev_pdf);
    int light_side = s == 2 || !x->specular[s - 2], camera_side = k - s >= 1 && !x->specular[s];
    if (g_upg && camera_side && (!light_side || g_upg == 2)) {
      /* x_{s-1}'s light vertex joined to x_s, the camera vertex before x_{s-1}'s. */
      float dist, cos_c, c_pdf, c_rev, cos_l, l_pdf, l_rev;
      vf_vec3 to_light_vertex = direction_between(x->position[s], x->position[s - 1], &dist);
      vf_bsdf_evaluate(&pd->from_camera[s], to_light_vertex, &cos_c, &c_pdf, &c_rev);
      vf_bsdf_evaluate(lb, vf_neg(to_light_vertex), &cos_l, &l_pdf, &l_rev);
      float cos_at_light = fabsf(vf_dot(x->normal[s - 1], to_light_vertex));
      w_vm[s] = vf_mis_weight_gather_camera(&light[s - 1], camera[k - s], c, cos_c, c_pdf, c_rev, dist, cos_at_light,
                                            l_rev, l_pdf);
    } else if (g_upg && light_side) {
      /* The gathering at x_{s-1} of the light vertex there, joined from its predecessor
       * x_{s-2}: the light's own point (its quantities as light_start() forms them for the
       * direction towards x_1) or a light vertex (after its hit, then scattered). The
       * camera vertex's own densities, without merging's continuation ratio: the vertex is
       * x_{s-1} itself. */
      float dist;
      vf_vec3 to_camera_vertex = direction_between(x->position[s - 2], x->position[s - 1], &dist);
      vf_bsdf_evaluate(cb, vf_neg(to_camera_vertex), &cos_camera, &camera_pdf, &camera_rev_pdf);
      float cos_at_camera = fabsf(vf_dot(x->normal[s - 1], to_camera_vertex));
      vf_mis before;
      float cos_light = 1.0f, light_pdf = 0.0f, light_rev_pdf = 0.0f;
      if (s == 2) {
        vf_mis_light_start(&before, c, r.direct_pdf_a * pick, r.emission_pdf_w * pick, cos0, ts->light->is_delta,
                           ts->light->is_finite);
      } else {
        before = light[s - 2];
        vf_bsdf_evaluate(&pd->from_light[s - 2], to_camera_vertex, &cos_light, &light_pdf, &light_rev_pdf);
      }
      w_vm[s] = vf_mis_weight_gather(before, &camera[k + 1 - s], c, s > 2, cos_light, light_pdf, light_rev_pdf, dist,
                                     cos_at_camera, camera_pdf, camera_rev_pdf);
    }
  }
}

/* ---------------------------------------------------------------------------------------- */
/* Path generation                                                                           */

static int load_test_scene(test_scene *ts, const char *name, vf_light_kind kind) {
  memset(ts, 0, sizeof *ts);
  int err = VF_OK;
  if (strcmp(name, "features") == 0) /* tests/worker/render/feature_scene.h: every feature of worker/render/surface.h */
    err = (ts->scene = feature_scene(FEATURE_SMOOTH | FEATURE_TEXTURED | FEATURE_NORMAL_MAP | FEATURE_CUTOUT))
              ? VF_OK
              : VF_ESCENE;
  else
    err = vf_scene_load(name, &ts->scene);
  if (err == VF_OK) {
    ts->lobes = calloc((size_t)ts->scene->num_materials, sizeof *ts->lobes);
    if (ts->lobes == NULL) return VF_ENOMEM;
    for (int m = 0; m < ts->scene->num_materials; m++) vf_bsdf_lobes_of(&ts->scene->materials[m], &ts->lobes[m]);
  }
  if (err == VF_OK) err = vf_accel_create(ts->scene, &ts->accel);
  if (err == VF_OK) err = vf_lights_create(ts->scene, &ts->lights);
  if (err != VF_OK) {
    fprintf(stderr, "%s: %s\n", name, vf_error_detail(err));
    return err;
  }
  for (int i = 0; i < ts->lights->count; i++)
    if (ts->lights->lights[i].kind == kind) ts->light = &ts->lights->lights[i];
  for (int i = 0; i < ts->scene->num_point_lights; i++)
    if (ts->scene->point_lights[i].is_spot) ts->spot = &ts->scene->point_lights[i];
  vf_camera_init(&ts->camera, &ts->scene->camera, ts->scene->settings.width, ts->scene->settings.height);
  ts->n_light = (double)ts->scene->settings.width * ts->scene->settings.height;
  return ts->light ? VF_OK : VF_ESCENE;
}

static void destroy_test_scene(test_scene *ts) {
  free(ts->lobes);
  vf_lights_destroy(ts->lights);
  vf_accel_destroy(ts->accel);
  vf_scene_destroy(ts->scene);
}

static void add_path(const test_scene *ts, const full_path *x, path_set *diffuse, path_set *specular) {
  int n = 0;
  for (int i = 1; i < x->k; i++) n += x->specular[i];
  path_set *set = n == 0 ? diffuse : n == 1 ? specular : NULL;
  path_data pd;
  vf_camera_link link;
  if (set == NULL || set->count == MAX_PATHS) return;
  if (!vf_camera_link_point(&ts->camera, x->position[x->k], x->position[x->k - 1], &link)) return;
  if (!prepare_path(ts, x, &pd)) return;
  set->paths[set->count++] = *x;
}

/* The lens point of a camera sub-path or a connection to the camera: lens_sample() of
 * worker/render/light_pass.c. */
/* Where the walks' numbers come from: the sampler under test (common/sampler.h), each
 * number of a walk from a pair of its own (its first coordinate), the walk's index the
 * sample index. The identities hold path by path, whatever numbers made the path; the
 * walks of each sampler are other paths. */
static vf_sampler_kind walk_sampler = VF_SAMPLER_INDEPENDENT;
typedef struct {
  vf_sampler s;
  uint32_t pair;
} walk_numbers;

static float walk_float(walk_numbers *n) { return vf_sampler_1d(&n->s, n->pair++); }

static vf_vec3 lens_point(const test_scene *ts, walk_numbers *rng) {
  if (!(ts->camera.lens_radius > 0.0f)) return ts->camera.position;
  float u1 = walk_float(rng), u2 = walk_float(rng);
  return vf_camera_lens_point(&ts->camera, u1, u2);
}

/* The camera's end x_k of a path closed at p from the light: a lens point, or p's foot on
 * an orthographic view plane (computed here from the plane, not by the renderer's link);
 * 0 when p is behind that plane. */
static int camera_end(const test_scene *ts, walk_numbers *rng, vf_vec3 p, vf_vec3 *end) {
  if (!(ts->camera.pixel_size > 0.0f)) {
    *end = lens_point(ts, rng);
    return 1;
  }
  float depth = vf_dot(vf_sub(p, ts->camera.position), ts->camera.forward);
  *end = vf_sub(p, vf_scale(ts->camera.forward, depth));
  return depth > 0.0f;
}

/* From the light: every non-specular vertex that sees the camera closes a path. */
static void walk_from_light(const test_scene *ts, walk_numbers *rng, path_set *diffuse, path_set *specular) {
  full_path x = {0};
  float rnd[4] = {walk_float(rng), walk_float(rng), walk_float(rng), walk_float(rng)};
  vf_vec3 dir, n;
  float emission_pdf, direct_pdf, cos_light;
  vf_light_emit(ts->lights, ts->light, rnd, &x.position[0], &dir, &n, &emission_pdf, &direct_pdf, &cos_light);
  x.normal[0] = n;
  vf_vec3 origin = ts->spot ? x.position[0] : vf_offset_ray_origin(x.position[0], n, vf_accel_scale(ts->accel));
  for (int m = 1; m < MAX_SEGMENTS; m++) {
    vf_hit hit;
    vf_bsdf b;
    if (!vf_accel_intersect(ts->accel, origin, dir, INFINITY, &hit)) return;
    if (ts->lights->shape_light[hit.shape] >= 0) return;
    if (!bsdf_at_hit(ts, hit.shape, hit.primitive, hit.u, hit.v, hit.normal, vf_neg(dir), &b)) return;
    x.position[m] = hit.position;
    x.normal[m] = hit.normal;
    x.material[m] = b.material;
    x.specular[m] = b.is_delta;
    x.shape[m] = hit.shape;
    x.primitive[m] = hit.primitive;
    x.bu[m] = hit.u;
    x.bv[m] = hit.v;
    vf_vec3 lens;
    if (camera_end(ts, rng, hit.position, &lens) && !b.is_delta &&
        !occluded(ts, hit.position, hit.normal, lens, vf_vec3_splat(0.0f))) {
      x.k = m + 1;
      x.position[m + 1] = lens;
      add_path(ts, &x, diffuse, specular);
    }
    float srnd[3] = {walk_float(rng), walk_float(rng), walk_float(rng)};
    float pdf, rev, cos_gen;
    unsigned event;
    if (vf_is_zero(vf_bsdf_sample(&b, srnd, &dir, &pdf, &rev, &cos_gen, &event))) return;
    origin = vf_offset_ray_origin(hit.position, vf_dot(hit.normal, dir) > 0.0f ? hit.normal : vf_neg(hit.normal), vf_accel_scale(ts->accel));
  }
}

/* From the camera: every non-specular vertex closes a path with a point sampled on the
 * light, and hitting the light closes one too (camera vertices are reversed into x). */
static void walk_from_camera(const test_scene *ts, walk_numbers *rng, path_set *diffuse, path_set *specular) {
  full_path z = {0}; /* z.position[j] = z_j, z_0 on the lens */
  full_path x = {0};
  float rx = walk_float(rng) * (float)ts->camera.width, ry = walk_float(rng) * (float)ts->camera.height;
  z.position[0] = ts->camera.pixel_size > 0.0f ? vf_camera_view_point(&ts->camera, rx, ry) : lens_point(ts, rng);
  vf_vec3 dir = ts->camera.pixel_size > 0.0f ? ts->camera.forward
                : ts->camera.lens_radius > 0.0f ? vf_camera_lens_direction(&ts->camera, z.position[0], rx, ry)
                                                : vf_camera_direction(&ts->camera, rx, ry);
  vf_vec3 origin = z.position[0];
  for (int m = 1; m < MAX_SEGMENTS; m++) {
    vf_hit hit;
    vf_bsdf b;
    if (!vf_accel_intersect(ts->accel, origin, dir, INFINITY, &hit)) return;
    /* Closes the path x_0 = z_m .. x_m = z_0. */
    int close_at_light = ts->lights->shape_light[hit.shape] >= 0;
    z.position[m] = hit.position;
    z.normal[m] = hit.normal;
    if (close_at_light) {
      if (!(vf_dot(hit.normal, dir) < 0.0f)) return; /* the back of the one-sided light */
      x.k = m;
      for (int j = 0; j <= m; j++) copy_vertex(&x, m - j, &z, j);
      add_path(ts, &x, diffuse, specular);
      return;
    }
    if (!bsdf_at_hit(ts, hit.shape, hit.primitive, hit.u, hit.v, hit.normal, vf_neg(dir), &b)) return;
    z.material[m] = b.material;
    z.specular[m] = b.is_delta;
    z.shape[m] = hit.shape;
    z.primitive[m] = hit.primitive;
    z.bu[m] = hit.u;
    z.bv[m] = hit.v;
    if (!b.is_delta) {
      float rnd[2] = {walk_float(rng), walk_float(rng)};
      vf_vec3 to_light, lp, ln;
      float dist, direct_pdf_w, emission_pdf_w, cos_at_light;
      vf_vec3 le = vf_light_illuminate(ts->lights, ts->light, hit.position, rnd, &to_light, &dist, &lp, &ln,
                                       &direct_pdf_w, &emission_pdf_w, &cos_at_light);
      if (!vf_is_zero(le) && !vf_is_zero(vf_bsdf_evaluate(&b, to_light, NULL, NULL, NULL)) &&
          !occluded(ts, hit.position, hit.normal, lp, ts->spot ? vf_vec3_splat(0.0f) : ln)) {
        x.k = m + 1;
        x.position[0] = lp;
        x.normal[0] = ln;
        for (int j = 0; j <= m; j++) copy_vertex(&x, m + 1 - j, &z, j);
        add_path(ts, &x, diffuse, specular);
      }
    }
    float srnd[3] = {walk_float(rng), walk_float(rng), walk_float(rng)};
    float pdf, rev, cos_gen;
    unsigned event;
    if (vf_is_zero(vf_bsdf_sample(&b, srnd, &dir, &pdf, &rev, &cos_gen, &event))) return;
    origin = vf_offset_ray_origin(hit.position, vf_dot(hit.normal, dir) > 0.0f ? hit.normal : vf_neg(hit.normal), vf_accel_scale(ts->accel));
  }
}

/* ---------------------------------------------------------------------------------------- */
/* The checks                                                                                */

static test_scene g_scene;
static path_set g_diffuse, g_specular; /* no specular vertex; exactly one */

typedef struct {
  double max_rel_dev;   /* over every used technique: |recursive - direct| / direct */
  double max_sum_dev;   /* |sum of recursive weights - 1| */
  double vm_share;      /* mean over paths of the total VM weight */
  int paths, worst_path, worst_s, worst_is_vm;
  double worst_rec, worst_dir;
} deviation;

static const char *technique_label(int is_vm) { return is_vm ? "VM" : "VC"; }

static void print_path(const full_path *x, const technique_set *t, const double rec_vc[],
                       const double rec_vm[], const double dir_vc[], const double dir_vm[]) {
  printf("    k = %d: light", x->k);
  for (int i = 1; i < x->k; i++) printf(" -> %s%s", x->material[i]->name, x->specular[i] ? "(S)" : "");
  printf(" -> camera\n");
  for (int s = 0; s <= x->k; s++) {
    if (t->vc[s]) printf("      VC s=%d t=%d  recursive %.6f  eq.12 %.6f\n", s, x->k + 1 - s, rec_vc[s], dir_vc[s]);
    if (t->vm[s]) printf("      VM s=%d t=%d  recursive %.6f  eq.12 %.6f\n", s, x->k + 2 - s, rec_vm[s], dir_vm[s]);
  }
}

/* A merge radius per pixel (tech. rep. sec. 6.1, --radius per-pixel): when set, path p is
 * weighed with eta times path_eta_scale(p), as the pixel it ends in would weigh it, from
 * 1/16 to 16 times eta across paths, while its light sub-path's quantities are traced
 * with a config of yet another radius, as the light pass traces them before any pixel is
 * known: the stored quantities must not depend on the radius. */
static int g_pixel_radii;
static int g_pixel_samples; /* below */
static double path_eta_scale(int p) {
  return (g_pixel_radii ? pow(4.0, (double)(p % 5) - 2.0) : 1.0) / (g_pixel_samples ? pow(2.0, (double)(p % 5)) : 1.0);
}
/* Single-stage vcm (worker/render/single_stage.h): the light sub-paths were traced in the
 * iteration before the weights', under its radius, eta_{k-1} / eta_k = (k / (k + 1))^(alpha
 * - 1), 2^0.25 for k = 1 at alpha 0.75. */
static int g_single_stage;
static double light_eta(double eta) {
  return eta * (g_pixel_radii ? 37.0 : 1.0) * (g_single_stage ? pow(2.0, 0.25) : 1.0);
}

/* Camera sub-paths allocated per pixel (common/allocation.h, --pilot): when set, the pixel
 * path p ends in traces k = 2^(p mod 5) camera sub-paths an iteration, 1 to 16, so that its
 * camera techniques count that many times against light tracing's n_light: in eq. 12,
 * every count over the camera's is n_light / k for light tracing, and eta / k for merging
 * (its camera sub-paths merge with radius r / sqrt(k), path_eta_scale). The recursion takes
 * it as the pixel's config does (worker/render/pixel_radius.h, vf_merge_params_at), in the
 * camera's d_vcm, light tracing's weight and eta. */
static double path_light_paths(int p) { return g_scene.n_light / (g_pixel_samples ? pow(2.0, (double)(p % 5)) : 1.0); }

/* Checks every path of a set under one algorithm and eta; prints `examples` paths. */
static deviation check_set(const path_set *set, vf_algorithm a, double eta, int examples) {
  deviation dev = {0};
  vf_mis_config c_light = config_for(a, light_eta(eta), g_scene.n_light);
  for (int p = 0; p < set->count; p++) {
    const full_path *x = &set->paths[p];
    path_data pd;
    technique_set t;
    double rec_vc[MAX_VERTICES + 1], rec_vm[MAX_VERTICES + 1], dir_vc[MAX_VERTICES + 1], dir_vm[MAX_VERTICES + 1];
    double path_eta = eta * path_eta_scale(p);
    vf_mis_config c = config_for(a, path_eta, path_light_paths(p));
    if (!prepare_path(&g_scene, x, &pd)) continue;
    implemented_techniques(x, a, g_scene.spot != NULL, &t);
    recursive_weights(&g_scene, x, &pd, &c_light, &c, &t, rec_vc, rec_vm);
    direct_weights(x, &pd, &t, path_eta, path_light_paths(p), dir_vc, dir_vm);
    double sum = 0.0, vm = 0.0;
    int used = 0;
    for (int s = 0; s <= x->k; s++)
      for (int is_vm = 0; is_vm < 2; is_vm++) {
        if (!(is_vm ? t.vm[s] : t.vc[s])) continue;
        double r = is_vm ? rec_vm[s] : rec_vc[s], d = is_vm ? dir_vm[s] : dir_vc[s];
        double rel = fabs(r - d) / d;
        if (!(rel <= dev.max_rel_dev)) { /* NaN lands here too */
          dev.max_rel_dev = isnan(rel) ? INFINITY : rel;
          dev.worst_path = p, dev.worst_s = s, dev.worst_is_vm = is_vm, dev.worst_rec = r, dev.worst_dir = d;
        }
        sum += r;
        if (is_vm) vm += r;
        used++;
      }
    if (used == 0) continue; /* e.g. BPM on a path whose only merge vertex is specular */
    dev.paths++;
    dev.vm_share += vm;
    double sd = fabs(sum - 1.0);
    if (!(sd <= dev.max_sum_dev)) dev.max_sum_dev = isnan(sd) ? INFINITY : sd;
    if (p < examples) print_path(x, &t, rec_vc, rec_vm, dir_vc, dir_vm);
  }
  if (dev.paths) dev.vm_share /= dev.paths;
  return dev;
}

static const double weight_tolerance = 1e-3; /* relative, per weight: float recursion */
static const double sum_tolerance = 1e-4;

static void check_algorithm(const path_set *set, const char *family, vf_algorithm a, const double *etas, int num_etas,
                            int examples) {
  for (int e = 0; e < num_etas; e++) {
    deviation dev = check_set(set, a, etas[e], e == 0 ? examples : 0);
    printf("  %-4s %-9s eta %-6g: %4d paths, max |sum - 1| %.2e, max rel. weight deviation %.2e, mean VM share %.3f\n",
           vf_algorithm_name(a), family, etas[e], dev.paths, dev.max_sum_dev, dev.max_rel_dev, dev.vm_share);
    CHECK(dev.paths > 100);
    CHECK_NEAR(dev.max_sum_dev, 0.0, sum_tolerance);
    if (!(dev.max_rel_dev <= weight_tolerance)) {
      const full_path *x = &set->paths[dev.worst_path];
      printf("  worst: path %d (k = %d), %s s = %d: recursive %.9g, eq. 12 %.9g\n", dev.worst_path, x->k,
             technique_label(dev.worst_is_vm), dev.worst_s, dev.worst_rec, dev.worst_dir);
      path_data pd;
      technique_set t;
      double rv[MAX_VERTICES + 1], rm[MAX_VERTICES + 1], dv[MAX_VERTICES + 1], dm[MAX_VERTICES + 1];
      double path_eta = etas[e] * path_eta_scale(dev.worst_path);
      vf_mis_config c_light = config_for(a, light_eta(etas[e]), g_scene.n_light);
      vf_mis_config c = config_for(a, path_eta, path_light_paths(dev.worst_path));
      prepare_path(&g_scene, x, &pd);
      implemented_techniques(x, a, g_scene.spot != NULL, &t);
      recursive_weights(&g_scene, x, &pd, &c_light, &c, &t, rv, rm);
      direct_weights(x, &pd, &t, path_eta, path_light_paths(dev.worst_path), dv, dm);
      print_path(x, &t, rv, rm, dv, dm);
    }
    CHECK_NEAR(dev.max_rel_dev, 0.0, weight_tolerance);
  }
}

/* eta_VCM = pi r^2 n_light spans the range where merging and connections trade places:
 * r = sqrt(eta / (pi n_light)), about 1e-4 .. 1e-2 scene units at 512 x 512. */
static const double etas[] = {1.0, 0.01, 100.0};
#define NUM_ETAS ((int)(sizeof etas / sizeof *etas))

static void test_path_sets_are_large_enough(void) {
  printf("  %d paths without specular vertices, %d with one\n", g_diffuse.count, g_specular.count);
  CHECK(g_diffuse.count >= 1000);
  CHECK(g_specular.count >= 200);
  int by_length[MAX_VERTICES] = {0};
  for (int p = 0; p < g_diffuse.count; p++) by_length[g_diffuse.paths[p].k]++;
  for (int k = 2; k <= MAX_SEGMENTS; k++) CHECK(by_length[k] >= 50);
  /* The specular vertex next to the light, next to the camera, and in between. */
  int at_light = 0, at_camera = 0, inside = 0, camera_sees_light_via_mirror = 0;
  for (int p = 0; p < g_specular.count; p++) {
    const full_path *x = &g_specular.paths[p];
    at_light += x->specular[1];
    at_camera += x->specular[x->k - 1];
    inside += !x->specular[1] && !x->specular[x->k - 1];
    camera_sees_light_via_mirror += x->k == 2;
  }
  printf("  specular vertex at x_1: %d, at x_{k-1}: %d, elsewhere: %d; light seen in a ball: %d\n", at_light,
         at_camera, inside, camera_sees_light_via_mirror);
  CHECK(at_light >= 50 && at_camera >= 50 && inside >= 50);
}

/* upg: the techniques of vcm, its merges weighted as gatherings, preferring either side. */
static void check_upg(const path_set *set, const char *family, const double *e, int num_etas) {
  for (g_upg = 1; g_upg <= 2; g_upg++) {
    printf("  upg gathering from the %s's side where both can\n", g_upg == 1 ? "light" : "camera");
    check_algorithm(set, family, VF_ALGO_UPG, e, num_etas, 0);
  }
  g_upg = 0;
}

static void test_upg_weights_match_eq12(void) {
  check_upg(&g_diffuse, "diffuse", etas, NUM_ETAS);
  check_upg(&g_specular, "specular", etas, NUM_ETAS);
}

static void test_vcm_weights_match_eq12_without_specular_vertices(void) {
  check_algorithm(&g_diffuse, "diffuse", VF_ALGO_VCM, etas, NUM_ETAS, 2);
}

static void test_vcm_weights_match_eq12_with_one_specular_vertex(void) {
  check_algorithm(&g_specular, "specular", VF_ALGO_VCM, etas, NUM_ETAS, 2);
}

static void test_bpt_weights_match_eq12(void) {
  check_algorithm(&g_diffuse, "diffuse", VF_ALGO_BPT, etas, 1, 0);
  check_algorithm(&g_specular, "specular", VF_ALGO_BPT, etas, 1, 0);
}

static void test_bpm_weights_match_eq12(void) {
  check_algorithm(&g_diffuse, "diffuse", VF_ALGO_BPM, etas, NUM_ETAS, 0);
  check_algorithm(&g_specular, "specular", VF_ALGO_BPM, etas, 1, 0);
}

static void test_pt_weights_match_eq12(void) {
  check_algorithm(&g_diffuse, "diffuse", VF_ALGO_PT, etas, 1, 0);
  check_algorithm(&g_specular, "specular", VF_ALGO_PT, etas, 1, 0);
}

/* With one light the selection probability is 1; it enters every technique but emission
 * hits (p(x_0) = pick / area for emission and light sampling alike), so make it matter. */
static void test_vcm_weights_match_eq12_with_light_selection(void) {
  vf_light *l = &g_scene.lights->lights[g_scene.light - g_scene.lights->lights];
  float pick = l->pick_probability;
  l->pick_probability = 0.2f;
  check_algorithm(&g_diffuse, "diffuse", VF_ALGO_VCM, etas, 1, 0);
  check_algorithm(&g_specular, "specular", VF_ALGO_VCM, etas, 1, 0);
  check_algorithm(&g_diffuse, "diffuse", VF_ALGO_PT, etas, 1, 0);
  l->pick_probability = pick;
}

/* The power heuristic (--mis-beta, paper eq. 10): the same recursion with every density
 * ratio raised to beta must give w_i = (n_i p_i)^beta / sum_j (n_j p_j)^beta, and still sum
 * to 1, for every algorithm that combines techniques. */
static void check_power_heuristic(const char *family, int with_specular) {
  static const double betas[] = {2.0, 3.0};
  for (size_t b = 0; b < sizeof betas / sizeof *betas; b++) {
    g_beta = betas[b];
    printf("  beta %g\n", g_beta);
    check_algorithm(&g_diffuse, family, VF_ALGO_VCM, etas, NUM_ETAS, 0);
    if (with_specular) check_algorithm(&g_specular, "specular", VF_ALGO_VCM, etas, 1, 0);
    check_algorithm(&g_diffuse, family, VF_ALGO_BPT, etas, 1, 0);
    check_algorithm(&g_diffuse, family, VF_ALGO_BPM, etas, 1, 0);
    check_upg(&g_diffuse, family, etas, 1);
    check_algorithm(&g_diffuse, family, VF_ALGO_PT, etas, 1, 0);
  }
  g_beta = 1.0;
}

static void test_power_heuristic_weights_match_eq12(void) { check_power_heuristic("diffuse", 1); }

/* Radii differing between pixels: every algorithm's weights, with and without a specular
 * vertex, and the power heuristic. */
static void test_weights_match_eq12_with_a_radius_per_pixel(void) {
  g_pixel_radii = 1;
  check_algorithm(&g_diffuse, "diffuse", VF_ALGO_VCM, etas, NUM_ETAS, 0);
  check_algorithm(&g_specular, "specular", VF_ALGO_VCM, etas, NUM_ETAS, 0);
  check_algorithm(&g_diffuse, "diffuse", VF_ALGO_BPM, etas, 1, 0);
  check_upg(&g_diffuse, "diffuse", etas, 1);
  check_upg(&g_specular, "specular", etas, 1);
  g_beta = 2.0;
  check_algorithm(&g_diffuse, "diffuse", VF_ALGO_VCM, etas, 1, 0);
  g_beta = 1.0;
  g_pixel_radii = 0;
}

/* Single-stage vcm: each camera sub-path merges with the light vertices of the iteration
 * before, whose quantities were formed under that iteration's radius; its weights, formed
 * with this iteration's radius (the stored c_vc and c_vm are radius-free, tech. rep. sec.
 * 6.1), still match eq. 12 and sum to 1: with the global radius and radii per pixel, with
 * and without a specular vertex, under the power heuristic. */
static void test_weights_match_eq12_single_stage(void) {
  g_single_stage = 1;
  for (g_pixel_radii = 0; g_pixel_radii <= 1; g_pixel_radii++) {
    check_algorithm(&g_diffuse, "diffuse", VF_ALGO_VCM, etas, NUM_ETAS, 0);
    check_algorithm(&g_specular, "specular", VF_ALGO_VCM, etas, NUM_ETAS, 0);
  }
  g_pixel_radii = 0;
  g_beta = 2.0;
  check_algorithm(&g_diffuse, "diffuse", VF_ALGO_VCM, etas, 1, 0);
  g_beta = 1.0;
  g_single_stage = 0;
}

/* --light-path-pixels N: n_light is the number of blocks of N pixels, not of pixels (the
 * renderer's vf_vcm.num_light_paths), in light tracing's weight, the camera's d_vcm and
 * eta = pi r^2 n_light alike: the weights still match eq. 12 and sum to 1, two-stage and
 * single-stage, for vcm and bpt, at 8 and 1024 pixels a light sub-path. */
static void test_weights_match_eq12_with_fewer_light_paths_than_pixels(void) {
  double pixels = g_scene.n_light;
  const double shares[] = {8.0, 1024.0};
  for (int i = 0; i < 2; i++) {
    g_scene.n_light = ceil(pixels / shares[i]);
    printf("  n_light = pixels / %g\n", shares[i]);
    check_algorithm(&g_diffuse, "diffuse", VF_ALGO_VCM, etas, NUM_ETAS, 0);
    check_algorithm(&g_specular, "specular", VF_ALGO_VCM, etas, NUM_ETAS, 0);
    check_algorithm(&g_diffuse, "diffuse", VF_ALGO_BPT, etas, 1, 0);
    g_single_stage = 1;
    check_algorithm(&g_diffuse, "diffuse", VF_ALGO_VCM, etas, NUM_ETAS, 0);
    check_algorithm(&g_specular, "specular", VF_ALGO_VCM, etas, NUM_ETAS, 0);
    g_single_stage = 0;
  }
  g_scene.n_light = pixels;
}

/* --pilot: pixels of 1 to 16 camera sub-paths an iteration; vcm and bpt (pt has no light
 * tracing to weigh against), with and without a specular vertex, with radii per pixel,
 * under the power heuristic. */
static void test_weights_match_eq12_with_camera_sub_paths_allocated_per_pixel(void) {
  g_pixel_samples = 1;
  for (g_pixel_radii = 0; g_pixel_radii <= 1; g_pixel_radii++) {
    check_algorithm(&g_diffuse, "diffuse", VF_ALGO_VCM, etas, NUM_ETAS, 0);
    check_algorithm(&g_specular, "specular", VF_ALGO_VCM, etas, NUM_ETAS, 0);
  }
  g_pixel_radii = 0;
  check_algorithm(&g_diffuse, "diffuse", VF_ALGO_BPT, etas, 1, 0);
  check_algorithm(&g_specular, "specular", VF_ALGO_BPT, etas, 1, 0);
  check_algorithm(&g_diffuse, "diffuse", VF_ALGO_PT, etas, 1, 0);
  g_beta = 2.0;
  check_algorithm(&g_diffuse, "diffuse", VF_ALGO_VCM, etas, 1, 0);
  check_algorithm(&g_diffuse, "diffuse", VF_ALGO_BPT, etas, 1, 0);
  g_beta = 1.0;
  g_pixel_samples = 0;
}

static void test_power_heuristic_weights_match_eq12_through_rough_lobes(void) { check_power_heuristic("rough", 0); }

/* The rough family's vertices by lobe: on the gold ball, reflecting off and refracting
 * through the glass ball (the path's neighbours on one side of its surface, or on both),
 * on the glTF floor. */
static void test_rough_paths_reach_every_rough_lobe(void) {
  int gold = 0, glass_reflect = 0, glass_refract = 0, floor = 0;
  for (int p = 0; p < g_diffuse.count; p++) {
    const full_path *x = &g_diffuse.paths[p];
    for (int i = 1; i < x->k; i++) {
      const vf_material *m = x->material[i];
      double before = vf_dot(x->normal[i], vf_sub(x->position[i - 1], x->position[i]));
      double after = vf_dot(x->normal[i], vf_sub(x->position[i + 1], x->position[i]));
      if (strcmp(m->name, "gold") == 0) gold++;
      else if (strcmp(m->name, "frosted glass") == 0) *(before * after < 0.0 ? &glass_refract : &glass_reflect) += 1;
      else if (m->gltf) floor++;
    }
  }
  printf("  %d paths; vertices on the rough gold %d, reflecting off the rough glass %d, refracting through it %d, "
         "on the glTF floor %d\n",
         g_diffuse.count, gold, glass_reflect, glass_refract, floor);
  CHECK(g_diffuse.count >= 1000);
  CHECK_INT_EQ(g_specular.count, 0);
  CHECK(gold >= 100 && glass_reflect >= 30 && glass_refract >= 100 && floor >= 100);
}

static void test_weights_match_eq12_through_rough_lobes(void) {
  check_algorithm(&g_diffuse, "rough", VF_ALGO_VCM, etas, NUM_ETAS, 2);
  check_algorithm(&g_diffuse, "rough", VF_ALGO_BPT, etas, 1, 0);
  check_algorithm(&g_diffuse, "rough", VF_ALGO_BPM, etas, 1, 0);
  check_algorithm(&g_diffuse, "rough", VF_ALGO_PT, etas, 1, 0);
  check_upg(&g_diffuse, "rough", etas, NUM_ETAS);
}

/* The feature family's vertices: on the smooth balls (shading normals), on the textured
 * floor and glTF ball, on the normal-mapped back wall, and paths that pass a cut-out
 * grating's hole (a segment crossing its plane inside its square). */
static void test_feature_paths_reach_every_feature(void) {
  int smooth = 0, textured = 0, mapped = 0, through_holes = 0;
  const vf_scene *sc = g_scene.scene;
  for (int p = 0; p < g_diffuse.count; p++) {
    const full_path *x = &g_diffuse.paths[p];
    for (int i = 1; i < x->k; i++) {
      const vf_shape *sh = &sc->shapes[x->shape[i]];
      const vf_material *m = &sc->materials[sh->material];
      smooth += sh->normals != NULL;
      textured += m->textures[VF_TEXTURE_COLOR].texture != 0;
      mapped += m->textures[VF_TEXTURE_NORMAL].texture != 0;
    }
    for (int i = 0; i < x->k; i++) {
      vf_vec3 a = x->position[i], b = x->position[i + 1];
      if ((a.y - 0.5f) * (b.y - 0.5f) >= 0.0f) continue;
      float t = (0.5f - a.y) / (b.y - a.y), px = a.x + t * (b.x - a.x), pz = a.z + t * (b.z - a.z);
      through_holes += fabsf(px) < 0.6f && fabsf(pz) < 0.6f;
    }
  }
  printf("  %d paths; vertices on smooth meshes %d, textured %d, normal-mapped %d; segments through the grating's "
         "holes %d\n",
         g_diffuse.count, smooth, textured, mapped, through_holes);
  CHECK(g_diffuse.count >= 1000);
  CHECK(smooth >= 100 && textured >= 100 && mapped >= 100 && through_holes >= 100);
}

static void test_weights_match_eq12_through_shaded_and_textured_vertices(void) {
  check_algorithm(&g_diffuse, "features", VF_ALGO_VCM, etas, NUM_ETAS, 2);
  check_algorithm(&g_diffuse, "features", VF_ALGO_BPT, etas, 1, 0);
  check_algorithm(&g_diffuse, "features", VF_ALGO_BPM, etas, 1, 0);
  check_algorithm(&g_diffuse, "features", VF_ALGO_PT, etas, 1, 0);
  check_upg(&g_diffuse, "features", etas, NUM_ETAS);
}

/* Loads scene `name` into g_scene and walks its path sets; 0 when it cannot be loaded. */
static int walk_scene(const char *name, vf_light_kind light) {
  if (load_test_scene(&g_scene, name, light) != VF_OK) return 0;
  printf("%s (%s, %s)\n", name,
         g_scene.camera.pixel_size > 0.0f ? "orthographic" : g_scene.camera.lens_radius > 0.0f ? "thin lens" : "pinhole",
         g_scene.spot ? "spot light" : "area light");
  g_diffuse.count = g_specular.count = 0;
  for (uint64_t w = 0; w < WALKS; w++) {
    walk_numbers rng = {.pair = 0};
    if (walk_sampler == VF_SAMPLER_INDEPENDENT)
      vf_sampler_start(&rng.s, walk_sampler, 20240611u, 0, w, VF_STREAM_TEST);
    else /* the walks from the light and from the camera each a sequence over their index */
      vf_sampler_start(&rng.s, walk_sampler, 20240611u, w / 2 * VF_SOBOL_REPLICATES, w % 2, VF_STREAM_TEST);
    if (w % 2 == 0) walk_from_light(&g_scene, &rng, &g_diffuse, &g_specular);
    else walk_from_camera(&g_scene, &rng, &g_diffuse, &g_specular);
  }
  return 1;
}

/* The pinhole, the thin lens and the orthographic camera with an area light, the pinhole
 * with a spot. */
static const struct {
  const char *name;
  vf_light_kind light;
} test_scenes[] = {{"cornell", VF_LIGHT_AREA_MESH},
                   {"cornell-dof", VF_LIGHT_AREA_MESH},
                   {"cornell-ortho", VF_LIGHT_AREA_MESH},
                   {"cornell-spot", VF_LIGHT_SPOT}};

int main(void) {
  for (int k = 0; k < VF_SAMPLER_COUNT_; k++) {
    walk_sampler = (vf_sampler_kind)k;
    printf("sampler %s\n", vf_sampler_name(walk_sampler));
    for (size_t i = 0; i < sizeof test_scenes / sizeof *test_scenes; i++) {
      if (!walk_scene(test_scenes[i].name, test_scenes[i].light)) return 1;
      RUN(test_path_sets_are_large_enough);
      RUN(test_vcm_weights_match_eq12_without_specular_vertices);
      RUN(test_vcm_weights_match_eq12_with_one_specular_vertex);
      RUN(test_bpt_weights_match_eq12);
      RUN(test_bpm_weights_match_eq12);
      RUN(test_pt_weights_match_eq12);
      RUN(test_vcm_weights_match_eq12_with_light_selection);
      RUN(test_upg_weights_match_eq12);
      RUN(test_power_heuristic_weights_match_eq12);
      RUN(test_weights_match_eq12_with_a_radius_per_pixel);
      RUN(test_weights_match_eq12_single_stage);
      RUN(test_weights_match_eq12_with_fewer_light_paths_than_pixels);
      RUN(test_weights_match_eq12_with_camera_sub_paths_allocated_per_pixel);
      destroy_test_scene(&g_scene);
    }
    if (!walk_scene("cornell-rough", VF_LIGHT_AREA_MESH)) return 1;
    RUN(test_rough_paths_reach_every_rough_lobe);
    RUN(test_weights_match_eq12_through_rough_lobes);
    RUN(test_power_heuristic_weights_match_eq12_through_rough_lobes);
    destroy_test_scene(&g_scene);
    if (!walk_scene("features", VF_LIGHT_AREA_MESH)) return 1;
    RUN(test_feature_paths_reach_every_feature);
    RUN(test_weights_match_eq12_through_shaded_and_textured_vertices);
    destroy_test_scene(&g_scene);
  }
  return check_finish();
}
