/* The recursive MIS quantities of vertex connection and merging.
 *
 * Every sub-path vertex carries three numbers, d_vcm, d_vc and d_vm (tech. rep. sec. 4,
 * eq. 31-36). They hold the partial sums of pdf ratios of every technique that could have
 * produced the sub-path up to that vertex, so that when a light vertex y_{s-1} and a camera
 * vertex z_{t-1} are connected or merged, the full path's balance-heuristic weight
 *   w = 1 / (w_light + 1 + w_camera)                                        (eq. 37)
 * follows from the two vertices alone, without walking the paths again.
 *
 * The quantities are updated in two steps per vertex, both here:
 *   - when a ray of length dist hits vertex i with |cos| cos_fix, the forward area density
 *     1 / p_i gains dist^2 / cos_fix (the first factor of eq. 34-36);
 *   - when direction i -> i+1 is sampled with solid-angle density pdf_w and reverse density
 *     rev_pdf_w, the bracketed terms of eq. 35-36 are formed and d_vcm becomes 1 / pdf_w;
 *     a specular choice instead zeroes d_vcm and scales the others by cos (eq. 53-55).
 * The techniques an algorithm lacks are removed by zeroing their factors: BPT sets the
 * merging factor eta_VCM to zero (sec. 5.5), BPM the connection factor 1 / eta_VCM (5.6),
 * and path tracing keeps only emission hits and next-event estimation.
 *
 * The vertices store d_vcm and the radius-free c_vc and c_vm of the report's section 6.1
 * (eq. 56-61) in place of d_vc and d_vm, which follow from them and eta_VCM when a weight
 * is formed (eq. 62-63, vf_mis_d_vc and vf_mis_d_vm):
 *   d_vc = c_vc + mis(eta_VCM) c_vm,   d_vm = mis(1 / eta_VCM) c_vc + c_vm,
 * so that the merge radius, and with it eta_VCM = pi r^2 n_light, can be chosen per camera
 * sub-path (--radius per-pixel): every technique that samples a full path then weighs it
 * with the radius of the path's pixel, and the weights still sum to one (sec. 6.1). The
 * recursion is the same linear map as eq. 35-36 split by its dependence on eta_VCM: with
 * the factors of a missing technique zeroed, d_vc and d_vm are exactly the report's.
 *
 * vf_mis_pow() is the heuristic's exponent applied to each density ratio (the report's
 * mis() of eq. 12 and 31-47): beta = 1 is the balance heuristic, as the report derives
 * the scheme; any beta >= 1 is the power heuristic (paper eq. 10), exact in the recursion
 * because every quantity is a sum of products of density ratios, and a product's power is
 * the product of its factors' powers. --mis-beta chooses it (common/settings.h). All
 * functions are pure, so the test suite drives the same code over hand-built paths
 * (tests/worker/render/test_mis.c). */
#ifndef VF_MIS_H
#define VF_MIS_H

#include <math.h>

typedef struct {
  float d_vcm, c_vc, c_vm; /* eq. 59-61 */
} vf_mis;

/* The weights' constants. vm_weight and vc_weight depend on the merge radius: with a radius
 * per pixel, each camera sub-path and each projection onto the image has its own copy. */
typedef struct {
  float vm_weight; /* mis(eta_VCM) when merging takes part in the weights, else 0 */
  float vc_weight; /* mis(1 / eta_VCM) when connections take part, else 0 */
  float light_paths; /* n_light: light sub-paths per iteration (one per pixel) */
  float beta;      /* the heuristic's exponent: 1 balance, 2 and more power */
  int pt;          /* path tracing: only emission hits (s = 0) and light sampling (s = 1) */
} vf_mis_config;

/* mis(x) = x^beta, the heuristic applied to one density ratio. The balance heuristic, the
 * default, is x itself; beta = 2 a product. */
static inline float vf_mis_pow(float x, float beta) {
  if (beta == 1.0f) return x;
  if (beta == 2.0f) return x * x;
  return powf(x, beta);
}
static inline float vf_mis_h(const vf_mis_config *c, float x) { return vf_mis_pow(x, c->beta); }

