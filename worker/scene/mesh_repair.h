/* Repairs of a mesh file's vertex normals and tangents (mesh_repair.c), before its
 * identical vertices are joined. Private to worker/scene/. */
#ifndef VF_SCENE_MESH_REPAIR_H
#define VF_SCENE_MESH_REPAIR_H

#include "parse.h"

struct aiScene;

/* Mends every mesh of the file in place (Assimp's arrays) and notes, once per kind and
 * starting with `file`, how many were mended: normals zero or not finite become the
 * area-weighted normal of the faces around the vertex; normals of a length off 1 by more
 * than 1e-3 are counted (the transform normalises every normal), tangents likewise; tangents zero, not finite
 * or along the normal become the direction of increasing s on a face of the vertex (any
 * direction orthogonal to the normal without uvs), with the bitangent N x T. VF_ENOMEM
 * only. */
int vf_scene_mesh_repair(const parse_ctx *c, const char *file, const struct aiScene *ai);

#endif
