/* The renderer's state, as the phases of an iteration share it.
 *
 * Private to the renderer: vcm.c sets it up and runs the iteration as three phases, each
 * in a file of its own (vcm.h has the overview):
 *   1. light_pass.c      light sub-paths, their stored vertices, light tracing to the camera;
 *   2. vertex_merging.c  the range-search grid over those vertices (hashgrid.c);
 *   3. camera_pass.c     camera sub-paths and their techniques, tile by tile, whose vertex
 *                        merging queries vertex_merging.c runs at the end of each tile
 *                        (through the fast path of merge_pipeline.c).
 * bpt runs 1 and 3 as one pass instead, fused_pass.c: each camera tile traces its own
 * pixels' light sub-paths, then its camera sub-paths; single-stage vcm (single_stage.c)
 * builds 2 over the light vertices the iteration before kept, then runs that pass.
 * Both passes trace with wavefront.h. Everything here is read and written by those files
 * only; nothing outside worker/ sees it. */
#ifndef VF_VCM_INTERNAL_H
#define VF_VCM_INTERNAL_H

#include "../../common/allocation.h"
#include "../../common/pool.h"
#include "../../common/settings.h"
#include "../../common/vec3.h"
#include "accel.h"
#include "bsdf.h"
#include "camera.h"
#include "hashgrid.h"
#include "light.h"
#include "medium.h"
#include "mis.h"
#include "photon_gathering.h"
#include "../scene/scene.h"
#include "vcm.h"

#include <stdint.h>

/* vf_vcm.shape_medium of a shape whose surroundings its box does not tell. */
#define VF_SHAPE_MEDIUM_UNKNOWN (-2)

/* Light sub-paths are traced in fixed chunks, each writing its own vertex and splat lists,
 * which are then read in chunk order. Results therefore do not depend on which thread
 * traced which chunk. */
#define LIGHT_CHUNK 1024u
/* Light sub-paths end out of order but are stored in path order (light_retire): a path
 * that ends before an older one waits in a ring of this many slots, one per path. */
#define RETIRE_RING 256u
#define RING_IN_FLIGHT UINT32_MAX /* thread_scratch.ring_count of a slot whose path has not ended */
/* The light pass's splats are added to the image in bands of this many rows, one band per
 * task. */
#define SPLAT_BAND 32u
/* Camera sub-paths are traced in square tiles of this side (camera_pass.c). */
#define CAMERA_TILE 32u

/* A camera tile: task `index` of the camera pass (and, in bpt's fused pass, the chunk of
 * its pixels' light sub-paths), its top-left pixel (x0, y0) and its size, less than
 * CAMERA_TILE at the image's right and bottom edges. */
typedef struct {
  uint32_t index, x0, y0, width, height;
} camera_tile;

/* A stored light vertex: one cache line. Its BSDF is not stored but set up again from
 * shape, normal and fix when a connection needs it (vf_bsdf_setup is a pure function
 * of them, so it is the BSDF the light sub-path had): rebuilding a frame costs less than
 * moving twice the bytes through the light pass and the gather. bpt's fused pass, whose
 * vertices live only as long as their camera tile, keeps the BSDFs beside them
 * (light_chunk.bsdfs). On a shape shaded from
 * its barycentrics (vf_vcm.interpolated: vertex normals, textures) the vertex holds the
 * triangle and barycentrics instead of the normal, and the set-up starts from them
 * (vf_surface_bsdf, with the geometric normal the hit had: worker/render/surface.h). */
typedef struct {
  vf_vec3 position; /* first: the hash grid reads it at offset 0 */
  vf_vec3 throughput;
  vf_vec3 fix;      /* world, unit, towards the previous light vertex */
  union {
    vf_vec3 normal; /* geometric normal at the vertex, as the hit reported it */
    struct {
      uint32_t primitive;
      float u, v;
    } point;        /* on an interpolated shape */
  } at;
  vf_mis mis;
  uint32_t path_length_shape; /* segments from the light (low bits) and shape index */
} light_vertex;
_Static_assert(sizeof(light_vertex) == 64, "a light vertex is one cache line");

