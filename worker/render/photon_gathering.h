/* Unbiased photon gathering (UPG): vertex merging without its bias.
 *
 * Vertex merging (vertex_merging.h) takes a light vertex y* found within r of camera
 * vertex x as if it were x: the path ...y_{s-1} y* ~ x z_{t-2}... is scored with the BSDF
 * at x for y*'s direction (thesis eq. 2.68) and with the acceptance probability of y*
 * landing near x approximated by p(y_{s-1} -> x) pi r^2 (eq. 2.59). Both approximations
 * are the bias of VCM, which shows in corners and along edges (thesis sec. 4.3).
 *
 * UPG (Qin, Sun, Hou, Ren and Zhou 2015; thesis sec. 2.4.3-2.4.6) keeps the event "a light
 * sub-path's vertex landed within r of x" as the sampling event but scores the path it
 * stands for exactly: y* is dropped, and its predecessor L = y_{s-1} is joined to x.
 *   - The path L -> x is a connection path: its contribution f is the connection's, with
 *     the true BSDFs at L and x, the geometry term and a visibility ray (eq. 2.67).
 *   - Its density is p(light sub-path to L) p(camera sub-path to x) p_acc, where p_acc is
 *     the probability that L's continuation lands within r of x (eq. 2.57):
 *       p_acc = integral over directions w of pdf_L(w) [the first hit along w lies within
 *               r of x on a surface where a light vertex is stored].
 *     p_acc has no closed form, but 1/p_acc has an unbiased estimator (eq. 2.61-2.62): the
 *     number of trials N of a Bernoulli process with success probability p_acc has
 *     E[N] = 1/p_acc.
 *   - Trials are made affordable by an angular bound (eq. 2.63-2.66). Every direction that
 *     can land within r of x lies in the cone C from L around L -> x of half-angle
 *     asin(r / |x - L|) (the whole sphere when L is within r). A trial draws w uniformly
 *     in C, accepts it with probability pdf_L(w) / M where M >= pdf_L over C, and succeeds
 *     when accepted and its ray lands as above. Its success probability is
 *     p_acc / (|C| M), so
 *       1/p_acc = E[N] / p_b,   p_b = |C| M                              (eq. 2.63-2.64)
 *     is exact for any bound M: the thesis needs the integral of pdf_L over C in closed
 *     form (derived only for Lambertian and Phong lobes), this scheme only a bound of pdf_L
 *     over C, which every lobe has (vf_upg_bound). A looser bound costs pdf evaluations,
 *     not rays: rays are traced for accepted directions only, on average
 *     P(C) / p_acc of them per gathering, P(C) the lobe's probability of C, whatever M.
 *   - The expected number of trials of a gathering is |C| M / p_acc, and gatherings of the
 *     pair (L, x) happen with probability p_acc: the expected work per pair is |C| M,
 *     bounded however small p_acc is.
 *   - When the cone's trials would number more than the sub-path's own draws (|C| M >= 1: a
 *     wide cone, L close to x, or a loose bound), the trials are the draws instead: the
 *     continuation sampled as the sub-path samples it (roulette, lobe, direction), failing
 *     at once when it ends, is specular or leaves C; then E[N] = 1/p_acc with no bound at
 *     all (vf_upg_inverse_acceptance_draws). Either estimator is exact; the choice depends
 *     on L and x alone.
 *
 * The estimate of a gathering is therefore
 *     w_VM f(L -> x) / (p_L p_x) * N / p_b / n_light
 * with p_L and p_x folded into the sub-paths' throughputs. The MIS weight w_VM is VCM's
 * merge weight for a light vertex that landed exactly at x from L (L's quantities
 * scattered towards x and hit at x, as a connection forms them): every technique's weight
 * then uses the same approximate acceptance density p(L -> x) pi r^2, so the weights of the
 * techniques that sample a path still sum to one, and an unbiased estimate of each
 * technique stays unbiased after weighting (thesis sec. 2.4.6; Veach's condition, eq. 2.10).
 * The thesis clamps the approximate density to 1 in the weights (eq. 2.80-2.82); that
 * changes only how well the weights are chosen, not the sum, and is not done here.
 *
 * The same works from the camera's side (the thesis's UPG*): the camera vertex x found
 * near light vertex y is dropped and x's predecessor C on the camera sub-path is joined to
 * y, with 1/p_acc of C's continuation landing within r of y on a surface where a camera
 * vertex gathers (thesis eq. 2.56). It samples the same paths with the same approximate
 * density, so its weight is merging's at y (vf_mis_weight_gather_camera).
 *
 * Which side joins is decided by the path, so that each path is estimated once
 * (gathering_pass.c): the light's side cannot join where y was reached by an ideal
 * specular choice at L (a delta lobe is zero for any fixed direction, thesis sec. 2.4.4)
 * or L is the point of a directional or environment light (at infinity); the camera's side
 * cannot where x was reached by an ideal specular choice or C is the lens. A path either
 * side can join goes to the side --gather-from prefers, a path one side can join to that
 * side, and a path neither can join (a caustic seen directly, or through a mirror) is
 * merged as VCM merges it and counted (vf_vcm_stats.upg_fallbacks, which the film keeps as
 * biased_merges): the estimate is then biased on those paths, as VCM is. A scene without delta lobes and lights at infinity has
 * none; vf_vcm_describe says which a scene has.
 *
 * In media (a scene with participating media: medium.h, segment.h; vcm merges at medium
 * vertices with UPBP's point-point estimator, volume_merging.h). A camera vertex x in a
 * medium gathers the light vertices in media within r of it (volume_merging.c's grid):
 * the neighbourhood of eq. 2.55 becomes the ball of radius r around x. Both kinds of
 * gathering then join through media, and the argument above holds with the sub-path's
 * continuation taken whole, direction and free flight:
 *   - p_acc (eq. 2.56-2.57) is the probability that L's continuation lands: a direction w
 *     with density pdf_L (a medium vertex's: HG times its continuation), then the
 *     segment along w walked as the sub-path walks it (vf_segment_trace: distances sampled
 *     in every medium it crosses, through index-matched boundaries, the path ending where
 *     tracking absorbs it), ending for a target in a medium by scattering within the ball,
 *     for a target on a surface by passing every medium to its first surface, which lies
 *     within r of x and stores vertices:
 *       p_acc = integral over w of pdf_L(w) P_flight(w).
 *     A flight that scatters before the surface, or passes the ball, is a failed trial.
 *   - The Bernoulli process (eq. 2.61-2.62) needs only independent draws of that event:
 *     each trial draws its direction (in the cone with the bound, or the sub-path's own
 *     draw) and then its flight with the sub-path's own free-flight sampler, numbers from
 *     the gathering's stream. So it is exact for density grids as well: delta tracking is
 *     an unbiased sampler of the flight's event, and the flight's density, which has no
 *     closed form, is never evaluated. A medium that only absorbs samples no distance
 *     (its flights always pass) and is all in the transmittance below.
 *   - The cone holds the ball as it held the disc (vf_upg_cone); a medium vertex's bound M
 *     is HG at the cone's direction closest to the forward direction (g >= 0) or to the
 *     backward one (g < 0), times the continuation (vf_upg_bound). A rejected direction
 *     costs no ray, an accepted one its first ray (to at most |x - L| + 2 r, beyond which
 *     nothing lands) and its flight.
 *   - The contribution (eq. 2.67) is the connection's through media: the throughput at L
 *     times f_L, the transmittance T of the join L -> x, f_x and G = cos_L cos_x / |x - L|^2
 *     (a medium vertex's f is sigma_s HG and its cosine 1). T is exact in homogeneous
 *     media and ratio tracking's unbiased estimate in grids, from numbers independent of
 *     the trials', so that E[T N / p_b] = T / p_acc. The light sub-path itself carried
 *     T / P(flight) to the light vertex; the join needs neither, p_acc holds the flight.
 *   - The weight is merging's for the light vertex landed at x from L, its hit taking the
 *     join's distance densities (vf_mis_hit_media) and a scattering at a medium L counting
 *     vf_vcm.medium_merge surface merges; at a medium x it is merging's in media
 *     (vf_mis_weight_merge_medium, ratio mis(4 r / 3)): vf_mis_weight_gather_media and
 *     vf_mis_weight_gather_camera_media. Every technique of a path again shares one
 *     approximate acceptance density, so the weights sum to one (sec. 2.4.6;
 *     tests/worker/render/test_medium.c checks it from both sides on paths in a medium).
 *   - Sides follow the rule below (a medium vertex is never a specular choice). A light
 *     vertex in a medium reached through a delta lobe (a volumetric caustic: light focused
 *     by glass into fog) cannot be joined from the light's side; from the camera's side it
 *     can, unless the camera vertex is the first of its sub-path (the lens before it): the
 *     caustic seen directly in the fog is merged as vcm merges in media and counted, as a
 *     caustic seen directly on a surface is (on cornell-fog about 5% of gatherings).
 *   - The medium a tentative flight starts in follows from L's place: a medium vertex's
 *     own, a light's (vf_vcm.light_medium), through a surface that bounds media the side
 *     of the direction, else the medium around a surface that bounds none (stored light
 *     vertices do not keep it: vf_medium_at_point finds it, once per gathering).
 *
 * Random numbers: a gathering's trials draw from a stream of its own, a pure function of
 * (seed, iteration, camera sub-path, camera vertex), and the light vertices of a camera
 * vertex are gathered in the grid's order: renders are reproducible whatever the thread
 * count. */
