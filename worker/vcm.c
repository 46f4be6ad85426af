#include "vcm.h"

#include "../common/error.h"
#include "../common/clock.h"
#include "../common/rng.h"
#include "bsdf.h"
#include "camera.h"
#include "hashgrid.h"
#include "light.h"
#include "mis.h"
#include "sampling.h"

#include <sys/mman.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif
#ifdef __x86_64__
#include <immintrin.h>
#endif
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Light sub-paths are traced in fixed chunks, each writing its own vertex and splat lists,
 * which are then read in chunk order. Results therefore do not depend on which thread
 * traced which chunk. */
#define LIGHT_CHUNK 1024u
/* Light sub-paths end out of order but are stored in path order (light_retire): a path
 * that ends before an older one waits in a ring of this many slots, one per path. */
#define RETIRE_RING 256u
#define RING_IN_FLIGHT UINT32_MAX /* thread_stats.ring_count of a slot whose path has not ended */
/* Camera sub-paths are traced in square tiles: neighbouring pixels query neighbouring grid
 * cells at their first hit, so a tile reuses what its previous rows brought into cache. */
#define CAMERA_TILE 32u
/* The light pass's splats are added to the image in bands of this many rows, one band per
 * task. */
#define SPLAT_BAND 32u
#define GATHER_CHUNK 16384u
#define GATHER_AHEAD 16u

/* A stored light vertex: one cache line. Its BSDF is not stored but set up again from
 * material, normal and fix when a connection needs it (vf_bsdf_setup is a pure function
 * of them, so it is the BSDF the light sub-path had): rebuilding a frame costs less than
 * moving twice the bytes through the light pass and the gather. */
typedef struct {
  vf_vec3 position; /* first: the hash grid reads it at offset 0 */
  vf_vec3 throughput;
  vf_vec3 fix;      /* world, unit, towards the previous light vertex */
  vf_vec3 normal;   /* geometric normal at the vertex, as the hit reported it */
  vf_mis mis;
  uint32_t path_length_material; /* segments from the light (low bits) and material index */
} light_vertex;
_Static_assert(sizeof(light_vertex) == 64, "a light vertex is one cache line");

/* Path lengths are at most VF_MAX_PATH_LENGTH (common/settings.h): 10 bits. */
#define VERTEX_LENGTH_BITS 10u
_Static_assert(VF_MAX_PATH_LENGTH < (1 << VERTEX_LENGTH_BITS), "path lengths fit their bits");
#define VERTEX_MAX_MATERIALS (1u << (32u - VERTEX_LENGTH_BITS))
static int vertex_path_length(const light_vertex *lv) {
  return (int)(lv->path_length_material & ((1u << VERTEX_LENGTH_BITS) - 1u));
}
static uint32_t vertex_material(const light_vertex *lv) { return lv->path_length_material >> VERTEX_LENGTH_BITS; }

/* What merging needs of the light vertices, in the grid's order, in two arrays: the
 * distance and path-length tests of a query's candidates read only merge_point (16 bytes,
 * four to a line), and only the candidates that pass read their photon (32 bytes, aligned:
 * one line). A merging query is bound by the lines it misses, not by its arithmetic. */
typedef struct {
  float x, y, z;
  uint32_t path_length_material; /* as in light_vertex */
} merge_point;
_Static_assert(sizeof(merge_point) == 16, "find_hits reads a merge point as four floats");
#define MERGE_POINT_PAD 7u /* find_hits reads up to this many points past the last */

typedef struct {
  vf_vec3 throughput;
  vf_vec3 direction; /* world, towards the previous light vertex */
  float d_vcm, d_vm;
} photon;
_Static_assert(sizeof(photon) == 32, "two photons to a cache line");

typedef struct {
  uint32_t pixel;
  vf_vec3 rgb;
  uint16_t path; /* the light sub-path's index within its chunk (< LIGHT_CHUNK) */
  uint16_t band; /* the pixel's band of rows (SPLAT_BAND) */
} splat;
_Static_assert(LIGHT_CHUNK <= 65536 && VF_MAX_IMAGE_SIDE / SPLAT_BAND < 65536, "splat's fields hold their values");

/* Light sub-paths finish out of order (wavefront, below). A chunk's vertex list holds them
 * in path order all the same (light_retire), and the splats are sorted back into it, so
 * that every list is what tracing the paths one by one would give. Connections read the
 * vertices of their pixel's path from this list, and the grid is built over the lists of
 * all chunks where they are (vf_hashgrid_build_segments): nothing copies them together. */
typedef struct {
  light_vertex *vertices;
  uint32_t num_vertices, vertex_capacity;
  splat *splats, *sorted_splats; /* sorted_splats: room to sort into, splat_capacity */
  uint32_t num_splats, splat_capacity;
  int out_of_memory;
} light_chunk;

/* A sub-path's state between vertices. */
typedef struct {
  vf_vec3 origin, direction;
  vf_vec3 throughput;
  int path_length;
  int is_finite_light; /* light sub-paths: whether the first segment has a distance */
  int specular_path;   /* camera sub-paths: every scattering so far was specular */
  vf_mis mis;
} path_state;

typedef struct {
  int light_paths;       /* trace light sub-paths at all */
  int store_vertices;    /* keep light vertices for connection or merging */
  int camera_paths;
  int light_to_camera;   /* t = 1 */
  int emission;          /* s = 0 */
  int emission_specular_only; /* ppm and bpm: s = 0 only along purely specular camera paths */
  int light_sample;      /* s = 1 */
  int connection;        /* s > 1, t > 1 */
  int merging;
  int ppm;               /* merge once, at the first non-specular camera vertex, unweighted */
  int lt;                /* light tracing alone: unweighted, includes y0 */
} techniques;

/* A camera vertex waiting to be merged: merging is deferred to the end of each camera
 * tile, where the queries of the whole tile run as a software pipeline that keeps several
 * grid lookups in flight (section "Merging" below). */
typedef struct {
  vf_bsdf bsdf;
  vf_vec3 position;
  vf_vec3 throughput;
  vf_mis mis;
  int path_length;
  uint32_t tile_pixel; /* index into the tile's color buffer */
} merge_query;

/* Shadow rays are not traced one by one where they arise but gathered into packets of
 * VF_ACCEL_PACKET and traced together (vf_accel_occluded_packet): Embree traverses a
 * packet of 8 rays 1.1 to 1.6 times faster per ray than single rays, whether or not they
 * share an origin, and one of 16 faster again with AVX-512 (docs/BENCHMARKS.md). No
 * path's course depends on a shadow ray's answer, only the contribution it guards, so the
 * contributions wait in a queue until their packet is traced and are then added in the
 * order they arose: films stay bit for bit those of tracing each ray at once. */
typedef struct {
  vf_vec3 org[VF_ACCEL_PACKET], dir[VF_ACCEL_PACKET];
  float tfar[VF_ACCEL_PACKET];
  int owner[VF_ACCEL_PACKET]; /* what each ray guards: a queue entry or a splat */
  int n;
} shadow_packet;

/* A camera sub-path's contribution waiting for its shadow ray (or, without one, for those
 * of the contributions before it): added to its pixel of the tile when its turn comes. */
#define DEFERRED_MAX 64
typedef struct {
  vf_vec3 value;
  uint32_t tile_pixel;
  int blocked;
} deferred;

/* One thread's state: aligned to the cache line (and allocated so), so that no line holds
 * two threads' fields. */
typedef struct {
  _Alignas(64) uint64_t rays, nonfinite;
  merge_query *queries; /* this thread's pending merges, owned */
  uint32_t num_queries, query_capacity;
  shadow_packet packet;
  deferred pending[DEFERRED_MAX];
  int num_pending;
  float *tile_rgb; /* the camera tile being traced, where pending contributions go */
  light_vertex *ring_vertices; /* the light pass's retire ring: RETIRE_RING slots of lane_capacity */
  uint32_t ring_count[RETIRE_RING]; /* vertices of each slot's path once it has ended, else RING_IN_FLIGHT */
} thread_stats;

struct vf_vcm {
  const vf_scene *scene;
  const vf_accel *accel;
  vf_settings settings;
  vf_pool *pool;
  vf_camera camera;
  vf_lights *lights;
  techniques t;
  vf_bsdf_lobes *lobes; /* per material, owned */
  vf_vec3 scene_center;
  float scene_radius;
  float offset_scale; /* for vf_offset_ray_origin */
  uint32_t num_pixels;
  uint32_t lane_capacity; /* most vertices a light sub-path stores */
  int has_specular, has_glossy, has_diffuse;
  vf_algorithm requested;    /* settings.algorithm as given; settings.algorithm is what runs */
  const char *auto_reason;   /* why auto chose settings.algorithm, NULL unless requested auto */

  /* Per iteration. */
  uint64_t iteration;
  float radius, radius_sq, vm_normalization;
  vf_mis_config mis;
  light_chunk *chunks;
  uint32_t num_chunks;
  uint32_t num_vertices;     /* in all chunks */
  vf_grid_segment *segments; /* the chunks' vertex lists, for the grid: num_chunks of them */
  unsigned chunk_shift;      /* the grid names vertex i of chunk c (c << chunk_shift) + i */
  merge_point *merge_points; /* the same in the grid's order (for merging), or NULL */
  photon *photons;
  uint32_t photon_capacity;
  uint32_t *path_begin, *path_end; /* per light sub-path, into its chunk's vertices */
  uint32_t num_bands, band_pixels; /* the light image's bands of SPLAT_BAND rows, band_pixels each */
  uint32_t *band_start;            /* per chunk, num_bands + 1: where its splats of each band begin */
  vf_hashgrid *grid;
  int merge_avx512; /* the CPU runs AVX-512 F and VL: merging tests eight candidates at once */
  float *camera_rgb, *light_rgb;
  thread_stats *stats;
};

/* An array that merging reads at random (photons, merge points): on 2 MiB pages where
 * the kernel has them (transparent huge pages, which Debian enables on request), so that
 * its tens of megabytes need a few dozen TLB entries instead of thousands. Freed with
 * free(). Measured on cornell 512x512, vcm, alternating 4 rounds: camera pass 174.5-176.8
 * -> 171.6-173.3 ms, 2% more iterations per second (with the light vertices, then one
 * joined array). The grid's own arrays gained nothing, nor did the chunks' vertex lists
 * once aligned to the cache line (docs/BENCHMARKS.md). */
#define HUGE_PAGE ((size_t)2 << 20)
static void *huge_alloc(size_t size) {
  size = (size + HUGE_PAGE - 1) / HUGE_PAGE * HUGE_PAGE; /* aligned_alloc: a multiple of the alignment */
  void *p = aligned_alloc(HUGE_PAGE, size);
#ifdef MADV_HUGEPAGE
  if (p != NULL) madvise(p, size, MADV_HUGEPAGE); /* advice only: 4 KiB pages if refused */
#endif
  return p;
}

