/* Mesh files of a scene (OBJ, PLY, glTF and whatever else Assimp reads): imported, checked
 * (finite vertices, normals and texture coordinates, indices in range) and brought into
 * world space with their vertex attributes. A JSON shape's "file" merges every mesh of
 * the file into one shape; an "import" (import.c) makes one shape per mesh instance.
 *
 * Node transforms are applied here, not by aiProcess_PreTransformVertices: that step
 * merges meshes by material (an import keeps them apart) and moves tangents by the inverse
 * transpose like normals, which bends them off the surface under a non-uniform scale.
 * Positions and tangents go through the node's matrix M, normals through M^-T, and a
 * mirroring M reverses the winding and the bitangent sign, so fronts stay the file's. */
#include "mesh.h"

#include "../../common/error.h"
#include "assimp_api.h"
#include "gltf.h"
#include "files.h"
#include "mesh_repair.h"

#include <assimp/cimport.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* Assimp's last error, trailing whitespace trimmed. The text is process-global: concurrent
 * imports on several threads may report each other's message (the codes stay right). */
static const char *assimp_error(char *buf, size_t n) {
  snprintf(buf, n, "%s", vf_assimp()->aiGetErrorString());
  for (size_t len = strlen(buf); len > 0 && (buf[len - 1] == ' ' || buf[len - 1] == '\n'); len--) buf[len - 1] = '\0';
  return buf;
}

static const vf_scene_memfile *find_memfile(const parse_ctx *c, const char *file) {
  for (int i = 0; i < c->num_memfiles; i++)
    if (strcmp(c->memfiles[i].name, file) == 0) return &c->memfiles[i];
  return NULL;
}

/* ---- checking the file's values --------------------------------------------------------- */

static int finite3(const struct aiVector3D *v) { return isfinite(v->x) && isfinite(v->y) && isfinite(v->z); }

/* Every position and texture coordinate finite. Runs before identical vertices are
 * joined: Assimp's spatial sort merges a NaN vertex into a neighbour and the bad value
 * would vanish unnoticed. Vertices are counted across the file's meshes in order, as the
 * messages name them. Normals and tangents are repaired instead (repair_mesh). */
static int check_values(const parse_ctx *c, const char *what, const struct aiScene *ai) {
  uint64_t vertex = 0;
  for (unsigned m = 0; m < ai->mNumMeshes; m++) {
    const struct aiMesh *mesh = ai->mMeshes[m];
    for (unsigned v = 0; v < mesh->mNumVertices; v++, vertex++) {
      const char *bad = NULL;
      if (!finite3(&mesh->mVertices[v])) bad = "a non-finite coordinate";
      else if (mesh->mTextureCoords[0] && !(isfinite(mesh->mTextureCoords[0][v].x) &&
                                             isfinite(mesh->mTextureCoords[0][v].y)))
        bad = "a non-finite texture coordinate";
      else if (mesh->mTextureCoords[1] && !(isfinite(mesh->mTextureCoords[1][v].x) &&
                                             isfinite(mesh->mTextureCoords[1][v].y)))
        bad = "a non-finite texture coordinate of set 1";
      if (bad != NULL)
        return vf_scene_fail(c, VF_EMESH, what, "vertex %llu has %s (vertex %u of mesh %u%s%s%s)",
                             (unsigned long long)vertex, bad, v, m, mesh->mName.length ? ", '" : "",
                             mesh->mName.data, mesh->mName.length ? "'" : "");
    }
  }
  return VF_OK;
}

/* Whether to join the file's identical vertices. Assimp's OBJ and STL importers give every
 * corner of a face a vertex of its own, so joining shrinks their arrays several times.
 * Indexed formats (glTF, PLY) share their vertices already, and there the join would cost
 * more time and memory than the rest of the load (docs/BENCHMARKS.md, "Loading the
 * showcase") to merge the few duplicates an exporter leaves; it runs for such a file only
 * when one of its meshes has no indices (every vertex serves one corner). */
