/* Mitsuba's serialized meshes, versions 3 and 4 (serialized.h). The layout: uint16 0x041C,
 * uint16 version, then a zlib stream of: uint32 flags (0x1 normals, 0x2 texture
 * coordinates, 0x8 colours, 0x2000 double precision), the name NUL-terminated (version 4),
 * uint64 vertex and triangle counts, positions, normals, texture coordinates and colours
 * per vertex, and 3 uint32 indices a triangle. Several meshes follow one another; the file
 * ends with their offsets (uint64 in version 4, uint32 in 3) and their uint32 count. All
 * little endian (Mitsuba's src/shapes/serialized.cpp documents it). */
#include "serialized.h"

#include "../../common/error.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <zlib.h>

/* A mesh of 2^32 - 1 vertices or triangles at most, as the scene model counts them. */
#define MAX_COUNT 0xFFFFFFFFull

int vf_serialized_is_serialized(const char *file) {
  size_t n = strlen(file);
  return n >= 11 && strcasecmp(file + n - 11, ".serialized") == 0;
}

static uint64_t le(const uint8_t *p, int n) {
  uint64_t v = 0;
  for (int i = n - 1; i >= 0; i--) v = v << 8 | p[i];
  return v;
}

static double value(const uint8_t *p, int size) {
  if (size == 8) {
    uint64_t bits = le(p, 8);
    double d;
    memcpy(&d, &bits, 8);
    return d;
  }
  uint32_t bits = (uint32_t)le(p, 4);
  float f;
  memcpy(&f, &bits, 4);
  return f;
}

/* Inflates the zlib stream at data[0, n) into out[0, want) exactly: the header's counts
 * say how many bytes the mesh has, so nothing is allocated on the stream's word. */
static int inflate_into(const uint8_t *data, size_t n, uint8_t *out, size_t want, size_t *got) {
  z_stream z = {0};
  if (inflateInit(&z) != Z_OK) return -1;
  z.next_in = (Bytef *)data;
  z.avail_in = (uInt)(n > UINT32_MAX ? UINT32_MAX : n);
  z.next_out = out;
  z.avail_out = (uInt)want;
  int zr = inflate(&z, Z_FINISH);
  *got = want - z.avail_out;
  inflateEnd(&z);
  return zr == Z_STREAM_END || zr == Z_BUF_ERROR || zr == Z_OK ? 0 : zr;
}

/* The mesh record in m[0, len): header parsed, arrays copied into s. */
static int decode_mesh(const uint8_t *m, size_t len, size_t at, uint32_t flags, uint64_t nv, uint64_t nt,
                       const char *what, vf_shape *s) {
  int size = flags & 0x2000 ? 8 : 4;
  const uint8_t *p = m + at;
  float *pos = malloc(3 * nv * sizeof *pos), *nor = flags & 1 ? malloc(3 * nv * sizeof *nor) : NULL;
  float *uv = flags & 2 ? malloc(2 * nv * sizeof *uv) : NULL;
  uint32_t *ix = malloc(3 * nt * sizeof *ix);
  int err = VF_OK;
  (void)len;
  if (pos == NULL || ix == NULL || (flags & 1 && nor == NULL) || (flags & 2 && uv == NULL)) {
    err = vf_error_set(VF_ENOMEM, "out of memory");
    goto fail;
  }
  float *arrays[2] = {pos, nor};
  for (int a = 0; a < 2; a++) {
    if (arrays[a] == NULL) continue;
    for (uint64_t i = 0; i < 3 * nv; i++, p += size) {
      double v = value(p, size);
      if (!(fabs(v) <= 3.4e38)) {
        err = vf_error_set(VF_EMESH, "%s: vertex %llu: %s is not a finite float", what, (unsigned long long)(i / 3),
                           a ? "a normal" : "a position");
        goto fail;
      }
      arrays[a][i] = (float)v;
    }
  }
  for (uint64_t v = 0; nor != NULL && v < nv; v++) {
    float *n = nor + 3 * v;
    double l = sqrt((double)n[0] * n[0] + (double)n[1] * n[1] + (double)n[2] * n[2]);
    if (!(l > 0)) {
      err = vf_error_set(VF_EMESH, "%s: vertex %llu: zero normal", what, (unsigned long long)v);
      goto fail;
    }
    for (int k = 0; k < 3; k++) n[k] = (float)(n[k] / l);
  }
  for (uint64_t i = 0; uv != NULL && i < 2 * nv; i++, p += size) {
    double v = value(p, size);
    if (!(fabs(v) <= 3.4e38)) {
      err = vf_error_set(VF_EMESH, "%s: vertex %llu: a texture coordinate is not a finite float", what,
                         (unsigned long long)(i / 2));
      goto fail;
    }
    uv[i] = (float)v;
  }
  if (flags & 8) p += 3 * nv * size; /* vertex colours: not kept */
  for (uint64_t i = 0; i < 3 * nt; i++, p += 4) {
    uint64_t k = le(p, 4);
    if (k >= nv) {
      err = vf_error_set(VF_EMESH, "%s: triangle %llu names vertex %llu of %llu", what, (unsigned long long)(i / 3),
                         (unsigned long long)k, (unsigned long long)nv);
      goto fail;
    }
    ix[i] = (uint32_t)k;
  }
  s->positions = pos;
  s->normals = nor;
  s->uvs = uv;
  s->indices = ix;
  s->num_vertices = (uint32_t)nv;
  s->num_triangles = (uint32_t)nt;
  return VF_OK;
fail:
  free(pos);
  free(nor);
  free(uv);
  free(ix);
  return err;
}