/* ---------------------------------------------------------------------------------------- */
/* Ray queries and small helpers                                                             */

static int intersect(vf_vcm *v, int thread, vf_vec3 org, vf_vec3 dir, vf_hit *hit) {
  v->stats[thread].rays++;
  return vf_accel_intersect(v->accel, org, dir, INFINITY, hit);
}

/* Traces the packet's shadow rays; returns the mask of those blocked. */
static uint32_t trace_packet(vf_vcm *v, int thread, shadow_packet *pk) {
  v->stats[thread].rays += (uint64_t)pk->n;
  uint32_t blocked = vf_accel_occluded_packet(v->accel, pk->org, pk->dir, pk->tfar, pk->n);
  pk->n = 0;
  return blocked;
}

/* Adds the shadow ray of the segment from p (normal n) to q (normal nq; zero vector: a
 * point in space) to the packet, for `owner`. Both ends are moved off their surfaces
 * towards each other. Always inline: as a call, its four vectors were packed into
 * registers and spilled at every shadow ray. */
static inline __attribute__((always_inline)) void queue_segment(vf_vcm *v, shadow_packet *pk, int owner, vf_vec3 p,
                                                                vf_vec3 n, vf_vec3 q, vf_vec3 nq) {
  vf_vec3 d = vf_sub(q, p);
  vf_vec3 o = vf_offset_ray_origin(p, vf_dot(n, d) > 0.0f ? n : vf_neg(n), v->offset_scale);
  vf_vec3 e = vf_is_zero(nq) ? q : vf_offset_ray_origin(q, vf_dot(nq, d) < 0.0f ? nq : vf_neg(nq), v->offset_scale);
  pk->org[pk->n] = o;
  pk->dir[pk->n] = vf_sub(e, o);
  pk->tfar[pk->n] = 1.0f;
  pk->owner[pk->n++] = owner;
}

/* The same for the ray from p (normal n) along dir to infinity. */
static void queue_direction(vf_vcm *v, shadow_packet *pk, int owner, vf_vec3 p, vf_vec3 n, vf_vec3 dir) {
  pk->org[pk->n] = vf_offset_ray_origin(p, vf_dot(n, dir) > 0.0f ? n : vf_neg(n), v->offset_scale);
  pk->dir[pk->n] = dir;
  pk->tfar[pk->n] = INFINITY;
  pk->owner[pk->n++] = owner;
}

static void rnd2(vf_rng *r, float out[2]) {
  out[0] = vf_rng_float(r);
  out[1] = vf_rng_float(r);
}

/* The BSDF at a hit for a path arriving from world_fix; 0 when nothing scatters there. */
static int bsdf_at(const vf_vcm *v, vf_bsdf *b, const vf_hit *hit, vf_vec3 world_fix) {
  int m = v->scene->shapes[hit->shape].material;
  return vf_bsdf_setup(b, &v->scene->materials[m], &v->lobes[m], hit->normal, world_fix);
}

/* The BSDF a stored light vertex had. */
static void bsdf_of_vertex(const vf_vcm *v, vf_bsdf *b, const light_vertex *lv) {
  uint32_t m = vertex_material(lv);
  vf_bsdf_setup(b, &v->scene->materials[m], &v->lobes[m], lv->normal, lv->fix);
}

/* Continues a sub-path from vertex `hit` with BSDF b: Russian roulette, direction sampling,
 * throughput and MIS update. A camera sub-path carries radiance, which a refraction
 * scales by 1/eta^2 (bsdf.h); a light sub-path carries flux, which it does not. Returns 0
 * when the path ends. */
static int scatter(vf_vcm *v, const vf_bsdf *b, const vf_hit *hit, path_state *s, vf_rng *rng, int radiance) {
  if (vf_rng_float(rng) >= b->continuation) return 0;
  float rnd[3] = {vf_rng_float(rng), vf_rng_float(rng), vf_rng_float(rng)};
  vf_vec3 gen;
  float pdf, rev_pdf, cos_gen;
  unsigned event;
  vf_vec3 f = vf_bsdf_sample(b, rnd, &gen, &pdf, &rev_pdf, &cos_gen, &event);
  if (vf_is_zero(f) || !(pdf > 0.0f)) return 0;
  int specular = (event & VF_BSDF_SPECULAR) != 0;
  vf_mis_scatter(&s->mis, &v->mis, cos_gen, pdf, rev_pdf, specular);
  float scale = cos_gen / pdf;
  if (radiance && (event & VF_BSDF_REFRACTION)) scale /= b->eta * b->eta;
  s->throughput = vf_mul(s->throughput, vf_scale(f, scale));
  s->specular_path &= specular;
  s->origin = vf_offset_ray_origin(hit->position, vf_dot(hit->normal, gen) > 0.0f ? hit->normal : vf_neg(hit->normal), v->offset_scale);
  s->direction = gen;
  return 1;
}

/* ---------------------------------------------------------------------------------------- */
/* Light sub-paths                                                                           */

static int append_vertices(light_chunk *c, const light_vertex *lv, uint32_t n) {
  if (n > c->vertex_capacity - c->num_vertices) {
    uint32_t cap = c->vertex_capacity ? 2 * c->vertex_capacity : 4 * LIGHT_CHUNK;
    while (cap - c->num_vertices < n) cap *= 2;
    /* Aligned to the cache line, as realloc's memory is not: each vertex is then one line,
     * which the grid's gather and the connections read at random. */
    light_vertex *p = aligned_alloc(64, (size_t)cap * sizeof *p);
    if (p == NULL) return 0;
    if (c->num_vertices > 0) memcpy(p, c->vertices, (size_t)c->num_vertices * sizeof *p);
    free(c->vertices);
    c->vertices = p;
    c->vertex_capacity = cap;
  }
  memcpy(&c->vertices[c->num_vertices], lv, (size_t)n * sizeof *lv);
  c->num_vertices += n;
  return 1;
}

static int push_splat(light_chunk *c, uint32_t pixel, uint32_t band, vf_vec3 rgb, uint32_t path) {
  if (c->num_splats == c->splat_capacity) {
    uint32_t cap = c->splat_capacity ? 2 * c->splat_capacity : 4 * LIGHT_CHUNK;
    splat *p = realloc(c->splats, (size_t)cap * sizeof *p);
    if (p == NULL) {
      c->out_of_memory = 1;
      return 0;
    }
    c->splats = p;
    p = realloc(c->sorted_splats, (size_t)cap * sizeof *p);
    if (p == NULL) {
      c->out_of_memory = 1;
      return 0;
    }
    c->sorted_splats = p;
    c->splat_capacity = cap;
  }
  c->splats[c->num_splats++] = (splat){pixel, rgb, (uint16_t)path, (uint16_t)band};
  return 1;
}

/* Marks a splat that is not to be added (its shadow ray was blocked, or it is not finite). */
#define DROPPED_SPLAT UINT32_MAX

/* Traces the light pass's queued shadow rays: the splats they guard that turn out blocked,
 * or not finite, are dropped (the check of finiteness comes after the shadow ray's, as for
 * every contribution). */
static void resolve_splats(vf_vcm *v, int thread, light_chunk *c) {
  shadow_packet *pk = &v->stats[thread].packet;
  int n = pk->n;
  if (n == 0) return;
  uint32_t blocked = trace_packet(v, thread, pk);
  for (int i = 0; i < n; i++) {
    splat *sp = &c->splats[pk->owner[i]];
    if (blocked >> i & 1u) {
      sp->pixel = DROPPED_SPLAT;
    } else if (!vf_is_finite(sp->rgb)) {
      v->stats[thread].nonfinite++;
      sp->pixel = DROPPED_SPLAT;
    }
  }
}

/* A splat of the light pass that counts only if the segment from p (normal n) to the
 * camera is free. */
static void splat_if_visible(vf_vcm *v, int thread, light_chunk *c, uint32_t path, uint32_t pixel, uint32_t band,
                             vf_vec3 rgb, vf_vec3 p, vf_vec3 n) {
  if (!push_splat(c, pixel, band, rgb, path)) return;
  shadow_packet *pk = &v->stats[thread].packet;
  queue_segment(v, pk, (int)(c->num_splats - 1), p, n, v->camera.position, vf_vec3_splat(0.0f));
  if (pk->n == VF_ACCEL_PACKET) resolve_splats(v, thread, c);
}

/* Projects point p, seen along -dir_to_camera, onto the image: its raster pixel and the
 * camera's density of that direction per unit of image area (in solid angle); 0 when p is
 * behind the camera or outside the image. Checked before anything is evaluated at p: a
 * good part of the light vertices lie outside the view. */
static int camera_project(const vf_vcm *v, vf_vec3 p, vf_vec3 dir_to_camera, uint32_t *pixel, uint32_t *band,
                          float *image_to_solid_angle) {
  float x, y;
  if (!vf_camera_raster(&v->camera, p, &x, &y)) return 0;
  float cos_at_camera = -vf_dot(v->camera.forward, dir_to_camera);
  if (!(cos_at_camera > 0.0f)) return 0;
  *pixel = (uint32_t)y * (uint32_t)v->camera.width + (uint32_t)x;
  *band = (uint32_t)y / SPLAT_BAND;
  float image_to_camera = v->camera.image_plane_distance / cos_at_camera;
  *image_to_solid_angle = image_to_camera * image_to_camera / cos_at_camera;
  return 1;
}

/* The camera's area density of generating a point at distance dist with |cos| cos_at_p,
 * from camera_project's image_to_solid_angle. */
static float camera_pdf_a(float image_to_solid_angle, float dist, float cos_at_p) {
  return image_to_solid_angle * cos_at_p / (dist * dist);
}

/* t = 1: projects light vertex (hit, b) onto the image. */
static void connect_to_camera(vf_vcm *v, int thread, light_chunk *c, uint32_t path, const vf_hit *hit,
                              const vf_bsdf *b, const path_state *s) {
  vf_vec3 to_camera = vf_sub(v->camera.position, hit->position);
  float dist = vf_length(to_camera);
  if (!(dist > 0.0f)) return;
  to_camera = vf_scale(to_camera, 1.0f / dist);
  uint32_t pixel, band;
  float image_to_solid_angle;
  if (!camera_project(v, hit->position, to_camera, &pixel, &band, &image_to_solid_angle)) return;
  float cos_to_camera, dir_pdf, rev_pdf;
  vf_vec3 f = vf_bsdf_evaluate(b, to_camera, &cos_to_camera, &dir_pdf, &rev_pdf);
  if (vf_is_zero(f)) return;
  float pdf_a = camera_pdf_a(image_to_solid_angle, dist, cos_to_camera);
  if (!(pdf_a > 0.0f)) return;
  float w = v->t.lt ? 1.0f : vf_mis_weight_camera_connection(&s->mis, &v->mis, pdf_a, rev_pdf);
  /* Importance of the pinhole camera over the light sub-path density n_light. */
  vf_vec3 contrib = vf_scale(vf_mul(s->throughput, f), w * pdf_a / v->mis.light_paths);
  if (vf_is_zero(contrib)) return;
  splat_if_visible(v, thread, c, path, pixel, band, contrib, hit->position, hit->normal);
}