static int join_vertices(const char *name, const struct aiScene *ai) {
  size_t n = strlen(name);
  if (!vf_gltf_is_gltf(name) && !(n >= 4 && strcasecmp(name + n - 4, ".ply") == 0)) return 1;
  for (unsigned m = 0; m < ai->mNumMeshes; m++) {
    const struct aiMesh *mesh = ai->mMeshes[m];
    uint64_t corners = 0;
    for (unsigned f = 0; f < mesh->mNumFaces; f++) corners += mesh->mFaces[f].mNumIndices;
    if (mesh->mNumVertices >= corners) return 1;
  }
  return 0;
}

/* ---- polygons ------------------------------------------------------------------------------ */

uint64_t vf_scene_mesh_triangles(const struct aiMesh *mesh) {
  uint64_t n = 0;
  for (unsigned f = 0; f < mesh->mNumFaces; f++)
    if (mesh->mFaces[f].mNumIndices >= 3) n += mesh->mFaces[f].mNumIndices - 2;
  return n;
}

/* Whether polygon `face` (indices checked in range) is planar and convex: every turn of its
 * boundary on the same side about its Newell normal, the turns summing to one revolution
 * (a star's sum to several), every vertex within 1e-4 of the polygon's size of its plane.
 * A turn the other way counts as straight when it lies within what rounding the vertices
 * to floats can make of a straight one (a circle of 100,000 vertices has turns of 6e-5 rad
 * and edges not much longer than the floats' spacing). */
static int convex_planar(const struct aiMesh *mesh, const struct aiFace *face) {
  const unsigned n = face->mNumIndices;
  double nx = 0, ny = 0, nz = 0, size = 0;
  const struct aiVector3D *v = mesh->mVertices, *p0 = &v[face->mIndices[0]];
  for (unsigned k = 0; k < n; k++) {
    const struct aiVector3D *a = &v[face->mIndices[k]], *b = &v[face->mIndices[(k + 1) % n]];
    nx += ((double)a->y - b->y) * ((double)a->z + b->z);
    ny += ((double)a->z - b->z) * ((double)a->x + b->x);
    nz += ((double)a->x - b->x) * ((double)a->y + b->y);
    size = fmax(size, fabs((double)a->x - p0->x) + fabs((double)a->y - p0->y) + fabs((double)a->z - p0->z));
  }
  double len = sqrt(nx * nx + ny * ny + nz * nz), turning = 0.0;
  if (!(len > 0.0)) return 0;
  nx /= len, ny /= len, nz /= len;
  for (unsigned k = 0; k < n; k++) {
    const struct aiVector3D *a = &v[face->mIndices[k]], *b = &v[face->mIndices[(k + 1) % n]],
                            *d = &v[face->mIndices[(k + 2) % n]];
    if (fabs(((double)a->x - p0->x) * nx + ((double)a->y - p0->y) * ny + ((double)a->z - p0->z) * nz) > 1e-4 * size)
      return 0;
    double e1[3] = {(double)b->x - a->x, (double)b->y - a->y, (double)b->z - a->z};
    double e2[3] = {(double)d->x - b->x, (double)d->y - b->y, (double)d->z - b->z};
    double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2], cz = e1[0] * e2[1] - e1[1] * e2[0];
    double sine = cx * nx + cy * ny + cz * nz, cosine = e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2];
    double l1 = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]), l2 = sqrt(e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]);
    if (sine < -8.0 * FLT_EPSILON * size * (l1 + l2)) return 0; /* sin(turn) l1 l2 >= -8 eps size (1/l1 + 1/l2) l1 l2 */
    turning += atan2(sine, cosine);
  }
  return fabs(turning - 2.0 * M_PI) < 1e-3;
}