/* d_vc and d_vm of a vertex for the radius of c (tech. rep. eq. 62-63). */
static inline float vf_mis_d_vc(const vf_mis *m, const vf_mis_config *c) { return m->c_vc + c->vm_weight * m->c_vm; }
static inline float vf_mis_d_vm(const vf_mis *m, const vf_mis_config *c) { return c->vc_weight * m->c_vc + m->c_vm; }

/* Light sub-path start, y0 (eq. 31-33; point and directional lights eq. 48-50; infinite
 * lights sec. 5.1). Densities include the light-selection probability. */
static inline void vf_mis_light_start(vf_mis *m, const vf_mis_config *c, float direct_pdf_a, float emission_pdf_w,
                                      float cos_light, int is_delta, int is_finite) {
  m->d_vcm = vf_mis_h(c, direct_pdf_a / emission_pdf_w);
  m->c_vc = is_delta ? 0.0f : vf_mis_h(c, (is_finite ? cos_light : 1.0f) / emission_pdf_w); /* eq. 57 */
  m->c_vm = 0.0f;                                                                            /* eq. 58 */
}

/* Camera sub-path start, z0 (eq. 31-33, eye side): d_vcm = n_light / p(z1) in solid angle. */
static inline void vf_mis_camera_start(vf_mis *m, const vf_mis_config *c, float camera_pdf_w) {
  m->d_vcm = vf_mis_h(c, c->light_paths / camera_pdf_w);
  m->c_vc = 0.0f;
  m->c_vm = 0.0f;
}

/* A sub-path's ray of length dist found vertex i with |cos| cos_fix against its normal.
 * Infinite lights have no distance factor on their first segment (sec. 5.1). */
static inline void vf_mis_hit(vf_mis *m, const vf_mis_config *c, float dist, float cos_fix, int apply_distance) {
  if (apply_distance) m->d_vcm *= vf_mis_h(c, dist * dist);
  float inv = 1.0f / vf_mis_h(c, cos_fix);
  m->d_vcm *= inv;
  m->c_vc *= inv;
  m->c_vm *= inv;
}

/* vf_mis_hit through participating media (worker/render/segment.h): the segment's distance
 * densities join the cosines of its ends. fwd is the density of sampling vertex i's
 * distance from vertex i-1 (a medium vertex: scattering there; a surface: passing every
 * medium in between), rev the same for vertex i-1 seen from vertex i, which belongs with
 * the reverse cosine vf_mis_scatter gave c_vc and c_vm. A medium vertex's cos_fix is 1. */
static inline void vf_mis_hit_media(vf_mis *m, const vf_mis_config *c, float dist, float cos_fix, int apply_distance,
                                    float fwd, float rev) {
  if (apply_distance) m->d_vcm *= vf_mis_h(c, dist * dist);
  float inv = 1.0f / vf_mis_h(c, cos_fix * fwd);
  float r = vf_mis_h(c, rev);
  m->d_vcm *= inv;
  m->c_vc *= inv * r;
  m->c_vm *= inv * r;
}

/* A camera sub-path's ray left the scene through media, with probability fwd of passing
 * them and rev the density of the previous vertex from the far side: what vf_mis_hit_media
 * does without a vertex, before an environment light's weight. */
static inline void vf_mis_escape(vf_mis *m, const vf_mis_config *c, float fwd, float rev) {
  vf_mis_hit_media(m, c, 1.0f, 1.0f, 0, fwd, rev);
}

/* Direction sampled at vertex i (eq. 59-61, the radius-free form of eq. 34-36; or 53-55
 * for a specular choice). Independent of the merge radius. */
static inline void vf_mis_scatter_at(vf_mis *m, const vf_mis_config *c, float cos_gen, float pdf_w,
                                     float rev_pdf_w, int specular, float merge_here);
static inline void vf_mis_scatter(vf_mis *m, const vf_mis_config *c, float cos_gen, float pdf_w, float rev_pdf_w,
                                  int specular) {
  vf_mis_scatter_at(m, c, cos_gen, pdf_w, rev_pdf_w, specular, 1.0f);
}

/* vf_mis_scatter at a vertex where merging takes part with merge_here times a surface
 * vertex's weight (1 on surfaces; 0 at a medium vertex, where nothing merges). */
