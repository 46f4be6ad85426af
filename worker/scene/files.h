/* Where the files a JSON scene names come from when the scene travels in a farm job.
 *
 * A scene names files in its "file" fields, and a mesh file may name more (glTF buffers,
 * OBJ material libraries), which Assimp opens by paths derived from the mesh's name. To
 * ship exactly the files the loader reads, both ends load through one of these instead of
 * the file system:
 *
 * - recording (`submit`): a name opens base_dir/NAME (or NAME when absolute) and is
 *   recorded with that path, so afterwards the table of names is exactly what the load
 *   read, Assimp's own opens included;
 * - mapping (workers, and `submit` checking itself): a name opens the blob its table
 *   entry names in a blob store (common/blob.h); a name not in the table does not exist.
 *   Names are only looked up, never used as paths, so nothing can reach outside the store.
 *
 * Assimp's requests come through a C aiFileIO, so a load asks for the same names in both
 * modes and gives the same scene, hence the same content hash. */
#ifndef VF_SCENE_FILES_H
#define VF_SCENE_FILES_H

#include "../../common/blob.h"
#include "scene.h"

#include <stddef.h>

typedef struct vf_scene_files vf_scene_files;

/* A file held in memory, as a built-in scene carries its generated meshes (builtin.c); the
 * format is taken from the extension of `name`. Borrowed: the parser only reads it during
 * the call. */
typedef struct {
  const char *name;
  const void *data;
  size_t size;
} vf_scene_memfile;

/* *out (vf_scene_files_destroy) on success only; VF_ENOMEM. The mapping mode borrows
 * table and store_dir for its lifetime. */
int vf_scene_files_recording(const char *base_dir, vf_scene_files **out);
int vf_scene_files_mapping(const vf_blob_table *table, const char *store_dir, vf_scene_files **out);
void vf_scene_files_destroy(vf_scene_files *files);

/* Recording mode: the files opened so far, each name once, and the path each was read
 * from (borrowed, valid until destroy). */
size_t vf_scene_files_count(const vf_scene_files *files);
const char *vf_scene_files_name(const vf_scene_files *files, size_t i);
const char *vf_scene_files_path(const vf_scene_files *files, size_t i);

/* For the readers of a scene (parse.c, vf_scene_resolve): the path to open for `name`, into
 * out (recorded in recording mode); VF_ENOENT with a detail when there is none. */
int vf_scene_files_resolve(vf_scene_files *files, const char *name, char *out, size_t n);
/* Imports mesh `name` through Assimp with every file it opens resolved as above; Assimp's
 * result (NULL on failure, aiGetErrorString says why). */
const struct aiScene *vf_scene_files_import(vf_scene_files *files, const char *name, unsigned flags);

#endif