int vf_serialized_decode(const uint8_t *data, size_t n, long index, const char *what, vf_shape *s, int *has_colors) {
  if (n < 8 || le(data, 2) != 0x041C) return vf_error_set(VF_EMESH, "%s: not a serialized mesh (no 0x041C header)", what);
  int version = (int)le(data + 2, 2);
  if (version != 3 && version != 4)
    return vf_error_set(VF_EMESH, "%s: serialized format version %d is not supported (3 and 4 are)", what, version);
  uint64_t count = le(data + n - 4, 4), width = version == 4 ? 8 : 4;
  if (count == 0 || count > (n - 4) / width) return vf_error_set(VF_EMESH, "%s: the table of meshes is damaged", what);
  if (index < 0 || (uint64_t)index >= count)
    return vf_error_set(VF_EMESH, "%s: shape_index %ld: the file has %llu meshes", what, index, (unsigned long long)count);
  uint64_t table = n - 4 - width * count, i = (uint64_t)index;
  uint64_t offset = le(data + table + width * i, (int)width);
  uint64_t end = i + 1 < count ? le(data + table + width * (i + 1), (int)width) : table;
  if (offset + 4 > end || end > table || le(data + offset, 2) != 0x041C)
    return vf_error_set(VF_EMESH, "%s: mesh %ld's offset is damaged", what, index);
  /* The header first (flags, name up to 64 KiB, counts), then the whole record. */
  uint8_t head[4 + 65536 + 16];
  size_t got;
  if (inflate_into(data + offset + 4, end - offset - 4, head, sizeof head, &got) != 0 || got < 20)
    return vf_error_set(VF_EMESH, "%s: mesh %ld's compressed stream is damaged", what, index);
  uint32_t flags = (uint32_t)le(head, 4);
  size_t at = 4;
  if (version == 4) {
    while (at < got && head[at] != 0) at++;
    at++;
  }
  if (at + 16 > got) return vf_error_set(VF_EMESH, "%s: mesh %ld's header is damaged", what, index);
  uint64_t nv = le(head + at, 8), nt = le(head + at + 8, 8);
  at += 16;
  if (nv == 0 || nt == 0 || nv > MAX_COUNT || nt > MAX_COUNT)
    return vf_error_set(VF_EMESH, "%s: mesh %ld has %llu vertices and %llu triangles", what, index, (unsigned long long)nv,
                        (unsigned long long)nt);
  int size = flags & 0x2000 ? 8 : 4;
  uint64_t per_vertex = 3 + (flags & 1 ? 3 : 0) + (flags & 2 ? 2 : 0) + (flags & 8 ? 3 : 0);
  uint64_t want = at + nv * per_vertex * (uint64_t)size + nt * 12;
  /* A record cannot inflate beyond zlib's 1032:1: a larger claim is a damaged header. */
  if (want / 1032 > end - offset) return vf_error_set(VF_EMESH, "%s: mesh %ld's counts exceed its data", what, index);
  uint8_t *m = malloc(want + 1);
  if (m == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  int err;
  if (inflate_into(data + offset + 4, end - offset - 4, m, want + 1, &got) != 0 || got != want)
    err = vf_error_set(VF_EMESH, "%s: mesh %ld holds %zu bytes where its counts need %llu", what, index, got,
                       (unsigned long long)want);
  else if ((err = decode_mesh(m, want, at, flags, nv, nt, what, s)) == VF_OK)
    *has_colors = (flags & 8) != 0;
  free(m);
  return err;
}
