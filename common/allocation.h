/* Camera sub-paths allocated per pixel from a pilot (vf_settings.pilot).
 *
 * Where an image's error sits varies by orders of magnitude from pixel to pixel, and one
 * camera sub-path per pixel and iteration spends the same on a pixel that is done as on
 * one that is not (docs/BENCHMARKS.md, "Camera sub-paths per pixel"). With a pilot of P
 * iterations, a pilot render comes first: iterations [0, P) with one camera sub-path a
 * pixel and random numbers of their own (the job seed's pilot seed, vf_allocation_seed),
 * whose film decides each pixel p's count k_p, a power of two from 1 to
 * VF_ALLOCATION_MAX, of camera sub-paths per iteration. Every iteration of the job, from
 * 0, then traces them, and the job's film keeps the counts. The pilot's film is not part of
 * the image: its iterations' estimates chose the counts, and a pixel's later samples must
 * not be the ones that chose how many it gets (its own numbers keep them independent, so
 * the image stays unbiased), nor should its single-sample iterations weigh as much as the
 * job's (the film adds every iteration alike). It costs P iterations of one camera
 * sub-path a pixel, which the job's film counts in its times. The film of [0, P) is a pure
 * function of (seed, P) whatever machines and threads rendered its parts (its sums are
 * exact), so the counts are too: any machine computes the same, and every iteration stays
 * a pure function of (seed, iteration, path, allocation).
 *
 * The counts. A pixel's estimate of an iteration has variance v_p, the mean of k_p camera
 * sub-paths about v_p / k_p (the light-tracing frame's share does not fall with k_p, which
 * this leaves out), and an iteration costs about sum k_p camera sub-paths. The efficiency
 * of the image, the inverse of (cost x squared error) = 1 / (sum k_p * sum v_p / k_p), is
 * largest with k_p proportional to sqrt(v_p) (Cauchy-Schwarz); bounded to [1,
 * VF_ALLOCATION_MAX] and rounded to powers of two, the proportion's scale is the one of a
 * fixed ladder of candidates that makes the efficiency largest on the pilot's own
 * estimates (ties to the smaller). v_p: the film's error estimate of the pixel
 * (vf_film_estimate_rmse's per-pixel terms, times the number of iterations), smoothed by
 * a 7x7 binomial filter, since one pixel's estimate of a short pilot is too noisy to
 * allocate by alone.
 *
 * The estimator. An iteration's estimate of pixel p is the mean of its k_p camera
 * sub-paths plus the light-tracing frame. In the MIS weights the camera sub-paths of p
 * count k_p times: light tracing's share at p weighs n_light / k_p light sub-paths against
 * one camera sub-path (tech. rep. eq. 31-33 and 46-47 with the camera side's count k_p),
 * so that the weights of every technique sampling a path through p still sum to one
 * (tests/worker/render/test_mis.c). In a vcm render of a scene without media, p's camera
 * sub-paths merge with radius r / sqrt(k_p), so that merging's count falls by k_p as light
 * tracing's does and the allocation does not move light from light tracing to merging
 * (worker/render/pixel_radius.h, vf_merge_params_at). The j-th camera sub-path of pixel p in iteration k
 * takes point (k / 2) k_p + j of the pixel's sequence of replicate k mod 2
 * (common/sampler.h): an aligned block of k_p points, a (0, log2 k_p, 2)-net in every
 * pair of dimensions.
 *
 * The algorithm. A pilot also tells how much an iteration of each algorithm would gain:
 * `--algorithm auto` with a pilot renders the pilots of pt, bpt and vcm, and for each the
 * counts above and their predicted variance v = mean_p sum_c v_p / k_p (the report's) and
 * the cost of an iteration t_light + t_camera mean(k), its light and camera passes' measured
 * seconds per pilot iteration (the light sub-paths, light tracing and the grid do not grow
 * with k); it takes the largest 1 / (cost x v), pt's counted over a margin of 1.25, since
 * what pt samples rarely is in no estimate (worker/render/render.h,
 * vf_render_choose_algorithm). Times are measurements, so the choice is made once and kept
 * in the settings (a farm job gets the allocation with it, docs/PROTOCOL.md "Pilots"); the
 * counts it hands on are the chosen algorithm's own, or those of merging per pixel below.
 *
 * Merging per pixel. bpt and vcm trace the same sub-paths; vcm adds vertex merging, whose
 * worth varies across an image as the error does (caustics seen in a diffuse floor against
 * plain diffuse walls; Grittmann et al. 2022, efficiency-aware MIS). A pixel's byte may
 * therefore also carry VF_ALLOCATION_NO_MERGING: in a vcm render, that pixel's camera
 * sub-paths do not merge and every technique sampling a path through the pixel weighs it
 * without merging (eta_VCM = 0 in the pixel's weights, worker/render/pixel_radius.h), so
 * that the pixel's estimator is bpt's and the image's stays unbiased where merging is off
 * and consistent where it is on. Every technique of a full path belongs to the path's
 * pixel (the camera sub-path's, or the one light tracing projects to), so the weights of
 * each path still sum to one. The choice per pixel (vf_allocation_choose) compares the
 * pilots of bpt and vcm: the pixels of a tile of 16 x 16 do without merging only where
 * bpt's predicted efficiency over the tile (the inverse of its variance times the cost of
 * a camera sub-path) is the margin times vcm's. Tiles, not pixels, and merging the
 * default, because a short pilot of bpt misses what bpt samples rarely: on the showcase, a
 * region of 32 x 32 pixels whose bpt pilot predicted 0.65-1.0 times vcm's efficiency had
 * 6-34 times vcm's squared error after 256 iterations; decided pixel by pixel, half or
 * more of its pixels lost merging (the smoothed estimates' noise against the margin), and
 * the image's relative RMSE rose 1.2-2.9 times
 * (docs/BENCHMARKS.md, "Merging per pixel").
 * The counts then follow each pixel's own algorithm, k_p proportional to sqrt(v_p / c_p)
 * (Cauchy-Schwarz with the pixels' costs c_p). */
