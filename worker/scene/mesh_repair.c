/* Repairs of a mesh file's vertex normals and tangents (mesh_repair.h): what other tools
 * accept (Blender recomputes such normals) is mended and counted, never refused whole. */
#include "mesh_repair.h"

#include "../../common/error.h"

#include <assimp/scene.h>

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
  uint64_t normals;    /* zero or not finite: from the faces */
  uint64_t unit;       /* finite, non-zero, length off 1 by more than 1e-3: normalised */
  uint64_t tangents;   /* zero, not finite or along the normal: from the faces */
  uint64_t tangent_unit; /* finite, length off 1 by more than 1e-3: normalised */
} repairs;

static double length3(const struct aiVector3D *v) { return sqrt((double)v->x * v->x + (double)v->y * v->y + (double)v->z * v->z); }

/* The area-weighted normal of the faces around each vertex (Newell's normal of each face,
 * twice its area, added to its corners), into acc (3 per vertex). */
static void face_normals(const struct aiMesh *mesh, double *acc) {
  memset(acc, 0, 3 * sizeof(double) * mesh->mNumVertices);
  for (unsigned f = 0; f < mesh->mNumFaces; f++) {
    const struct aiFace *face = &mesh->mFaces[f];
    const unsigned n = face->mNumIndices;
    double nx = 0, ny = 0, nz = 0;
    int ok = n >= 3;
    for (unsigned k = 0; ok && k < n; k++) ok = face->mIndices[k] < mesh->mNumVertices;
    if (!ok) continue; /* refused where faces are read */
    for (unsigned k = 0; k < n; k++) {
      const struct aiVector3D *a = &mesh->mVertices[face->mIndices[k]], *b = &mesh->mVertices[face->mIndices[(k + 1) % n]];
      nx += ((double)a->y - b->y) * ((double)a->z + b->z);
      ny += ((double)a->z - b->z) * ((double)a->x + b->x);
      nz += ((double)a->x - b->x) * ((double)a->y + b->y);
    }
    for (unsigned k = 0; k < n; k++) {
      double *o = &acc[3 * (size_t)face->mIndices[k]];
      o[0] += nx, o[1] += ny, o[2] += nz;
    }
  }
}

/* A unit vector along (x, y, z), or any unit vector orthogonal to `normal` when it has none. */
static struct aiVector3D unit_or_orthogonal(double x, double y, double z, const struct aiVector3D *normal) {
  double len = sqrt(x * x + y * y + z * z);
  struct aiVector3D out;
  if (len > 0.0 && isfinite(len)) {
    out.x = (ai_real)(x / len), out.y = (ai_real)(y / len), out.z = (ai_real)(z / len);
    return out;
  }
  /* the axis least along the normal, made orthogonal to it */
  double n[3] = {normal->x, normal->y, normal->z}, e[3] = {0, 0, 0};
  int k = fabs(n[0]) <= fabs(n[1]) && fabs(n[0]) <= fabs(n[2]) ? 0 : fabs(n[1]) <= fabs(n[2]) ? 1 : 2;
  e[k] = 1.0;
  double d = e[0] * n[0] + e[1] * n[1] + e[2] * n[2];
  x = e[0] - d * n[0], y = e[1] - d * n[1], z = e[2] - d * n[2];
  len = sqrt(x * x + y * y + z * z);
  out.x = (ai_real)(x / len), out.y = (ai_real)(y / len), out.z = (ai_real)(z / len);
  return out;
}

/* The direction of increasing s on a face around vertex v (its first corner of v with
 * usable uvs), orthogonal to normal; zero when no face has one. */
static void face_tangent(const struct aiMesh *mesh, unsigned v, const struct aiVector3D *normal, double t[3]) {
  t[0] = t[1] = t[2] = 0.0;
  const struct aiVector3D *uv = mesh->mTextureCoords[0];
  for (unsigned f = 0; uv && f < mesh->mNumFaces; f++) {
    const struct aiFace *face = &mesh->mFaces[f];
    const unsigned n = face->mNumIndices;
    for (unsigned k = 0; n >= 3 && k < n; k++) {
      if (face->mIndices[k] != v) continue;
      unsigned i0 = v, i1 = face->mIndices[(k + 1) % n], i2 = face->mIndices[(k + n - 1) % n];
      if (i1 >= mesh->mNumVertices || i2 >= mesh->mNumVertices) continue;
      const struct aiVector3D *p = mesh->mVertices;
      double ds1 = uv[i1].x - uv[i0].x, dt1 = uv[i1].y - uv[i0].y, ds2 = uv[i2].x - uv[i0].x, dt2 = uv[i2].y - uv[i0].y;
      double det = ds1 * dt2 - ds2 * dt1;
      if (!(fabs(det) > 0.0)) continue;
      double e1[3] = {(double)p[i1].x - p[i0].x, (double)p[i1].y - p[i0].y, (double)p[i1].z - p[i0].z};
      double e2[3] = {(double)p[i2].x - p[i0].x, (double)p[i2].y - p[i0].y, (double)p[i2].z - p[i0].z};
      double nn[3] = {normal->x, normal->y, normal->z}, d = 0.0;
      for (int j = 0; j < 3; j++) t[j] = (e1[j] * dt2 - e2[j] * dt1) / det;
      for (int j = 0; j < 3; j++) d += t[j] * nn[j];
      for (int j = 0; j < 3; j++) t[j] -= d * nn[j];
      if (t[0] != 0.0 || t[1] != 0.0 || t[2] != 0.0) return;
    }
  }
}