/* Light tracing alone also projects the light's own point y0 (the s = 1, t = 1 technique,
 * which the full estimator leaves to emission hits). */
static void connect_emitter_to_camera(vf_vcm *v, int thread, light_chunk *c, uint32_t path, const vf_light *l,
                                      vf_vec3 p, vf_vec3 n, float pick_and_area_pdf) {
  vf_vec3 to_camera = vf_sub(v->camera.position, p);
  float dist = vf_length(to_camera);
  if (!(dist > 0.0f)) return;
  to_camera = vf_scale(to_camera, 1.0f / dist);
  float cos_out = vf_dot(n, to_camera);
  if (!(cos_out > 0.0f)) return;
  uint32_t pixel, band;
  float image_to_solid_angle;
  if (!camera_project(v, p, to_camera, &pixel, &band, &image_to_solid_angle)) return;
  float pdf_a = camera_pdf_a(image_to_solid_angle, dist, cos_out);
  if (!(pdf_a > 0.0f)) return;
  vf_vec3 contrib = vf_scale(l->radiance, pdf_a / (v->mis.light_paths * pick_and_area_pdf));
  splat_if_visible(v, thread, c, path, pixel, band, contrib, p, n);
}

/* A light sub-path in flight. The light pass traces VF_ACCEL_PACKET of them at once, as a
 * wavefront: each step sends the rays of all lanes to Embree as one packet (8 unrelated
 * rays in one packet are traced ~1.3 times faster than single rays on cornell), then
 * continues each lane's path; a lane whose path ends starts the chunk's next path. A
 * path's vertices are written to its slot of the retire ring, where they wait until every
 * older path of the chunk has been stored. */
typedef struct {
  path_state s;
  vf_rng rng;
  uint32_t path;          /* global index */
  uint32_t num_vertices;
  light_vertex *vertices; /* the path's slot of the retire ring: room for the longest path */
} light_lane;

/* Closest hits of the m rays: one packet, or single rays when too few to fill one. Both
 * give the same hits (vf_accel_intersect_packet). */
#define PACKET_MIN 2
static uint32_t intersect_rays(vf_vcm *v, int thread, const vf_vec3 *org, const vf_vec3 *dir, int m, vf_hit *hits) {
  if (m >= PACKET_MIN) {
    v->stats[thread].rays += (uint64_t)m;
    return vf_accel_intersect_packet(v->accel, org, dir, m, hits);
  }
  uint32_t found = 0;
  for (int k = 0; k < m; k++) found |= (uint32_t)intersect(v, thread, org[k], dir[k], &hits[k]) << k;
  return found;
}

/* One step of a wavefront: the closest hits of the next rays of the active lanes (bit i of
 * `active`: lane i, whose path state is states[i]), as one packet. Ray k is lane
 * lane_of[k]'s, *m rays in all; bit k of the result is set when ray k hit, in hits[k]. */
static uint32_t trace_lanes(vf_vcm *v, int thread, path_state *const *states, uint32_t active, int *lane_of, int *m,
                            vf_hit *hits) {
  vf_vec3 org[VF_ACCEL_PACKET], dir[VF_ACCEL_PACKET];
  int n = 0;
  for (int i = 0; i < VF_ACCEL_PACKET; i++)
    if (active >> i & 1u) {
      lane_of[n] = i;
      org[n] = states[i]->origin;
      dir[n++] = states[i]->direction;
    }
  *m = n;
  return intersect_rays(v, thread, org, dir, n, hits);
}

/* Emits light sub-path `path` into the lane; returns 1 when it has a ray to trace. */
static int light_start(vf_vcm *v, int thread, light_chunk *c, light_lane *lane, uint32_t path, uint32_t begin) {
  lane->path = path;
  lane->num_vertices = 0;
  lane->rng = vf_rng_for_path(v->settings.seed, v->iteration, path, VF_STREAM_LIGHT);
  vf_rng *rng = &lane->rng;
  path_state *s = &lane->s;
  const vf_light *l = vf_lights_pick(v->lights, vf_rng_float(rng));
  float rnd[4] = {vf_rng_float(rng), vf_rng_float(rng), vf_rng_float(rng), vf_rng_float(rng)};
  vf_vec3 normal;
  float emission_pdf, direct_pdf, cos_light;
  vf_vec3 energy = vf_light_emit(v->lights, l, rnd, &s->origin, &s->direction, &normal, &emission_pdf, &direct_pdf,
                                 &cos_light);
  if (vf_is_zero(energy) || !(emission_pdf > 0.0f)) return 0;
  if (v->t.lt && l->is_finite && !l->is_delta)
    connect_emitter_to_camera(v, thread, c, path - begin, l, s->origin, normal, l->pick_probability * direct_pdf);
  emission_pdf *= l->pick_probability;
  direct_pdf *= l->pick_probability;
  s->throughput = vf_scale(energy, 1.0f / emission_pdf);
  s->path_length = 0;
  s->is_finite_light = l->is_finite;
  s->specular_path = 1;
  vf_mis_light_start(&s->mis, &v->mis, direct_pdf, emission_pdf, cos_light, l->is_delta, l->is_finite);
  if (l->kind == VF_LIGHT_AREA_MESH || l->kind == VF_LIGHT_AREA_SPHERE)
    s->origin = vf_offset_ray_origin(s->origin, normal, v->offset_scale);
  return 1;
}

/* Continues the lane's light sub-path at the hit of its last ray: stores the vertex,
 * projects it onto the camera and scatters. Returns 0 when the path ends there. */
static int light_bounce(vf_vcm *v, int thread, light_chunk *c, light_lane *lane, const vf_hit *hit, uint32_t begin) {
  path_state *s = &lane->s;
  vf_bsdf b;
  if (!bsdf_at(v, &b, hit, vf_neg(s->direction))) return 0;
  s->path_length++;
  vf_mis_hit(&s->mis, hit->t, b.local_fix.z, s->path_length > 1 || s->is_finite_light);
  if (!b.is_delta) {
    if (v->t.store_vertices) {
      uint32_t material = (uint32_t)v->scene->shapes[hit->shape].material;
      lane->vertices[lane->num_vertices++] =
          (light_vertex){hit->position, s->throughput, vf_neg(s->direction), hit->normal, s->mis,
                         (uint32_t)s->path_length | material << VERTEX_LENGTH_BITS};
    }
    if (v->t.light_to_camera) connect_to_camera(v, thread, c, lane->path - begin, hit, &b, s);
  }
  if (s->path_length + 2 > v->settings.max_path_length) return 0;
  return scatter(v, &b, hit, s, &lane->rng, 0);
}

/* The ring slot of light sub-path `path`. */
static light_vertex *ring_slot(const vf_vcm *v, int thread, uint32_t path) {
  return v->stats[thread].ring_vertices + (size_t)(path % RETIRE_RING) * v->lane_capacity;
}

/* The lane's path has ended, its vertices in its ring slot. Every ended path at the head
 * of the ring, from *oldest (the chunk's oldest path not yet stored) up to `next` (the
 * next to start), then goes to the chunk's list in path order, its range recorded: a
 * chunk's list is in path order, as connections want it (a camera tile reads the light
 * paths of its pixels, which are neighbours in the list only in path order), without a
 * pass that would sort it afterwards. */
static void light_retire(vf_vcm *v, int thread, light_chunk *c, const light_lane *lane, uint32_t *oldest,
                         uint32_t next) {
  thread_stats *ts = &v->stats[thread];
  ts->ring_count[lane->path % RETIRE_RING] = lane->num_vertices;
  while (*oldest < next && ts->ring_count[*oldest % RETIRE_RING] != RING_IN_FLIGHT) {
    uint32_t p = (*oldest)++, n = ts->ring_count[p % RETIRE_RING];
    ts->ring_count[p % RETIRE_RING] = RING_IN_FLIGHT;
    v->path_begin[p] = c->num_vertices;
    if (n > 0 && !append_vertices(c, ring_slot(v, thread, p), n)) c->out_of_memory = 1;
    v->path_end[p] = c->num_vertices;
  }
}

/* Gives the lane the chunk's next path that has a ray to trace; returns 0 when none is
 * left, or when the ring is full (the oldest path still in flight): the caller tries again
 * after the next step. */
static int light_refill(vf_vcm *v, int thread, light_chunk *c, light_lane *lane, uint32_t *next, uint32_t *oldest,
                        uint32_t begin, uint32_t end) {
  while (*next < end && *next - *oldest < RETIRE_RING) {
    uint32_t path = (*next)++;
    lane->vertices = ring_slot(v, thread, path);
    if (v->t.light_paths && light_start(v, thread, c, lane, path, begin)) return 1;
    lane->path = path; /* ended at its light, or no light paths at all: no vertices */
    lane->num_vertices = 0;
    light_retire(v, thread, c, lane, oldest, *next);
  }
  return 0;
}

typedef struct {
  vf_vcm *v;
} pass_ctx;

/* The chunk's splats that count, by band of the image (SPLAT_BAND rows) and in path order
 * within each band: two stable counting sorts, by path, then by band, so that each path's
 * splats keep the order they were made in. The chunk's band b is then
 * splats[band_start[b] .. band_start[b + 1]), band_start being the chunk's row of
 * vf_vcm.band_start. */
static void sort_splats(const vf_vcm *v, light_chunk *c, uint32_t chunk, uint32_t paths) {
  uint32_t start[LIGHT_CHUNK + 1] = {0};
  for (uint32_t i = 0; i < c->num_splats; i++)
    if (c->splats[i].pixel != DROPPED_SPLAT) start[c->splats[i].path + 1]++;
  for (uint32_t p = 0; p < paths; p++) start[p + 1] += start[p];
  for (uint32_t i = 0; i < c->num_splats; i++)
    if (c->splats[i].pixel != DROPPED_SPLAT) c->sorted_splats[start[c->splats[i].path]++] = c->splats[i];
  uint32_t n = start[paths - 1];
  uint32_t *band_start = &v->band_start[(size_t)chunk * (v->num_bands + 1)];
  memset(band_start, 0, (v->num_bands + 1) * sizeof *band_start);
  for (uint32_t i = 0; i < n; i++) band_start[c->sorted_splats[i].band + 1]++;
  /* band_start[b + 1] becomes where band b begins, and after the scatter where it ends. */
  for (uint32_t b = 0, sum = 0; b < v->num_bands; b++) {
    uint32_t count = band_start[b + 1];
    band_start[b + 1] = sum;
    sum += count;
  }
  for (uint32_t i = 0; i < n; i++) {
    const splat *sp = &c->sorted_splats[i];
    c->splats[band_start[sp->band + 1]++] = *sp;
  }
  c->num_splats = n;
}