/* Faces of up to VF_MAX_POLYGON_VERTICES vertices go through Assimp's triangulation (ear
 * clipping, quadratic in a face's size: 0.1 s at 4,000 vertices, 7 s at 32,000, and a
 * 100,000-vertex face never ends). A file with a larger face is triangulated here as fans,
 * in linear time, which needs every polygon of the file convex and planar: refused
 * otherwise, naming the face. */
static int triangulate(const parse_ctx *c, const char *what, const struct aiScene **ai) {
  unsigned largest = 0;
  for (unsigned m = 0; m < (*ai)->mNumMeshes; m++)
    for (unsigned f = 0; f < (*ai)->mMeshes[m]->mNumFaces; f++)
      if ((*ai)->mMeshes[m]->mFaces[f].mNumIndices > largest) largest = (*ai)->mMeshes[m]->mFaces[f].mNumIndices;
  char why[256];
  if (largest <= 3) return VF_OK;
  if (largest <= VF_MAX_POLYGON_VERTICES) {
    if ((*ai = vf_assimp()->aiApplyPostProcessing(*ai, aiProcess_Triangulate)) == NULL) /* released on failure */
      return vf_scene_fail(c, VF_EMESH, what, "triangulation failed: %s", assimp_error(why, sizeof why));
    return VF_OK;
  }
  for (unsigned m = 0; m < (*ai)->mNumMeshes; m++) {
    const struct aiMesh *mesh = (*ai)->mMeshes[m];
    for (unsigned f = 0; f < mesh->mNumFaces; f++) {
      const struct aiFace *face = &mesh->mFaces[f];
      if (face->mNumIndices <= 3) continue;
      for (unsigned k = 0; k < face->mNumIndices; k++)
        if (face->mIndices[k] >= mesh->mNumVertices)
          return vf_scene_fail(c, VF_EMESH, what, "face %u of mesh %u has an out-of-range vertex index", f, m);
      if (!convex_planar(mesh, face))
        return vf_scene_fail(c, VF_EMESH, what,
                             "face %u of mesh %u (%u vertices) is not a convex planar polygon, and the file has a face of "
                             "%u vertices: faces of more than %d vertices are triangulated as fans, which needs every "
                             "polygon of the file convex (triangulate the file before import)",
                             f, m, face->mNumIndices, largest, VF_MAX_POLYGON_VERTICES);
    }
  }
  return VF_OK;
}

int vf_scene_import_file(const parse_ctx *c, const char *file, const char *fpath, const char *what,
                         const struct aiScene **out) {
  char full[4096], why[256];
  const struct aiScene *ai = NULL;
  int err;
  const unsigned flags = 0; /* triangulate() below */
  if (vf_assimp_load(file) == NULL)
    return vf_scene_fail(c, VF_EMODULE, fpath, "%s", vf_error_detail(VF_EMODULE));
  const vf_scene_memfile *mf = find_memfile(c, file);
  if (mf != NULL) {
    const char *dot = strrchr(mf->name, '.');
    if (mf->size > UINT32_MAX) return vf_scene_fail(c, VF_EMESH, fpath, "'%s' is too large", file);
    ai = vf_assimp()->aiImportFileFromMemory(mf->data, (unsigned)mf->size, flags, dot ? dot + 1 : "");
  } else {
    if ((err = vf_scene_resolve(c, file, fpath, full, sizeof full)) < 0) return err;
    FILE *f = fopen(full, "rb"); /* Assimp's own message does not say why */
    if (f == NULL) return vf_scene_fail(c, VF_ENOENT, fpath, "cannot open '%s': %s", file, strerror(errno));
    fclose(f);
    /* A farm job's mesh is imported under its name, so that the files it names in turn
     * (glTF buffers, OBJ material libraries) resolve by name as well. */
    ai = c->files ? vf_scene_files_import(c->files, file, flags) : vf_assimp()->aiImportFile(full, flags);
  }
  if (ai == NULL) return vf_scene_fail(c, VF_EMESH, fpath, "cannot read '%s': %s", file, assimp_error(why, sizeof why));
  if ((ai->mFlags & AI_SCENE_FLAGS_INCOMPLETE) || ai->mNumMeshes == 0) {
    vf_assimp()->aiReleaseImport(ai);
    return vf_scene_fail(c, VF_EMESH, what, "the file contains no mesh");
  }
  if ((err = check_values(c, what, ai)) < 0 || (err = vf_scene_mesh_repair(c, file, ai)) < 0 ||
      (err = triangulate(c, what, &ai)) < 0) {
    if (ai != NULL) vf_assimp()->aiReleaseImport(ai);
    return err;
  }
  /* On failure Assimp has released the scene. */
  if (join_vertices(mf != NULL ? mf->name : file, ai) &&
      (ai = vf_assimp()->aiApplyPostProcessing(ai, aiProcess_JoinIdenticalVertices)) == NULL)
    return vf_scene_fail(c, VF_EMESH, what, "post-processing failed: %s", assimp_error(why, sizeof why));
  *out = ai;
  return VF_OK;
}

