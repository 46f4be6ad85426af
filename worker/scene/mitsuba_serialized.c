/* Mitsuba's serialized meshes, versions 3 and 4 (mitsuba_serialized.h). The layout:
 * uint16 0x041C, uint16 version, then a zlib stream of: uint32 flags (0x1 normals, 0x2
 * texture coordinates, 0x8 colours, 0x2000 double precision), the name NUL-terminated
 * (version 4), uint64 vertex and triangle counts, positions, normals, texture coordinates
 * and colours per vertex, and 3 uint32 (uint64 beyond 2^32 vertices) indices a triangle.
 * Several meshes follow one another; the file ends with their offsets (uint64 in version
 * 4, uint32 in 3) and their uint32 count. All little endian. */
#include "mitsuba_serialized.h"

#include "../../common/error.h"
#include "../../common/file.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

/* Beyond this a mesh is better converted to PLY than carried inline in a JSON scene. */
#define MAX_INFLATED ((size_t)256 << 20)
#define MAX_FILE ((size_t)1 << 30)

static uint64_t le(const uint8_t *p, int n) {
  uint64_t v = 0;
  for (int i = n - 1; i >= 0; i--) v = v << 8 | p[i];
  return v;
}

/* The zlib stream at data[0, n) inflated into *out (free), *len bytes. */
static int inflate_all(const vf_xml_node *e, const uint8_t *data, size_t n, uint8_t **out, size_t *len) {
  z_stream z = {0};
  size_t cap = 1 << 16, have = 0;
  uint8_t *buf = malloc(cap);
  if (buf == NULL || inflateInit(&z) != Z_OK) return free(buf), vf_error_set(VF_ENOMEM, "out of memory");
  z.next_in = (Bytef *)data;
  z.avail_in = (uInt)(n > UINT32_MAX ? UINT32_MAX : n);
  int zr = Z_OK;
  while (zr == Z_OK) {
    if (have == cap) {
      uint8_t *grown = cap >= MAX_INFLATED ? NULL : realloc(buf, 2 * cap);
      if (grown == NULL) {
        inflateEnd(&z);
        free(buf);
        return mts_fail(e, "a mesh of more than %zu MiB: convert it to PLY", MAX_INFLATED >> 20);
      }
      buf = grown;
      cap *= 2;
    }
    z.next_out = buf + have;
    z.avail_out = (uInt)(cap - have);
    zr = inflate(&z, Z_NO_FLUSH);
    have = cap - z.avail_out;
  }
  inflateEnd(&z);
  if (zr != Z_STREAM_END) return free(buf), mts_fail(e, "the mesh's compressed stream is damaged (zlib %d)", zr);
  *out = buf;
  *len = have;
  return VF_OK;
}

/* count values of `size` bytes (4: float, 8: double) at p into a JSON array. */
static cJSON *numbers(const uint8_t *p, size_t count, int size) {
  cJSON *a = cJSON_CreateArray();
  for (size_t i = 0; a != NULL && i < count; i++) {
    double v;
    if (size == 8) {
      uint64_t bits = le(p + 8 * i, 8);
      memcpy(&v, &bits, 8);
    } else {
      uint32_t bits = (uint32_t)le(p + 4 * i, 4);
      float f;
      memcpy(&f, &bits, 4);
      v = f;
    }
    cJSON *n = isfinite(v) ? cJSON_CreateNumber(v) : NULL;
    if (n == NULL || !cJSON_AddItemToArray(a, n)) {
      cJSON_Delete(n);
      cJSON_Delete(a);
      return NULL;
    }
  }
  return a;
}

