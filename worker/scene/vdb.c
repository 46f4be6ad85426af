/* vdb.h's operations through the OpenVDB module (vdb_module.h), opened on first use.
 *
 * Where the module is looked for, first found wins:
 *   1. beside the running program (/proc/self/exe's folder): the build tree's vcmfarm;
 *   2. in ../lib/vcmfarm/ from there: an installed vcmfarm (`cmake --install`, the
 *      container image), wherever its prefix is;
 *   3. in the build tree that compiled this library (VF_VDB_MODULE_BUILD_DIR): its tests
 *      and tools, whose programs live in folders of their own.
 * A module that is found but cannot be loaded, or serves another version, is an error
 * naming it; none found is an error naming every place looked in. Either fails the read or
 * write of the grid, and only that: a scene without grids never loads the module. */
#include "vdb.h"

#include "vdb_module.h"

#include "../../common/error.h"

#include <dlfcn.h>
#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#ifndef VF_VDB_MODULE_BUILD_DIR
#error "VF_VDB_MODULE_BUILD_DIR must name the build tree's folder of libvf_vdb.so"
#endif

static pthread_once_t once = PTHREAD_ONCE_INIT;
static const vf_vdb_module *module;
/* Why the module is not there, kept for every caller after the first. */
static char failure[4 * PATH_MAX];

static int exists(const char *path) { return access(path, F_OK) == 0; }

/* The folder of the running program into dir; 0 when it cannot be known. */
static int program_dir(char *dir, size_t size) {
  ssize_t n = readlink("/proc/self/exe", dir, size - 1);
  if (n <= 0) return 0;
  dir[n] = '\0';
  char *slash = strrchr(dir, '/');
  if (slash == NULL) return 0;
  *slash = '\0';
  return 1;
}

/* Appends `dir`/`suffix` to the n candidates unless it is too long or already there. */
static void add_candidate(char candidates[][PATH_MAX], int *n, const char *dir, const char *suffix) {
  if (snprintf(candidates[*n], PATH_MAX, "%s/%s%s", dir, suffix, VF_VDB_MODULE_FILE) >= PATH_MAX) return;
  for (int i = 0; i < *n; i++)
    if (strcmp(candidates[i], candidates[*n]) == 0) return;
  (*n)++;
}

static void open_module(void) {
  char dir[PATH_MAX], candidates[3][PATH_MAX];
  int n = 0;
  if (program_dir(dir, sizeof dir)) {
    add_candidate(candidates, &n, dir, "");
    add_candidate(candidates, &n, dir, "../lib/vcmfarm/");
  }
  add_candidate(candidates, &n, VF_VDB_MODULE_BUILD_DIR, "");
  for (int i = 0; i < n; i++) {
    if (!exists(candidates[i])) continue;
    void *handle = dlopen(candidates[i], RTLD_NOW | RTLD_LOCAL);
    if (handle == NULL) {
      const char *why = dlerror();
      snprintf(failure, sizeof failure, "OpenVDB support (%s) cannot be loaded: %.1024s", candidates[i], why ? why : "?");
      return;
    }
    vf_vdb_module_open_fn entry = (vf_vdb_module_open_fn)dlsym(handle, VF_VDB_MODULE_ENTRY);
    const vf_vdb_module *m = entry ? entry(VF_VDB_MODULE_VERSION, vf_error_set) : NULL;
    if (m == NULL || m->version != VF_VDB_MODULE_VERSION) {
      snprintf(failure, sizeof failure, "OpenVDB support (%s) is of another vcmfarm version (module version %d wanted)",
               candidates[i], VF_VDB_MODULE_VERSION);
      dlclose(handle);
      return;
    }
    module = m; /* kept open for the life of the process */
    return;
  }
  int w = snprintf(failure, sizeof failure, "OpenVDB support (%s) is not installed: looked in", VF_VDB_MODULE_FILE);
  for (int i = 0; i < n && w > 0 && (size_t)w < sizeof failure; i++)
    w += snprintf(failure + w, sizeof failure - (size_t)w, "%s %s", i ? "," : "", candidates[i]);
}

/* The module, or NULL with the error recorded (`label`: the grid the caller wanted). */
static const vf_vdb_module *get(const char *label) {
  pthread_once(&once, open_module);
  if (module == NULL) vf_error_set(VF_ESCENE, "%s: %s", label, failure);
  return module;
}

int vf_vdb_read_grid(const char *path, const char *label, const char *grid_name, vf_density_grid *out) {
  const vf_vdb_module *m = get(label);
  return m ? m->read_grid(path, label, grid_name, out) : VF_ESCENE;
}

int vf_vdb_read_grid_memory(const void *data, size_t size, const char *label, const char *grid_name,
                            vf_density_grid *out) {
  const vf_vdb_module *m = get(label);
  return m ? m->read_grid_memory(data, size, label, grid_name, out) : VF_ESCENE;
}

int vf_vdb_write_grid_memory(const vf_density_grid *grid, const char *grid_name, void **data, size_t *size) {
  char label[160];
  snprintf(label, sizeof label, "VDB grid '%.100s'", grid_name);
  const vf_vdb_module *m = get(label);
  return m ? m->write_grid_memory(grid, grid_name, data, size) : VF_ESCENE;
}

int vf_vdb_write_grid(const vf_density_grid *grid, const char *grid_name, const char *path) {
  const vf_vdb_module *m = get(path);
  return m ? m->write_grid(grid, grid_name, path) : VF_ESCENE;
}