/* ---- transforms --------------------------------------------------------------------------- */

void vf_affine_identity(vf_affine *a) {
  memset(a, 0, sizeof *a);
  a->m[0][0] = a->m[1][1] = a->m[2][2] = 1.0;
}

void vf_affine_from_ai(const struct aiMatrix4x4 *t, vf_affine *a) {
  const double r[3][4] = {{t->a1, t->a2, t->a3, t->a4}, {t->b1, t->b2, t->b3, t->b4}, {t->c1, t->c2, t->c3, t->c4}};
  memcpy(a->m, r, sizeof r);
}

void vf_affine_mul(const vf_affine *a, const vf_affine *b, vf_affine *out) {
  vf_affine r;
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 4; j++) {
      r.m[i][j] = a->m[i][0] * b->m[0][j] + a->m[i][1] * b->m[1][j] + a->m[i][2] * b->m[2][j] + (j == 3 ? a->m[i][3] : 0);
    }
  *out = r;
}

double vf_affine_det(const vf_affine *a) {
  const double(*m)[4] = a->m;
  return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
         m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

void vf_affine_point(const vf_affine *a, const double in[3], double out[3]) {
  for (int i = 0; i < 3; i++) out[i] = a->m[i][0] * in[0] + a->m[i][1] * in[1] + a->m[i][2] * in[2] + a->m[i][3];
}

void vf_affine_vector(const vf_affine *a, const double in[3], double out[3]) {
  for (int i = 0; i < 3; i++) out[i] = a->m[i][0] * in[0] + a->m[i][1] * in[1] + a->m[i][2] * in[2];
}

/* The cofactor matrix of M's linear part: det(M) M^-T, defined for every M. */
static void cofactor(const vf_affine *a, double c[3][3]) {
  const double(*m)[4] = a->m;
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      int i1 = (i + 1) % 3, i2 = (i + 2) % 3, j1 = (j + 1) % 3, j2 = (j + 2) % 3;
      c[i][j] = m[i1][j1] * m[i2][j2] - m[i1][j2] * m[i2][j1];
    }
}

/* v scaled to unit length in double, stored as floats; 0 when v has no direction. */
static int store_unit(const double v[3], float *out) {
  double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (!(len > 0.0) || !isfinite(len)) return 0;
  for (int k = 0; k < 3; k++) out[k] = (float)(v[k] / len);
  return 1;
}