#ifndef VF_PHOTON_GATHERING_H
#define VF_PHOTON_GATHERING_H

#include "../../common/rng.h"
#include "../../common/vec3.h"
#include "bsdf.h"
#include "light.h"

#include <stdint.h>

/* A gathering whose trials reach this count stops there and is counted (truncated): its
 * estimate is then short. The expected count is |C| M / p_acc, which is this large only
 * where p_acc is tiny, and such pairs are gathered with probability p_acc. */
#define VF_UPG_MAX_TRIALS (1u << 20)

/* Where tentative directions start: a light vertex with its BSDF, or a light's own point
 * (light, with its unit normal for area lights). */
typedef struct {
  const vf_bsdf *bsdf;     /* NULL for a light's point */
  const vf_light *light;   /* when bsdf is NULL: area, point or spot */
  vf_vec3 light_normal;    /* area lights: the emitting side's unit normal */
} vf_upg_source;

/* The counts of the estimator, added to by vf_upg_inverse_acceptance. */
typedef struct {
  uint64_t gatherings;      /* 1/p_acc estimates made */
  uint64_t trials;          /* tentative directions drawn */
  uint64_t rays;            /* of which accepted and traced */
  uint64_t truncated;       /* gatherings stopped at VF_UPG_MAX_TRIALS */
  uint64_t bound_exceeded;  /* directions whose density exceeded the bound (must stay 0) */
} vf_upg_counts;

