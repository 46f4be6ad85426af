/* Mesh files of a scene (OBJ, PLY, glTF and whatever else Assimp reads), merged into one
 * world-space triangle shape and checked: finite vertices, indices in range. */
#include "scene_parse.h"

#include "../common/error.h"
#include "scene_files.h"

#include <assimp/cimport.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Assimp's last error, trailing whitespace trimmed. The text is process-global: concurrent
 * imports on several threads may report each other's message (the codes stay right). */
static const char *assimp_error(char *buf, size_t n) {
  snprintf(buf, n, "%s", aiGetErrorString());
  for (size_t len = strlen(buf); len > 0 && (buf[len - 1] == ' ' || buf[len - 1] == '\n'); len--) buf[len - 1] = '\0';
  return buf;
}

static const vf_scene_memfile *find_memfile(const parse_ctx *c, const char *file) {
  for (int i = 0; i < c->num_memfiles; i++)
    if (strcmp(c->memfiles[i].name, file) == 0) return &c->memfiles[i];
  return NULL;
}

int vf_scene_resolve(const parse_ctx *c, const char *file, const char *path, char *out, size_t n) {
  if (c->files != NULL) { /* a farm job's scene: its files by name (scene_files.h) */
    int err = vf_scene_files_resolve(c->files, file, out, n);
    return err < 0 ? vf_scene_fail(c, err, path, "%s", vf_error_detail(err)) : VF_OK;
  }
  int w = file[0] == '/' ? snprintf(out, n, "%s", file) : snprintf(out, n, "%s/%s", c->base_dir, file);
  if (w < 0 || (size_t)w >= n) return vf_scene_fail(c, VF_ESCENE, path, "path too long");
  return VF_OK;
}

/* Imports `file` through Assimp and merges all its meshes (node transforms applied) into s.
 * Errors in the file's content are VF_EMESH and named "shapes[i] (file)". */
int vf_scene_load_mesh_file(const parse_ctx *c, const char *file, const char *path, vf_shape *s) {
  char fpath[PATH_LEN], what[PATH_LEN + 80], full[4096], why[256];
  const struct aiScene *ai = NULL;
  float *positions = NULL;
  uint32_t *indices = NULL;
  int err;
  vf_scene_join(fpath, path, "file");
  snprintf(what, sizeof what, "%s (%s)", path, file);
  /* Joining identical vertices runs after the finiteness check: Assimp's spatial sort
   * merges a NaN vertex into a neighbour and the bad value would vanish unnoticed. */
  const unsigned flags = aiProcess_Triangulate | aiProcess_PreTransformVertices;
  const vf_scene_memfile *mf = find_memfile(c, file);
  if (mf != NULL) {
    const char *dot = strrchr(mf->name, '.');
    if (mf->size > UINT32_MAX) return vf_scene_fail(c, VF_EMESH, fpath, "'%s' is too large", file);
    ai = aiImportFileFromMemory(mf->data, (unsigned)mf->size, flags, dot ? dot + 1 : "");
  } else {
    if ((err = vf_scene_resolve(c, file, fpath, full, sizeof full)) < 0) return err;
    FILE *f = fopen(full, "rb"); /* Assimp's own message does not say why */
    if (f == NULL) return vf_scene_fail(c, VF_ENOENT, fpath, "cannot open '%s': %s", file, strerror(errno));
    fclose(f);
    /* A farm job's mesh is imported under its name, so that the files it names in turn
     * (glTF buffers, OBJ material libraries) resolve by name as well. */
    ai = c->files ? vf_scene_files_import(c->files, file, flags) : aiImportFile(full, flags);
  }
  if (ai == NULL) return vf_scene_fail(c, VF_EMESH, fpath, "cannot read '%s': %s", file, assimp_error(why, sizeof why));
  if ((ai->mFlags & AI_SCENE_FLAGS_INCOMPLETE) || ai->mNumMeshes == 0) {
    err = vf_scene_fail(c, VF_EMESH, what, "the file contains no mesh");
    goto done;
  }
  uint64_t vertex = 0;
  for (unsigned m = 0; m < ai->mNumMeshes; m++)
    for (unsigned v = 0; v < ai->mMeshes[m]->mNumVertices; v++, vertex++) {
      const struct aiVector3D *p = &ai->mMeshes[m]->mVertices[v];
      if (!isfinite(p->x) || !isfinite(p->y) || !isfinite(p->z)) {
        err = vf_scene_fail(c, VF_EMESH, what, "vertex %llu has a non-finite coordinate", (unsigned long long)vertex);
        goto done;
      }
    }
  if ((ai = aiApplyPostProcessing(ai, aiProcess_JoinIdenticalVertices)) == NULL) {
    /* Assimp has released the scene itself. */
    return vf_scene_fail(c, VF_EMESH, what, "post-processing failed: %s", assimp_error(why, sizeof why));
  }
  uint64_t nv = 0, nt = 0;
  for (unsigned m = 0; m < ai->mNumMeshes; m++) {
    nv += ai->mMeshes[m]->mNumVertices;
    /* Points and lines (mNumIndices < 3) are not surfaces: left out. */
    for (unsigned f = 0; f < ai->mMeshes[m]->mNumFaces; f++) nt += ai->mMeshes[m]->mFaces[f].mNumIndices == 3;
  }
  if (nt == 0) {
    err = vf_scene_fail(c, VF_EMESH, what, "the file contains no triangles");
    goto done;
  }
  if (nv > UINT32_MAX / 3 || nt > UINT32_MAX / 3) {
    err = vf_scene_fail(c, VF_EMESH, what, "too many vertices or triangles");
    goto done;
  }
  positions = malloc(3 * nv * sizeof *positions);
  indices = malloc(3 * nt * sizeof *indices);
  if (positions == NULL || indices == NULL) {
    err = vf_error_set(VF_ENOMEM, "out of memory");
    goto done;
  }
  uint32_t v0 = 0, t = 0;
  for (unsigned m = 0; m < ai->mNumMeshes; m++) {
    const struct aiMesh *mesh = ai->mMeshes[m];
    for (unsigned v = 0; v < mesh->mNumVertices; v++) {
      positions[3 * (v0 + v) + 0] = mesh->mVertices[v].x;
      positions[3 * (v0 + v) + 1] = mesh->mVertices[v].y;
      positions[3 * (v0 + v) + 2] = mesh->mVertices[v].z;
    }
    for (unsigned f = 0; f < mesh->mNumFaces; f++) {
      const struct aiFace *face = &mesh->mFaces[f];
      if (face->mNumIndices != 3) continue;
      for (int k = 0; k < 3; k++) {
        if (face->mIndices[k] >= mesh->mNumVertices) {
          err = vf_scene_fail(c, VF_EMESH, what, "face %u of mesh %u has an out-of-range vertex index", f, m);
          goto done;
        }
        indices[3 * t + k] = v0 + face->mIndices[k];
      }
      t++;
    }
    v0 += mesh->mNumVertices;
  }
  s->positions = positions;
  s->indices = indices;
  s->num_vertices = (uint32_t)nv;
  s->num_triangles = (uint32_t)nt;
  positions = NULL;
  indices = NULL;
  err = VF_OK;
done:
  free(indices);
  free(positions);
  aiReleaseImport(ai);
  return err;
}