int vf_scene_transform_range(const parse_ctx *c, const char *path, const vf_affine *a, vf_shape *s, uint32_t v0,
                             uint32_t t0) {
  double cof[3][3], det = vf_affine_det(a);
  double sign = det < 0.0 ? -1.0 : 1.0;
  cofactor(a, cof);
  for (uint32_t v = v0; v < s->num_vertices; v++) {
    double p[3] = {s->positions[3 * v], s->positions[3 * v + 1], s->positions[3 * v + 2]}, w[3];
    vf_affine_point(a, p, w);
    for (int k = 0; k < 3; k++) {
      if (!(fabs(w[k]) <= FLT_MAX)) return vf_scene_fail(c, VF_ESCENE, path, "moves vertex %u out of range", v);
      s->positions[3 * v + k] = (float)w[k];
    }
    if (s->normals != NULL) { /* normals: M^-T n = cof(M) n / det(M) */
      float *n = &s->normals[3 * v];
      double d[3];
      for (int k = 0; k < 3; k++) d[k] = sign * (cof[k][0] * n[0] + cof[k][1] * n[1] + cof[k][2] * n[2]);
      if (!store_unit(d, n)) return vf_scene_fail(c, VF_ESCENE, path, "flattens the normal of vertex %u", v);
    }
    if (s->tangents != NULL) { /* tangents lie in the surface: they move with it */
      float *t = &s->tangents[4 * v];
      double d[3], in[3] = {t[0], t[1], t[2]};
      vf_affine_vector(a, in, d);
      if (!store_unit(d, t)) return vf_scene_fail(c, VF_ESCENE, path, "flattens the tangent of vertex %u", v);
      t[3] = (float)(sign * t[3]); /* a mirror turns the bitangent: B' = M B = -w' (N' x T') */
    }
  }
  /* A mirroring transform turns counter-clockwise into clockwise; swapping two corners keeps
   * every triangle facing the side it faced in the file, which is what emission refers to. */
  if (det < 0.0)
    for (uint32_t t = t0; t < s->num_triangles; t++) {
      uint32_t tmp = s->indices[3 * t + 1];
      s->indices[3 * t + 1] = s->indices[3 * t + 2];
      s->indices[3 * t + 2] = tmp;
    }
  return VF_OK;
}

/* ---- appending meshes to shapes ------------------------------------------------------------ */

static int grow(void **p, uint64_t count, size_t size) {
  void *q = realloc(*p, (size_t)count * size);
  if (q == NULL && count > 0) return vf_error_set(VF_ENOMEM, "out of memory");
  *p = q;
  return VF_OK;
}

/* Keeps an attribute only while every mesh appended has it: a shape holds it for all its
 * vertices or not at all. Allocation of what is kept happens when the arrays grow (realloc
 * of NULL); `keep` gets the VF_ATTR_* bits kept, the return value those dropped. */
static unsigned settle_attributes(vf_shape *s, const struct aiMesh *mesh, unsigned *keep) {
  unsigned has = (mesh->mNormals ? VF_ATTR_NORMALS : 0) | (mesh->mTextureCoords[0] ? VF_ATTR_UVS : 0) |
                 (mesh->mTangents && mesh->mBitangents && mesh->mNormals ? VF_ATTR_TANGENTS : 0) |
                 (mesh->mTextureCoords[0] && mesh->mTextureCoords[1] ? VF_ATTR_UVS1 : 0) |
                 (mesh->mColors[0] ? VF_ATTR_COLORS : 0);
  if (s->num_vertices == 0) {
    *keep = has;
    return 0;
  }
  unsigned had = (s->normals ? VF_ATTR_NORMALS : 0) | (s->uvs ? VF_ATTR_UVS : 0) | (s->tangents ? VF_ATTR_TANGENTS : 0) |
                 (s->uvs1 ? VF_ATTR_UVS1 : 0) | (s->colors ? VF_ATTR_COLORS : 0);
  *keep = had & has;
  if (!(*keep & VF_ATTR_UVS1)) free(s->uvs1), s->uvs1 = NULL;
  if (!(*keep & VF_ATTR_COLORS)) free(s->colors), s->colors = NULL;
  if (!(*keep & VF_ATTR_NORMALS)) free(s->normals), s->normals = NULL;
  if (!(*keep & VF_ATTR_UVS)) free(s->uvs), s->uvs = NULL;
  if (!(*keep & VF_ATTR_TANGENTS)) free(s->tangents), s->tangents = NULL;
  return had ^ has;
}

