/* Medium interfaces (interfaces.h): closedness and orientation of the shapes that bound
 * media, and the nesting that gives each its exterior. */
#include "interfaces.h"

#include "../../common/error.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* ---- closedness ---------------------------------------------------------------------------- */

/* Vertices sorted by position, to join the copies a mesh file makes along its seams (a
 * vertex per normal or uv) into one. */
typedef struct {
  uint32_t bits[3]; /* the position's bit patterns, -0 folded into +0 */
  uint32_t vertex;
} keyed_vertex;

static int compare_keyed(const void *a, const void *b) {
  const keyed_vertex *x = a, *y = b;
  for (int k = 0; k < 3; k++)
    if (x->bits[k] != y->bits[k]) return x->bits[k] < y->bits[k] ? -1 : 1;
  return (x->vertex > y->vertex) - (x->vertex < y->vertex);
}

/* An edge between joined vertices lo < hi, and whether the triangle runs it from lo to hi. */
typedef struct {
  uint32_t lo, hi;
  uint32_t forward;
} edge;

static int compare_edges(const void *a, const void *b) {
  const edge *x = a, *y = b;
  if (x->lo != y->lo) return x->lo < y->lo ? -1 : 1;
  if (x->hi != y->hi) return x->hi < y->hi ? -1 : 1;
  return (x->forward > y->forward) - (x->forward < y->forward);
}

enum { MESH_OPEN, MESH_INCONSISTENT, MESH_CLOSED };

/* MESH_CLOSED when every edge of the non-degenerate triangles (vertices joined by
 * position) is shared by exactly two of them in opposite directions; MESH_INCONSISTENT
 * when every edge has two triangles but some run it the same way; else MESH_OPEN.
 * *boundary counts the edges not shared by exactly two. VF_ENOMEM as a negative value. */
static int mesh_closedness(const vf_shape *s, uint64_t *boundary) {
  keyed_vertex *keyed = malloc((size_t)s->num_vertices * sizeof *keyed);
  uint32_t *joined = malloc((size_t)s->num_vertices * sizeof *joined);
  edge *edges = malloc(3 * (size_t)s->num_triangles * sizeof *edges);
  int result = MESH_CLOSED;
  *boundary = 0;
  if (keyed == NULL || joined == NULL || edges == NULL) {
    result = vf_error_set(VF_ENOMEM, "out of memory");
    goto done;
  }
  for (uint32_t v = 0; v < s->num_vertices; v++) {
    for (int k = 0; k < 3; k++) {
      float f = s->positions[3 * (size_t)v + k];
      f = f == 0.0f ? 0.0f : f;
      memcpy(&keyed[v].bits[k], &f, sizeof f);
    }
    keyed[v].vertex = v;
  }
  qsort(keyed, s->num_vertices, sizeof *keyed, compare_keyed);
  for (uint32_t i = 0, first = 0; i < s->num_vertices; i++) {
    if (i > 0 && memcmp(keyed[i].bits, keyed[i - 1].bits, sizeof keyed[i].bits) != 0) first = i;
    joined[keyed[i].vertex] = keyed[first].vertex;
  }
  size_t n = 0;
  for (uint32_t t = 0; t < s->num_triangles; t++) {
    uint32_t v[3];
    for (int k = 0; k < 3; k++) v[k] = joined[s->indices[3 * (size_t)t + k]];
    if (v[0] == v[1] || v[1] == v[2] || v[2] == v[0]) continue; /* degenerate: no edges */
    for (int k = 0; k < 3; k++) {
      uint32_t a = v[k], b = v[(k + 1) % 3];
      edges[n++] = (edge){a < b ? a : b, a < b ? b : a, a < b};
    }
  }
  if (n == 0) result = MESH_OPEN;
  qsort(edges, n, sizeof *edges, compare_edges);
  for (size_t i = 0; i < n;) {
    size_t j = i + 1;
    while (j < n && edges[j].lo == edges[i].lo && edges[j].hi == edges[i].hi) j++;
    if (j - i != 2) {
      (*boundary)++;
      result = MESH_OPEN;
    } else if (edges[i].forward == edges[i + 1].forward && result == MESH_CLOSED) {
      result = MESH_INCONSISTENT;
    }
    i = j;
  }
done:
  free(edges);
  free(joined);
  free(keyed);
  return result;
}

/* Six times the signed volume a closed mesh encloses: positive when it faces outwards. */
static double signed_volume6(const vf_shape *s) {
  double v = 0.0;
  for (uint32_t t = 0; t < s->num_triangles; t++) {
    const float *a = &s->positions[3 * (size_t)s->indices[3 * (size_t)t]];
    const float *b = &s->positions[3 * (size_t)s->indices[3 * (size_t)t + 1]];
    const float *d = &s->positions[3 * (size_t)s->indices[3 * (size_t)t + 2]];
    v += a[0] * ((double)b[1] * d[2] - (double)b[2] * d[1]) - a[1] * ((double)b[0] * d[2] - (double)b[2] * d[0]) +
         a[2] * ((double)b[0] * d[1] - (double)b[1] * d[0]);
  }
  return v;
}

