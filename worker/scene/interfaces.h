/* Medium interfaces (interfaces.c): which shapes bound a medium region, checked closed and
 * wound outwards, and the medium outside each (medium.h, docs/SCENES.md, "Media").
 * Computed once at load from the geometry alone (no ray tracer). Private to
 * worker/scene/. */
#ifndef VF_SCENE_INTERFACES_H
#define VF_SCENE_INTERFACES_H

#include "parse.h"

/* Sets interface, interior and exterior of every shape of the scene:
 * - interface = 1 for a shape with an interior, and, in a scene with at least one medium,
 *   for a closed shape whose material refracts (a dielectric lobe) and has no interior
 *   (its interior is then vacuum, -1: a clear glass ball in fog is clear inside);
 * - exterior = the interior of the innermost interface shape that contains the shape (by
 *   enclosed volume), else scene->medium; -1 for shapes without an interface.
 * A mesh is closed when every edge (vertices joined by position) is shared by exactly two
 * triangles, traversed in opposite directions; a closed mesh that encloses a negative
 * volume (facing inwards) has its triangles turned to face outwards, with a note.
 * Shapes [0, first_lenient) are the scene file's own: one with an interior that is not
 * closed fails (VF_ESCENE naming the shape); later shapes (imports) lose their interior
 * with a note instead. VF_ENOMEM. */
int vf_scene_resolve_interfaces(const parse_ctx *c, int first_lenient);

#endif