/* Adds the splats of band `band` to the light image, chunk by chunk in chunk order: each
 * pixel gets its terms in the order of one pass over the paths, whatever the thread
 * count, and the bands run in parallel. */
static void splat_band_task(void *ctx, size_t band, int thread) {
  (void)thread;
  vf_vcm *v = ((pass_ctx *)ctx)->v;
  size_t first = band * (size_t)v->band_pixels;
  size_t last = first + v->band_pixels < v->num_pixels ? first + v->band_pixels : v->num_pixels;
  float *light_rgb = v->light_rgb;
  memset(&light_rgb[3 * first], 0, 3 * sizeof(float) * (last - first));
  for (uint32_t c = 0; c < v->num_chunks; c++) {
    const uint32_t *band_start = &v->band_start[(size_t)c * (v->num_bands + 1)];
    const splat *splats = v->chunks[c].splats;
    for (uint32_t i = band_start[band]; i < band_start[band + 1]; i++) {
      const splat *sp = &splats[i];
      light_rgb[3 * (size_t)sp->pixel + 0] += sp->rgb.x;
      light_rgb[3 * (size_t)sp->pixel + 1] += sp->rgb.y;
      light_rgb[3 * (size_t)sp->pixel + 2] += sp->rgb.z;
    }
  }
}

static void light_task(void *ctx, size_t task, int thread) {
  vf_vcm *v = ((pass_ctx *)ctx)->v;
  light_chunk *c = &v->chunks[task];
  c->num_vertices = c->num_splats = 0;
  c->out_of_memory = 0;
  uint32_t begin = (uint32_t)task * LIGHT_CHUNK;
  uint32_t end = begin + LIGHT_CHUNK < v->num_pixels ? begin + LIGHT_CHUNK : v->num_pixels;
  light_lane lanes[VF_ACCEL_PACKET];
  path_state *states[VF_ACCEL_PACKET];
  uint32_t next = begin, oldest = begin, active = 0;
  for (int i = 0; i < VF_ACCEL_PACKET; i++) {
    states[i] = &lanes[i].s;
    if (light_refill(v, thread, c, &lanes[i], &next, &oldest, begin, end)) active |= 1u << i;
  }
  while (active) {
    vf_hit hits[VF_ACCEL_PACKET];
    int lane_of[VF_ACCEL_PACKET], m;
    uint32_t found = trace_lanes(v, thread, states, active, lane_of, &m, hits);
    for (int k = 0; k < m; k++) {
      light_lane *lane = &lanes[lane_of[k]];
      if ((found >> k & 1u) && light_bounce(v, thread, c, lane, &hits[k], begin)) continue;
      light_retire(v, thread, c, lane, &oldest, next);
      if (!light_refill(v, thread, c, lane, &next, &oldest, begin, end)) active &= ~(1u << lane_of[k]);
    }
    /* Lanes left idle by a full ring start again once it has drained (a rare event: the
     * ring holds many times the paths of the lanes). */
    if (next < end && active != (1u << VF_ACCEL_PACKET) - 1u)
      for (int i = 0; i < VF_ACCEL_PACKET; i++)
        if (!(active >> i & 1u) && light_refill(v, thread, c, &lanes[i], &next, &oldest, begin, end))
          active |= 1u << i;
  }
  resolve_splats(v, thread, c);
  sort_splats(v, c, (uint32_t)task, end - begin);
}

/* The light vertex the grid names `index` (vf_vcm.chunk_shift). */
static const light_vertex *grid_vertex(const vf_vcm *v, uint32_t index) {
  return &v->chunks[index >> v->chunk_shift].vertices[index & ((1u << v->chunk_shift) - 1u)];
}

/* Copies what merging needs of the light vertices into the grid's order, so that the
 * vertices a query accepts lie next to each other in memory. */
static void gather_task(void *ctx, size_t task, int thread) {
  vf_vcm *v = ((pass_ctx *)ctx)->v;
  const vf_grid_point *points = vf_hashgrid_points(v->grid);
  uint32_t n = vf_hashgrid_count(v->grid);
  uint32_t begin = (uint32_t)task * GATHER_CHUNK, end = begin + GATHER_CHUNK < n ? begin + GATHER_CHUNK : n;
  for (uint32_t k = begin; k < end; k++) {
    /* The vertices are read in grid order, that is at random: fetch ahead of use. */
    if (k + GATHER_AHEAD < end) __builtin_prefetch(grid_vertex(v, points[k + GATHER_AHEAD].index));
    const light_vertex *lv = grid_vertex(v, points[k].index);
    v->merge_points[k] = (merge_point){points[k].x, points[k].y, points[k].z, lv->path_length_material};
    v->photons[k] = (photon){lv->throughput, lv->fix, lv->mis.d_vcm, lv->mis.d_vm};
  }
}

/* ---------------------------------------------------------------------------------------- */
/* Camera sub-paths                                                                          */

/* s = 0: radiance of a light found by the camera sub-path, weighted. */
static vf_vec3 emission_weighted(const vf_vcm *v, const vf_light *l, const path_state *s, vf_vec3 radiance,
                                 float direct_pdf, float emission_pdf) {
  if (vf_is_zero(radiance)) return radiance;
  if (s->path_length == 1) return radiance; /* seen directly: no other technique can */
  if (v->t.emission_specular_only) return s->specular_path ? radiance : vf_vec3_splat(0.0f);
  float w = vf_mis_weight_emission(&s->mis, direct_pdf * l->pick_probability, emission_pdf * l->pick_probability);
  return vf_scale(radiance, w);
}

/* Adds the camera sub-paths' waiting contributions to their pixels, in the order they
 * arose, once the queued shadow rays are traced: those whose ray was blocked are left out. */
static void resolve_deferred(vf_vcm *v, int thread) {
  thread_stats *ts = &v->stats[thread];
  shadow_packet *pk = &ts->packet;
  int n = pk->n;
  if (n > 0) {
    uint32_t blocked = trace_packet(v, thread, pk);
    for (int i = 0; i < n; i++) ts->pending[pk->owner[i]].blocked = (int)(blocked >> i & 1u);
  }
  for (int i = 0; i < ts->num_pending; i++) {
    const deferred *d = &ts->pending[i];
    if (d->blocked) continue;
    float *rgb = &ts->tile_rgb[3 * (size_t)d->tile_pixel];
    rgb[0] += d->value.x;
    rgb[1] += d->value.y;
    rgb[2] += d->value.z;
  }
  ts->num_pending = 0;
}

/* Adds value to the pixel after the contributions before it; returns the index of its
 * queue entry, the owner of the shadow ray that guards it (queue_segment or
 * queue_direction, then packet_queued), if any. */
static int defer(vf_vcm *v, int thread, vf_vec3 value, uint32_t tile_pixel) {
  thread_stats *ts = &v->stats[thread];
  if (ts->num_pending == DEFERRED_MAX) resolve_deferred(v, thread);
  ts->pending[ts->num_pending] = (deferred){value, tile_pixel, 0};
  return ts->num_pending++;
}

/* After queue_segment or queue_direction for an entry: traces the packet when full. */
static void packet_queued(vf_vcm *v, int thread) {
  if (v->stats[thread].packet.n == VF_ACCEL_PACKET) resolve_deferred(v, thread);
}

/* s = 1: next-event estimation, added to tile_pixel if the light is visible. */
static void light_sample(vf_vcm *v, int thread, const vf_hit *hit, const vf_bsdf *b, const path_state *s,
                         vf_rng *rng, uint32_t tile_pixel) {
  vf_vec3 zero = vf_vec3_splat(0.0f);
  const vf_light *l = vf_lights_pick(v->lights, vf_rng_float(rng));
  float rnd[2];
  rnd2(rng, rnd);
  vf_vec3 dir, lp, ln;
  float dist, direct_pdf, emission_pdf, cos_at_light;
  vf_vec3 radiance = vf_light_illuminate(v->lights, l, hit->position, rnd, &dir, &dist, &lp, &ln, &direct_pdf,
                                         &emission_pdf, &cos_at_light);
  if (vf_is_zero(radiance) || !(direct_pdf > 0.0f)) return;
  float cos_to_light, bsdf_pdf, bsdf_rev_pdf;
  vf_vec3 f = vf_bsdf_evaluate(b, dir, &cos_to_light, &bsdf_pdf, &bsdf_rev_pdf);
  if (vf_is_zero(f)) return;
  if (l->is_delta) bsdf_pdf = 0.0f; /* a delta light cannot be hit by a sampled direction */
  float pick = l->pick_probability;
  float w = vf_mis_weight_light_sample(&s->mis, &v->mis, bsdf_pdf, bsdf_rev_pdf, direct_pdf * pick,
                                       emission_pdf * pick, cos_to_light, cos_at_light);
  vf_vec3 contrib = vf_scale(vf_mul(radiance, f), w * cos_to_light / (pick * direct_pdf));
  if (vf_is_zero(contrib)) return;
  int entry = defer(v, thread, vf_mul(s->throughput, contrib), tile_pixel);
  shadow_packet *pk = &v->stats[thread].packet;
  if (isinf(dist))
    queue_direction(v, pk, entry, hit->position, hit->normal, dir);
  else
    queue_segment(v, pk, entry, hit->position, hit->normal, lp, l->kind == VF_LIGHT_POINT ? zero : ln);
  packet_queued(v, thread);
}

/* The BSDFs of the light vertices a camera sub-path connects to: every camera vertex
 * connects to the same light sub-path, so each light vertex's BSDF is set up once per
 * camera sub-path, when first needed, instead of once per connection. Light sub-paths
 * longer than the cache set up the rest per connection. */
#define LIGHT_BSDF_CACHE 16
typedef struct {
  vf_bsdf bsdf[LIGHT_BSDF_CACHE];
  uint32_t ready; /* bit i: bsdf[i] is set up */
} light_bsdf_cache;

static const vf_bsdf *light_bsdf(const vf_vcm *v, light_bsdf_cache *cache, uint32_t i, const light_vertex *lv,
                                 vf_bsdf *scratch) {
  if (i >= LIGHT_BSDF_CACHE) {
    bsdf_of_vertex(v, scratch, lv);
    return scratch;
  }
  if (!(cache->ready >> i & 1u)) {
    bsdf_of_vertex(v, &cache->bsdf[i], lv);
    cache->ready |= 1u << i;
  }
  return &cache->bsdf[i];
}

/* s > 1, t > 1: connection of camera vertex (hit, b) to light vertex lv, the i-th of its
 * light sub-path, added to tile_pixel if the two see each other. */
