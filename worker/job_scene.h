/* Scenes as they travel in farm jobs: a built-in name, or the text of a JSON scene.
 *
 * A JSON scene is loaded from a private temporary directory holding only its text, so
 * the farm renders exactly what was submitted, wherever it runs. Scenes that name other
 * files (meshes, environment maps) cannot travel yet: they fail to load here, on the
 * submitting machine first, with a detail saying so. Shipping meshes by content hash is
 * the next step (docs/PROTOCOL.md). */
#ifndef VF_JOB_SCENE_H
#define VF_JOB_SCENE_H

#include "scene.h"

#include <stddef.h>

/* 1 if name is a built-in scene name. */
int vf_job_scene_is_builtin(const char *name);

/* Loads a job's scene; *out (vf_scene_destroy) on success only. Errors are those of
 * vf_scene_load, with the detail naming `label` instead of the temporary file. */
int vf_job_scene_load(int builtin, const char *text, size_t len, const char *label, vf_scene **out);

#endif
