/* A scene's background replaced after loading (background.c): what `vcmfarm render
 * --background` and `continue --background` do to any scene (docs/SCENES.md, "lights"). */
#ifndef VF_SCENE_BACKGROUND_H
#define VF_SCENE_BACKGROUND_H

#include "scene.h"

/* Replaces the scene's "background" or "environment" light by `spec`: a constant radiance
 * "R,G,B" or "V" (grey), each finite and >= 0, or an EXR file (a name ending in .exr, any
 * case), a latitude-longitude map as the "environment" light reads it, of scale 1. The
 * scene's other lights stay; its hash is recomputed, so a film rendered with a background
 * continues only with the same one. On failure the scene is unchanged: VF_EUSAGE naming
 * `spec` for a malformed colour, the EXR reader's code for an unreadable map, VF_ESCENE for
 * a negative or non-finite pixel. */
int vf_scene_set_background(vf_scene *scene, const char *spec);

#endif
