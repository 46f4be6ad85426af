/* Memory of a density grid (docs/BENCHMARKS.md, "Participating media"):
 *
 *     build/tests/bench_grid_memory [N]      # N^3 voxels, default 256
 *
 * Writes an N^3 float grid to a .vdb file with OpenVDB (tests/worker/scene/vdb_fixtures.h)
 * in a child process, loads a scene whose medium reads it, and prints the dense grid's bytes, the process's
 * resident memory before and after the load, and its peak during the load (OpenVDB's
 * tree, read and converted, is freed after it). */
#include "common/error.h"
#include "tests/worker/scene/vdb_fixtures.h"
#include "worker/scene/load.h"
#include "worker/scene/scene.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

/* Resident memory now, in MiB, from /proc/self/statm. */
static double resident_mib(void) {
  FILE *f = fopen("/proc/self/statm", "r");
  long size = 0, resident = 0;
  if (f == NULL || fscanf(f, "%ld %ld", &size, &resident) != 2) resident = 0;
  if (f) fclose(f);
  return (double)resident * (double)sysconf(_SC_PAGESIZE) / (1024.0 * 1024.0);
}

static double peak_mib(void) {
  struct rusage ru;
  getrusage(RUSAGE_SELF, &ru);
  return (double)ru.ru_maxrss / 1024.0;
}

int main(int argc, char **argv) {
  int n = argc > 1 ? atoi(argv[1]) : 256;
  if (n < 2 || n > 512) {
    fprintf(stderr, "usage: bench_grid_memory [N], 2 <= N <= 512\n");
    return 2;
  }
  char dir[] = "/tmp/vf-grid-XXXXXX";
  if (mkdtemp(dir) == NULL) return 1;
  char vdb[512], json[512];
  snprintf(vdb, sizeof vdb, "%s/grid.vdb", dir);
  snprintf(json, sizeof json, "%s/scene.json", dir);
  const int lo[3] = {0, 0, 0}, dims[3] = {n, n, n};
  const double scale[3] = {2.0 / n, 2.0 / n, 2.0 / n}, translate[3] = {-1.0, -1.0, -1.0};
  /* Written by a child, so that none of the writer's memory is this process's. */
  pid_t child = fork();
  if (child == 0) _exit(vdb_fixture_write(vdb, VDB_FIXTURE_GOOD, "density", lo, dims, scale, translate) != 0);
  int status = 0;
  if (child < 0 || waitpid(child, &status, 0) != child || !WIFEXITED(status) || WEXITSTATUS(status) != 0) return 1;
  FILE *f = fopen(json, "w");
  if (f == NULL) return 1;
  fprintf(f, "{\"camera\": {\"position\": [0, 0, 4], \"forward\": [0, 0, -1], \"up\": [0, 1, 0], \"fov\": 40},\n"
             " \"media\": {\"smoke\": {\"sigma_a\": 0.5, \"sigma_s\": 2, \"density\": {\"file\": \"grid.vdb\"}}},\n"
             " \"materials\": {},\n"
             " \"shapes\": [{\"type\": \"sphere\", \"center\": [0, 0, 0], \"radius\": 1.8, \"interior\": \"smoke\"}],\n"
             " \"lights\": [{\"type\": \"point\", \"position\": [0, 3, 3], \"intensity\": [10, 10, 10]}]}\n");
  fclose(f);
  double before = resident_mib();
  vf_scene *scene = NULL;
  int err = vf_scene_load(json, &scene);
  double after = resident_mib(), peak = peak_mib();
  if (err != VF_OK) {
    fprintf(stderr, "load: %s\n", vf_error_detail(err));
    return 1;
  }
  const vf_density_grid *g = scene->media[0].grid;
  printf("grid %ux%ux%u: %.1f MiB of densities; resident %.1f MiB before the load, %.1f MiB after, peak %.1f MiB\n",
         g->nx, g->ny, g->nz, (double)g->nx * g->ny * g->nz * sizeof(float) / (1024.0 * 1024.0), before, after, peak);
  vf_scene_destroy(scene);
  remove(vdb);
  remove(json);
  rmdir(dir);
  return 0;
}
