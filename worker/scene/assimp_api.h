/* The Assimp functions the scene library calls (mesh.c, files.c, import.c,
 * import_material.c), as a table that the module libvf_assimp.so (assimp_module.c) fills
 * with Assimp's own: Assimp is loaded by the processes that import a mesh or a model, on
 * their first import, not by every command (common/module.h). Members have the names and
 * types of Assimp's C functions; a call `api->aiReleaseImport(s)` is Assimp's. */
#ifndef VF_SCENE_ASSIMP_API_H
#define VF_SCENE_ASSIMP_API_H

#include "../../common/module.h"

#include <assimp/cfileio.h>
#include <assimp/cimport.h>
#include <assimp/material.h>

/* Changed whenever the list changes (a module of another version is refused by name). */
#define VF_ASSIMP_API_VERSION 1
#define VF_ASSIMP_MODULE_FILE "libvf_assimp.so"

#define VF_ASSIMP_FUNCTIONS(X)                                                                      \
  X(aiImportFile) X(aiImportFileEx) X(aiImportFileFromMemory) X(aiApplyPostProcessing)             \
  X(aiReleaseImport) X(aiGetErrorString) X(aiGetMaterialString) X(aiGetMaterialIntegerArray)        \
  X(aiGetMaterialFloatArray) X(aiGetMaterialColor) X(aiGetMaterialTexture) X(aiGetMaterialTextureCount)

typedef struct {
  vf_module_head head; /* VF_ASSIMP_API_VERSION, sizeof(vf_assimp_api) */
  VF_ASSIMP_FUNCTIONS(VF_MODULE_MEMBER)
} vf_assimp_api;

/* Assimp's functions, the module loaded on the first call (thread-safe); NULL when it
 * cannot be, with VF_EMODULE set, its detail "LABEL: why" (the file to import). */
const vf_assimp_api *vf_assimp_load(const char *label);
/* The same, for code that holds an Assimp scene: every one was made through a successful
 * vf_assimp_load, so the table is there. */
const vf_assimp_api *vf_assimp(void);

#endif
