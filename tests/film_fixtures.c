#include "film_fixtures.h"

#include "common/error.h"
#include "common/file.h"
#include "common/exr_util.h"
#include "common/film_planes.h"

#include <dirent.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

static char scratch_dir[512];

int fixture_scratch_open(const char *test) {
  snprintf(scratch_dir, sizeof scratch_dir, "%s/%s.XXXXXX", VF_BINARY_DIR, test);
  if (mkdtemp(scratch_dir) != NULL) return 0;
  fprintf(stderr, "%s: cannot create a scratch directory %s\n", test, scratch_dir);
  return -1;
}

const char *fixture_scratch_dir(void) { return scratch_dir; }

const char *fixture_path(const char *name) {
  static char paths[16][1024];
  static int next;
  char *p = paths[next++ % 16];
  snprintf(p, sizeof paths[0], "%s/%s", scratch_dir, name);
  return p;
}

int fixture_scratch_close(void) {
  vf_file_remove_tree(scratch_dir);
  if (!fixture_exists(scratch_dir)) return 0;
  printf("  note: could not remove %s\n", scratch_dir);
  return -1;
}

unsigned char *fixture_slurp(const char *path, size_t *size) {
  FILE *fp = fopen(path, "rb");
  if (fp == NULL) return NULL;
  fseek(fp, 0, SEEK_END);
  long n = ftell(fp);
  fseek(fp, 0, SEEK_SET);
  unsigned char *buf = malloc((size_t)n + 1);
  if (fread(buf, 1, (size_t)n, fp) != (size_t)n) n = 0;
  fclose(fp);
  *size = (size_t)n;
  return buf;
}

int fixture_spill(const char *path, const void *bytes, size_t size) {
  FILE *fp = fopen(path, "wb");
  if (fp == NULL) return 0;
  int ok = fwrite(bytes, 1, size, fp) == size;
  return fclose(fp) == 0 && ok;
}

int fixture_spill_text(const char *path, const char *text) { return fixture_spill(path, text, strlen(text)); }

int fixture_file_holds(const char *path, const void *bytes, size_t size) {
  size_t n = 0;
  unsigned char *now = fixture_slurp(path, &n);
  int same = now && n == size && memcmp(now, bytes, size) == 0;
  free(now);
  return same;
}

int fixture_file_holds_text(const char *path, const char *text) { return fixture_file_holds(path, text, strlen(text)); }

int fixture_exists(const char *path) {
  struct stat st;
  return stat(path, &st) == 0;
}

int fixture_no_temp_files(void) {
  DIR *d = opendir(scratch_dir);
  if (d == NULL) return 0;
  int clean = 1;
  struct dirent *e;
  while ((e = readdir(d)) != NULL)
    if (strstr(e->d_name, ".tmp.")) clean = 0;
  closedir(d);
  return clean;
}

int fixture_run_with_file_limit(long limit, int (*child)(void *), void *user) {
  fflush(stdout);
  fflush(stderr);
  pid_t pid = fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    signal(SIGXFSZ, SIG_IGN);
    struct rlimit lim = {(rlim_t)limit, (rlim_t)limit};
    setrlimit(RLIMIT_FSIZE, &lim);
    exit(child(user));
  }
  int status = 0;
  waitpid(pid, &status, 0);
  return status;
}

int fixture_run(int (*cmd)(int, char **), const char *name, ...) {
  enum { MAX_ARGS = 40 };
  char *argv[MAX_ARGS];
  int argc = 0;
  va_list ap;
  va_start(ap, name);
  for (const char *a = name; a != NULL && argc < MAX_ARGS - 1; a = va_arg(ap, const char *)) argv[argc++] = (char *)a;
  va_end(ap);
  argv[argc] = NULL;
  fflush(stdout);
  int status = cmd(argc, argv);
  fflush(stdout);
  return status;
}

uint64_t fixture_xorshift(uint64_t *s) {
  *s ^= *s << 13;
  *s ^= *s >> 7;
  *s ^= *s << 17;
  return *s;
}

double fixture_uniform(uint64_t *s) { return (double)(fixture_xorshift(s) >> 11) * 0x1.0p-53; }

void fixture_iteration_inputs(int w, int h, uint64_t iteration, float *cam, float *light) {
  uint64_t s = 0x9e3779b97f4a7c15ULL ^ (iteration * 0xbf58476d1ce4e5b9ULL + 1);
  for (int i = 0; i < 3 * w * h; i++) {
    cam[i] = (float)(fixture_uniform(&s) * pow(10.0, 4 * fixture_uniform(&s) - 2));
    light[i] = (float)(fixture_uniform(&s) * 0.1);
  }
}

vf_film *fixture_film(int w, int h, uint64_t begin, uint64_t end, int seed) {
  vf_film *film = NULL;
  if (vf_film_create(w, h, &film) != VF_OK) return NULL;
  float *cam = malloc(sizeof(float) * 3 * (size_t)(w * h)), *light = malloc(sizeof(float) * 3 * (size_t)(w * h));
  for (uint64_t i = begin; i < end && cam && light; i++) {
    fixture_iteration_inputs(w, h, i, cam, light);
    vf_film_add_iteration(film, i, cam, light, NULL);
  }
  free(cam);
  free(light);
  memset(film->scene_hash, 0xab, sizeof film->scene_hash);
  snprintf(film->settings_text, sizeof film->settings_text,
           "algorithm=vcm max_path_length=10 radius_factor=0.003 alpha=0.75 seed=%d resolution=%dx%d", seed, w, h);
  film->render_seconds = 1.25 * (double)(end - begin);
  return film;
}

typedef struct {
  vf_film_sums sums;
} forge_source;

static void forge_fill(void *user, int x0, int y0, int w, int h, float *const *planes) {
  vf_film_planes_fill(((forge_source *)user)->sums, x0, y0, w, h, planes);
}

int fixture_forge_film(const char *path, const vf_film *film, const char *iterations) {
  vf_exr_out out;
  int err = vf_exr_create(path, film->width, film->height, VF_FILM_TILE, VF_EXR_ZIP, VF_FILM_V2_CHANNELS,
                          vf_film_v2_channels, &out);
  if (err != VF_OK) return err;
  char hex[65];
  for (int i = 0; i < 32; i++) snprintf(hex + 2 * i, 3, "%02x", film->scene_hash[i]);
  exr_attr_set_int(out.ctx, 0, "vcmfarm:format_version", 2);
  exr_attr_set_string(out.ctx, 0, "vcmfarm:scene_hash", hex);
  exr_attr_set_string(out.ctx, 0, "vcmfarm:settings", film->settings_text);
  exr_attr_set_string(out.ctx, 0, "vcmfarm:iterations", iterations);
  exr_attr_set_double(out.ctx, 0, "vcmfarm:render_seconds", 0);
  exr_attr_set_string(out.ctx, 0, "vcmfarm:nonfinite_samples", "0");
  exr_attr_set_string(out.ctx, 0, "vcmfarm:scene", film->scene_name);
  forge_source source = {vf_film_sums_of(film)};
  source.sums.iterations = 1; /* the high parts: sum / 1 */
  if ((err = vf_exr_write_pixels(&out, VF_FILM_V2_CHANNELS, vf_film_v2_channels, forge_fill, &source)) != VF_OK) {
    vf_exr_abort(&out);
    return err;
  }
  return vf_exr_commit(&out);
}