/* Path lengths are at most VF_MAX_PATH_LENGTH (common/settings.h): 10 bits. */
#define VERTEX_LENGTH_BITS 10u
_Static_assert(VF_MAX_PATH_LENGTH < (1 << VERTEX_LENGTH_BITS), "path lengths fit their bits");
#define VERTEX_MAX_SHAPES (1u << (32u - VERTEX_LENGTH_BITS))
static inline int vertex_path_length(const light_vertex *lv) {
  return (int)(lv->path_length_shape & ((1u << VERTEX_LENGTH_BITS) - 1u));
}
static inline uint32_t vertex_shape(const light_vertex *lv) { return lv->path_length_shape >> VERTEX_LENGTH_BITS; }
/* The shape index of a light vertex in a medium, whose at.point.primitive is the medium. */
#define VERTEX_IN_MEDIUM (VERTEX_MAX_SHAPES - 1u)
static inline int vertex_in_medium(const light_vertex *lv) { return vertex_shape(lv) == VERTEX_IN_MEDIUM; }

/* What the light pass makes for the light image (light_pass.c). */
typedef struct splat splat;

/* Light sub-paths finish out of order (wavefront.h). A chunk's vertex list holds them in
 * path order all the same (light_retire), and the splats are sorted back into it, so
 * that every list is what tracing the paths one by one would give. Connections read the
 * vertices of their pixel's path from this list, and the grid is built over the lists of
 * all chunks where they are (vf_hashgrid_build_segments): nothing copies them together. */
typedef struct {
  light_vertex *vertices;
  vf_bsdf *bsdfs; /* the vertices' BSDFs, kept only by bpt's fused pass (vf_vcm.fused) */
  uint32_t num_vertices, vertex_capacity;
  splat *splats;
  uint32_t num_splats, splat_capacity;
  int out_of_memory;
} light_chunk;

/* upg: the first point of a light sub-path, on its light, for joining it to a camera
 * vertex that gathers the sub-path's first stored vertex (gathering_pass.c). */
typedef struct {
  vf_vec3 position;
  vf_vec3 normal;   /* area lights: the unit normal of the emitting side */
  vf_vec3 radiance; /* area lights: Le there (texture included, before its coat); point and spot: intensity */
  vf_light_coat coat; /* area lights: the clear coat there (light.h; weight 0: none) */
  int32_t light;    /* its index, or -1 for a light at infinity (or no sub-path) */
} light_origin;

/* A merge radius and what follows from it: the MIS constants of every weight of a full
 * path (eta_VCM, tech. rep. eq. 62-63) and vertex merging's normalisation 1 / (pi r^2
 * n_light). One for the whole image (vf_vcm.merge), or each camera sub-path's own with a
 * radius per pixel (pixel_radius.h). */
typedef struct {
  vf_mis_config mis;
  float radius, radius_sq, vm_normalization;
  int merges; /* its camera sub-paths merge: the render's vertex merging, unless the pixel's
               * allocation turns it off (common/allocation.h, VF_ALLOCATION_NO_MERGING) */
} merge_params;

/* A sub-path's state between vertices. */
typedef struct {
  vf_vec3 origin, direction;
  vf_vec3 throughput;
  int path_length;
  int is_finite_light; /* light sub-paths: whether the first segment has a distance */
  int specular_path;   /* camera sub-paths: every scattering so far was specular */
  vf_mis mis;
  const merge_params *merge; /* camera sub-paths: their pixel's radius (light sub-paths: unused) */
  int medium;          /* the medium the next ray travels in (-1: vacuum; segment.h) */
  int from_medium;     /* the next ray leaves a vertex in a medium */
} path_state;

typedef struct {
  int light_paths;       /* trace light sub-paths at all */
  int store_vertices;    /* keep light vertices for connection or vertex merging */
  int camera_paths;
  int light_to_camera;   /* t = 1 */
  int emission;          /* s = 0 */
  int emission_specular_only; /* ppm and bpm: s = 0 only along purely specular camera paths */
  int light_sample;      /* s = 1 */
  int connection;        /* s > 1, t > 1 */
  int vertex_merging;
  int ppm;               /* merge once, at the first non-specular camera vertex, unweighted */
  int lt;                /* light tracing alone: unweighted, includes y0 */
} techniques;

/* A camera vertex waiting for vertex merging: it is deferred to the end of each camera
 * tile, where the queries of the whole tile run as a software pipeline that keeps several
 * grid lookups in flight (merge_pipeline.c; the reference, one query at a time, is
 * vertex_merging.c's). */