/* Every triangle's winding reversed (and the tangent frames' handedness with it), as a
 * shape's "flip" does. */
static void turn_inside_out(vf_shape *s) {
  for (uint32_t t = 0; t < s->num_triangles; t++) {
    uint32_t k = s->indices[3 * (size_t)t + 1];
    s->indices[3 * (size_t)t + 1] = s->indices[3 * (size_t)t + 2];
    s->indices[3 * (size_t)t + 2] = k;
  }
  for (uint32_t v = 0; s->tangents != NULL && v < s->num_vertices; v++) s->tangents[4 * (size_t)v + 3] *= -1.0f;
}

/* ---- containment --------------------------------------------------------------------------- */

typedef struct {
  double lo[3], hi[3];
  double volume; /* enclosed, > 0 */
} region;

static void region_of(const vf_shape *s, region *r) {
  if (s->kind == VF_SHAPE_SPHERE) {
    const double c[3] = {s->center.x, s->center.y, s->center.z};
    for (int k = 0; k < 3; k++) r->lo[k] = c[k] - s->radius, r->hi[k] = c[k] + s->radius;
    r->volume = 4.0 / 3.0 * M_PI * (double)s->radius * s->radius * s->radius;
    return;
  }
  for (int k = 0; k < 3; k++) r->lo[k] = INFINITY, r->hi[k] = -INFINITY;
  for (uint32_t v = 0; v < s->num_vertices; v++)
    for (int k = 0; k < 3; k++) {
      double p = s->positions[3 * (size_t)v + k];
      r->lo[k] = p < r->lo[k] ? p : r->lo[k];
      r->hi[k] = p > r->hi[k] ? p : r->hi[k];
    }
  r->volume = fabs(signed_volume6(s)) / 6.0;
}

/* A point on the shape's surface: a sphere's point on +x, a mesh's centroid of its first
 * triangle of non-zero area (away from edges and vertices that another shape may share). */
static void surface_point(const vf_shape *s, double p[3]) {
  if (s->kind == VF_SHAPE_SPHERE) {
    p[0] = (double)s->center.x + s->radius, p[1] = s->center.y, p[2] = s->center.z;
    return;
  }
  uint32_t best = 0;
  for (uint32_t t = 0; t < s->num_triangles; t++) {
    const float *a = &s->positions[3 * (size_t)s->indices[3 * (size_t)t]];
    const float *b = &s->positions[3 * (size_t)s->indices[3 * (size_t)t + 1]];
    const float *d = &s->positions[3 * (size_t)s->indices[3 * (size_t)t + 2]];
    double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
    double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    if (n[0] != 0.0 || n[1] != 0.0 || n[2] != 0.0) {
      best = t;
      break;
    }
  }
  for (int k = 0; k < 3; k++)
    p[k] = ((double)s->positions[3 * (size_t)s->indices[3 * (size_t)best] + k] +
            s->positions[3 * (size_t)s->indices[3 * (size_t)best + 1] + k] +
            s->positions[3 * (size_t)s->indices[3 * (size_t)best + 2] + k]) / 3.0;
}

/* The number of times the ray from p along dir crosses mesh s (Moller-Trumbore, in double). */
static unsigned crossings(const vf_shape *s, const double p[3], const double dir[3]) {
  unsigned n = 0;
  for (uint32_t t = 0; t < s->num_triangles; t++) {
    const float *a = &s->positions[3 * (size_t)s->indices[3 * (size_t)t]];
    const float *b = &s->positions[3 * (size_t)s->indices[3 * (size_t)t + 1]];
    const float *d = &s->positions[3 * (size_t)s->indices[3 * (size_t)t + 2]];
    double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
    double q[3] = {dir[1] * e2[2] - dir[2] * e2[1], dir[2] * e2[0] - dir[0] * e2[2], dir[0] * e2[1] - dir[1] * e2[0]};
    double det = e1[0] * q[0] + e1[1] * q[1] + e1[2] * q[2];
    if (det == 0.0) continue;
    double o[3] = {p[0] - a[0], p[1] - a[1], p[2] - a[2]};
    double u = (o[0] * q[0] + o[1] * q[1] + o[2] * q[2]) / det;
    if (u < 0.0 || u > 1.0) continue;
    double w[3] = {o[1] * e1[2] - o[2] * e1[1], o[2] * e1[0] - o[0] * e1[2], o[0] * e1[1] - o[1] * e1[0]};
    double v = (dir[0] * w[0] + dir[1] * w[1] + dir[2] * w[2]) / det;
    if (v < 0.0 || u + v > 1.0) continue;
    n += (e2[0] * w[0] + e2[1] * w[1] + e2[2] * w[2]) / det > 0.0;
  }
  return n;
}

