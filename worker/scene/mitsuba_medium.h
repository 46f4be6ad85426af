/* Mitsuba 3 media as the JSON scene's (mitsuba_medium.c, docs/SCENES.md, "Media"): a
 * homogeneous <medium> with its phase function. Private to worker/scene/. */
#ifndef VF_SCENE_MITSUBA_MEDIUM_H
#define VF_SCENE_MITSUBA_MEDIUM_H

#include "mitsuba_props.h"

/* The medium `e` (a <medium>, or a <ref> to one) in the JSON scene's "media", once per
 * element: its name there in *name (borrowed from the JSON), or NULL when it cannot be
 * converted (a heterogeneous medium, a textured coefficient), which is noted. */
int mts_medium(mts_ctx *c, vf_xml_node *e, const char **name);

#endif
