/* Finding and opening the program's modules (module.h). */
#include "module.h"

#include "error.h"

#include <dlfcn.h>
#include <limits.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#ifndef VF_MODULE_BUILD_DIR
#error "VF_MODULE_BUILD_DIR must name the build tree's folder of the modules"
#endif

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

/* Appends `dir`/`suffix``file` to the n candidates unless it is too long or already there. */
static void add_candidate(char candidates[][PATH_MAX], int *n, const char *dir, const char *suffix, const char *file) {
  if (snprintf(candidates[*n], PATH_MAX, "%s/%s%s", dir, suffix, file) >= PATH_MAX) return;
  for (int i = 0; i < *n; i++)
    if (strcmp(candidates[i], candidates[*n]) == 0) return;
  (*n)++;
}

/* Loads m->table, or writes m->failure. */
static void load(vf_module *m) {
  char dir[PATH_MAX], candidates[3][PATH_MAX];
  int n = 0;
  if (program_dir(dir, sizeof dir)) {
    add_candidate(candidates, &n, dir, "", m->file);
    add_candidate(candidates, &n, dir, "../lib/vcmfarm/", m->file);
  }
  add_candidate(candidates, &n, VF_MODULE_BUILD_DIR, "", m->file);
  for (int i = 0; i < n; i++) {
    if (access(candidates[i], F_OK) != 0) continue;
    void *handle = dlopen(candidates[i], RTLD_NOW | RTLD_LOCAL);
    if (handle == NULL) {
      const char *why = dlerror();
      snprintf(m->failure, sizeof m->failure, "%s (%.900s) cannot be loaded: %.900s", m->what, candidates[i],
               why ? why : "?");
      return;
    }
    vf_module_open_fn entry = (vf_module_open_fn)dlsym(handle, VF_MODULE_ENTRY);
    const vf_module_head *head = entry ? entry(m->version, vf_error_set) : NULL;
    if (head == NULL || head->version != m->version || head->size != m->size) {
      snprintf(m->failure, sizeof m->failure, "%s (%.1024s) is of another vcmfarm version (module version %d wanted)",
               m->what, candidates[i], m->version);
      dlclose(handle);
      return;
    }
    __atomic_store_n(&m->table, head, __ATOMIC_RELEASE); /* the module stays open for the life of the process */
    return;
  }
  int w = snprintf(m->failure, sizeof m->failure, "%s (%s) is not installed: looked in", m->what, m->file);
  for (int i = 0; i < n && w > 0 && (size_t)w < sizeof m->failure; i++)
    w += snprintf(m->failure + w, sizeof m->failure - (size_t)w, "%s %s", i ? "," : "", candidates[i]);
}

const void *vf_module_get(vf_module *m, const char *label) {
  const void *loaded = __atomic_load_n(&m->table, __ATOMIC_ACQUIRE);
  if (loaded != NULL) return loaded;
  pthread_mutex_lock(&m->lock);
  if (!m->tried) {
    load(m);
    m->tried = 1;
  }
  const void *table = m->table;
  pthread_mutex_unlock(&m->lock);
  if (table == NULL) vf_error_set(VF_EMODULE, "%s: %s", label, m->failure);
  return table;
}