/* Whether p is inside closed shape s (bounding box r): for a mesh, the parity of the
 * crossings of rays from p, by a majority of three directions of no simple ratio (a ray
 * through an edge or a vertex may count a crossing twice or not at all; three such
 * accidents at once do not happen by chance). */
static int contains(const vf_shape *s, const region *r, const double p[3]) {
  for (int k = 0; k < 3; k++)
    if (!(p[k] > r->lo[k] && p[k] < r->hi[k])) return 0;
  if (s->kind == VF_SHAPE_SPHERE) {
    double d[3] = {p[0] - s->center.x, p[1] - s->center.y, p[2] - s->center.z};
    return d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < (double)s->radius * s->radius;
  }
  static const double dirs[3][3] = {{0.37193, 0.56021, 0.74007}, {-0.62471, 0.31393, 0.71512},
                                    {0.20173, -0.88931, 0.41069}}; /* unit within 1e-4: the length does not matter */
  int inside = 0;
  for (int i = 0; i < 3; i++) inside += crossings(s, p, dirs[i]) & 1u;
  return inside >= 2;
}

/* ---- the scene's interfaces ------------------------------------------------------------------ */

static int refracts(const vf_scene *s, const vf_shape *sh) {
  return sh->material >= 0 && !vf_is_zero(s->materials[sh->material].dielectric);
}

int vf_scene_resolve_interfaces(const parse_ctx *c, int first_lenient) {
  vf_scene *s = c->scene;
  region *regions = NULL;
  int err = VF_OK, num_interfaces = 0;
  for (int i = 0; i < s->num_shapes; i++) {
    vf_shape *sh = &s->shapes[i];
    const char *what = sh->interior >= 0 ? "an interior" : "a material-less boundary";
    sh->interface = 0;
    sh->exterior = -1;
    if (sh->interior < 0 && sh->material >= 0 && !(s->num_media > 0 && refracts(s, sh))) continue;
    if (sh->kind == VF_SHAPE_SPHERE) {
      sh->interface = 1;
      num_interfaces++;
      continue;
    }
    uint64_t boundary = 0;
    int closed = mesh_closedness(sh, &boundary);
    if (closed < 0) return closed;
    if (closed != MESH_CLOSED) {
      const char *why = closed == MESH_OPEN ? "is not closed" : "is closed but inconsistently wound";
      if (sh->interior < 0 && sh->material >= 0) continue; /* refracting but open: no region, as before media */
      if (i < first_lenient) {
        if (closed == MESH_OPEN)
          return vf_scene_fail(c, VF_ESCENE, NULL, "shapes[%d] (%s): has %s but is not closed (%llu edges are not "
                               "shared by exactly two triangles): a medium needs a closed surface", i, sh->name, what,
                               (unsigned long long)boundary);
        return vf_scene_fail(c, VF_ESCENE, NULL, "shapes[%d] (%s): has %s but is inconsistently wound (neighbouring "
                             "triangles face opposite sides): a medium needs a consistently wound closed surface", i,
                             sh->name, what);
      }
      if ((err = vf_scene_note(c, "%s: the mesh %s: its interior medium '%s' is ignored", sh->name, why,
                               s->media[sh->interior].name)) < 0)
        return err;
      sh->interior = -1;
      continue;
    }
    if (signed_volume6(sh) < 0.0) {
      turn_inside_out(sh);
      if ((err = vf_scene_note(c, "%s: a medium boundary wound inside-out (facing inwards): turned to face outwards",
                               sh->name)) < 0)
        return err;
    }
    sh->interface = 1;
    num_interfaces++;
  }
  if (num_interfaces == 0) return VF_OK;
  if ((regions = calloc((size_t)s->num_shapes, sizeof *regions)) == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  for (int i = 0; i < s->num_shapes; i++)
    if (s->shapes[i].interface) region_of(&s->shapes[i], &regions[i]);
  for (int i = 0; i < s->num_shapes; i++) {
    vf_shape *sh = &s->shapes[i];
    if (!sh->interface) continue;
    double p[3];
    int innermost = -1;
    surface_point(sh, p);
    for (int k = 0; k < s->num_shapes; k++) {
      if (k == i || !s->shapes[k].interface) continue;
      if (innermost >= 0 && !(regions[k].volume < regions[innermost].volume)) continue;
      if (contains(&s->shapes[k], &regions[k], p)) innermost = k;
    }
    sh->exterior = innermost >= 0 ? s->shapes[innermost].interior : s->medium;
  }
  free(regions);
  return VF_OK;
}
