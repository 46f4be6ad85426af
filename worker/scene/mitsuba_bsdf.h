/* Mitsuba 3 BSDFs and textures as vcmfarm materials (mitsuba_bsdf.c): each <bsdf> becomes
 * one material of the JSON scene, named by its id, with the mapping and its approximations
 * of docs/SCENES.md ("Mitsuba 3 scenes"), every approximation noted. Private to
 * worker/scene/. */
#ifndef VF_SCENE_MITSUBA_BSDF_H
#define VF_SCENE_MITSUBA_BSDF_H

#include "mitsuba_props.h"

/* The material for <bsdf> element `bsdf` (NULL: Mitsuba's default, diffuse 0.5), added to
 * c->materials once per element; its name (borrowed from the JSON scene) into *name.
 * Errors name the element (mts_fail); a bitmap file that cannot be opened is VF_ENOENT. */
int mts_material(mts_ctx *c, vf_xml_node *bsdf, const char **name);

/* The JSON texture object {"file", "wrap"} of a <texture type="bitmap">, into *out (owned
 * by the caller); checks the file opens. `color`: for a colour slot (sRGB-decoded 8-bit
 * texels, so `raw` is noted). 0 when the texture is another type (out NULL). */
int mts_bitmap(mts_ctx *c, vf_xml_node *texture, int color, cJSON **out);

#endif
