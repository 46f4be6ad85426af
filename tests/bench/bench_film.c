/* Film I/O and merge speed: what a user pays to merge or continue, what a render pays per
 * checkpoint and what the coordinator pays per checkpoint.
 *
 *   bench_film [RUNS] [DIR] [FILM ...]      defaults: 5 /tmp
 *
 * With FILMs (e.g. rendered by tests/bench/film_size.sh): reads each once, then writes it
 * as format versions 3 (48-bit hi/lo pairs, what builds before the exact sums wrote) and 4
 * (exact fixed-point sums) and reads it back, RUNS times each, the versions alternating
 * run by run so that both see the same machine, and prints per version the file's bytes
 * per pixel and the median wall time (and process CPU time, all threads) of a write
 * (atomic: fsync and rename) and of a read (decode and validate). VERSIONS="1 2 3 4" in
 * the environment chooses others. Without FILMs: the same for a 1920x1080 film of 4
 * iterations of random data, and the merge of two such films in memory. */
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

/* Writes film in each of `versions` and reads it back, runs times, the versions in turn
 * within each run: one line of figures per version. */
#define MAX_RUNS 64
#define MAX_VERSIONS 4

static int measure(const vf_film *film, const char *label, const int *versions, int nv, int runs, const char *path) {
  double write[MAX_VERSIONS][MAX_RUNS], write_cpu[MAX_VERSIONS][MAX_RUNS], read[MAX_VERSIONS][MAX_RUNS],
      read_cpu[MAX_VERSIONS][MAX_RUNS];
  off_t size[MAX_VERSIONS] = {0};
  for (int r = 0; r < runs; r++)
    for (int v = 0; v < nv; v++) {
      double w0 = vf_seconds_now(), c0 = cpu_now();
      int err = vf_film_write_version(film, path, versions[v]);
      double w1 = vf_seconds_now(), c1 = cpu_now();
      if (err != VF_OK) return fail("write", err);
      struct stat st = {0};
      stat(path, &st);
      size[v] = st.st_size;
      vf_film *back = NULL;
      if ((err = vf_film_read(path, &back)) != VF_OK) return fail("read", err);
      double w2 = vf_seconds_now(), c2 = cpu_now();
      vf_film_destroy(back);
      write[v][r] = w1 - w0;
      write_cpu[v][r] = c1 - c0;
      read[v][r] = w2 - w1;
      read_cpu[v][r] = c2 - c1;
    }
  unlink(path);
  double pixels = (double)film->width * (double)film->height;
  for (int v = 0; v < nv; v++)
    printf("| %s | %dx%d | %d | %.1f | %.2f | %.3f (%.2f) | %.3f (%.2f) |\n", label, film->width, film->height,
           versions[v], (double)size[v] / 1e6, (double)size[v] / pixels, median(write[v], runs),
           median(write_cpu[v], runs), median(read[v], runs), median(read_cpu[v], runs));
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
  int versions[MAX_VERSIONS] = {3, 4}, nv = 2;
  const char *chosen = getenv("VERSIONS");
  if (chosen != NULL) {
    nv = 0;
    for (const char *c = chosen; *c && nv < MAX_VERSIONS; c++)
      if (*c >= '1' && *c <= '4') versions[nv++] = *c - '0';
  }
  printf("median of %d runs; seconds of wall time (process CPU time, all threads)\n\n", runs);
  printf("| film | size | version | MB | bytes/px | write s | read s |\n|---|---|---|---|---|---|---|\n");
  for (int i = 3; i < argc; i++) {
    vf_film *film = NULL;
    int err = vf_film_read(argv[i], &film);
    if (err != VF_OK) return fail(argv[i], err);
    const char *name = strrchr(argv[i], '/') ? strrchr(argv[i], '/') + 1 : argv[i];
    if (measure(film, name, versions, nv, runs, path)) return 1;
    vf_film_destroy(film);
  }
  if (argc > 3) return 0;
  vf_film *a = random_film(0), *b = random_film(4);
  if (!a || !b) return 1;
  if (measure(a, "random", versions, nv, runs, path)) return 1;
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