/* Normals that are zero or not finite become their faces' (area-weighted, as Blender
 * recomputes them); finite ones of a length off 1 are counted (the transform normalises
 * every normal). Tangents that are zero, not finite or along the normal become the
 * direction of increasing s on a face of the vertex (any direction orthogonal to the
 * normal without uvs), with the bitangent N x T. Assimp's arrays are written in place. */
static int repair_mesh(struct aiMesh *mesh, repairs *r) {
  if (mesh->mNormals == NULL) return VF_OK;
  double *acc = NULL;
  for (unsigned v = 0; v < mesh->mNumVertices; v++) {
    struct aiVector3D *n = &mesh->mNormals[v];
    double len = length3(n);
    if (len > 0.0 && isfinite(len)) {
      r->unit += fabs(len - 1.0) > 1e-3;
      continue;
    }
    if (acc == NULL) {
      if ((acc = malloc(3 * sizeof(double) * ((size_t)mesh->mNumVertices + 1))) == NULL)
        return vf_error_set(VF_ENOMEM, "out of memory");
      face_normals(mesh, acc);
    }
    const double *a = &acc[3 * (size_t)v], alen = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    if (alen > 0.0 && isfinite(alen)) n->x = (ai_real)(a[0] / alen), n->y = (ai_real)(a[1] / alen), n->z = (ai_real)(a[2] / alen);
    else n->x = 0, n->y = 0, n->z = 1; /* on no face of area: its triangles are skipped, any unit normal does */
    r->normals++;
  }
  free(acc);
  for (unsigned v = 0; mesh->mTangents && v < mesh->mNumVertices; v++) {
    struct aiVector3D *t = &mesh->mTangents[v], *n = &mesh->mNormals[v];
    double len = length3(t), along = len > 0.0 ? fabs((t->x * n->x + t->y * n->y + t->z * n->z) / len) : 1.0;
    if (len > 0.0 && isfinite(len) && along < 1.0 - 1e-6) {
      r->tangent_unit += fabs(len - 1.0) > 1e-3;
      continue;
    }
    double d[3];
    face_tangent(mesh, v, n, d);
    *t = unit_or_orthogonal(d[0], d[1], d[2], n);
    if (mesh->mBitangents) {
      struct aiVector3D *b = &mesh->mBitangents[v];
      b->x = n->y * t->z - n->z * t->y, b->y = n->z * t->x - n->x * t->z, b->z = n->x * t->y - n->y * t->x;
    }
    r->tangents++;
  }
  return VF_OK;
}

int vf_scene_mesh_repair(const parse_ctx *c, const char *file, const struct aiScene *ai) {
  repairs r = {0, 0, 0, 0};
  int err;
  for (unsigned m = 0; m < ai->mNumMeshes; m++)
    if ((err = repair_mesh(ai->mMeshes[m], &r)) < 0) return err;
  if (r.normals > 0 && (err = vf_scene_note(c, "%s: %llu vertex normals that were zero or not finite were repaired from "
                                               "their faces", file, (unsigned long long)r.normals)) < 0)
    return err;
  if (r.unit > 0 && (err = vf_scene_note(c, "%s: %llu vertex normals not of unit length were normalised", file,
                                         (unsigned long long)r.unit)) < 0)
    return err;
  if (r.tangent_unit > 0 && (err = vf_scene_note(c, "%s: %llu tangents not of unit length were normalised", file,
                                                 (unsigned long long)r.tangent_unit)) < 0)
    return err;
  if (r.tangents > 0 && (err = vf_scene_note(c, "%s: %llu tangents that were zero, not finite or along the normal "
                                                "were repaired from their faces", file, (unsigned long long)r.tangents)) < 0)
    return err;
  return VF_OK;
}
