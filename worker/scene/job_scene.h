/* Scenes as they travel in farm jobs: a built-in name, or the text of a JSON scene with a
 * table of the files it names (common/blob.h: name -> content hash), whose bytes are
 * blobs in a store.
 *
 * Both ends load a JSON scene the same way: its files by name from the table, through the
 * blob store (worker/scene/files.h), never from the directory it came from. `submit`
 * first records what a load from the scene's directory reads, stages those files as
 * blobs, and loads again from the stage exactly as a worker will from its cache; so the
 * hash the job carries is the hash every worker computes. */
#ifndef VF_JOB_SCENE_H
#define VF_JOB_SCENE_H

#include "../../common/blob.h"
#include "scene.h"

#include <stddef.h>

/* 1 if name is a built-in scene name. */
int vf_job_scene_is_builtin(const char *name);

/* Loads a job's scene; *out (vf_scene_destroy) on success only. A JSON scene's files come
 * from `files` (may be NULL: none) with their bytes in blob store `store_dir`; a built-in
 * scene takes no files. Errors are those of vf_scene_load, with details naming `label`. */
int vf_job_scene_load(int builtin, const char *text, size_t len, const vf_blob_table *files, const char *store_dir,
                      const char *label, vf_scene **out);

/* `submit`'s side: loads the JSON scene text read from `path`, resolving its files against
 * path's directory, and stores every file the load read as a blob in `stage_dir` (a
 * private directory the caller creates and removes), adding it to *files (empty on entry;
 * the caller clears it). Then loads the scene again through the table and stage, as a
 * worker will, and checks that both loads hash equal. *out is that second scene.
 * Errors of vf_scene_load; VF_EINVAL naming a file above VF_BLOB_MAX_BYTES. */
int vf_job_scene_collect(const char *path, const char *text, size_t len, const char *stage_dir,
                         vf_blob_table *files, vf_scene **out);

#endif