/* Copies the mesh's vertex attributes (file space) from vertex v0 on. */
static void copy_vertices(const struct aiMesh *mesh, vf_shape *s, uint32_t v0) {
  for (unsigned v = 0; v < mesh->mNumVertices; v++) {
    float *p = &s->positions[3 * (v0 + v)];
    p[0] = mesh->mVertices[v].x, p[1] = mesh->mVertices[v].y, p[2] = mesh->mVertices[v].z;
    if (s->normals) { /* checked non-zero and finite at import; normalised by the transform */
      float *n = &s->normals[3 * (v0 + v)];
      n[0] = mesh->mNormals[v].x, n[1] = mesh->mNormals[v].y, n[2] = mesh->mNormals[v].z;
    }
    if (s->uvs) { /* Assimp gives every format OpenGL's v (0 at the bottom; its glTF reader
                   * flips glTF's): our t = 0 is the top row, so t = 1 - v */
      s->uvs[2 * (v0 + v)] = mesh->mTextureCoords[0][v].x;
      s->uvs[2 * (v0 + v) + 1] = 1.0f - mesh->mTextureCoords[0][v].y;
    }
    if (s->uvs1) {
      s->uvs1[2 * (v0 + v)] = mesh->mTextureCoords[1][v].x;
      s->uvs1[2 * (v0 + v) + 1] = 1.0f - mesh->mTextureCoords[1][v].y;
    }
    if (s->colors) { /* glTF's COLOR_0 is linear; clamped so that albedos stay at most 1 (NaN: 1) */
      const struct aiColor4D *col = &mesh->mColors[0][v];
      const float rgb[3] = {col->r, col->g, col->b};
      for (int k = 0; k < 3; k++) s->colors[3 * (v0 + v) + k] = rgb[k] >= 0.0f ? (rgb[k] <= 1.0f ? rgb[k] : 1.0f) : rgb[k] < 0.0f ? 0.0f : 1.0f;
    }
    if (s->tangents) { /* Assimp keeps glTF's w as the bitangent B = w (N x T): recover it */
      const struct aiVector3D *n = &mesh->mNormals[v], *t = &mesh->mTangents[v], *b = &mesh->mBitangents[v];
      double cx = n->y * t->z - n->z * t->y, cy = n->z * t->x - n->x * t->z, cz = n->x * t->y - n->y * t->x;
      float *o = &s->tangents[4 * (v0 + v)];
      o[0] = t->x, o[1] = t->y, o[2] = t->z;
      o[3] = cx * b->x + cy * b->y + cz * b->z < 0.0 ? -1.0f : 1.0f;
    }
  }
}

/* Whether the triangle (a, b, c) has no area: its edges' cross product, in double from the
 * floats, is exactly zero. */
static int zero_area(const struct aiVector3D *a, const struct aiVector3D *b, const struct aiVector3D *c) {
  double e1[3] = {(double)b->x - a->x, (double)b->y - a->y, (double)b->z - a->z};
  double e2[3] = {(double)c->x - a->x, (double)c->y - a->y, (double)c->z - a->z};
  return e1[1] * e2[2] - e1[2] * e2[1] == 0.0 && e1[2] * e2[0] - e1[0] * e2[2] == 0.0 &&
         e1[0] * e2[1] - e1[1] * e2[0] == 0.0;
}

