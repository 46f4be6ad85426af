/* Block means of films against a reference film, for the merging-bias benchmarks
 * (docs/BENCHMARKS.md, "MIS heuristic"):
 *
 *     block_means REF.exr FILM.exr... [--blocks N]
 *
 * Splits the image into N x N blocks (8 by default) and prints, for each film, the ratio of
 * its mean (RGB averaged) to the reference's in every block, then the largest and smallest
 * ratio and the mean of the whole image. A consistent but biased estimator (merging with a
 * fixed radius) shows as blocks far from 1 where an unbiased one stays within its noise. */
#include "common/error.h"
#include "common/film.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int block_means(const char *path, int blocks, int *width, int *height, double **out) {
  vf_film *film = NULL;
  int err = vf_film_read(path, &film);
  if (err != VF_OK) {
    fprintf(stderr, "block_means: %s: %s\n", path, vf_error_detail(err));
    return err;
  }
  size_t pixels = (size_t)film->width * film->height;
  float *rgb = malloc(3 * pixels * sizeof *rgb);
  double *m = calloc((size_t)blocks * blocks + 1, sizeof *m);
  if (rgb == NULL || m == NULL) {
    free(rgb);
    free(m);
    vf_film_destroy(film);
    return VF_ENOMEM;
  }
  vf_film_mean(film, rgb);
  for (int y = 0; y < film->height; y++)
    for (int x = 0; x < film->width; x++) {
      size_t p = (size_t)y * film->width + x;
      double v = (rgb[3 * p] + rgb[3 * p + 1] + rgb[3 * p + 2]) / 3.0;
      m[(y * blocks / film->height) * blocks + x * blocks / film->width] += v;
      m[blocks * blocks] += v;
    }
  double per_block = (double)pixels / (blocks * blocks);
  for (int b = 0; b < blocks * blocks; b++) m[b] /= per_block;
  m[blocks * blocks] /= (double)pixels;
  *width = film->width;
  *height = film->height;
  *out = m;
  free(rgb);
  vf_film_destroy(film);
  return VF_OK;
}

int main(int argc, char **argv) {
  int blocks = 8, first = 1, last = argc;
  if (argc >= 3 && strcmp(argv[argc - 2], "--blocks") == 0) {
    blocks = atoi(argv[argc - 1]);
    last = argc - 2;
  }
  if (last - first < 2 || blocks < 1 || blocks > 64) {
    fprintf(stderr, "usage: block_means REF.exr FILM.exr... [--blocks N]\n");
    return 2;
  }
  int rw, rh;
  double *ref;
  if (block_means(argv[first], blocks, &rw, &rh, &ref) != VF_OK) return 1;
  for (int f = first + 1; f < last; f++) {
    int w, h;
    double *m;
    if (block_means(argv[f], blocks, &w, &h, &m) != VF_OK) return 1;
    if (w != rw || h != rh) {
      fprintf(stderr, "block_means: %s is %dx%d, the reference %dx%d\n", argv[f], w, h, rw, rh);
      return 2;
    }
    double lo = 1e300, hi = -1e300;
    printf("%s against %s, %dx%d blocks (ratio of means):\n", argv[f], argv[first], blocks, blocks);
    for (int by = 0; by < blocks; by++) {
      for (int bx = 0; bx < blocks; bx++) {
        double r = m[by * blocks + bx] / ref[by * blocks + bx];
        if (r < lo) lo = r;
        if (r > hi) hi = r;
        printf(" %6.3f", r);
      }
      printf("\n");
    }
    printf("  blocks from %.4f to %.4f; whole image %.4f\n", lo, hi, m[blocks * blocks] / ref[blocks * blocks]);
    free(m);
  }
  free(ref);
  return 0;
}
