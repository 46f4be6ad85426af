/* OpenVDB float grids as the scene model's dense density grids (medium.h), behind a C
 * interface of its own: vdb.cpp is the only file that sees OpenVDB's C++ API, and the
 * only C++ of the scene library. Exceptions never cross this interface: every failure is
 * a VF_* code with a detail (common/error.h).
 *
 * Reading: the grid named `grid_name` must be a float grid with a linear, axis-aligned
 * index-to-world transform (a scale per axis, positive, and a translation). The dense
 * grid spans the bounding box of its active voxels: one sample per voxel, at the voxel's
 * centre, so its world box is the voxels' box (index bounds +- 0.5 mapped to world
 * space). Voxels inside that box that are not active read as the grid's background,
 * which must be 0 (a density grid is empty outside its voxels). Every value must be
 * finite and >= 0, there must be at least one active voxel, and at most
 * VF_GRID_MAX_SAMPLES samples; the size is checked before anything is allocated.
 *
 * Errors: VF_EMODULE (OpenVDB support is not installed: common/module.h), VF_ENOENT (the
 * file cannot be opened), VF_ESCENE (not a VDB file, damaged, no
 * such grid, not float, a transform or values it refuses, too large), VF_ENOMEM. Details
 * begin with `label` (the file as the scene names it). Out-parameters on success only;
 * the grid's density array is then the caller's (vf_medium_release frees it inside a
 * medium; free(out->density) otherwise). Thread-safe. */
#ifndef VF_SCENE_VDB_H
#define VF_SCENE_VDB_H

#include "medium.h"

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* From the file at `path`. */
int vf_vdb_read_grid(const char *path, const char *label, const char *grid_name, vf_density_grid *out);
/* From a VDB file's bytes in memory (borrowed for the call), as a built-in scene hands its
 * generated grid to the parser (builtin.c). */
int vf_vdb_read_grid_memory(const void *data, size_t size, const char *label, const char *grid_name,
                            vf_density_grid *out);

/* A VDB file's bytes holding `grid` as one float grid named `grid_name`: every sample with
 * a non-zero density an active voxel, background 0, a transform of per-axis scale and
 * translation that puts the voxels' box at grid->box_min .. box_max. *data (free) and
 * *size on success only; VF_EINVAL for an empty or inconsistent grid, VF_ENOMEM, VF_EIO. */
int vf_vdb_write_grid_memory(const vf_density_grid *grid, const char *grid_name, void **data, size_t *size);
/* The same into the file at `path` (VF_EIO naming it when it cannot be written). */
int vf_vdb_write_grid(const vf_density_grid *grid, const char *grid_name, const char *path);

#ifdef __cplusplus
}
#endif

#endif
