/* Loading a scene (load.c): the scene library's entry point. A name is a built-in scene
 * (builtin.h), a path a JSON scene file (json.h, docs/SCENES.md) or a model file read as
 * the JSON scene that imports it. The result is the model of scene.h. Scenes travelling in
 * farm jobs load through job_scene.h instead. */
#ifndef VF_SCENE_LOAD_H
#define VF_SCENE_LOAD_H

#include "scene.h"

#include <stddef.h>

/* Loads a built-in scene by name, or else a JSON scene file (docs/SCENES.md). On failure
 * returns VF_ENOENT (scene, mesh or map file missing), VF_EMESH (a mesh file's content),
 * VF_ESCENE (anything else wrong with the scene, including unreadable EXR maps) or
 * VF_ENOMEM, with a detail naming the file, the field and the problem, e.g.
 * "box.json: shapes[2].material: unknown material 'gold'". *out is written only on success
 * and the caller owns the scene (vf_scene_destroy). Thread-safe apart from Assimp's
 * process-global error text, which concurrent failing imports may mix up. */
int vf_scene_load(const char *name_or_path, vf_scene **out);

/* A model file (vf_scene_is_model_file: .gltf, .glb or .obj) loads as a whole scene: its
 * meshes, materials, lights and cameras (docs/SCENES.md, "import"); so does a Mitsuba 3
 * scene (.xml, mitsuba.h), whose `camera` is a sensor's id or index. vf_scene_load_camera
 * is vf_scene_load choosing the file's camera by name or index (`camera`; NULL: its first
 * perspective camera, else a default one). A camera that is not there is VF_ESCENE listing
 * the file's cameras; a camera for a built-in or JSON scene is VF_EUSAGE. */
int vf_scene_load_camera(const char *name_or_path, const char *camera, vf_scene **out);
int vf_scene_is_model_file(const char *path);
/* The JSON scene text that imports model file `path` (of a Mitsuba scene: that says the
 * same, vf_mitsuba_scene_text) (by its name alone, from its own
 * directory), choosing `camera` (may be NULL): what vf_scene_load parses for a model file
 * and what a farm job carries. *text (free) and *len on success only; VF_ENOMEM. */
int vf_scene_model_text(const char *path, const char *camera, char **text, size_t *len);

/* `name` could not be read as a scene file (error err, with its detail). When it looks like
 * a scene name rather than a path (no '/', no ".json"), the detail gains the list of
 * built-in names, so a misspelt built-in says what there is. Returns err. */
int vf_scene_not_found(const char *name, int err);

#endif
