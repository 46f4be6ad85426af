/* Render settings: everything besides the scene that determines a film's content.
 *
 * Two films can be merged only if their settings text is identical (and their scenes
 * hash equal). The text form is canonical: fixed key order, fixed number formats, so the
 * same settings always give the same bytes. */
#ifndef VF_SETTINGS_H
#define VF_SETTINGS_H

#include "sampler.h"

#include <stddef.h>
#include <stdint.h>

typedef enum {
  VF_ALGO_VCM, /* vertex connection and merging: every technique */
  VF_ALGO_BPT, /* bidirectional path tracing: connections only (tech. rep. 5.5) */
  VF_ALGO_PT,  /* path tracing with next-event estimation and MIS */
  VF_ALGO_LT,  /* light tracing to the camera alone */
  VF_ALGO_PPM, /* progressive photon mapping: merge at the first non-specular camera vertex */
  VF_ALGO_BPM, /* bidirectional photon mapping: merging only, MIS-weighted (tech. rep. 5.6) */
  VF_ALGO_AUTO, /* the cheapest of the above that covers the scene's light transport, chosen
                 * by the renderer from the scene (worker/render/vcm.c, vf_vcm_algorithm). The
                 * settings text keeps "auto": the choice is a pure function of scene and
                 * settings, so every worker and every continue makes the same one. With a
                 * pilot it is chosen by measurement instead, once, before the render
                 * (vf_render_choose_algorithm), and the settings name the one chosen. */
  VF_ALGO_UPG,  /* vcm with unbiased photon gathering in place of vertex merging
                 * (worker/render/photon_gathering.h) */
  VF_ALGO_AUTO_UNBIASED, /* auto among the unbiased ones, pt, bpt and upg (vcm.c); kept as
                          * "auto-unbiased" in the settings text as auto is */
  VF_ALGO_COUNT_
} vf_algorithm;

/* The longest path a render may ask for, in segments. */
#define VF_MAX_PATH_LENGTH 1000
#define VF_MAX_IMAGE_SIDE 65536 /* pixels, width or height */

/* The side upg gathers from where both sides can (worker/render/gathering_pass.h): the
 * light's (the thesis's UPG: a camera vertex joins the gathered light vertex's
 * predecessor) or the camera's (UPG*: the gathered light vertex joins the camera vertex's
 * predecessor), or auto: path by path the side whose joining vertex scatters less sharply
 * (in the manner of Qin et al.'s hybrid). */
typedef enum { VF_GATHER_LIGHT, VF_GATHER_CAMERA, VF_GATHER_AUTO, VF_GATHER_COUNT_ } vf_gather_side;

/* The merge radius (worker/render/pixel_radius.h): one for the whole image, r_i = r_1
 * sqrt(i^(alpha-1)) with r_1 = radius_factor times the scene's radius, or one per pixel,
 * r_1 scaled by the pixel's footprint against the image's median footprint (tech. rep.
 * sec. 6.1), with the same schedule. */
typedef enum { VF_RADIUS_GLOBAL, VF_RADIUS_PER_PIXEL, VF_RADIUS_COUNT_ } vf_radius_mode;