typedef struct {
  vf_bsdf bsdf;
  vf_vec3 position;
  vf_vec3 throughput;
  vf_mis mis;
  int path_length;
  uint32_t tile_pixel; /* index into the tile's color buffer */
  uint32_t pixel;      /* the camera sub-path's (upg's gatherings draw from its stream) */
  merge_params merge;  /* its pixel's radius */
} vertex_merging_query;

/* upg in media: where a camera vertex is (gathering_prev.place and .here). */
typedef struct {
  vf_vec3 normal; /* a surface's outward geometric normal, as the hit reported it */
  uint32_t shape; /* the hit's shape, or VF_HIT_MEDIUM (segment.h) for a point in medium `medium` */
  int medium;     /* the medium the sub-path arrived in (-1: vacuum) */
} gathering_place;

/* upg: the camera vertex before a query's, where gathering from the camera's side joins
 * the gathered light vertex (gathering_pass.c): its BSDF, position, the throughput and MIS
 * quantities it was reached with (before it scattered). valid is 0 where there is none
 * (the query's vertex is the first hit: its predecessor is the lens). */
typedef struct {
  vf_bsdf bsdf;
  vf_vec3 position;
  vf_vec3 throughput;
  vf_mis mis;
  int valid;
  /* In a scene with media (vf_vcm.has_media): where the predecessor is, and where the
   * query's own vertex is, for the media their joins and tentative draws leave in. */
  gathering_place place, here;
} gathering_prev;

/* Shadow rays are not traced one by one where they arise but gathered into packets of
 * VF_ACCEL_PACKET and traced together (vf_accel_occluded_packet): Embree traverses a
 * packet of 8 rays faster per ray than single rays, whether or not they share an origin
 * (docs/BENCHMARKS.md, "Raw Embree rate"). No path's course depends on a shadow ray's
 * answer, only the contribution it guards, so the contributions wait in a queue until
 * their packet is traced and are then added in the order they arose: films stay bit for
 * bit those of tracing each ray at once. */
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

/* One thread's counts of the iteration, which vf_vcm_iteration adds up into its
 * vf_vcm_stats. Aligned to the cache line (and allocated so), so that no line holds two
 * threads' counters. */
typedef struct {
  _Alignas(64) uint64_t rays; /* closest-hit and occlusion queries */
  uint64_t nonfinite;         /* NaN or Inf estimates refused */
  vf_upg_counts upg;          /* upg's gatherings (photon_gathering.h) */
  uint64_t upg_fallbacks;     /* upg: light vertices merged as vcm merges them */
  double light_seconds;       /* bpt's fused pass: wall time in the tiles' light sub-paths */
} thread_stats;

/* One thread's working memory: the queues and buffers its tasks of both passes work in,
 * kept from task to task and from iteration to iteration so that nothing is allocated per
 * path or per vertex. Aligned to the cache line (and allocated so), so that no line holds
 * two threads' fields. */
typedef struct {
  _Alignas(64) vertex_merging_query *queries; /* this thread's pending vertex merging queries, owned */
  gathering_prev *query_prev; /* upg: each query's camera predecessor, owned (query_capacity of them) */
  uint32_t num_queries, query_capacity;
  shadow_packet packet;
  deferred pending[DEFERRED_MAX];
  int num_pending;
  float *tile_rgb; /* the camera tile being traced, where pending contributions go */
  light_vertex *ring_vertices; /* the light pass's retire ring: RETIRE_RING slots of lane_capacity */
  /* Room to sort a chunk's splats into, owned: one per thread, not per chunk (a large
   * image has thousands of chunks, and a second array each doubled the splats' memory;
   * docs/BENCHMARKS.md, "Memory"). */
  struct splat *sort_scratch;
  uint32_t sort_capacity;
  uint32_t ring_count[RETIRE_RING]; /* vertices of each slot's path once it has ended, else RING_IN_FLIGHT */
  /* bpt's fused pass (vf_vcm.fused): the BSDFs of the retire ring's vertices, and the
   * vertex and BSDF lists of the tile being traced with each path's range, owned, lent to
   * the tile's chunk while its light sub-paths are traced (vf_light_pass_tile). */
  vf_bsdf *ring_bsdfs;
  light_vertex *tile_vertices;
  vf_bsdf *tile_bsdfs;
  uint32_t tile_capacity;
  uint32_t tile_begin[CAMERA_TILE * CAMERA_TILE], tile_end[CAMERA_TILE * CAMERA_TILE];
} thread_scratch;