int vf_scene_append_mesh(const parse_ctx *c, const char *what, const struct aiMesh *mesh, unsigned mesh_index,
                         const vf_affine *a, vf_shape *s, vf_mesh_tally *tally) {
  uint64_t nt = vf_scene_mesh_triangles(mesh);
  uint64_t nv = (uint64_t)s->num_vertices + mesh->mNumVertices, nt_all = (uint64_t)s->num_triangles + nt;
  if (nv > UINT32_MAX / 4 || nt_all > UINT32_MAX / 3)
    return vf_scene_fail(c, VF_EMESH, what, "too many vertices or triangles");
  unsigned keep;
  tally->dropped |= settle_attributes(s, mesh, &keep);
  int err;
  if ((err = grow((void **)&s->positions, 3 * nv, sizeof(float))) < 0 ||
      (err = grow((void **)&s->indices, 3 * nt_all, sizeof(uint32_t))) < 0 ||
      ((keep & VF_ATTR_NORMALS) && (err = grow((void **)&s->normals, 3 * nv, sizeof(float))) < 0) ||
      ((keep & VF_ATTR_UVS) && (err = grow((void **)&s->uvs, 2 * nv, sizeof(float))) < 0) ||
      ((keep & VF_ATTR_UVS1) && (err = grow((void **)&s->uvs1, 2 * nv, sizeof(float))) < 0) ||
      ((keep & VF_ATTR_COLORS) && (err = grow((void **)&s->colors, 3 * nv, sizeof(float))) < 0) ||
      ((keep & VF_ATTR_TANGENTS) && (err = grow((void **)&s->tangents, 4 * nv, sizeof(float))) < 0))
    return err;
  uint32_t v0 = s->num_vertices, t0 = s->num_triangles, t = t0;
  copy_vertices(mesh, s, v0);
  /* Points and lines (mNumIndices < 3) are not surfaces: left out. Polygons are left only
   * in files with a face too large for Assimp's triangulation, all convex: fans. */
  for (unsigned f = 0; f < mesh->mNumFaces; f++) {
    const struct aiFace *face = &mesh->mFaces[f];
    if (face->mNumIndices < 3) continue;
    for (unsigned k = 0; k < face->mNumIndices; k++)
      if (face->mIndices[k] >= mesh->mNumVertices)
        return vf_scene_fail(c, VF_EMESH, what, "face %u of mesh %u has an out-of-range vertex index", f, mesh_index);
    for (unsigned k = 1; k + 1 < face->mNumIndices; k++) {
      unsigned i0 = face->mIndices[0], i1 = face->mIndices[k], i2 = face->mIndices[k + 1];
      if (zero_area(&mesh->mVertices[i0], &mesh->mVertices[i1], &mesh->mVertices[i2])) {
        tally->degenerate++;
        continue;
      }
      s->indices[3 * t] = v0 + i0;
      s->indices[3 * t + 1] = v0 + i1;
      s->indices[3 * t + 2] = v0 + i2;
      t++;
    }
  }
  s->num_vertices = (uint32_t)nv;
  s->num_triangles = t;
  return vf_scene_transform_range(c, what, a, s, v0, t0);
}

/* ---- walking the node hierarchy ------------------------------------------------------------ */

static int walk(const parse_ctx *c, const char *what, const struct aiScene *ai, const struct aiNode *node,
                const vf_affine *parent, int depth, vf_scene_instance_fn fn, void *user) {
  vf_affine local, world;
  if (depth > 256) return vf_scene_fail(c, VF_EMESH, what, "node hierarchy deeper than 256 levels");
  vf_affine_from_ai(&node->mTransformation, &local);
  vf_affine_mul(parent, &local, &world);
  for (unsigned i = 0; i < node->mNumMeshes; i++) {
    if (node->mMeshes[i] >= ai->mNumMeshes)
      return vf_scene_fail(c, VF_EMESH, what, "node '%s' names a missing mesh", node->mName.data);
    int err = fn(user, node, node->mMeshes[i], &world);
    if (err < 0) return err;
  }
  for (unsigned i = 0; i < node->mNumChildren; i++) {
    int err = walk(c, what, ai, node->mChildren[i], &world, depth + 1, fn, user);
    if (err < 0) return err;
  }
  return VF_OK;
}

int vf_scene_walk_nodes(const parse_ctx *c, const char *what, const struct aiScene *ai, const vf_affine *root,
                        vf_scene_instance_fn fn, void *user) {
  if (ai->mRootNode == NULL) return vf_scene_fail(c, VF_EMESH, what, "the file has no node hierarchy");
  return walk(c, what, ai, ai->mRootNode, root, 0, fn, user);
}