static void connect_vertices(vf_vcm *v, int thread, const vf_hit *hit, const vf_bsdf *b, const path_state *s,
                             const light_vertex *lv, uint32_t i, light_bsdf_cache *cache, uint32_t tile_pixel) {
  vf_vec3 d = vf_sub(lv->position, hit->position);
  float dist2 = vf_length_sq(d);
  if (!(dist2 > 0.0f)) return;
  float dist = sqrtf(dist2);
  d = vf_scale(d, 1.0f / dist);
  float cos_camera, camera_pdf, camera_rev_pdf;
  vf_vec3 fc = vf_bsdf_evaluate(b, d, &cos_camera, &camera_pdf, &camera_rev_pdf);
  if (vf_is_zero(fc)) return;
  vf_bsdf scratch;
  const vf_bsdf *lb = light_bsdf(v, cache, i, lv, &scratch);
  float cos_light, light_pdf, light_rev_pdf;
  vf_vec3 fl = vf_bsdf_evaluate(lb, vf_neg(d), &cos_light, &light_pdf, &light_rev_pdf);
  if (vf_is_zero(fl)) return;
  /* Each side's density of sampling the other vertex, in area measure there. */
  float camera_pdf_a = camera_pdf * cos_light / dist2;
  float light_pdf_a = light_pdf * cos_camera / dist2;
  float w = vf_mis_weight_connection(&lv->mis, &s->mis, &v->mis, camera_pdf_a, light_pdf_a, light_rev_pdf,
                                     camera_rev_pdf);
  vf_vec3 contrib = vf_scale(vf_mul(vf_mul(fc, fl), lv->throughput), w * cos_camera * cos_light / dist2);
  if (vf_is_zero(contrib)) return;
  int entry = defer(v, thread, vf_mul(s->throughput, contrib), tile_pixel);
  queue_segment(v, &v->stats[thread].packet, entry, hit->position, hit->normal, lv->position, lv->normal);
  packet_queued(v, thread);
}

/* ---------------------------------------------------------------------------------------- */
/* Merging                                                                                   */

/* Merges camera vertex q with light vertex k (an index into the grid's order), which lies
 * within the radius: the vertex merging estimate with its MIS weight (eq. 38-39). */
static vf_vec3 merge_one(const vf_vcm *v, const merge_query *q, uint32_t k) {
  uint32_t length_material = v->merge_points[k].path_length_material;
  if ((int)(length_material & ((1u << VERTEX_LENGTH_BITS) - 1u)) + q->path_length > v->settings.max_path_length)
    return vf_vec3_splat(0.0f);
  const photon *ph = &v->photons[k];
  float cos_camera, camera_pdf, camera_rev_pdf;
  vf_vec3 f = vf_bsdf_evaluate(&q->bsdf, ph->direction, &cos_camera, &camera_pdf, &camera_rev_pdf);
  if (vf_is_zero(f)) return f;
  float w = 1.0f;
  if (!v->t.ppm) {
    /* The reverse step is taken at the light vertex: its Russian roulette applies. */
    camera_rev_pdf *= v->lobes[length_material >> VERTEX_LENGTH_BITS].continuation / q->bsdf.continuation;
    vf_mis light = {ph->d_vcm, 0.0f, ph->d_vm};
    w = vf_mis_weight_merge(&light, &q->mis, &v->mis, camera_pdf, camera_rev_pdf);
  }
  return vf_scale(vf_mul(f, ph->throughput), w);
}

#ifdef __SSE2__
/* Which of the four merge points k .. k + 3 lie before `end`, within the radius of
 * (qx, qy, qz) and are at most `longest` segments long: bit i for point k + i. SSE2
 * (every x86-64 has it) turns the four points into one register per coordinate and tests
 * them together, with the same float operations in the same order as one at a time, so
 * the same points pass. Indices are compared as signed after flipping their top bit:
 * SSE2 has no unsigned comparison. */
static inline unsigned group_mask(const float *points, uint32_t k, __m128i end_flipped, __m128 qx, __m128 qy,
                                  __m128 qz, __m128 radius_sq, __m128i longest) {
  const float *p = points + 4 * (size_t)k;
  __m128 a = _mm_load_ps(p), b = _mm_load_ps(p + 4), c = _mm_load_ps(p + 8), d = _mm_load_ps(p + 12);
  __m128 ab_lo = _mm_unpacklo_ps(a, b), ab_hi = _mm_unpackhi_ps(a, b); /* ax bx ay by, az bz aw bw */
  __m128 cd_lo = _mm_unpacklo_ps(c, d), cd_hi = _mm_unpackhi_ps(c, d);
  __m128 dx = _mm_sub_ps(_mm_movelh_ps(ab_lo, cd_lo), qx);
  __m128 dy = _mm_sub_ps(_mm_movehl_ps(cd_lo, ab_lo), qy);
  __m128 dz = _mm_sub_ps(_mm_movelh_ps(ab_hi, cd_hi), qz);
  __m128i length = _mm_and_si128(_mm_castps_si128(_mm_movehl_ps(cd_hi, ab_hi)),
                                 _mm_set1_epi32((1 << VERTEX_LENGTH_BITS) - 1));
  __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz));
  __m128i index = _mm_add_epi32(_mm_set1_epi32((int)(k ^ 0x80000000u)), _mm_setr_epi32(0, 1, 2, 3));
  __m128i pass = _mm_and_si128(_mm_castps_si128(_mm_cmple_ps(d2, radius_sq)), _mm_cmplt_epi32(index, end_flipped));
  pass = _mm_andnot_si128(_mm_cmpgt_epi32(length, longest), pass);
  return (unsigned)_mm_movemask_ps(_mm_castsi128_ps(pass));
}

/* The offsets of the set bits of a 4-bit mask, in order (the rest 0), and their number: a
 * group's passing points are appended with one vector store and no branch per point, whose
 * outcome is random. */
static const uint32_t set_bits[16][4] __attribute__((aligned(16))) = {
    {0, 0, 0, 0}, {0, 0, 0, 0}, {1, 0, 0, 0}, {0, 1, 0, 0}, {2, 0, 0, 0}, {0, 2, 0, 0}, {1, 2, 0, 0}, {0, 1, 2, 0},
    {3, 0, 0, 0}, {0, 3, 0, 0}, {1, 3, 0, 0}, {0, 1, 3, 0}, {2, 3, 0, 0}, {0, 2, 3, 0}, {1, 2, 3, 0}, {0, 1, 2, 3}};
static const uint8_t bit_count[16] = {0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4};

/* The light vertices of the candidate ranges within the radius of query q and short
 * enough to merge with it (merge_one would give the others nothing), in grid order: up to
 * max of them into hits[0 .. max), which has room for max + 4 (the slots past max take
 * writes past it). Returns their number, which may exceed max. Nearly every range holds
 * at most eight points; each is tested as two groups of four, whatever its length, so
 * that nothing here branches on the data but the rare longer range: the lengths of ranges
 * and the outcomes of the tests are random, and each mispredicted branch would cost as
 * much as testing a group. Groups may read up to seven points past a range, or past the
 * last point (the array has room), and ignore them. */
static int find_hits(const vf_vcm *v, const merge_query *q, const vf_index_range *ranges, int n, uint32_t *hits,
                     int max) {
  const float *points = (const float *)v->merge_points;
  __m128 qx = _mm_set1_ps(q->position.x), qy = _mm_set1_ps(q->position.y), qz = _mm_set1_ps(q->position.z);
  __m128 radius_sq = _mm_set1_ps(v->radius_sq);
  __m128i longest = _mm_set1_epi32(v->settings.max_path_length - q->path_length); /* >= 1 */
  int found = 0;
  for (int r = 0; r < n; r++) {
    uint32_t k = ranges[r].begin, end = ranges[r].end;
    __m128i end_flipped = _mm_set1_epi32((int)(end ^ 0x80000000u));
    do {
      for (int g = 0; g < 2; g++, k += 4) {
        unsigned mask = group_mask(points, k, end_flipped, qx, qy, qz, radius_sq, longest);
        __m128i at = _mm_add_epi32(_mm_set1_epi32((int)k), _mm_load_si128((const __m128i *)set_bits[mask]));
        _mm_storeu_si128((__m128i *)(hits + (found < max ? found : max)), at);
        found += bit_count[mask];
      }
    } while (k < end);
  }
  return found;
}

#ifdef __x86_64__
#define MERGE_AVX512 1
/* find_hits on CPUs with AVX-512 (F and VL; vf_vcm_create looks): a range's eight points in
 * one step instead of two groups of four. Two 64-byte loads hold the eight points; one
 * permutation per field gathers them into a register per coordinate; the tests are the
 * same float operations, in the same order, as group_mask's, and the passing indices are
 * packed in order into one register (VPCOMPRESSD) and stored whole: compressing straight
 * into memory is microcoded on AMD Zen 4, and made merging slower than SSE2 there. So the
 * same hits, in the same order (test_vcm compares the frames). This target allows FMA:
 * the build's -ffp-contract=off (CMakeLists.txt) keeps every product and sum rounded on
 * its own, here and in the code inlined into run_merges_avx512. The caller's hits[] needs
 * room for max + 8. */
__attribute__((target("avx512f,avx512vl,popcnt"))) static inline int find_hits_avx512(
    const vf_vcm *v, const merge_query *q, const vf_index_range *ranges, int n, uint32_t *hits, int max) {
  const float *points = (const float *)v->merge_points;
  __m256 qx = _mm256_set1_ps(q->position.x), qy = _mm256_set1_ps(q->position.y), qz = _mm256_set1_ps(q->position.z);
  __m256 radius_sq = _mm256_set1_ps(v->radius_sq);
  __m256i longest = _mm256_set1_epi32(v->settings.max_path_length - q->path_length); /* >= 1 */
  __m256i length_mask = _mm256_set1_epi32((1 << VERTEX_LENGTH_BITS) - 1);
  __m256i iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  /* Field f of point i (of the sixteen floats of a, then b) is float 4 i + f. */
  __m512i field_x = _mm512_setr_epi32(0, 4, 8, 12, 16, 20, 24, 28, 0, 0, 0, 0, 0, 0, 0, 0);
  __m512i field_y = _mm512_add_epi32(field_x, _mm512_set1_epi32(1));
  __m512i field_z = _mm512_add_epi32(field_x, _mm512_set1_epi32(2));
  __m512i field_w = _mm512_add_epi32(field_x, _mm512_set1_epi32(3));
  int found = 0;
  for (int r = 0; r < n; r++) {
    uint32_t k = ranges[r].begin, end = ranges[r].end;
    __m256i end_v = _mm256_set1_epi32((int)end);
    do {
      const float *p = points + 4 * (size_t)k;
      __m512 a = _mm512_loadu_ps(p), b = _mm512_loadu_ps(p + 16);
      __m256 dx = _mm256_sub_ps(_mm512_castps512_ps256(_mm512_permutex2var_ps(a, field_x, b)), qx);
      __m256 dy = _mm256_sub_ps(_mm512_castps512_ps256(_mm512_permutex2var_ps(a, field_y, b)), qy);
      __m256 dz = _mm256_sub_ps(_mm512_castps512_ps256(_mm512_permutex2var_ps(a, field_z, b)), qz);
      __m256i length = _mm256_and_si256(
          _mm256_castps_si256(_mm512_castps512_ps256(_mm512_permutex2var_ps(a, field_w, b))), length_mask);
      __m256 d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
      __mmask8 pass = _mm256_cmp_ps_mask(d2, radius_sq, _CMP_LE_OS);
      __m256i index = _mm256_add_epi32(_mm256_set1_epi32((int)k), iota);
      pass &= _mm256_cmplt_epu32_mask(index, end_v) & _mm256_cmple_epi32_mask(length, longest);
      _mm256_storeu_si256((__m256i *)(hits + (found < max ? found : max)), _mm256_maskz_compress_epi32(pass, index));
      found += __builtin_popcount(pass);
      k += 8;
    } while (k < end);
  }
  return found;
}
#endif