typedef struct {
  vf_algorithm algorithm;
  int max_path_length;  /* path segments (edges), >= 1 */
  double radius_factor; /* r_1 = radius_factor * scene bounding-sphere radius */
  double alpha;         /* radius reduction exponent, r_i = r_1 sqrt(i^(alpha-1)) */
  uint64_t seed;
  int width, height;    /* film resolution in pixels */
  vf_sampler_kind sampler; /* where the paths' random numbers come from (common/sampler.h) */
  double mis_beta;      /* the MIS heuristic's exponent: 1 balance (the default), >= 1 power
                         * (paper eq. 10; worker/render/mis.h) */
  vf_gather_side gather; /* upg only: the side it prefers to gather from (light by default) */
  vf_radius_mode radius; /* merging algorithms: one merge radius, or one per pixel */
  int vcm_stages;        /* vcm: 2, the two-stage iteration (every light sub-path traced and
                          * stored before any camera sub-path; the default), or 1, the
                          * single-stage one of the tech. rep.'s sec. 6.2 (camera sub-paths
                          * merge with the light vertices of the iteration before:
                          * worker/render/single_stage.h). They are different estimators:
                          * films of the two never merge. */
  int light_path_pixels; /* pixels that share one light sub-path per iteration: 1 (the
                          * default, one light sub-path a pixel) or a power of two up to
                          * VF_MAX_LIGHT_PATH_PIXELS. The image falls into blocks of that
                          * many pixels (vf_light_path_block); each block's top-left pixel
                          * traces the light sub-path (with its path index, so its stream is
                          * the default's) that every camera sub-path of the block connects
                          * to, and n_light (light tracing's 1 / n_light, vertex merging's
                          * eta = pi r^2 n_light) counts the blocks. Fewer stored light
                          * vertices per iteration: the memory of large images. Algorithms
                          * with light sub-paths but upg; films of different values never
                          * merge. */
  int pilot;             /* 0 (the default): one camera sub-path a pixel in every iteration.
                          * Else the iterations of a pilot render (common/allocation.h):
                          * its film, of random numbers of their own and one camera
                          * sub-path a pixel, decides each pixel's number of camera
                          * sub-paths per iteration once; every iteration of the job then
                          * traces those, weighed in the MIS (worker/render/camera_pass.c),
                          * and the film keeps them. pt, bpt and vcm (and auto when it
                          * chooses one of them), the two-stage iteration; films of
                          * different pilots or allocations never merge. */
} vf_settings;

/* The longest pilot; the shortest is 2 (one iteration of each of the sampler's replicates). */
#define VF_MAX_PILOT (1 << 20)

/* The most pixels one light sub-path may serve: a block of 32x32, one camera tile. */
#define VF_MAX_LIGHT_PATH_PIXELS 1024

/* The block of pixels sharing a light sub-path (light_path_pixels = 2^k): 2^ceil(k/2)
 * columns by 2^floor(k/2) rows, as log2 of each (2 -> 2x1, 4 -> 2x2, 8 -> 4x2, 64 -> 8x8). */
static inline void vf_light_path_block(int light_path_pixels, unsigned *log2_width, unsigned *log2_height) {
  unsigned k = 0;
  while (k < 31 && (1 << k) < light_path_pixels) k++;
  *log2_width = (k + 1) / 2;
  *log2_height = k / 2;
}

/* The power heuristic's largest exponent: weights are sums of products of density ratios
 * raised to beta, in float, and ratios of 1e9 (a light seen at a grazing angle through a
 * small radius) must not overflow: (1e9)^4 = 1e36 < 3.4e38. */
#define VF_MAX_MIS_BETA 4.0

/* Defaults: vcm, path length 10, radius factor 0.003, alpha 0.75, seed 1, 512x512, the
 * sobol sampler (docs/BENCHMARKS.md, "Samplers": it reaches an error sooner), the balance
 * heuristic (mis_beta 1). */
void vf_settings_default(vf_settings *s);

const char *vf_algorithm_name(vf_algorithm a);
/* auto or auto-unbiased: the renderer resolves it from the scene. */
static inline int vf_algorithm_is_auto(vf_algorithm a) { return a == VF_ALGO_AUTO || a == VF_ALGO_AUTO_UNBIASED; }
/* Whether the settings ask for the algorithm to be chosen by pilots (auto with a pilot:
 * vf_render_choose_algorithm), once, by whoever starts the render or the job. */
static inline int vf_settings_choose_by_pilots(const vf_settings *s) {
  return s->algorithm == VF_ALGO_AUTO && s->pilot > 0;
}
/* VF_EUSAGE with a detail listing the valid names when `name` is not one. */
int vf_algorithm_parse(const char *name, vf_algorithm *out);