/* The density (solid angle) with which the source's sub-path continues in unit direction
 * dir: for a light vertex its BSDF's density with lobe selection and Russian roulette,
 * zero where f is (the walk ends there); for a light's point the emission's directional
 * density. */
float vf_upg_density(const vf_upg_source *src, vf_vec3 dir);

/* How sharply the source scatters: the peak density of its lobes, weighted by their
 * selection probabilities (diffuse 1/pi, Phong (n + 1) / 2 pi, GGX 1 / (4 pi alpha^2 cos)
 * with cos the incoming direction's; a medium vertex HG's peak (1 + |g|) / (4 pi
 * (1 - |g|)^2); a light's point its emission's largest density).
 * gathering_pass.c joins, where both sides can, at the vertex of the smaller one under
 * --gather-from auto: the estimate's f / p_acc varies least over the cone there. */
float vf_upg_sharpness(const vf_upg_source *src);

/* An upper bound of vf_upg_density over the cone of unit axis `axis` and half-angle
 * theta, given as cos(theta) and 1 - cos(theta) (the latter without cancellation for narrow
 * cones); INFINITY where no bound is known (a rough dielectric of index 1). */
float vf_upg_bound(const vf_upg_source *src, vf_vec3 axis, float cos_half, float one_minus_cos_half);

/* The cone from `from` that holds the ball of radius r around `to`: its unit axis,
 * cos and 1 - cos of its half-angle (the whole sphere, cos = -1, when `from` lies within
 * the ball). Returns the distance |to - from|. */
float vf_upg_cone(vf_vec3 from, vf_vec3 to, float r, vf_vec3 *axis, float *cos_half, float *one_minus_cos_half);

/* Whether a tentative direction lands: its ray's first hit lies within the radius of the
 * gathering point on a surface that stores light vertices (in media, its flight ends
 * there, or scatters within the radius of a gathering point in a medium: "In media"). */
typedef int (*vf_upg_lands)(void *ctx, vf_vec3 dir);

/* The unbiased estimate N / p_b of 1 / p_acc for the source and the cone (vf_upg_cone),
 * with trials' numbers from rng and their landing decided by lands(ctx, dir). bound is
 * vf_upg_bound's for the cone (finite). Adds to *counts. */
double vf_upg_inverse_acceptance(const vf_upg_source *src, vf_vec3 axis, float cos_half, float one_minus_cos_half,
                                 float bound, vf_rng *rng, vf_upg_lands lands, void *ctx, vf_upg_counts *counts);

/* The same without a bound: each trial is a draw of the sub-path's own continuation (Russian
 * roulette, lobe and direction, by vf_bsdf_sample: a light vertex only), which fails at
 * once when it ends, is specular or leaves the cone, and else is traced. E[N] = 1/p_acc
 * directly. Slower where the cone is narrow; the renderer uses it only where
 * vf_upg_bound has no bound, and the tests as an independent check. */
double vf_upg_inverse_acceptance_draws(const vf_bsdf *bsdf, vf_vec3 axis, float cos_half, vf_rng *rng,
                                       vf_upg_lands lands, void *ctx, vf_upg_counts *counts);

#endif
