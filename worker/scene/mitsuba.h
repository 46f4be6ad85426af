/* Mitsuba 3 XML scenes (mitsuba.c): a scene file read as the JSON scene of docs/SCENES.md
 * that says the same, so a local render and a farm job (which carries that text and ships
 * the mesh and texture files it names by content hash) load it by one path, as model files
 * do (load.h). docs/SCENES.md, "Mitsuba 3 scenes", tables the subset, the mapping of every
 * element and Mitsuba's conventions. */
#ifndef VF_SCENE_MITSUBA_H
#define VF_SCENE_MITSUBA_H

#include <stddef.h>

/* 1 if path ends in .xml (any case); in ext (".serialized"). */
int vf_mitsuba_is_xml(const char *path);
int vf_mitsuba_has_extension(const char *path, const char *ext);

/* The JSON scene text (*text, free; *len) equivalent to Mitsuba scene `path`, its files
 * named relative to path's directory, with the sensor chosen by id or index `camera` (NULL:
 * the first). What it approximates or leaves out is in the text's "notes", one line each.
 * On failure *text is untouched and the error (VF_ESCENE; VF_ENOENT for a file that cannot
 * be opened; VF_ENOMEM) names the file, the line, the element and the reason, e.g.
 * "box.xml:12: <bsdf type="hair">: ...". */
int vf_mitsuba_scene_text(const char *path, const char *camera, char **text, size_t *len);

#endif
