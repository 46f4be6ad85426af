/* Helper of test_farm.sh (not a test by itself): compares a farm's film with a
 * single-process render of the same iterations.
 *
 *   farm_compare [--exact] FARM.exr REFERENCE.exr EXPECTED_ITERATIONS
 *
 * Passes (exit 0) when both films hold exactly the expected iteration set (e.g.
 * "[0,24)": none missing, none counted twice) and the largest difference of their mean
 * radiance over all pixels and channels is at most 1e-5 times the reference's image mean,
 * and their counts (non-finite samples, biased merges), which every iteration adds to
 * exactly, are equal; with --exact, only when they are moreover the same film bit for
 * bit: the same scene hash and settings, the same allocation of camera sub-paths (a pilot's,
 * or none on either), and every sum and sum of squares the same value in every bit. Prints
 * what it found either way. */
#include "common/film.h"
#include "common/error.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int load(const char *path, vf_film **film) {
  int err = vf_film_read(path, film);
  if (err != VF_OK) fprintf(stderr, "farm_compare: %s\n", vf_error_detail(err));
  return err;
}

/* How many of the films' sums and sums of squares differ in any bit (NaN included). */
static size_t bits_differing(const vf_film *a, const vf_film *b) {
  size_t n = (size_t)a->width * (size_t)a->height * 3, differing = 0;
  for (size_t i = 0; i < n; i++)
    differing += memcmp(&a->sum[i], &b->sum[i], sizeof a->sum[i]) != 0 ||
                 memcmp(&a->square_sum[i], &b->square_sum[i], sizeof a->square_sum[i]) != 0;
  return differing;
}

int main(int argc, char **argv) {
  int exact = argc == 5 && strcmp(argv[1], "--exact") == 0;
  argv += exact;
  argc -= exact;
  if (argc != 4) {
    fprintf(stderr, "usage: farm_compare [--exact] FARM.exr REFERENCE.exr EXPECTED_ITERATIONS\n");
    return 2;
  }
  vf_film *farm = NULL, *ref = NULL;
  if (load(argv[1], &farm) != VF_OK || load(argv[2], &ref) != VF_OK) return 1;
  int ok = 1;
  char farm_set[256], ref_set[256];
  vf_iterset_format(&farm->iterations, farm_set, sizeof farm_set);
  vf_iterset_format(&ref->iterations, ref_set, sizeof ref_set);
  if (strcmp(farm_set, argv[3]) != 0 || strcmp(ref_set, argv[3]) != 0) {
    printf("iteration sets: farm %s, reference %s, expected %s\n", farm_set, ref_set, argv[3]);
    ok = 0;
  }
  if (farm->nonfinite_samples != ref->nonfinite_samples || farm->biased_merges != ref->biased_merges) {
    printf("counts: non-finite samples farm %llu, reference %llu; biased merges farm %llu, reference %llu\n",
           (unsigned long long)farm->nonfinite_samples, (unsigned long long)ref->nonfinite_samples,
           (unsigned long long)farm->biased_merges, (unsigned long long)ref->biased_merges);
    ok = 0;
  }
  if (farm->width != ref->width || farm->height != ref->height) {
    printf("sizes differ: %dx%d vs %dx%d\n", farm->width, farm->height, ref->width, ref->height);
    return 1;
  }
  size_t n = (size_t)farm->width * (size_t)farm->height * 3;
  float *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b);
  if (a == NULL || b == NULL) return 1;
  vf_film_mean(farm, a);
  vf_film_mean(ref, b);
  double mean = 0.0, max_diff = 0.0;
  for (size_t i = 0; i < n; i++) {
    mean += b[i];
    double d = fabs((double)a[i] - (double)b[i]);
    if (!(d <= max_diff)) max_diff = d; /* NaN propagates as a failure */
  }
  mean /= (double)n;
  int close = max_diff <= 1e-5 * mean && mean > 0.0;
  if (exact) {
    size_t differing = bits_differing(farm, ref);
    int same_texts = memcmp(farm->scene_hash, ref->scene_hash, sizeof farm->scene_hash) == 0 &&
                     strcmp(farm->settings_text, ref->settings_text) == 0;
    size_t pixels = (size_t)farm->width * (size_t)farm->height;
    int same_allocation = (farm->samples == NULL) == (ref->samples == NULL) &&
                          (farm->samples == NULL || memcmp(farm->samples, ref->samples, pixels) == 0);
    printf("exact: %zu of %zu sums differ in some bit; scene hash and settings %s; allocation %s\n", differing, n,
           same_texts ? "equal" : "DIFFER", farm->samples == NULL && ref->samples == NULL ? "none on either"
                                            : same_allocation                            ? "equal"
                                                                                         : "DIFFERS");
    close = close && differing == 0 && same_texts && same_allocation;
  }
  printf("farm %s, reference %s: max |difference| %.3g, image mean %.6g, limit %.3g: %s\n", farm_set, ref_set,
         max_diff, mean, 1e-5 * mean, close && ok ? "equal" : "DIFFERENT");
  free(a);
  free(b);
  vf_film_destroy(farm);
  vf_film_destroy(ref);
  return close && ok ? 0 : 1;
}
