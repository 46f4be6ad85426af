/* Mesh files through Assimp (mesh.c): imported, checked, and brought into world space
 * with their vertex attributes, for a JSON shape's "file" (every mesh of the file merged
 * into one shape) and for whole-scene imports (import.c: one shape per mesh instance).
 * Private to worker/scene/. */
#ifndef VF_SCENE_MESH_H
#define VF_SCENE_MESH_H

#include "parse.h"

#include <stdint.h>

/* Imports mesh `file` (relative to the scene's directory, or a memfile) into shape s, which
 * the field at `path` describes: every mesh of the file merged, node transforms applied,
 * with the vertex attributes every mesh has (scene.h). VF_ENOENT, VF_EMESH or VF_ENOMEM
 * with a detail. */
int vf_scene_load_mesh_file(const parse_ctx *c, const char *file, const char *path, vf_shape *s);

struct aiScene;
struct aiMesh;
struct aiNode;
struct aiMatrix4x4;

/* Imports `file` (memfile, farm job file or relative to the scene's directory) through
 * Assimp, triangulated (faces above VF_MAX_POLYGON_VERTICES: see there); every position, normal, tangent and channel-0 texture coordinate
 * checked finite and every normal non-zero before identical vertices are joined. Errors
 * name `fpath` (the field naming the file) for opening and reading, `what` (the file) for
 * its content; either may be NULL (then only the scene label). *out (aiReleaseImport) on
 * success only. */
int vf_scene_import_file(const parse_ctx *c, const char *file, const char *fpath, const char *what,
                         const struct aiScene **out);

/* Faces of more vertices than this are not given to Assimp's triangulation (quadratic):
 * the file is triangulated as fans if all its polygons are convex, else refused. */
#define VF_MAX_POLYGON_VERTICES 4096
/* Triangles of an imported mesh: n - 2 per face of n >= 3 vertices. */
uint64_t vf_scene_mesh_triangles(const struct aiMesh *mesh);

/* An affine map in double: rows of p' = M p + t, the translation in column 3. */
typedef struct {
  double m[3][4];
} vf_affine;
void vf_affine_identity(vf_affine *a);
void vf_affine_from_ai(const struct aiMatrix4x4 *t, vf_affine *a);
/* out = a b (b applied first); out may alias either. */
void vf_affine_mul(const vf_affine *a, const vf_affine *b, vf_affine *out);
double vf_affine_det(const vf_affine *a);
void vf_affine_point(const vf_affine *a, const double in[3], double out[3]);
void vf_affine_vector(const vf_affine *a, const double in[3], double out[3]);

/* Moves vertices [v0, num_vertices) and triangles [t0, num_triangles) of s by a: positions
 * and tangents by M, normals by M^-T (renormalised), and a mirroring M swaps two corners of
 * each triangle and negates the tangents' bitangent sign, so fronts stay the file's.
 * VF_ESCENE naming `path` when a vertex leaves float range or a normal or tangent is
 * flattened (a singular M). */
int vf_scene_transform_range(const parse_ctx *c, const char *path, const vf_affine *a, vf_shape *s, uint32_t v0,
                             uint32_t t0);

/* Vertex attributes, as bits: what vf_scene_append_mesh had to drop. */
enum { VF_ATTR_NORMALS = 1u, VF_ATTR_UVS = 2u, VF_ATTR_TANGENTS = 4u, VF_ATTR_UVS1 = 8u, VF_ATTR_COLORS = 16u };

/* What vf_scene_append_mesh left out of a file's meshes, for its notes. */
typedef struct {
  unsigned dropped;    /* VF_ATTR_* bits lost in merging */
  uint64_t degenerate; /* triangles of zero area (in the file's coordinates), skipped */
} vf_mesh_tally;

/* Appends Assimp mesh `mesh_index` of a file, through `a` (its node's world transform), to
 * shape s: positions, triangles (points and lines left out), and normals, texture
 * coordinates of channel 0 (t = 1 - Assimp's v, so t = 0 is an image's top row) and
 * tangents (w from Assimp's bitangent) while every mesh appended to s has them; the
 * VF_ATTR_* bits of those lost in merging go into tally->dropped. Triangles of zero area
 * (a repeated corner, or three corners on a line, exactly, in the file's coordinates) are
 * left out and counted in tally->degenerate. Errors name `what`. */
int vf_scene_append_mesh(const parse_ctx *c, const char *what, const struct aiMesh *mesh, unsigned mesh_index,
                         const vf_affine *a, vf_shape *s, vf_mesh_tally *tally);
/* Notes once per file what merging dropped and how many degenerate triangles were skipped. */
int vf_scene_note_dropped(const parse_ctx *c, const char *file, const vf_mesh_tally *tally);

/* Calls fn for every (node, mesh) of the file's hierarchy, depth first, with the node's
 * world transform: root x the product of the node transforms from the file's root down.
 * Stops at and returns fn's first error; errors of its own (a hierarchy deeper than 256, a
 * node naming a missing mesh) name `what`. */
typedef int (*vf_scene_instance_fn)(void *user, const struct aiNode *node, unsigned mesh, const vf_affine *world);
int vf_scene_walk_nodes(const parse_ctx *c, const char *what, const struct aiScene *ai, const vf_affine *root,
                        vf_scene_instance_fn fn, void *user);
/* The world transform of node: the product of its and its parents' transforms. */
void vf_scene_node_world(const struct aiNode *node, vf_affine *out);

#endif
