/* vdb.h's operations through the OpenVDB module (vdb_module.h), opened on first use
 * (common/module.h): a scene without grids never loads it. */
#include "vdb.h"

#include "vdb_module.h"

#include "../../common/error.h"

#include <stdio.h>

static vf_module vdb = VF_MODULE_INIT(VF_VDB_MODULE_FILE, "OpenVDB support", VF_VDB_MODULE_VERSION,
                                      sizeof(vf_vdb_module));

/* The module, or NULL with the error recorded (`label`: the grid the caller wanted). */
static const vf_vdb_module *get(const char *label) {
  return vf_module_get(&vdb, label);
}

int vf_vdb_read_grid(const char *path, const char *label, const char *grid_name, vf_density_grid *out) {
  const vf_vdb_module *m = get(label);
  return m ? m->read_grid(path, label, grid_name, out) : VF_EMODULE;
}

int vf_vdb_read_grid_memory(const void *data, size_t size, const char *label, const char *grid_name,
                            vf_density_grid *out) {
  const vf_vdb_module *m = get(label);
  return m ? m->read_grid_memory(data, size, label, grid_name, out) : VF_EMODULE;
}

int vf_vdb_write_grid_memory(const vf_density_grid *grid, const char *grid_name, void **data, size_t *size) {
  char label[160];
  snprintf(label, sizeof label, "VDB grid '%.100s'", grid_name);
  const vf_vdb_module *m = get(label);
  return m ? m->write_grid_memory(grid, grid_name, data, size) : VF_EMODULE;
}

int vf_vdb_write_grid(const vf_density_grid *grid, const char *grid_name, const char *path) {
  const vf_vdb_module *m = get(path);
  return m ? m->write_grid(grid, grid_name, path) : VF_EMODULE;
}