static int mesh(const vf_xml_node *e, const uint8_t *m, size_t len, int version, cJSON *js) {
  size_t at = 4;
  if (len < 4) return mts_fail(e, "the mesh record is truncated");
  uint32_t flags = (uint32_t)le(m, 4);
  int size = flags & 0x2000 ? 8 : 4;
  if (version == 4) {
    while (at < len && m[at] != 0) at++;
    at++;
  }
  if (at + 16 > len) return mts_fail(e, "the mesh record is truncated");
  uint64_t nv = le(m + at, 8), nt = le(m + at + 8, 8);
  at += 16;
  if (nv == 0 || nt == 0 || nv > UINT32_MAX || nt > UINT32_MAX) return mts_fail(e, "a mesh of %llu vertices and %llu triangles",
                                                                              (unsigned long long)nv, (unsigned long long)nt);
  size_t per_vertex = 3 + (flags & 1 ? 3 : 0) + (flags & 2 ? 2 : 0) + (flags & 8 ? 3 : 0);
  size_t need = at + (size_t)nv * per_vertex * size + (size_t)nt * 3 * 4;
  if (need != len) return mts_fail(e, "the mesh record holds %zu bytes where its counts need %zu", len, need);
  const uint8_t *p = m + at;
  cJSON *pos = numbers(p, 3 * nv, size), *nor = NULL, *uv = NULL;
  p += 3 * nv * size;
  if (flags & 1) nor = numbers(p, 3 * nv, size), p += 3 * nv * size;
  if (flags & 2) uv = numbers(p, 2 * nv, size), p += 2 * nv * size;
  if (flags & 8) p += 3 * nv * size; /* vertex colours: noted by the caller */
  int ok = pos != NULL && (!(flags & 1) || nor != NULL) && (!(flags & 2) || uv != NULL);
  if (ok) ok = cJSON_AddItemToObject(js, "positions", pos) ? (pos = NULL, 1) : 0;
  if (ok && nor) ok = cJSON_AddItemToObject(js, "normals", nor) ? (nor = NULL, 1) : 0;
  if (ok && uv) ok = cJSON_AddItemToObject(js, "uvs", uv) ? (uv = NULL, 1) : 0;
  cJSON_Delete(pos);
  cJSON_Delete(nor);
  cJSON_Delete(uv);
  if (!ok) return mts_fail(e, "a vertex value that is not finite (or out of memory)");
  cJSON *ix = cJSON_CreateArray();
  if (ix == NULL || !cJSON_AddItemToObject(js, "indices", ix)) return cJSON_Delete(ix), vf_error_set(VF_ENOMEM, "out of memory");
  for (size_t i = 0; i < 3 * nt; i++) {
    uint64_t k = le(p + 4 * i, 4);
    if (k >= nv) return mts_fail(e, "triangle %zu names vertex %llu of %llu", i / 3, (unsigned long long)k, (unsigned long long)nv);
    cJSON *n = cJSON_CreateNumber((double)k);
    if (n == NULL || !cJSON_AddItemToArray(ix, n)) return cJSON_Delete(n), vf_error_set(VF_ENOMEM, "out of memory");
  }
  return VF_OK;
}

int mts_serialized(mts_ctx *c, const vf_xml_node *e, const char *path, long shape_index, cJSON *js) {
  uint8_t *data = NULL, *inflated = NULL;
  size_t n = 0, len = 0;
  int err = vf_file_read_all(path, MAX_FILE, &data, &n);
  if (err != VF_OK) return mts_fail(e, "cannot read '%s'", path);
  if (n < 8 || le(data, 2) != 0x041C) {
    err = mts_fail(e, "'%s' is not a serialized mesh (no 0x041C header)", path);
    goto done;
  }
  int version = (int)le(data + 2, 2);
  if (version != 3 && version != 4) {
    err = mts_fail(e, "serialized format version %d is not supported (3 and 4 are)", version);
    goto done;
  }
  uint64_t count = le(data + n - 4, 4), width = version == 4 ? 8 : 4;
  if (count == 0 || count > (n - 4) / width) {
    err = mts_fail(e, "the file's table of meshes is damaged");
    goto done;
  }
  if (shape_index < 0 || (uint64_t)shape_index >= count) {
    err = mts_fail(e, "shape_index %ld: the file has %llu meshes", shape_index, (unsigned long long)count);
    goto done;
  }
  uint64_t offset = le(data + n - 4 - width * (count - (uint64_t)shape_index), (int)width);
  uint64_t end = (uint64_t)shape_index + 1 < count ? le(data + n - 4 - width * (count - (uint64_t)shape_index - 1), (int)width)
                                                    : n - 4 - width * count;
  if (offset + 4 > end || end > n || le(data + offset, 2) != 0x041C) {
    err = mts_fail(e, "mesh %ld's offset in the file is damaged", shape_index);
    goto done;
  }
  if ((err = inflate_all(e, data + offset + 4, end - offset - 4, &inflated, &len)) < 0) goto done;
  if ((err = mesh(e, inflated, len, version, js)) < 0) goto done;
  if ((le(inflated, 4) & 8) && (err = mts_note(c, e, "vertex colours are not supported: ignored")) < 0) goto done;
done:
  free(inflated);
  free(data);
  return err;
}