/* What vertex merging reads of the light vertices, in the grid's order (vertex_merging.h). */
typedef struct merge_point merge_point;
typedef struct photon photon;
typedef struct medium_photon medium_photon; /* volume_merging.c */

struct vf_vcm {
  const vf_scene *scene;
  const vf_accel *accel;
  vf_settings settings;
  vf_pool *pool;
  vf_camera camera;
  vf_lights *lights;
  techniques t;
  vf_bsdf_lobes *lobes; /* per material, owned */
  unsigned char *interpolated; /* per shape: vf_surface_interpolated, owned */
  int any_interpolated;        /* some shape is: hits may need their vertices and texels prefetched */
  float *shape_continuation;   /* per shape: its material's Russian-roulette probability, owned */
  vf_vec3 scene_center;
  float scene_radius;
  float offset_scale; /* for vf_offset_ray_origin */
  uint32_t num_pixels;
  /* --light-path-pixels (settings.h): the pixels sharing a light sub-path form blocks of
   * 2^light_block_w columns by 2^light_block_h rows, whose top-left pixels trace light
   * sub-paths, num_light_paths of them (n_light); both shifts 0 by default, every pixel
   * tracing its own. */
  unsigned light_block_w, light_block_h;
  uint32_t num_light_paths;
  uint32_t lane_capacity; /* most vertices a light sub-path stores */
  /* bpt: each camera tile traces its own pixels' light sub-paths first, keeping their
   * vertices' BSDFs, and connects to them while they are in cache; nothing is stored for
   * the whole iteration (fused_pass.h). The chunks are then the camera tiles. */
  int fused;
  /* upg: vertex merging gathers without bias (gathering_pass.c): the light sub-paths' first
   * points, per path, and each grid point's light vertex, as the grid names it. */
  int upg;
  light_origin *origins;
  uint32_t *photon_source;
  int has_specular, has_glossy, has_diffuse;
  /* Participating media (medium.h, segment.h): the scene's, prepared, owned; the media the
   * camera and each light (per vf_lights.lights) are in. has_media is 0 and the rest
   * unused in a scene without media, whose renders do not change by their existence. */
  int has_media;
  int has_boundaries; /* some shape has no material: an index-matched boundary (segment.h) */
  vf_medium_rt *media;
  int camera_medium;
  int *light_medium;
  /* Per shape, owned: the medium around a shape without an interface where its box shows
   * it (the scene's), else VF_SHAPE_MEDIUM_UNKNOWN (found by vf_medium_at_point). */
  int *shape_medium;
  /* The scene's medium is homogeneous and extinguishes: it fills all space, so nothing
   * from a light at infinity arrives (enclose fog in a shape to light it by the sky). */
  int infinite_dark;
  /* Merging in media (volume_merging.h): what a merge at a medium vertex adds to the MIS
   * quantities in the units of a surface merge, mis(4 r / 3) (0 without merging); the
   * iteration's light vertices in media and their grid. */
  float medium_merge;
  medium_photon *medium_photons;
  uint32_t num_medium_photons, medium_photon_capacity;
  vf_hashgrid *volume_grid;
  vf_algorithm requested;    /* settings.algorithm as given; settings.algorithm is what runs */
  const char *auto_reason;   /* why auto chose settings.algorithm, NULL unless requested auto */

  /* --radius per-pixel: each pixel's merge radius over the global one's, owned
   * (pixel_radius.h); NULL with a global radius. */
  float *pixel_scale;
  float pixel_scale_max;
  int vc_in_weights, vm_in_weights; /* the algorithm combines connections, merges */

  /* --pilot (common/allocation.h): each pixel's camera sub-paths per iteration, owned
   * (NULL until vf_vcm_set_allocation); allocated: the current iteration traces them
   * (vf_pixel_samples), which the pilot render's (pilot_phase) do not; job_seed: the
   * settings' seed, which the pilot phase replaces by its own. */
  uint8_t *samples;
  int allocated, pilot_phase;
  uint64_t job_seed;

