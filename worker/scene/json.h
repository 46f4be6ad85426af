/* The JSON scene format (json.c, docs/SCENES.md): its only implementation. Built-in scenes
 * (builtin.c), model files (load.c) and farm jobs' scenes (job_scene.c) all come through
 * here. */
#ifndef VF_SCENE_JSON_H
#define VF_SCENE_JSON_H

#include "files.h"
#include "scene.h"

#include <stddef.h>

/* Parses a JSON scene text of `length` bytes. `label` names the scene in error details and
 * becomes scene->source; relative "file" paths are resolved against `base_dir` unless they
 * equal the name of one of `memfiles` (which may be NULL when num_memfiles is 0). Errors
 * and *out as for vf_scene_load (load.h). */
int vf_scene_parse(const char *text, size_t length, const char *label, const char *base_dir,
                   const vf_scene_memfile *memfiles, int num_memfiles, vf_scene **out);

/* Parses JSON scene text whose files all come from `files` (files.h: recorded from a
 * directory, or mapped to a blob store). Errors and *out as vf_scene_parse; a name the mapping
 * does not hold is VF_ENOENT "cannot open 'NAME': not among the job's files". */
int vf_scene_parse_files(const char *text, size_t length, const char *label, vf_scene_files *files,
                         vf_scene **out);

#endif