#ifndef VF_ALLOCATION_H
#define VF_ALLOCATION_H

#include "film.h"
#include "settings.h"

#include <stddef.h>
#include <stdint.h>

/* The most camera sub-paths of a pixel per iteration: a power of two. */
#define VF_ALLOCATION_MAX 16
/* A pixel's byte: its count in the bits below VF_ALLOCATION_COUNT_BITS, and this flag for a
 * pixel of a vcm render that does not merge (see above). */
#define VF_ALLOCATION_COUNT_BITS 0x1fu
#define VF_ALLOCATION_NO_MERGING 0x80u
/* log2 of it, plus one: the counts 1, 2, 4, 8, 16. */
#define VF_ALLOCATION_LEVELS 5

/* The camera sub-paths of a pixel whose byte is b. */
static inline uint32_t vf_allocation_count(uint8_t b) { return b & VF_ALLOCATION_COUNT_BITS; }
/* Whether a pixel whose byte is b merges (in a render that merges at all). */
static inline int vf_allocation_merges(uint8_t b) { return !(b & VF_ALLOCATION_NO_MERGING); }

typedef struct {
  uint64_t pixels[VF_ALLOCATION_LEVELS]; /* pixels of 1, 2, 4, 8, 16 camera sub-paths */
  uint64_t no_merging;   /* pixels flagged VF_ALLOCATION_NO_MERGING */
  double mean;           /* camera sub-paths per pixel and iteration */
  double predicted_gain; /* the efficiency over one a pixel, on the pilot's estimates */
  double variance;       /* of an iteration's estimate with these counts, on the pilot's
                          * (smoothed) estimates: the mean over pixels of sum_c v_p / k_p */
} vf_allocation_report;

/* Each pixel's count (width x height bytes into samples) from the pilot's film, which must
 * hold exactly the iterations [0, pilot) of the settings its text names (VF_EINVAL naming
 * what it holds otherwise). report may be NULL. */
int vf_allocation_compute(const vf_film *film, uint8_t *samples, vf_allocation_report *report);

/* The smoothed per-pixel variances vf_allocation_compute allocates by (width x height
 * doubles into variance), from a film as it asks (the same errors). */
int vf_allocation_variances(const vf_film *film, double *variance);

/* The side in pixels of the square tiles that merge or not as one (see above). */
#define VF_ALLOCATION_MERGE_TILE 16

/* Merging per pixel from the pilots of bpt and vcm (see above): the pixels of a tile of
 * VF_ALLOCATION_MERGE_TILE^2 merge unless margin B bpt_cost <= V vcm_cost, B and V the
 * sums of the tile's bpt_variance and vcm_variance as vf_allocation_variances gives them,
 * the costs those of one camera sub-path a pixel in an iteration of each; the counts are
 * then allocated as vf_allocation_compute's over the pixels' own variances and costs.
 * width x height bytes into samples; report (may be NULL) as vf_allocation_compute's,
 * with its variance the predicted of an iteration. VF_EINVAL for a cost that is not
 * positive and finite. */
int vf_allocation_choose(const double *bpt_variance, const double *vcm_variance, double bpt_cost, double vcm_cost,
                         double margin, int width, int height, uint8_t *samples, vf_allocation_report *report);

/* The report of an allocation of n pixels. */
void vf_allocation_describe(const uint8_t *samples, size_t n, vf_allocation_report *report);

/* The report in words: "1.53 camera sub-paths a pixel on average; pixels of 1, 2, 4, 8, 16:
 * a, b, c, d, e", and "; no merging in N pixels" when some are flagged so. */
void vf_allocation_summary(const vf_allocation_report *report, char *out, size_t size);

/* VF_EFILM with a detail naming `name` and the pixel unless every count is a power of two
 * from 1 to VF_ALLOCATION_MAX and no bit but VF_ALLOCATION_NO_MERGING is set besides. */
int vf_allocation_validate(const uint8_t *samples, size_t n, const char *name);

/* VF_EINVAL naming `name` and the pixel when a pixel turns merging off
 * (VF_ALLOCATION_NO_MERGING) and `algorithm` is not vcm, the one algorithm that takes it. */
int vf_allocation_check_algorithm(const uint8_t *samples, size_t n, vf_algorithm algorithm, const char *name);

/* The text a film keeps its allocation in (docs/FILM.md, attribute vcmfarm:allocation):
 * "1:" and the counts, zlib-compressed, in base64. *text is malloc'ed; VF_ENOMEM. */
int vf_allocation_encode(const uint8_t *samples, size_t n, char **text);
/* Reads it back into n counts, validated. VF_EFILM naming `name` for text that is not an
 * allocation of n pixels. */
int vf_allocation_decode(const char *text, size_t n, uint8_t *samples, const char *name);

/* The sobol sampler's point for camera sub-path j of a pixel of k camera sub-paths per
 * iteration in iteration `iteration`, in the pixel's sequence of replicate iteration mod 2
 * (see above). */
static inline uint32_t vf_allocation_sobol_index(uint64_t iteration, uint32_t k, uint32_t j) {
  return (uint32_t)(iteration / 2u * k + j);
}

/* The seed of a job's pilot render: the job seed's, hashed, so that its numbers are
 * independent of every iteration's of the job. */
uint64_t vf_allocation_seed(uint64_t seed);

#endif