#else
/* find_hits one candidate at a time, for targets without SSE2: the same tests in the same
 * order, so the same hits (the vector version's comment above says why it branches less). */
static int find_hits(const vf_vcm *v, const merge_query *q, const vf_index_range *ranges, int n, uint32_t *hits,
                     int max) {
  uint32_t longest = (uint32_t)(v->settings.max_path_length - q->path_length); /* >= 1 */
  int found = 0;
  for (int r = 0; r < n; r++)
    for (uint32_t k = ranges[r].begin; k < ranges[r].end; k++) {
      const merge_point *mp = &v->merge_points[k];
      float dx = mp->x - q->position.x, dy = mp->y - q->position.y, dz = mp->z - q->position.z;
      hits[found < max ? found : max] = k;
      found += (dx * dx + dy * dy + dz * dz <= v->radius_sq) &
               ((mp->path_length_material & ((1u << VERTEX_LENGTH_BITS) - 1u)) <= longest);
    }
  return found;
}
#endif

static vf_vec3 merge_all(const vf_vcm *v, const merge_query *q, const vf_index_range *ranges, int n) {
  vf_vec3 sum = vf_vec3_splat(0.0f);
  const merge_point *points = v->merge_points;
  for (int r = 0; r < n; r++)
    for (uint32_t k = ranges[r].begin; k < ranges[r].end; k++) {
      const merge_point *gp = &points[k];
      float dx = gp->x - q->position.x, dy = gp->y - q->position.y, dz = gp->z - q->position.z;
      if (dx * dx + dy * dy + dz * dz <= v->radius_sq) sum = vf_add(sum, merge_one(v, q, k));
    }
  return vf_scale(sum, v->vm_normalization);
}

/* Merges a camera vertex at once: the path when a query cannot be queued. */
static vf_vec3 merge_now(const vf_vcm *v, const merge_query *q) {
  vf_index_range ranges[VF_HASHGRID_MAX_RANGES];
  int n = vf_hashgrid_candidates(v->grid, q->position, ranges);
  return merge_all(v, q, ranges, n);
}

/* A slot in the queue of merges run at the end of the tile, or NULL if the queue cannot
 * grow (the caller then merges at once). The caller writes the query into the slot
 * itself: built elsewhere and copied, its 150 bytes were written twice. */
static merge_query *queue_merge(vf_vcm *v, int thread) {
  thread_stats *ts = &v->stats[thread];
  if (ts->num_queries == ts->query_capacity) {
    uint32_t cap = ts->query_capacity ? 2 * ts->query_capacity : 4096;
    merge_query *p = realloc(ts->queries, (size_t)cap * sizeof *p);
    if (p == NULL) return NULL;
    ts->queries = p;
    ts->query_capacity = cap;
  }
  return &ts->queries[ts->num_queries++];
}

/* Runs the tile's queued merges as a four-stage software pipeline, each stage AHEAD
 * queries behind the previous one:
 *   A. compute the query's grid cells, prefetching their cell-table entries;
 *   B. read its candidate ranges, prefetching their sorted positions;
 *   C. test distances, prefetching the photon records of the hits;
 *   D. evaluate the hits (BSDF and MIS weight) and add them to the pixel.
 * Every miss of a query is then in flight while other queries compute, instead of each
 * query waiting for its own misses in turn. Results are added in queue order, so they do
 * not depend on the thread. */
#define AHEAD 4
#define RING (4 * AHEAD)
#define MAX_HITS 24
static inline __attribute__((always_inline)) void merge_pipeline(vf_vcm *v, int thread, float *tile_rgb,
                                                                 int avx512) {
  thread_stats *ts = &v->stats[thread];
  int n = (int)ts->num_queries;
  if (n == 0) return; /* nothing queued: no merging, or no grid this iteration */
  const merge_query *q = ts->queries;
  const merge_point *points = v->merge_points;
  const vf_grid_lookup *lookup = vf_hashgrid_lookup(v->grid);
  vf_grid_cells cells[RING];
  vf_index_range ranges[RING][VF_HASHGRID_MAX_RANGES];
  int num_ranges[RING], num_hits[RING];
  uint32_t hits[RING][MAX_HITS + 8]; /* room for find_hits' writes past MAX_HITS */
  for (int i = 0; i < n + 3 * AHEAD; i++) {
    int a = i, b = i - AHEAD, c = i - 2 * AHEAD, d = i - 3 * AHEAD;
    if (a < n) vf_grid_cells_of(lookup, q[a].position, &cells[a % RING]);
    if (b >= 0 && b < n) {
      int m = num_ranges[b % RING] = vf_grid_ranges_of(lookup, &cells[b % RING], ranges[b % RING]);
      for (int r = 0; r < m; r++) {
        /* The lines that find_hits reads first, then any of a longer range. */
        const char *p0 = (const char *)&points[ranges[b % RING][r].begin];
        const char *p1 = (const char *)&points[ranges[b % RING][r].end];
        __builtin_prefetch(p0);
        __builtin_prefetch(p0 + 64);
        __builtin_prefetch(p0 + 127);
        for (p0 += 191; p0 < p1; p0 += 64) __builtin_prefetch(p0);
      }
    }
    if (c >= 0 && c < n) {
      int h = num_hits[c % RING] =
#ifdef MERGE_AVX512
          avx512 ? find_hits_avx512(v, &q[c], ranges[c % RING], num_ranges[c % RING], hits[c % RING], MAX_HITS) :
#endif
                 find_hits(v, &q[c], ranges[c % RING], num_ranges[c % RING], hits[c % RING], MAX_HITS);
      for (int k = 0; k < h && k < MAX_HITS; k++) __builtin_prefetch(&v->photons[hits[c % RING][k]]);
    }
    if (d >= 0 && d < n) {
      vf_vec3 sum;
      if (num_hits[d % RING] > MAX_HITS) {
        sum = merge_all(v, &q[d], ranges[d % RING], num_ranges[d % RING]);
      } else {
        sum = vf_vec3_splat(0.0f);
        for (int k = 0; k < num_hits[d % RING]; k++) sum = vf_add(sum, merge_one(v, &q[d], hits[d % RING][k]));
        sum = vf_scale(sum, v->vm_normalization);
      }
      vf_vec3 contrib = vf_mul(q[d].throughput, sum);
      float *rgb = &tile_rgb[3 * (size_t)q[d].tile_pixel];
      rgb[0] += contrib.x;
      rgb[1] += contrib.y;
      rgb[2] += contrib.z;
    }
  }
  ts->num_queries = 0;
}

/* The pipeline compiled twice, with find_hits and with find_hits_avx512, where the CPU
 * has AVX-512 (vf_vcm.merge_avx512): the choice is made once per tile, and each version
 * inlines its own test. */
static void run_merges_sse2(vf_vcm *v, int thread, float *tile_rgb) { merge_pipeline(v, thread, tile_rgb, 0); }

#ifdef MERGE_AVX512
__attribute__((target("avx512f,avx512vl,popcnt"))) static void run_merges_avx512(vf_vcm *v, int thread,
                                                                                 float *tile_rgb) {
  merge_pipeline(v, thread, tile_rgb, 1);
}
#endif

static void run_merges(vf_vcm *v, int thread, float *tile_rgb) {
#ifdef MERGE_AVX512
  if (v->merge_avx512) {
    run_merges_avx512(v, thread, tile_rgb);
    return;
  }
#endif
  run_merges_sse2(v, thread, tile_rgb);
}

/* A contribution without a shadow ray, in its turn. */
static void defer_unshadowed(vf_vcm *v, int thread, vf_vec3 value, uint32_t tile_pixel) {
  if (!vf_is_zero(value)) defer(v, thread, value, tile_pixel);
}

/* A camera sub-path in flight. The camera pass, like the light pass, traces
 * VF_ACCEL_PACKET of them at once as a wavefront over the tile's pixels. Its contributions
 * go to its pixel through the deferred queue and its merges to the merge queue, each in
 * the path's own order, so that every pixel sums the same terms in the same order as when
 * its path was traced alone. */
typedef struct {
  path_state s;
  vf_rng rng;
  uint32_t pixel, tile_pixel;
  light_bsdf_cache cache; /* of the light sub-path this camera sub-path connects to */
} camera_lane;

/* Starts the camera sub-path of pixel (px, py), the tile's pixel tile_pixel. */
static void camera_start(vf_vcm *v, camera_lane *lane, uint32_t px, uint32_t py, uint32_t tile_pixel) {
  uint32_t pixel = py * (uint32_t)v->camera.width + px;
  lane->pixel = pixel;
  lane->tile_pixel = tile_pixel;
  lane->cache.ready = 0;
  lane->rng = vf_rng_for_path(v->settings.seed, v->iteration, pixel, VF_STREAM_CAMERA);
  float jx = vf_rng_float(&lane->rng), jy = vf_rng_float(&lane->rng);
  path_state *s = &lane->s;
  s->origin = v->camera.position;
  s->direction = vf_camera_direction(&v->camera, (float)px + jx, (float)py + jy);
  s->throughput = vf_vec3_splat(1.0f);
  s->path_length = 1;
  s->specular_path = 1;
  vf_mis_camera_start(&s->mis, &v->mis, vf_camera_pdf_w(&v->camera, s->direction));
}

/* Continues the lane's camera sub-path where its last ray ended (hit NULL: it left the
 * scene): emission, light sampling, connections, merging, scattering. Returns 0 when the
 * path ends there. */