static inline void vf_mis_scatter_at(vf_mis *m, const vf_mis_config *c, float cos_gen, float pdf_w,
                                     float rev_pdf_w, int specular, float merge_here) {
  if (specular) {
    m->d_vcm = 0.0f;
    m->c_vc *= vf_mis_h(c, cos_gen);
    m->c_vm *= vf_mis_h(c, cos_gen);
    return;
  }
  float g = vf_mis_h(c, cos_gen / pdf_w);
  m->c_vc = c->pt ? 0.0f : g * (m->c_vc * vf_mis_h(c, rev_pdf_w) + m->d_vcm); /* eq. 60 */
  m->c_vm = c->pt ? 0.0f : g * (m->c_vm * vf_mis_h(c, rev_pdf_w) + merge_here); /* eq. 61 */
  m->d_vcm = vf_mis_h(c, 1.0f / pdf_w);
}

/* s = 0: the camera sub-path hit a light (eq. 42-43). Densities include light selection. */
static inline float vf_mis_weight_emission(const vf_mis *cam, const vf_mis_config *c, float direct_pdf_a,
                                            float emission_pdf_w) {
  float w_camera = vf_mis_h(c, direct_pdf_a) * cam->d_vcm + vf_mis_h(c, emission_pdf_w) * vf_mis_d_vc(cam, c);
  return 1.0f / (1.0f + w_camera);
}

/* s = 1: next-event estimation from camera vertex z_{t-1} (eq. 44-45). bsdf_dir_pdf_w must
 * be 0 for delta lights (they cannot be hit); light densities include light selection. */
static inline float vf_mis_weight_light_sample_at(const vf_mis *cam, const vf_mis_config *c, float bsdf_dir_pdf_w,
                                                  float bsdf_rev_pdf_w, float direct_pdf_w, float emission_pdf_w,
                                                  float cos_to_light, float cos_at_light, float vm_camera) {
  float w_light = vf_mis_h(c, bsdf_dir_pdf_w / direct_pdf_w);
  float w_camera = c->pt ? 0.0f
                         : vf_mis_h(c, emission_pdf_w * cos_to_light / (direct_pdf_w * cos_at_light)) *
                               (vm_camera + cam->d_vcm + vf_mis_d_vc(cam, c) * vf_mis_h(c, bsdf_rev_pdf_w));
  return 1.0f / (w_light + 1.0f + w_camera);
}
static inline float vf_mis_weight_light_sample(const vf_mis *cam, const vf_mis_config *c, float bsdf_dir_pdf_w,
                                               float bsdf_rev_pdf_w, float direct_pdf_w, float emission_pdf_w,
                                               float cos_to_light, float cos_at_light) {
  return vf_mis_weight_light_sample_at(cam, c, bsdf_dir_pdf_w, bsdf_rev_pdf_w, direct_pdf_w, emission_pdf_w,
                                       cos_to_light, cos_at_light, c->vm_weight);
}

/* t = 1: light vertex y_{s-1} projected onto the camera (eq. 46-47). camera_pdf_a is the
 * camera's density of generating y_{s-1}, in area measure at y_{s-1}. */
static inline float vf_mis_weight_camera_connection_at(const vf_mis *light, const vf_mis_config *c,
                                                       float camera_pdf_a, float bsdf_rev_pdf_w, float vm_light) {
  float w_light = vf_mis_h(c, camera_pdf_a / c->light_paths) *
                  (vm_light + light->d_vcm + vf_mis_d_vc(light, c) * vf_mis_h(c, bsdf_rev_pdf_w));
  return 1.0f / (w_light + 1.0f);
}
static inline float vf_mis_weight_camera_connection(const vf_mis *light, const vf_mis_config *c, float camera_pdf_a,
                                                    float bsdf_rev_pdf_w) {
  return vf_mis_weight_camera_connection_at(light, c, camera_pdf_a, bsdf_rev_pdf_w, c->vm_weight);
}

/* s > 1, t > 1: connection of y_{s-1} and z_{t-1} (eq. 40-41). *_dir_pdf_a are each side's
 * density of sampling the other vertex, converted to area measure there. */
