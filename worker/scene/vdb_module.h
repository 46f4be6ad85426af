/* The contract between the scene library and its OpenVDB module (vdb.cpp, built as
 * libvf_vdb.so; common/module.h). OpenVDB and what it links (Boost, TBB, log4cplus,
 * Blosc) cost every process that loads them about 40 ms of dynamic linking and a pool of
 * logging threads at start, whether it reads a grid or not; so only a process that reads
 * or writes a density grid loads them, through this module, on its first use (vdb.c).
 * Given the program's vf_error_set, VF_MODULE_ENTRY returns the table of vdb.h's
 * operations below, or NULL when it cannot serve that version. */
#ifndef VF_SCENE_VDB_MODULE_H
#define VF_SCENE_VDB_MODULE_H

#include "medium.h"

#include "../../common/module.h"

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Changed whenever this table or vf_density_grid changes: a module of another version is
 * refused by name, never called. */
#define VF_VDB_MODULE_VERSION 2
#define VF_VDB_MODULE_FILE "libvf_vdb.so"

/* vdb.h's four operations, with its contracts. */
typedef struct {
  vf_module_head head; /* VF_VDB_MODULE_VERSION, sizeof(vf_vdb_module) */
  int (*read_grid)(const char *path, const char *label, const char *grid_name, vf_density_grid *out);
  int (*read_grid_memory)(const void *data, size_t size, const char *label, const char *grid_name,
                          vf_density_grid *out);
  int (*write_grid_memory)(const vf_density_grid *grid, const char *grid_name, void **data, size_t *size);
  int (*write_grid)(const vf_density_grid *grid, const char *grid_name, const char *path);
} vf_vdb_module;

#ifdef __cplusplus
}
#endif

#endif
