/* Film I/O and merge speed at 1920x1080: what a user pays to merge or continue, and what
 * the coordinator pays per checkpoint.
 *
 *   bench_film [RUNS] [DIR]      defaults: 5 /tmp
 * Prints the median time of write, read and merge over RUNS runs and the file size. */
#include "common/clock.h"
#include "common/error.h"
#include "common/film.h"
#include "common/rng.h"

#include <stdio.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

static int compare(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

static vf_film *make_film(uint64_t first) {
  enum { W = 1920, H = 1080 };
  vf_film *f;
  if (vf_film_create(W, H, &f) != VF_OK) return NULL;
  float *cam = malloc(3 * sizeof(float) * W * H), *light = malloc(3 * sizeof(float) * W * H);
  vf_rng rng = vf_rng_for_path(1, first, 0, VF_STREAM_TEST);
  for (uint64_t k = first; k < first + 4; k++) {
    for (size_t i = 0; i < 3 * (size_t)W * H; i++) {
      cam[i] = vf_rng_float(&rng);
      light[i] = 0.1f * vf_rng_float(&rng);
    }
    vf_film_add_iteration(f, k, cam, light, NULL);
  }
  free(cam);
  free(light);
  snprintf(f->settings_text, sizeof f->settings_text, "algorithm=vcm max_path_length=10 radius_factor=0.003 "
                                                      "alpha=0.75 seed=1 resolution=1920x1080");
  return f;
}

int main(int argc, char **argv) {
  int runs = argc > 1 ? atoi(argv[1]) : 5;
  const char *dir = argc > 2 ? argv[2] : "/tmp";
  char path[4096];
  snprintf(path, sizeof path, "%s/vf_bench_film_%d.exr", dir, (int)getpid());
  vf_film *a = make_film(0), *b = make_film(4);
  if (!a || !b) return 1;
  double *t_write = malloc(runs * sizeof(double)), *t_read = malloc(runs * sizeof(double)),
         *t_merge = malloc(runs * sizeof(double));
  for (int r = 0; r < runs; r++) {
    double t0 = vf_seconds_now();
    if (vf_film_write(a, path) != VF_OK) return fprintf(stderr, "%s\n", vf_error_detail(VF_EIO)), 1;
    double t1 = vf_seconds_now();
    vf_film *back = NULL;
    if (vf_film_read(path, &back) != VF_OK) return fprintf(stderr, "%s\n", vf_error_detail(VF_EIO)), 1;
    double t2 = vf_seconds_now();
    vf_film *sum = NULL;
    vf_film_clone(a, &sum);
    double t3 = vf_seconds_now();
    if (vf_film_merge(sum, b) != VF_OK) return fprintf(stderr, "%s\n", vf_error_detail(VF_EIO)), 1;
    double t4 = vf_seconds_now();
    t_write[r] = t1 - t0;
    t_read[r] = t2 - t1;
    t_merge[r] = t4 - t3;
    vf_film_destroy(back);
    vf_film_destroy(sum);
  }
  struct stat st;
  stat(path, &st);
  unlink(path);
  qsort(t_write, runs, sizeof(double), compare);
  qsort(t_read, runs, sizeof(double), compare);
  qsort(t_merge, runs, sizeof(double), compare);
  printf("1920x1080 film (%.1f MB on disk), median of %d runs:\n", st.st_size / 1e6, runs);
  printf("  write  %8.1f ms\n  read   %8.1f ms\n  merge  %8.1f ms (in memory, two films)\n", 1e3 * t_write[runs / 2],
         1e3 * t_read[runs / 2], 1e3 * t_merge[runs / 2]);
  vf_film_destroy(a);
  vf_film_destroy(b);
  return 0;
}