static inline float vf_mis_weight_connection_at(const vf_mis *light, const vf_mis *cam, const vf_mis_config *c,
                                                float camera_dir_pdf_a, float light_dir_pdf_a, float light_rev_pdf_w,
                                                float camera_rev_pdf_w, float vm_light, float vm_camera) {
  float w_light = vf_mis_h(c, camera_dir_pdf_a) *
                  (vm_light + light->d_vcm + vf_mis_d_vc(light, c) * vf_mis_h(c, light_rev_pdf_w));
  float w_camera = vf_mis_h(c, light_dir_pdf_a) *
                   (vm_camera + cam->d_vcm + vf_mis_d_vc(cam, c) * vf_mis_h(c, camera_rev_pdf_w));
  return 1.0f / (w_light + 1.0f + w_camera);
}
static inline float vf_mis_weight_connection(const vf_mis *light, const vf_mis *cam, const vf_mis_config *c,
                                             float camera_dir_pdf_a, float light_dir_pdf_a, float light_rev_pdf_w,
                                             float camera_rev_pdf_w) {
  return vf_mis_weight_connection_at(light, cam, c, camera_dir_pdf_a, light_dir_pdf_a, light_rev_pdf_w,
                                     camera_rev_pdf_w, c->vm_weight, c->vm_weight);
}

/* s > 1, t > 1: merging y_{s-1} into z_{t-1} (eq. 38-39). camera_dir_pdf_w: the camera
 * BSDF's density of the light vertex's incoming direction; camera_rev_pdf_w the reverse. */
static inline float vf_mis_weight_merge(const vf_mis *light, const vf_mis *cam, const vf_mis_config *c,
                                        float camera_dir_pdf_w, float camera_rev_pdf_w) {
  float w_light = light->d_vcm * c->vc_weight + vf_mis_d_vm(light, c) * vf_mis_h(c, camera_dir_pdf_w);
  float w_camera = cam->d_vcm * c->vc_weight + vf_mis_d_vm(cam, c) * vf_mis_h(c, camera_rev_pdf_w);
  return 1.0f / (w_light + 1.0f + w_camera);
}

/* Merging y_{s-1} into z_{t-1} at a point in a medium (volume_merging.h): eq. (38)-(39)
 * relative to the merge's own eta_m = (4/3) pi r^3 n_light, the quantities counting every
 * merge in the units of a surface one; ratio = mis(eta_m / eta_s) = mis(4 r / 3). */
static inline float vf_mis_weight_merge_medium(const vf_mis *light, const vf_mis *cam, const vf_mis_config *c,
                                               float ratio, float camera_dir_pdf_w, float camera_rev_pdf_w) {
  float w_light = light->d_vcm * c->vc_weight + vf_mis_d_vm(light, c) * vf_mis_h(c, camera_dir_pdf_w);
  float w_camera = cam->d_vcm * c->vc_weight + vf_mis_d_vm(cam, c) * vf_mis_h(c, camera_rev_pdf_w);
  return 1.0f / ((w_light + w_camera) / ratio + 1.0f);
}

/* upg: light vertex y_{s-1}, found within the radius of camera vertex z_{t-1}, scored as
 * the connection of its predecessor y_{s-2} and z_{t-1} (photon_gathering.h). The weight is
 * merging's (eq. 38-39) for a light vertex that landed exactly at z_{t-1}: `light`, the
 * predecessor's quantities after its hit, scattered towards z_{t-1} (cos_light,
 * light_pdf_w and light_rev_pdf_w at the predecessor; `scatter` 0 for a light's own point,
 * whose vf_mis_light_start for that direction is `light` already) and hit there at
 * distance dist with |cos| cos_camera; then the camera side as vf_mis_weight_merge. */
static inline float vf_mis_weight_gather(vf_mis light, const vf_mis *cam, const vf_mis_config *c, int scatter,
                                         float cos_light, float light_pdf_w, float light_rev_pdf_w, float dist,
                                         float cos_camera, float camera_dir_pdf_w, float camera_rev_pdf_w) {
  if (scatter) vf_mis_scatter(&light, c, cos_light, light_pdf_w, light_rev_pdf_w, 0);
  vf_mis_hit(&light, c, dist, cos_camera, 1);
  return vf_mis_weight_merge(&light, cam, c, camera_dir_pdf_w, camera_rev_pdf_w);
}