/* What a film's own error estimate (vf_film_estimate_rmse, from the spread of its
 * iterations) measures under algorithm a: the estimate sees variance only, which is the
 * whole error of an unbiased algorithm (pt, bpt, lt, and upg, except on the light vertices
 * it merges as vcm, which the render counts) and not of a merely consistent one (vcm, ppm,
 * bpm: their merging's bias at the film's radii is in no estimate). VF_ESTIMATE_DEPENDS for
 * auto, which is either (the job's resolved algorithm says which). */
typedef enum { VF_ESTIMATE_ERROR, VF_ESTIMATE_VARIANCE, VF_ESTIMATE_DEPENDS } vf_estimate_scope;
vf_estimate_scope vf_algorithm_estimate_scope(vf_algorithm a);
/* "error", "variance" or "error or variance": the word info and status print. */
const char *vf_estimate_scope_name(vf_estimate_scope scope);

const char *vf_gather_name(vf_gather_side g);
/* VF_EUSAGE with a detail listing the valid names when `name` is not one. */
int vf_gather_parse(const char *name, vf_gather_side *out);

const char *vf_radius_mode_name(vf_radius_mode m);
/* VF_EUSAGE with a detail listing the valid names when `name` is not one. */
int vf_radius_mode_parse(const char *name, vf_radius_mode *out);
/* Whether algorithm a merges light vertices, so that its merge radius matters (auto may). */
int vf_algorithm_merges(vf_algorithm a);

const char *vf_sampler_name(vf_sampler_kind k);
/* VF_EUSAGE with a detail listing the valid names when `name` is not one. */
int vf_sampler_parse(const char *name, vf_sampler_kind *out);

/* Checks ranges (path length, radius factor > 0, 0 < alpha <= 1, resolution, 1 <= mis_beta
 * <= VF_MAX_MIS_BETA, vcm_stages 1 or 2 and 1 only for vcm or auto, light_path_pixels a
 * power of two up to VF_MAX_LIGHT_PATH_PIXELS and above 1 only with light sub-paths and not upg,
 * pilot 0 or from 2 to VF_MAX_PILOT, only for pt, bpt, vcm and auto with two stages). */
int vf_settings_validate(const vf_settings *s);

/* Canonical text, e.g. "algorithm=vcm max_path_length=10 radius_factor=0.003 alpha=0.75
 * seed=1 resolution=512x512 sampler=sobol". The sampler is written only when it is not
 * the independent one: every film and state file written before samplers existed was
 * rendered with independent numbers, and its text, which has no sampler, reads (and
 * merges) as independent, while a sobol film never merges with one. The MIS exponent is
 * written (" mis_beta=2") only when it is not 1, for the same reason: every text before it
 * existed was rendered with the balance heuristic. upg's side (" gather=camera") likewise
 * only when it is not the light's, the radius (" radius=per-pixel") only when not global,
 * the stages (" vcm_stages=1") only when not 2, " light_path_pixels=N" only when N is not 1,
 * and " pilot=N" only when N is not 0. Numbers in their shortest text that reads back exactly
 * (vf_double_format), so parse(format(s)) == s. VF_EINVAL if it does not fit in n bytes.
 * Before protocol version 6 the numbers had 17 digits ("0.0030000000000000001"): films and
 * state files of then are brought to this form when read (vf_settings_canonicalize). */
int vf_settings_format(const vf_settings *s, char *buf, size_t n);
/* Rewrites settings text (any valid form, n bytes of room) in canonical form, in place;
 * the parsing error, or VF_EINVAL when it would not fit, leaving text as it was. */
int vf_settings_canonicalize(char *text, size_t n);
/* The shortest "%g" text of v that reads back as v (at most 24 bytes with the NUL). */
void vf_double_format(double v, char *buf, size_t n);
/* Parses the canonical text (keys in any order, all required but the sampler, which is
 * independent when absent, and mis_beta, 1 when absent). */
int vf_settings_parse(vf_settings *s, const char *text);

#endif