static int camera_bounce(vf_vcm *v, int thread, camera_lane *lane, const vf_hit *hit) {
  path_state *s = &lane->s;
  uint32_t tile_pixel = lane->tile_pixel;
  if (hit == NULL) {
    if (v->lights->environment >= 0 && v->t.emission) {
      const vf_light *l = &v->lights->lights[v->lights->environment];
      float direct_pdf, emission_pdf;
      vf_vec3 le = vf_light_radiance_environment(v->lights, l, s->direction, &direct_pdf, &emission_pdf);
      defer_unshadowed(v, thread, vf_mul(s->throughput, emission_weighted(v, l, s, le, direct_pdf, emission_pdf)),
                       tile_pixel);
    }
    return 0;
  }
  float cos_fix = fabsf(vf_dot(hit->normal, s->direction));
  if (!(cos_fix > 1e-7f)) return 0; /* grazing: no emission or scattering to speak of */
  vf_mis_hit(&s->mis, hit->t, cos_fix, 1);
  int light_index = v->lights->shape_light[hit->shape];
  if (light_index >= 0 && v->t.emission) {
    const vf_light *l = &v->lights->lights[light_index];
    float direct_pdf, emission_pdf;
    vf_vec3 le = vf_light_radiance_area(l, s->direction, hit->normal, &direct_pdf, &emission_pdf);
    defer_unshadowed(v, thread, vf_mul(s->throughput, emission_weighted(v, l, s, le, direct_pdf, emission_pdf)),
                     tile_pixel);
  }
  if (s->path_length >= v->settings.max_path_length) return 0;
  vf_bsdf b;
  if (!bsdf_at(v, &b, hit, vf_neg(s->direction))) return 0;
  if (!b.is_delta) {
    if (v->t.light_sample) light_sample(v, thread, hit, &b, s, &lane->rng, tile_pixel);
    if (v->t.connection) {
      const light_vertex *path = v->chunks[lane->pixel / LIGHT_CHUNK].vertices;
      uint32_t first = v->path_begin[lane->pixel];
      for (uint32_t i = first; i < v->path_end[lane->pixel]; i++) {
        const light_vertex *lv = &path[i];
        if (vertex_path_length(lv) + 1 + s->path_length > v->settings.max_path_length) break;
        connect_vertices(v, thread, hit, &b, s, lv, i - first, &lane->cache, tile_pixel);
      }
    }
    if (v->t.merging && v->num_vertices > 0) {
      merge_query *q = queue_merge(v, thread);
      if (q != NULL) {
        *q = (merge_query){b, hit->position, s->throughput, s->mis, s->path_length, tile_pixel};
      } else {
        merge_query now = {b, hit->position, s->throughput, s->mis, s->path_length, tile_pixel};
        defer_unshadowed(v, thread, vf_mul(s->throughput, merge_now(v, &now)), tile_pixel);
      }
      if (v->t.ppm) return 0;
    }
  }
  if (!scatter(v, &b, hit, s, &lane->rng, 1)) return 0;
  s->path_length++;
  return 1;
}

/* Traces the camera sub-paths of the tile's pixels (tile_pixel = row * tw + column). */
static void trace_camera_tile(vf_vcm *v, int thread, uint32_t x0, uint32_t y0, uint32_t tw, uint32_t pixels) {
  camera_lane lanes[VF_ACCEL_PACKET];
  path_state *states[VF_ACCEL_PACKET];
  /* The next pixel to start: tile_pixel next, at column tx and row ty of the tile (kept
   * apart so that no pixel costs a division). */
  uint32_t next = 0, tx = 0, ty = 0, active = 0;
#define START_NEXT_PIXEL(lane)                                \
  do {                                                        \
    camera_start(v, (lane), x0 + tx, y0 + ty, next++);        \
    if (++tx == tw) tx = 0, ty++;                             \
  } while (0)
  for (int i = 0; i < VF_ACCEL_PACKET; i++) {
    states[i] = &lanes[i].s;
    if (next < pixels) {
      START_NEXT_PIXEL(&lanes[i]);
      active |= 1u << i;
    }
  }
  while (active) {
    vf_hit hits[VF_ACCEL_PACKET];
    int lane_of[VF_ACCEL_PACKET], m;
    uint32_t found = trace_lanes(v, thread, states, active, lane_of, &m, hits);
    for (int k = 0; k < m; k++) {
      int i = lane_of[k];
      if (camera_bounce(v, thread, &lanes[i], (found >> k & 1u) ? &hits[k] : NULL)) continue;
      if (next < pixels)
        START_NEXT_PIXEL(&lanes[i]);
      else
        active &= ~(1u << i);
    }
  }
#undef START_NEXT_PIXEL
}

static void camera_task(void *ctx, size_t task, int thread) {
  vf_vcm *v = ((pass_ctx *)ctx)->v;
  uint32_t width = (uint32_t)v->camera.width, height = (uint32_t)v->camera.height;
  uint32_t tiles_x = (width + CAMERA_TILE - 1) / CAMERA_TILE;
  uint32_t x0 = (uint32_t)(task % tiles_x) * CAMERA_TILE, y0 = (uint32_t)(task / tiles_x) * CAMERA_TILE;
  uint32_t x1 = x0 + CAMERA_TILE < width ? x0 + CAMERA_TILE : width;
  uint32_t y1 = y0 + CAMERA_TILE < height ? y0 + CAMERA_TILE : height;
  uint32_t tw = x1 - x0;
  float tile_rgb[3 * CAMERA_TILE * CAMERA_TILE];
  memset(tile_rgb, 0, 3 * sizeof(float) * tw * (y1 - y0));
  v->stats[thread].tile_rgb = tile_rgb;
  if (v->t.camera_paths) trace_camera_tile(v, thread, x0, y0, tw, tw * (y1 - y0));
  resolve_deferred(v, thread);
  run_merges(v, thread, tile_rgb);
  for (uint32_t y = y0; y < y1; y++)
    for (uint32_t x = x0; x < x1; x++) {
      const float *c = &tile_rgb[3 * ((y - y0) * tw + (x - x0))];
      float *out = &v->camera_rgb[3 * ((size_t)y * width + x)];
      if (isfinite(c[0]) && isfinite(c[1]) && isfinite(c[2])) {
        out[0] = c[0];
        out[1] = c[1];
        out[2] = c[2];
      } else {
        v->stats[thread].nonfinite++;
        out[0] = out[1] = out[2] = 0.0f;
      }
    }
}

/* ---------------------------------------------------------------------------------------- */
/* The iteration                                                                             */

double vf_vcm_merge_radius(const vf_vcm *v, uint64_t iteration) {
  double i = (double)iteration + 1.0;
  return v->settings.radius_factor * v->scene_radius * sqrt(pow(i, v->settings.alpha - 1.0));
}

static void setup_iteration(vf_vcm *v, uint64_t iteration) {
  v->iteration = iteration;
  double r = vf_vcm_merge_radius(v, iteration);
  double eta = M_PI * r * r * (double)v->num_pixels; /* n_VM / n_VC * pi r^2 (eq. 20), n_VC = 1 */
  v->radius = (float)r;
  v->radius_sq = (float)(r * r);
  v->vm_normalization = (float)(1.0 / eta);
  int vc_in_weights = v->settings.algorithm == VF_ALGO_VCM || v->settings.algorithm == VF_ALGO_BPT;
  int vm_in_weights = v->settings.algorithm == VF_ALGO_VCM || v->settings.algorithm == VF_ALGO_BPM;
  v->mis.vm_weight = vm_in_weights ? vf_mis_h((float)eta) : 0.0f;
  v->mis.vc_weight = vc_in_weights ? vf_mis_h((float)(1.0 / eta)) : 0.0f;
  v->mis.light_paths = (float)v->num_pixels;
  v->mis.pt = v->settings.algorithm == VF_ALGO_PT;
}

int vf_vcm_iteration(vf_vcm *v, uint64_t iteration, float *camera_rgb, float *light_rgb, vf_vcm_stats *stats) {
  setup_iteration(v, iteration);
  v->camera_rgb = camera_rgb;
  v->light_rgb = light_rgb;
  int threads = vf_pool_threads(v->pool);
  for (int t = 0; t < threads; t++) v->stats[t].rays = v->stats[t].nonfinite = 0;
  pass_ctx ctx = {v};

  /* 1. Light sub-paths, their vertices and their projections onto the camera. */
  double t0 = vf_seconds_now();
  vf_pool_run(v->pool, v->num_chunks, light_task, &ctx);
  uint64_t total = 0;
  uint32_t largest = 0;
  for (uint32_t c = 0; c < v->num_chunks; c++) {
    if (v->chunks[c].out_of_memory) return vf_error_set(VF_ENOMEM, "out of memory storing light vertices");
    total += v->chunks[c].num_vertices;
    if (v->chunks[c].num_vertices > largest) largest = v->chunks[c].num_vertices;
  }
  /* The grid names vertex i of chunk c (c << chunk_shift) + i: chunk_shift bits hold the
   * largest chunk's count. At 512x512 the names stay below 2^20 (2^8 chunks, none of 2^12
   * vertices); they run out only far beyond what memory holds. */
  v->chunk_shift = 0;
  while (v->chunk_shift < 32 && ((uint64_t)1 << v->chunk_shift) < largest) v->chunk_shift++;
  if (v->chunk_shift >= 32 || ((uint64_t)v->num_chunks << v->chunk_shift) > (uint64_t)UINT32_MAX + 1)
    return vf_error_set(VF_ENOMEM, "%llu light vertices in one iteration: more than the grid can index",
                        (unsigned long long)total);
  v->num_vertices = (uint32_t)total;
  vf_pool_run(v->pool, v->num_bands, splat_band_task, &ctx); /* the light image, band by band */

  double t1 = vf_seconds_now();
  /* 2. The range-search grid, only when merging. */
  if (v->t.merging && v->num_vertices > 0) {
    for (uint32_t c = 0; c < v->num_chunks; c++)
      v->segments[c] = (vf_grid_segment){v->chunks[c].vertices, v->chunks[c].num_vertices, c << v->chunk_shift};
    int err = vf_hashgrid_build_segments(v->grid, v->segments, v->num_chunks, sizeof(light_vertex), v->radius,
                                         v->pool);
    if (err != VF_OK) return err;
    uint32_t n = vf_hashgrid_count(v->grid);
    if (n > v->photon_capacity) {
      /* Photons aligned to the line, so that each lies in one; old contents are not kept.
       * Slack as for the vertices. */
      size_t capacity = n + n / 8 < UINT32_MAX ? (size_t)(n + n / 8) : UINT32_MAX;
      free(v->photons);
      free(v->merge_points);
      v->photons = huge_alloc(capacity * sizeof(photon));
      v->merge_points = huge_alloc((capacity + MERGE_POINT_PAD) * sizeof(merge_point));
      v->photon_capacity = v->photons && v->merge_points ? (uint32_t)capacity : 0;
      if (v->photon_capacity == 0) return VF_ENOMEM;
    }
    vf_pool_run(v->pool, (n + GATHER_CHUNK - 1) / GATHER_CHUNK, gather_task, &ctx);
    memset(&v->merge_points[n], 0, MERGE_POINT_PAD * sizeof *v->merge_points); /* read past a range, ignored */
  }

  double t2 = vf_seconds_now();
  /* 3. Camera sub-paths. */
  uint32_t tiles = ((uint32_t)v->camera.width + CAMERA_TILE - 1) / CAMERA_TILE *
                   (((uint32_t)v->camera.height + CAMERA_TILE - 1) / CAMERA_TILE);
  vf_pool_run(v->pool, tiles, camera_task, &ctx);
  double t3 = vf_seconds_now();
  stats->light_seconds += t1 - t0;
  stats->grid_seconds += t2 - t1;
  stats->camera_seconds += t3 - t2;

  for (int t = 0; t < threads; t++) {
    stats->rays += v->stats[t].rays;
    stats->nonfinite += v->stats[t].nonfinite;
  }
  stats->light_vertices += v->num_vertices;
  return VF_OK;
}