/* upg from the camera's side: camera vertex z_{t-1} found light vertex y_{s-1} within the
 * radius, and the path is scored as the connection of y_{s-1} and z_{t-2}, z_{t-1}'s
 * predecessor. The weight is merging's at y_{s-1} for a camera vertex that landed there:
 * `cam`, z_{t-2}'s quantities after its hit, scattered towards y_{s-1} (cos_camera,
 * camera_pdf_w, camera_rev_pdf_w at z_{t-2}) and hit there (dist, |cos| cos_light); then
 * the light vertex's own quantities `light` with the densities of its BSDF seen from the
 * camera's side: light_dir_pdf_w of the light vertex's incoming direction given the one
 * towards z_{t-2}, light_rev_pdf_w the reverse. */
static inline float vf_mis_weight_gather_camera(const vf_mis *light, vf_mis cam, const vf_mis_config *c,
                                                float cos_camera, float camera_pdf_w, float camera_rev_pdf_w, float dist,
                                                float cos_light, float light_dir_pdf_w, float light_rev_pdf_w) {
  vf_mis_scatter(&cam, c, cos_camera, camera_pdf_w, camera_rev_pdf_w, 0);
  vf_mis_hit(&cam, c, dist, cos_light, 1);
  return vf_mis_weight_merge(light, &cam, c, light_dir_pdf_w, light_rev_pdf_w);
}

/* vf_mis_weight_gather through participating media (photon_gathering.h, "In media"): the
 * predecessor's scattering counts merge_here surface merges (vf_mis_scatter_at: 1 on a
 * surface, vf_vcm.medium_merge at a medium vertex), the hit at z_{t-1} takes the joined
 * segment's distance densities (vf_mis_hit_media: fwd of z_{t-1} from the predecessor, rev
 * of the predecessor from z_{t-1}), and a gathering at a point in a medium has merging's
 * weight there (vf_mis_weight_merge_medium with ratio = mis(4 r / 3); ratio 0: a surface).
 * Without media (fwd = rev = 1, merge_here 1, ratio 0) it is vf_mis_weight_gather. */
static inline float vf_mis_weight_gather_media(vf_mis light, const vf_mis *cam, const vf_mis_config *c, int scatter,
                                               float merge_here, float cos_light, float light_pdf_w,
                                               float light_rev_pdf_w, float dist, float cos_camera, float fwd,
                                               float rev, float ratio, float camera_dir_pdf_w,
                                               float camera_rev_pdf_w) {
  if (scatter) vf_mis_scatter_at(&light, c, cos_light, light_pdf_w, light_rev_pdf_w, 0, merge_here);
  vf_mis_hit_media(&light, c, dist, cos_camera, 1, fwd, rev);
  if (ratio > 0.0f) return vf_mis_weight_merge_medium(&light, cam, c, ratio, camera_dir_pdf_w, camera_rev_pdf_w);
  return vf_mis_weight_merge(&light, cam, c, camera_dir_pdf_w, camera_rev_pdf_w);
}

/* vf_mis_weight_gather_camera through participating media, as vf_mis_weight_gather_media:
 * z_{t-2}'s scattering counts merge_here surface merges, the hit at y_{s-1} takes fwd (of
 * y_{s-1} from z_{t-2}) and rev (of z_{t-2} from y_{s-1}), and ratio > 0 makes it merging's
 * weight at a point in a medium. */
static inline float vf_mis_weight_gather_camera_media(const vf_mis *light, vf_mis cam, const vf_mis_config *c,
                                                      float merge_here, float cos_camera, float camera_pdf_w,
                                                      float camera_rev_pdf_w, float dist, float cos_light, float fwd,
                                                      float rev, float ratio, float light_dir_pdf_w,
                                                      float light_rev_pdf_w) {
  vf_mis_scatter_at(&cam, c, cos_camera, camera_pdf_w, camera_rev_pdf_w, 0, merge_here);
  vf_mis_hit_media(&cam, c, dist, cos_light, 1, fwd, rev);
  if (ratio > 0.0f) return vf_mis_weight_merge_medium(light, &cam, c, ratio, light_dir_pdf_w, light_rev_pdf_w);
  return vf_mis_weight_merge(light, &cam, c, light_dir_pdf_w, light_rev_pdf_w);
}

#endif
