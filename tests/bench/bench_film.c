/* Film I/O and merge speed: what a user pays to merge or continue, what a render pays per
 * checkpoint and what the coordinator pays per checkpoint.
 *
 *   bench_film [RUNS] [DIR] [FILM ...]      defaults: 5 /tmp
 *
 * With FILMs (e.g. rendered by tests/bench/film_size.sh): reads each once, then writes it
 * as format versions 1, 2 and 3 and reads it back, RUNS times each, and prints per
 * version the file's bytes per pixel and the median wall time (and process CPU time, all
 * threads) of a write (atomic: fsync and rename) and of a read (decode and validate).
 * Without: the same for a 1920x1080 film of 4 iterations of random data, and the merge of
 * two such films in memory. */
#include "common/clock.h"
#include "common/error.h"
#include "common/film.h"
#include "common/rng.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

static int compare(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

static double median(double *v, int n) {
  qsort(v, (size_t)n, sizeof *v, compare);
  return v[n / 2];
}

static double cpu_now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static vf_film *random_film(uint64_t first) {
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

static int fail(const char *what, int err) {
  fprintf(stderr, "bench_film: %s: %s\n", what, vf_error_detail(err));
  return 1;
}

/* Writes film in `version` and reads it back, runs times: one line of figures. */
#define MAX_RUNS 64

static int measure(const vf_film *film, const char *label, int version, int runs, const char *path) {
  double write[MAX_RUNS], write_cpu[MAX_RUNS], read[MAX_RUNS], read_cpu[MAX_RUNS];
  struct stat st = {0};
  for (int r = 0; r < runs; r++) {
    double w0 = vf_seconds_now(), c0 = cpu_now();
    int err = vf_film_write_version(film, path, version);
    double w1 = vf_seconds_now(), c1 = cpu_now();
    if (err != VF_OK) return fail("write", err);
    stat(path, &st);
    vf_film *back = NULL;
    if ((err = vf_film_read(path, &back)) != VF_OK) return fail("read", err);
    double w2 = vf_seconds_now(), c2 = cpu_now();
    vf_film_destroy(back);
    write[r] = w1 - w0;
    write_cpu[r] = c1 - c0;
    read[r] = w2 - w1;
    read_cpu[r] = c2 - c1;
  }
  unlink(path);
  double pixels = (double)film->width * (double)film->height;
  printf("| %s | %dx%d | %d | %.1f | %.2f | %.3f (%.2f) | %.3f (%.2f) |\n", label, film->width, film->height, version,
         (double)st.st_size / 1e6, (double)st.st_size / pixels, median(write, runs), median(write_cpu, runs),
         median(read, runs), median(read_cpu, runs));
  fflush(stdout);
  return 0;
}

int main(int argc, char **argv) {
  int runs = argc > 1 ? atoi(argv[1]) : 5;
  const char *dir = argc > 2 ? argv[2] : "/tmp";
  if (runs < 1) runs = 1;
  if (runs > MAX_RUNS) runs = MAX_RUNS;
  char path[4096];
  snprintf(path, sizeof path, "%s/vf_bench_film_%d.exr", dir, (int)getpid());
  printf("median of %d runs; seconds of wall time (process CPU time, all threads)\n\n", runs);
  printf("| film | size | version | MB | bytes/px | write s | read s |\n|---|---|---|---|---|---|---|\n");
  for (int i = 3; i < argc; i++) {
    vf_film *film = NULL;
    int err = vf_film_read(argv[i], &film);
    if (err != VF_OK) return fail(argv[i], err);
    const char *name = strrchr(argv[i], '/') ? strrchr(argv[i], '/') + 1 : argv[i];
    if (measure(film, name, 1, runs, path) || measure(film, name, 2, runs, path) || measure(film, name, 3, runs, path))
      return 1;
    vf_film_destroy(film);
  }
  if (argc > 3) return 0;
  vf_film *a = random_film(0), *b = random_film(4);
  if (!a || !b) return 1;
  if (measure(a, "random", 1, runs, path) || measure(a, "random", 2, runs, path) || measure(a, "random", 3, runs, path))
    return 1;
  double t_merge[MAX_RUNS];
  for (int r = 0; r < runs; r++) {
    vf_film *sum = NULL;
    vf_film_clone(a, &sum);
    double t0 = vf_seconds_now();
    int err = vf_film_merge(sum, b);
    if (err != VF_OK) return fail("merge", err);
    t_merge[r] = vf_seconds_now() - t0;
    vf_film_destroy(sum);
  }
  printf("\nmerge of two 1920x1080 films in memory: %.1f ms\n", 1e3 * median(t_merge, runs));
  vf_film_destroy(a);
  vf_film_destroy(b);
  return 0;
}