/* ---------------------------------------------------------------------------------------- */
/* Set-up                                                                                    */

static void choose_techniques(vf_vcm *v) {
  techniques *t = &v->t;
  memset(t, 0, sizeof *t);
  switch (v->settings.algorithm) {
  case VF_ALGO_VCM:
    t->light_paths = t->camera_paths = t->light_to_camera = t->emission = t->light_sample = 1;
    t->connection = t->merging = 1;
    break;
  case VF_ALGO_BPT:
    t->light_paths = t->camera_paths = t->light_to_camera = t->emission = t->light_sample = t->connection = 1;
    break;
  case VF_ALGO_PT: t->camera_paths = t->emission = t->light_sample = 1; break;
  case VF_ALGO_LT: t->light_paths = t->light_to_camera = t->lt = 1; break;
  case VF_ALGO_PPM:
    t->light_paths = t->camera_paths = t->emission = t->merging = t->ppm = 1;
    t->emission_specular_only = 1;
    break;
  case VF_ALGO_BPM:
    t->light_paths = t->camera_paths = t->emission = t->merging = 1;
    t->emission_specular_only = 1;
    break;
  default: break;
  }
  t->store_vertices = t->connection || t->merging;
}

static void analyse_scene(vf_vcm *v) {
  const vf_scene *sc = v->scene;
  for (int i = 0; i < sc->num_materials; i++) {
    const vf_material *m = &sc->materials[i];
    if (!vf_is_zero(m->mirror) || !vf_is_zero(m->dielectric)) v->has_specular = 1;
    if (!vf_is_zero(m->glossy)) v->has_glossy = 1;
    if (!vf_is_zero(m->diffuse)) v->has_diffuse = 1;
  }
}

/* --algorithm auto: the cheapest technique set that covers the scene's light transport
 * (docs/BENCHMARKS.md, "Time against error", has the measurements behind each branch).
 *
 * - Specular surfaces next to diffuse or glossy ones: SDS paths can exist. Of our
 *   techniques only merging samples them when they start at a point or directional light
 *   (paper sec. 6.1, "Limitations"), and with area lights connections see them only
 *   through chance emission hits: vcm.
 * - Otherwise every path has two consecutive non-specular vertices somewhere, so the
 *   unbiased techniques reach all of them and merging adds only a higher-variance
 *   duplicate of what connections already sample (its weight shrinks to nothing as the
 *   radius does). Of the unbiased sets, path tracing with light sampling reached every
 *   error target first on all such scenes of the suite (diffuse, knot, sharp glossy up to
 *   exponent 5000): light sub-paths cost more per iteration than they save: pt.
 * The choice reads only the scene's materials, so it is a pure function of scene and
 * settings: every worker and every `continue` makes the same one, and films keep "auto"
 * in their settings text. It cannot tell how much light the SDS paths carry: with area
 * lights in view of the light sampler (`cornell`) pt would be faster than the vcm chosen. */
static vf_algorithm resolve_auto(vf_vcm *v) {
  if (v->has_specular && (v->has_diffuse || v->has_glossy)) {
    v->auto_reason = "specular next to non-specular surfaces: SDS paths possible";
    return VF_ALGO_VCM;
  }
  v->auto_reason = v->has_specular ? "only specular surfaces: emission hits along specular chains suffice"
                                   : "no specular surfaces, so no SDS paths: light sampling suffices";
  return VF_ALGO_PT;
}

vf_algorithm vf_vcm_algorithm(const vf_vcm *v) { return v->settings.algorithm; }

void vf_vcm_limit_simd(vf_vcm *v) { v->merge_avx512 = 0; }

const char *vf_vcm_merge_simd(const vf_vcm *v) {
#ifdef __SSE2__
  return v->merge_avx512 ? "AVX-512" : "SSE2";
#else
  return "scalar";
#endif
}

void vf_vcm_describe(const vf_vcm *v, FILE *out) {
  const techniques *t = &v->t;
  int area = 0, point = 0, directional = 0;
  for (int i = 0; i < v->lights->count; i++) {
    vf_light_kind k = v->lights->lights[i].kind;
    area += k == VF_LIGHT_AREA_MESH || k == VF_LIGHT_AREA_SPHERE;
    point += k == VF_LIGHT_POINT;
    directional += k == VF_LIGHT_DIRECTIONAL;
  }
  int sds = v->has_specular && (v->has_diffuse || v->has_glossy);
  fprintf(out, "scene: %d area, %d point, %d directional light(s)%s; %s%s%s surfaces; SDS paths %s\n", area, point,
          directional, v->lights->environment >= 0 ? ", environment" : "", v->has_diffuse ? "diffuse " : "",
          v->has_glossy ? "glossy " : "", v->has_specular ? "specular" : "",
          sds ? "possible" : "impossible");
  if (v->requested == VF_ALGO_AUTO)
    fprintf(out, "auto: %s (%s)\n", vf_algorithm_name(v->settings.algorithm), v->auto_reason);
  fprintf(out,
          "techniques (%s): emission hits %s, light sampling %s, light tracing %s, connections %s, merging %s\n",
          vf_algorithm_name(v->settings.algorithm), t->emission ? (t->emission_specular_only ? "specular paths" : "on") : "off",
          t->light_sample ? "on" : "off", t->light_to_camera ? "on" : "off", t->connection ? "on" : "off",
          t->merging ? (t->ppm ? "first diffuse vertex" : "on") : "off");
  if (t->merging) fprintf(out, "merging tests its candidates with %s\n", vf_vcm_merge_simd(v));
  fprintf(out, "skipped: %s%s%s%s\n", t->store_vertices ? "" : "light-vertex storage, ",
          t->merging ? "" : "range-search grid, ", v->lights->environment >= 0 ? "" : "environment lookups, ",
          "connections at specular vertices, shadow rays for zero contributions");
  if (t->merging && sds == 0 && v->settings.algorithm == VF_ALGO_VCM)
    fprintf(out, "note: no specular surfaces, so merging only adds to paths connections already cover\n");
}

int vf_vcm_create(const vf_scene *scene, const vf_accel *accel, const vf_settings *settings, vf_pool *pool,
                  vf_vcm **out) {
  int err = VF_ENOMEM;
  vf_vcm *v = calloc(1, sizeof *v);
  if (v == NULL) return VF_ENOMEM;
  v->scene = scene;
  v->accel = accel;
  v->settings = *settings;
  v->pool = pool;
  vf_camera_init(&v->camera, &scene->camera, settings->width, settings->height);
  vf_scene_bounding_sphere(scene, &v->scene_center, &v->scene_radius);
  v->offset_scale = vf_accel_scale(accel);
  v->num_pixels = (uint32_t)settings->width * (uint32_t)settings->height;
  if ((uint32_t)scene->num_materials > VERTEX_MAX_MATERIALS) {
    free(v);
    return vf_error_set(VF_ESCENE, "the scene has %d materials; the renderer handles at most %u",
                        scene->num_materials, VERTEX_MAX_MATERIALS);
  }
  analyse_scene(v);
  v->requested = settings->algorithm;
  if (v->requested == VF_ALGO_AUTO) v->settings.algorithm = resolve_auto(v);
  choose_techniques(v);
  if ((err = vf_lights_create(scene, &v->lights)) != VF_OK) goto fail;
  err = VF_ENOMEM;
  v->num_chunks = (v->num_pixels + LIGHT_CHUNK - 1) / LIGHT_CHUNK;
  v->chunks = calloc(v->num_chunks, sizeof *v->chunks);
  v->band_pixels = SPLAT_BAND * (uint32_t)v->camera.width;
  v->num_bands = (v->num_pixels + v->band_pixels - 1) / v->band_pixels;
  v->band_start = calloc((size_t)v->num_chunks * (v->num_bands + 1), sizeof *v->band_start);
  v->path_begin = calloc(v->num_pixels, sizeof(uint32_t));
  v->path_end = calloc(v->num_pixels, sizeof(uint32_t));
  v->segments = calloc(v->num_chunks, sizeof *v->segments);
  v->stats = aligned_alloc(64, (size_t)vf_pool_threads(pool) * sizeof *v->stats);
  if (v->stats != NULL) memset(v->stats, 0, (size_t)vf_pool_threads(pool) * sizeof *v->stats);
  v->lobes = calloc(scene->num_materials > 0 ? (size_t)scene->num_materials : 1, sizeof *v->lobes);
  if (!v->chunks || !v->band_start || !v->path_begin || !v->path_end || !v->segments || !v->stats || !v->lobes)
    goto fail;
  for (int m = 0; m < scene->num_materials; m++) vf_bsdf_lobes_of(&scene->materials[m], &v->lobes[m]);
  v->lane_capacity = settings->max_path_length > 1 ? (uint32_t)settings->max_path_length : 1u;
  for (int t = 0; t < vf_pool_threads(pool); t++) {
    v->stats[t].ring_vertices = aligned_alloc(64, (size_t)RETIRE_RING * v->lane_capacity * sizeof(light_vertex));
    if (v->stats[t].ring_vertices == NULL) goto fail;
    for (uint32_t i = 0; i < RETIRE_RING; i++) v->stats[t].ring_count[i] = RING_IN_FLIGHT;
  }
  if (v->t.merging && (err = vf_hashgrid_create(&v->grid)) != VF_OK) goto fail;
#ifdef MERGE_AVX512
  __builtin_cpu_init();
  v->merge_avx512 = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl");
#endif
  *out = v;
  return VF_OK;
fail:
  vf_vcm_destroy(v);
  return err;
}

void vf_vcm_destroy(vf_vcm *v) {
  if (v == NULL) return;
  if (v->chunks)
    for (uint32_t c = 0; c < v->num_chunks; c++) {
      free(v->chunks[c].vertices);
      free(v->chunks[c].splats);
      free(v->chunks[c].sorted_splats);
    }
  free(v->chunks);
  free(v->band_start);
  free(v->segments);
  free(v->photons);
  free(v->merge_points);
  free(v->path_begin);
  free(v->path_end);
  if (v->stats)
    for (int t = 0; t < vf_pool_threads(v->pool); t++) {
      free(v->stats[t].queries);
      free(v->stats[t].ring_vertices);
    }
  free(v->stats);
  free(v->lobes);
  vf_hashgrid_destroy(v->grid);
  vf_lights_destroy(v->lights);
  free(v);
}