  /* Per iteration. */
  uint64_t iteration;
  double radius_exact;  /* the global merge radius r_i, of which merge.radius is the float */
  merge_params merge;   /* the global radius and its MIS constants */
  float grid_radius;    /* the largest merge radius of the iteration: the grid's */
  light_chunk *chunks;
  uint32_t num_chunks;
  uint32_t num_vertices;     /* in all chunks */
  vf_grid_segment *segments; /* the chunks' vertex lists, for the grid: num_chunks of them */
  unsigned chunk_shift;      /* the grid names vertex i of chunk c (c << chunk_shift) + i */
  /* The lists the grid was built over (vf_vertex_merging_build_grid), borrowed, and the
   * shift of its names for them, as chunks and chunk_shift name this iteration's. */
  const light_chunk *grid_chunks;
  unsigned grid_shift;
  /* --vcm-stages 1 (single_stage.h): the fused pass with merging; per camera tile, the
   * light vertices of iteration kept_iteration for the next iteration's grid, owned
   * (num_chunks of them), valid when kept_valid. */
  int single_stage;
  light_chunk *kept;
  int kept_valid;
  uint64_t kept_iteration;
  merge_point *merge_points; /* the grid's sorted points as merge points (borrowed), or NULL */
  photon *photons;
  float *photon_c_vc; /* a radius per pixel: each photon's c_vc, owned (photon_capacity); else NULL */
  uint32_t photon_capacity;
  uint32_t *path_begin, *path_end; /* per light sub-path, into its chunk's vertices */
  uint32_t num_bands, band_pixels; /* the light image's bands of SPLAT_BAND rows, band_pixels each */
  uint32_t *band_start;            /* per chunk, num_bands + 1: where its splats of each band begin */
  vf_hashgrid *grid;
  int vertex_merging_avx512; /* the CPU runs AVX-512 F and VL: vertex merging tests eight candidates at once */
  float *camera_rgb, *light_rgb;
  thread_stats *stats;     /* one per pool thread, owned */
  thread_scratch *scratch; /* one per pool thread, owned */
};

/* Whether pixel `pixel` (row * width + column) traces a light sub-path (--light-path-pixels:
 * the top-left pixel of its block; by default every pixel). */
static inline int vf_pixel_traces_light_path(const vf_vcm *v, uint32_t pixel) {
  if ((v->light_block_w | v->light_block_h) == 0) return 1;
  uint32_t width = (uint32_t)v->settings.width, x = pixel % width, y = pixel / width;
  return (x & ((1u << v->light_block_w) - 1u)) == 0 && (y & ((1u << v->light_block_h) - 1u)) == 0;
}

/* The pixel whose light sub-path the camera sub-path of `pixel` connects to: its block's
 * top-left pixel (by default itself). */
static inline uint32_t vf_light_path_pixel(const vf_vcm *v, uint32_t pixel) {
  if ((v->light_block_w | v->light_block_h) == 0) return pixel;
  uint32_t width = (uint32_t)v->settings.width, x = pixel % width, y = pixel / width;
  return (y >> v->light_block_h << v->light_block_h) * width + (x >> v->light_block_w << v->light_block_w);
}

/* The camera sub-paths pixel `pixel` traces in the current iteration: its allocation's
 * count past a pilot, else 1. */
static inline uint32_t vf_pixel_samples(const vf_vcm *v, uint32_t pixel) {
  return v->allocated ? vf_allocation_count(v->samples[pixel]) : 1u;
}

/* Whether a pixel of k camera sub-paths merges with radius r / sqrt(k) (pixel_radius.h,
 * vf_merge_params_at): past a pilot, in a render whose weights count merging, without
 * participating media. */
static inline int vf_vcm_allocation_shrinks_radius(const vf_vcm *v) {
  return v->allocated && v->vm_in_weights && !v->has_media;
}

/* Whether merge radii differ between the pixels of this iteration: a radius per pixel, or
 * an allocation that shrinks them. Then the photons keep the radius-free c_vc beside c_vm
 * (vf_photon_mis), for weights formed with each query's radius. */
static inline int vf_vcm_radii_vary(const vf_vcm *v) {
  return v->pixel_scale != NULL || vf_vcm_allocation_shrinks_radius(v);
}

_Static_assert(VF_MAX_LIGHT_PATH_PIXELS <= CAMERA_TILE * CAMERA_TILE, "a block of pixels sharing a light sub-path fits a tile");

#endif
