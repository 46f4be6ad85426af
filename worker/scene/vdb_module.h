/* The contract between the scene library and its OpenVDB module (vdb.cpp, built as
 * libvf_vdb.so). OpenVDB and what it links (Boost, TBB, log4cplus, Blosc) cost every
 * process that loads them about 40 ms of dynamic linking and a pool of logging threads at
 * start, whether it reads a grid or not; so only a process that reads or writes a density
 * grid loads them, through this module, on its first use (vdb.c). The module exports one
 * symbol, VF_VDB_MODULE_ENTRY: given the program's vf_error_set (the error detail is
 * thread-local state of the program's common/error.c, which the module does not link), it
 * returns its table of vdb.h's operations, or NULL when it cannot serve that version. */
#ifndef VF_SCENE_VDB_MODULE_H
#define VF_SCENE_VDB_MODULE_H

#include "medium.h"

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Changed whenever this table or vf_density_grid changes: a module of another version is
 * refused by name, never called. */
#define VF_VDB_MODULE_VERSION 1
#define VF_VDB_MODULE_ENTRY "vf_vdb_module_open"
#define VF_VDB_MODULE_FILE "libvf_vdb.so"

typedef int (*vf_vdb_error_fn)(int code, const char *fmt, ...);

/* vdb.h's four operations, with its contracts. */
typedef struct {
  int version; /* VF_VDB_MODULE_VERSION */
  int (*read_grid)(const char *path, const char *label, const char *grid_name, vf_density_grid *out);
  int (*read_grid_memory)(const void *data, size_t size, const char *label, const char *grid_name,
                          vf_density_grid *out);
  int (*write_grid_memory)(const vf_density_grid *grid, const char *grid_name, void **data, size_t *size);
  int (*write_grid)(const vf_density_grid *grid, const char *grid_name, const char *path);
} vf_vdb_module;

typedef const vf_vdb_module *(*vf_vdb_module_open_fn)(int version, vf_vdb_error_fn error_set);

#ifdef __cplusplus
}
#endif

#endif