void vf_scene_node_world(const struct aiNode *node, vf_affine *out) {
  vf_affine world, local;
  vf_affine_identity(&world);
  /* Parents were at most 256 deep when the meshes were walked; a cycle cannot be built
   * from a file (Assimp makes trees), the bound only keeps a broken one finite. */
  for (int depth = 0; node != NULL && depth <= 257; node = node->mParent, depth++) {
    vf_affine_from_ai(&node->mTransformation, &local);
    vf_affine_mul(&local, &world, &world);
  }
  *out = world;
}

/* ---- a JSON shape's "file": every mesh merged into one shape ---------------------------- */

typedef struct {
  const parse_ctx *c;
  const char *what;
  const struct aiScene *ai;
  vf_shape *s;
  vf_mesh_tally tally;
} merge_state;

static int merge_instance(void *user, const struct aiNode *node, unsigned mesh, const vf_affine *world) {
  merge_state *m = user;
  (void)node;
  return vf_scene_append_mesh(m->c, m->what, m->ai->mMeshes[mesh], mesh, world, m->s, &m->tally);
}

int vf_scene_note_dropped(const parse_ctx *c, const char *file, const vf_mesh_tally *tally) {
  int err = VF_OK;
  unsigned dropped = tally->dropped;
  if (tally->degenerate > 0)
    err = vf_scene_note(c, "%s: %llu degenerate triangles (zero area) were skipped", file,
                        (unsigned long long)tally->degenerate);
  if ((dropped & VF_ATTR_COLORS) && err == VF_OK)
    err = vf_scene_note(c, "%s: vertex colours only on some meshes merged into one shape: dropped", file);
  if ((dropped & VF_ATTR_UVS1) && err == VF_OK)
    err = vf_scene_note(c, "%s: a second uv set only on some meshes merged into one shape: dropped", file);
  if ((dropped & VF_ATTR_NORMALS) && err == VF_OK)
    err = vf_scene_note(c, "%s: vertex normals only on some meshes merged into one shape: rendered faceted", file);
  if ((dropped & VF_ATTR_UVS) && err == VF_OK)
    err = vf_scene_note(c, "%s: texture coordinates only on some meshes merged into one shape: dropped", file);
  if ((dropped & VF_ATTR_TANGENTS) && err == VF_OK)
    err = vf_scene_note(c, "%s: tangents only on some meshes merged into one shape: derived from the uvs", file);
  return err;
}

/* Imports `file` and merges all its meshes (node transforms applied) into s. Errors in the
 * file's content are VF_EMESH and named "shapes[i] (file)". */
int vf_scene_load_mesh_file(const parse_ctx *c, const char *file, const char *path, vf_shape *s) {
  char fpath[PATH_LEN], what[PATH_LEN + 80];
  const struct aiScene *ai = NULL;
  vf_scene_join(fpath, path, "file");
  snprintf(what, sizeof what, "%s (%s)", path, file);
  int err = vf_scene_import_file(c, file, fpath, what, &ai);
  if (err < 0) return err;
  vf_affine identity;
  vf_affine_identity(&identity);
  merge_state m = {c, what, ai, s, {0, 0}};
  err = vf_scene_walk_nodes(c, what, ai, &identity, merge_instance, &m);
  if (err == VF_OK && s->num_triangles == 0) err = vf_scene_fail(c, VF_EMESH, what, "the file contains no triangles");
  if (err == VF_OK) err = vf_scene_note_dropped(c, file, &m.tally);
  if (err == VF_OK && s->colors != NULL) { /* a JSON shape's material is the JSON's: colours are an import's */
    free(s->colors);
    s->colors = NULL;
    err = vf_scene_note(c, "%s: vertex colours of a shape's mesh file are ignored (an \"import\" applies them)", file);
  }
  vf_assimp()->aiReleaseImport(ai);
  return err;
}
