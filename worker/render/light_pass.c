/* Phase 1 of an iteration, the light sub-paths: light_pass.h. */
#include "light_pass.h"

#include "../../common/error.h"
#include "../../common/sampler.h"
#include "pixel_radius.h"
#include "segment.h"
#include "vcm_internal.h"
#include "wavefront.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* A projection of a light vertex onto the image, waiting to be added to the light image. */
struct splat {
  uint32_t pixel;
  vf_vec3 rgb;
  uint16_t path; /* the light sub-path's index within its chunk (< LIGHT_CHUNK) */
  uint16_t band; /* the pixel's band of rows (SPLAT_BAND) */
};
_Static_assert(LIGHT_CHUNK <= 65536 && VF_MAX_IMAGE_SIDE / SPLAT_BAND < 65536, "splat's fields hold their values");

/* Appends n vertices, and their BSDFs b where the chunk keeps them (light_chunk.bsdfs;
 * else b is NULL). */
static int append_vertices(light_chunk *c, const light_vertex *lv, const vf_bsdf *b, uint32_t n) {
  const int keep_bsdfs = b != NULL;
  if (n > c->vertex_capacity - c->num_vertices) {
    uint32_t cap = c->vertex_capacity ? 2 * c->vertex_capacity : 4 * LIGHT_CHUNK;
    while (cap - c->num_vertices < n) cap *= 2;
    /* Aligned to the cache line, as realloc's memory is not: each vertex is then one line,
     * which the grid's gather and the connections read at random. */
    light_vertex *p = aligned_alloc(64, (size_t)cap * sizeof *p);
    vf_bsdf *q = keep_bsdfs ? malloc((size_t)cap * sizeof *q) : NULL;
    if (p == NULL || (keep_bsdfs && q == NULL)) {
      free(p);
      free(q);
      return 0;
    }
    if (c->num_vertices > 0) {
      memcpy(p, c->vertices, (size_t)c->num_vertices * sizeof *p);
      if (keep_bsdfs) memcpy(q, c->bsdfs, (size_t)c->num_vertices * sizeof *q);
    }
    free(c->vertices);
    free(c->bsdfs);
    c->vertices = p;
    c->bsdfs = q;
    c->vertex_capacity = cap;
  }
  memcpy(&c->vertices[c->num_vertices], lv, (size_t)n * sizeof *lv);
  if (keep_bsdfs)
    for (uint32_t i = 0; i < n; i++) vf_bsdf_copy(&c->bsdfs[c->num_vertices + i], &b[i]); /* the part they use */
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
  shadow_packet *pk = &v->scratch[thread].packet;
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

/* A splat of the light pass that counts only if the segment from p (normal n) to the lens
 * point is free. */
static void splat_if_visible(vf_vcm *v, int thread, light_chunk *c, uint32_t path, uint32_t pixel, uint32_t band,
                             vf_vec3 rgb, vf_vec3 p, vf_vec3 n, vf_vec3 lens) {
  if (!push_splat(c, pixel, band, rgb, path)) return;
  shadow_packet *pk = &v->scratch[thread].packet;
  queue_segment(v, pk, (int)(c->num_splats - 1), p, n, lens, vf_vec3_splat(0.0f));
  if (pk->n == VF_ACCEL_PACKET) resolve_splats(v, thread, c);
}

/* A splat whose visibility is already folded into rgb (through media: segment.h). */
static void splat_unshadowed(light_chunk *c, uint32_t path, uint32_t pixel, uint32_t band, vf_vec3 rgb) {
  if (!vf_is_zero(rgb)) push_splat(c, pixel, band, rgb, path);
}

/* The lens point a light vertex connects to (t = 1): the pinhole, or a point sampled
 * uniformly on the thin lens from the light sub-path's stream (drawn only for a lens, so
 * pinhole and orthographic renders keep their streams; the orthographic camera ignores
 * it). Its density 1 / (pi r^2) is the camera sub-paths' too (p_connect = p_trace, tech.
 * rep. eq. 46), and it cancels against the importance's (camera.h). */
static vf_vec3 lens_sample(const vf_vcm *v, vf_sampler *sampler, uint32_t pair) {
  if (!(v->camera.lens_radius > 0.0f)) return v->camera.position;
  float u[2];
  vf_sampler_2d(sampler, pair, u);
  return vf_camera_lens_point(&v->camera, u[0], u[1]);
}

/* The raster pixel and splat band of a link's raster position. */
static void link_pixel(const vf_vcm *v, const vf_camera_link *l, uint32_t *pixel, uint32_t *band) {
  *pixel = (uint32_t)l->y * (uint32_t)v->camera.width + (uint32_t)l->x;
  *band = (uint32_t)l->y / SPLAT_BAND;
}

/* t = 1: connects light vertex (hit, b) to the camera (a lens point, or its foot on an
 * orthographic view plane) and projects it onto the image. */
static void connect_to_camera(vf_vcm *v, int thread, light_chunk *c, uint32_t path, const vf_hit *hit,
                              const vf_bsdf *b, const path_state *s, vf_sampler *sampler, uint32_t vertex_dims) {
  vf_vec3 lens = lens_sample(v, sampler, vf_dim_at(vertex_dims, VF_DIM_CAMERA_LENS));
  vf_camera_link link;
  if (!vf_camera_link_point(&v->camera, lens, hit->position, &link)) return;
  float cos_to_camera, dir_pdf, rev_pdf;
  vf_vec3 f = vf_bsdf_evaluate(b, link.to_camera, &cos_to_camera, &dir_pdf, &rev_pdf);
  if (vf_is_zero(f)) return;
  float pdf_a = vf_camera_link_pdf_a(&link, cos_to_camera);
  if (!(pdf_a > 0.0f)) return;
  /* Eq. (46)-(47); pdf_a is the camera's area density of the vertex from the lens point. */
  uint32_t pixel, band;
  link_pixel(v, &link, &pixel, &band);
  /* The weights of the path that ends in `pixel` take that pixel's radius (tech. rep. sec.
   * 6.1: every technique of one full path with the same radius). */
  merge_params merge;
  vf_merge_params_at(v, pixel, &merge);
  float w;
  if (__builtin_expect(v->has_media, 0)) {
    /* Through media: the transmittance; the camera's density of the vertex takes the
     * segment's distance density at the vertex (segment.h). Through index-matched
     * boundaries the walk traces the segment itself, else only its occlusion remains. */
    float fwd_camera, rev_vertex;
    int medium = vf_medium_leaving(v, hit, link.to_camera, s->medium);
    float density = vf_segment_vertex_density(v, hit);
    vf_vec3 zero = vf_vec3_splat(0.0f);
    int traced;
    vf_vec3 tr = vf_segment_connection(v, thread, medium, hit->position, hit->normal, density, link.end, zero, 1.0f, 0,
                                       sampler, &fwd_camera, &rev_vertex, &traced);
    if (vf_is_zero(tr)) return;
    w = v->t.lt ? 1.0f
                : vf_mis_weight_camera_connection_at(&s->mis, &merge.mis, pdf_a * rev_vertex, rev_pdf,
                                                     merge.mis.vm_weight * (vf_hit_in_medium(hit) ? v->medium_merge : 1.0f));
    f = vf_mul(f, tr);
    if (traced) {
      splat_unshadowed(c, path, pixel, band, vf_scale(vf_mul(s->throughput, f), w * pdf_a / v->merge.mis.light_paths));
      return;
    }
  } else {
    w = v->t.lt ? 1.0f : vf_mis_weight_camera_connection(&s->mis, &merge.mis, pdf_a, rev_pdf);
  }
  /* The importance times the geometry term over the lens density, W_e G / p(z0) = pdf_a
   * (camera.h), over the light sub-path density n_light. */
  vf_vec3 contrib = vf_scale(vf_mul(s->throughput, f), w * pdf_a / v->merge.mis.light_paths);
  if (vf_is_zero(contrib)) return;
  splat_if_visible(v, thread, c, path, pixel, band, contrib, hit->position, hit->normal, link.end);
}

/* Light tracing alone also projects the light's own point y0 (the s = 1, t = 1 technique,
 * which the full estimator leaves to emission hits). */
static void connect_emitter_to_camera(vf_vcm *v, int thread, light_chunk *c, uint32_t path, vf_vec3 radiance,
                                      const vf_light_coat *coat, vf_vec3 p, vf_vec3 n, float pick_and_area_pdf,
                                      vf_sampler *sampler, int medium) {
  vf_vec3 lens = lens_sample(v, sampler, VF_DIM_EMITTER_LENS);
  vf_camera_link link;
  if (!vf_camera_link_point(&v->camera, lens, p, &link)) return;
  float cos_out = vf_dot(n, link.to_camera);
  if (!(cos_out > 0.0f)) return;
  if (coat->weight > 0.0f) radiance = vf_scale(radiance, vf_light_coat_transmit(coat, link.to_camera));
  float pdf_a = vf_camera_link_pdf_a(&link, cos_out);
  if (!(pdf_a > 0.0f)) return;
  vf_vec3 contrib = vf_scale(radiance, pdf_a / (v->merge.mis.light_paths * pick_and_area_pdf));
  uint32_t pixel, band;
  link_pixel(v, &link, &pixel, &band);
  if (__builtin_expect(v->has_media, 0)) {
    float fwd, rev; /* lt alone: unweighted */
    vf_vec3 zero = vf_vec3_splat(0.0f);
    int traced;
    contrib = vf_mul(contrib, vf_segment_connection(v, thread, medium, p, n, 1.0f, link.end, zero, 1.0f, 0, sampler, &fwd,
                                                    &rev, &traced));
    if (traced) {
      splat_unshadowed(c, path, pixel, band, contrib);
      return;
    }
    if (vf_is_zero(contrib)) return;
  }
  splat_if_visible(v, thread, c, path, pixel, band, contrib, p, n, link.end);
}

/* The four numbers of vf_light_emit. Area lights read rnd[1], rnd[2] as the point and
 * rnd[0], rnd[3] as the direction (worker/render/light.c), the other kinds rnd[0], rnd[1] as their
 * first decision and rnd[2], rnd[3] as their second: each decision gets one pair
 * (sample_dims.h). The independent sampler draws them in index order, as it always did. */
static void emission_numbers(vf_sampler *sampler, const vf_light *l, float rnd[4]) {
  if (!sampler->sobol) {
    for (int k = 0; k < 4; k++) rnd[k] = vf_sampler_1d(sampler, VF_SAMPLER_FALLBACK);
    return;
  }
  float point[2], direction[2];
  vf_sampler_2d(sampler, VF_DIM_EMIT_POINT, point);
  vf_sampler_2d(sampler, VF_DIM_EMIT_DIRECTION, direction);
  if (l->kind == VF_LIGHT_AREA_MESH || l->kind == VF_LIGHT_AREA_SPHERE) {
    rnd[0] = direction[0], rnd[1] = point[0], rnd[2] = point[1], rnd[3] = direction[1];
  } else {
    rnd[0] = direction[0], rnd[1] = direction[1], rnd[2] = point[0], rnd[3] = point[1];
  }
}

/* A light sub-path in flight. The light pass traces VF_ACCEL_PACKET of them at once, as a
 * wavefront: each step sends the rays of all lanes to Embree as one packet (Embree traces
 * even unrelated rays faster in packets than one by one: docs/BENCHMARKS.md, "Raw Embree
 * rate"), then continues each lane's path; a lane whose path ends starts the chunk's next
 * path. A path's vertices are written to its slot of the retire ring, where they wait
 * until every older path of the chunk has been stored. */
typedef struct {
  path_state s;
  vf_sampler sampler;
  uint32_t local;         /* index within the chunk (chunk_paths) */
  uint32_t num_vertices;
  light_vertex *vertices; /* the path's slot of the retire ring: room for the longest path */
  vf_bsdf *bsdfs;         /* the slot's BSDFs, where the chunk keeps them (vf_vcm.fused) */
} light_lane;

/* The light sub-paths of a chunk: count of them, path `local` being the pixel at column
 * local % width and row local / width of a block whose top-left pixel is `first`. A chunk
 * of the light pass is a run of LIGHT_CHUNK pixels (width = count), a chunk of bpt's fused
 * pass a camera tile. Each path's range of the chunk's vertex list goes to begin[local]
 * and end[local]. */
typedef struct {
  uint32_t first, width, count;
  uint32_t *begin, *end;
} chunk_paths;

static uint32_t path_of(const vf_vcm *v, const chunk_paths *cp, uint32_t local) {
  return cp->first + local / cp->width * (uint32_t)v->camera.width + local % cp->width;
}

/* How the sobol sampler stratifies light sub-paths (docs/BENCHMARKS.md, "Stratifying the
 * light sub-paths", measured all three): 0 across iterations (each light sub-path index has
 * its scramble, the iteration is the sample index, as camera sub-paths do), 1 across the
 * paths of an iteration (the path index is the sample index, each iteration its own
 * scramble), 2 not at all (independent numbers). A build-time choice for measuring. */
#ifndef VF_LIGHT_STRATIFICATION
#define VF_LIGHT_STRATIFICATION 0
#endif

static void light_sampler_start(const vf_vcm *v, vf_sampler *sampler, uint32_t path) {
  vf_sampler_kind kind = v->settings.sampler;
  if (VF_LIGHT_STRATIFICATION == 1 && kind == VF_SAMPLER_SOBOL) {
    vf_sampler_start_across(sampler, v->settings.seed, v->iteration, path, VF_STREAM_LIGHT, v->iteration, path);
    return;
  }
  if (VF_LIGHT_STRATIFICATION == 2) kind = VF_SAMPLER_INDEPENDENT;
  path_sampler_start(sampler, kind, v->settings.seed, v->iteration, path, VF_STREAM_LIGHT);
}

/* Emits light sub-path `path`, the chunk's path `local`, into the lane; returns 1 when it
 * has a ray to trace. */
static int light_start(vf_vcm *v, int thread, light_chunk *c, light_lane *lane, uint32_t path, uint32_t local) {
  lane->local = local;
  lane->num_vertices = 0;
  vf_sampler *sampler = &lane->sampler;
  light_sampler_start(v, sampler, path);
  path_state *s = &lane->s;
  const vf_light *l = vf_lights_pick(v->lights, vf_sampler_1d(sampler, VF_DIM_LIGHT_PICK));
  float rnd[4];
  emission_numbers(sampler, l, rnd);
  vf_vec3 normal;
  float emission_pdf, direct_pdf, cos_light;
  if (__builtin_expect(v->infinite_dark, 0) && !l->is_finite) return 0; /* extinguished on its way */
  vf_light_coat coat;
  vf_vec3 energy = vf_light_emit_coated(v->lights, l, rnd, &s->origin, &s->direction, &normal, &emission_pdf,
                                        &direct_pdf, &cos_light, &coat);
  if (vf_is_zero(energy) || !(emission_pdf > 0.0f)) return 0;
  /* What the point emits before its coat (light.h): energy carries the coat's factor
   * towards the sampled direction, the camera and a gathering join see their own. */
  vf_vec3 emitted = l->textured ? vf_scale(energy, 1.0f / cos_light) : l->radiance;
  if (__builtin_expect(coat.weight > 0.0f && l->textured, 0)) /* products only: no cancellation */
    emitted = vf_scale(energy, 1.0f / (cos_light * vf_light_coat_transmit(&coat, s->direction)));
  if (v->upg) {
    /* The point for joining the sub-path's first vertex to a camera vertex: with what it
     * emits per unit of vf_light_emission_toward's factor (its radiance, texture
     * included, for an area light; its intensity for a point or spot light). */
    light_origin *o = &v->origins[path];
    o->position = s->origin;
    o->normal = normal;
    o->light = l->is_finite ? (int32_t)(l - v->lights->lights) : -1;
    int area = l->kind == VF_LIGHT_AREA_MESH || l->kind == VF_LIGHT_AREA_SPHERE;
    o->radiance = area ? (coat.weight > 0.0f ? emitted : vf_scale(energy, 1.0f / cos_light)) : l->radiance;
    o->coat = coat;
  }
  int medium = v->has_media ? v->light_medium[l - v->lights->lights] : -1;
  if (v->t.lt && l->is_finite && !l->is_delta)
    connect_emitter_to_camera(v, thread, c, local, emitted, &coat, s->origin, normal, l->pick_probability * direct_pdf,
                              sampler, medium);
  emission_pdf *= l->pick_probability;
  direct_pdf *= l->pick_probability;
  s->throughput = vf_scale(energy, 1.0f / emission_pdf);
  s->path_length = 0;
  s->medium = medium;
  s->from_medium = 0;
  s->is_finite_light = l->is_finite;
  s->specular_path = 1;
  vf_mis_light_start(&s->mis, &v->merge.mis, direct_pdf, emission_pdf, cos_light, l->is_delta, l->is_finite);
  if (l->kind == VF_LIGHT_AREA_MESH || l->kind == VF_LIGHT_AREA_SPHERE)
    s->origin = vf_offset_ray_origin(s->origin, normal, v->offset_scale);
  return 1;
}

/* Continues the lane's light sub-path at the hit of its last ray: stores the vertex,
 * projects it onto the camera and scatters. Returns 0 when the path ends there. */
static int light_bounce(vf_vcm *v, int thread, light_chunk *c, light_lane *lane, const vf_hit *hit) {
  path_state *s = &lane->s;
  vf_bsdf b;
  vf_segment seg;
  vf_hit through;
  if (__builtin_expect(v->has_media, 0)) {
    /* Through media and index-matched boundaries to the next vertex (segment.h). */
    if (hit != NULL) through = *hit;
    float u = vf_sampler_1d(&lane->sampler, vf_dim_medium(s->path_length + 1));
    int r = vf_segment_trace(v, thread, s->medium, s->from_medium, s->origin, s->direction, hit != NULL, &through, u,
                             &lane->sampler, &seg);
    if (r != VF_SEGMENT_VERTEX) return 0;
    s->throughput = vf_mul(s->throughput, seg.weight);
    s->medium = seg.medium; /* index-matched boundaries on the way may have changed it */
    hit = &through;
    if (vf_hit_in_medium(hit)) {
      bsdf_in_medium(v, &b, hit->primitive, hit->position, vf_neg(s->direction));
    } else if (!bsdf_at(v, &b, hit, vf_neg(s->direction))) {
      return 0;
    }
    s->path_length++;
    float cos_fix = vf_hit_in_medium(hit) ? 1.0f : fabsf(vf_dot(hit->normal, s->direction));
    vf_mis_hit_media(&s->mis, &v->merge.mis, hit->t, cos_fix, s->path_length > 1 || s->is_finite_light, seg.fwd,
                     seg.rev);
  } else {
    if (hit == NULL) return 0;
    if (!bsdf_at(v, &b, hit, vf_neg(s->direction))) return 0;
    s->path_length++;
    /* The geometric cosine (the BSDF's local_fix.z is the shading one where they differ;
     * both are the same bits where they do not). */
    vf_mis_hit(&s->mis, &v->merge.mis, hit->t, fabsf(vf_dot(hit->normal, s->direction)),
               s->path_length > 1 || s->is_finite_light);
  }
  uint32_t vertex_dims = vf_dim_vertex(VF_DIM_LIGHT_VERTEX, s->path_length);
  if (!b.is_delta) {
    if (v->t.store_vertices) {
      if (v->fused) vf_bsdf_copy(&lane->bsdfs[lane->num_vertices], &b);
      light_vertex *lv = &lane->vertices[lane->num_vertices++];
      lv->position = hit->position;
      lv->throughput = s->throughput;
      lv->fix = vf_neg(s->direction);
      uint32_t shape = hit->shape;
      if (__builtin_expect(vf_hit_in_medium(hit), 0)) {
        shape = VERTEX_IN_MEDIUM;
        lv->at.point.primitive = hit->primitive; /* the medium */
        lv->at.point.u = lv->at.point.v = 0.0f;
      } else if (__builtin_expect(v->interpolated[hit->shape], 0)) {
        lv->at.point.primitive = hit->primitive;
        lv->at.point.u = hit->u;
        lv->at.point.v = hit->v;
      } else {
        lv->at.normal = hit->normal;
      }
      lv->mis = s->mis;
      lv->path_length_shape = (uint32_t)s->path_length | shape << VERTEX_LENGTH_BITS;
    }
    if (v->t.light_to_camera) connect_to_camera(v, thread, c, lane->local, hit, &b, s, &lane->sampler, vertex_dims);
  }
  if (s->path_length + 2 > v->settings.max_path_length) return 0;
  return vf_wavefront_scatter(v, &b, hit, s, &lane->sampler, vertex_dims, 0);
}

/* The ring slot of the chunk's path `local`. */
static size_t ring_slot(const vf_vcm *v, uint32_t local) { return (size_t)(local % RETIRE_RING) * v->lane_capacity; }

/* The lane's path has ended, its vertices in its ring slot. Every ended path at the head
 * of the ring, from *oldest (the chunk's oldest path not yet stored) up to `next` (the
 * next to start), then goes to the chunk's list in path order, its range recorded: a
 * chunk's list is in path order, as connections want it (a camera tile reads the light
 * paths of its pixels, which are neighbours in the list only in path order), without a
 * pass that would sort it afterwards. Numbers here are the chunk's (chunk_paths). */
static void light_retire(vf_vcm *v, int thread, light_chunk *c, const chunk_paths *cp, const light_lane *lane,
                         uint32_t *oldest, uint32_t next) {
  thread_scratch *ts = &v->scratch[thread];
  ts->ring_count[lane->local % RETIRE_RING] = lane->num_vertices;
  while (*oldest < next && ts->ring_count[*oldest % RETIRE_RING] != RING_IN_FLIGHT) {
    uint32_t p = (*oldest)++, n = ts->ring_count[p % RETIRE_RING];
    ts->ring_count[p % RETIRE_RING] = RING_IN_FLIGHT;
    cp->begin[p] = c->num_vertices;
    size_t slot = ring_slot(v, p);
    if (n > 0 && !append_vertices(c, ts->ring_vertices + slot, v->fused ? ts->ring_bsdfs + slot : NULL, n))
      c->out_of_memory = 1;
    cp->end[p] = c->num_vertices;
  }
}

/* Gives the lane the chunk's next path that has a ray to trace; returns 0 when none is
 * left, or when the ring is full (the oldest path still in flight): the caller tries again
 * after the next step. */
static int light_refill(vf_vcm *v, int thread, light_chunk *c, const chunk_paths *cp, light_lane *lane,
                        uint32_t *next, uint32_t *oldest) {
  thread_scratch *ts = &v->scratch[thread];
  while (*next < cp->count && *next - *oldest < RETIRE_RING) {
    uint32_t local = (*next)++;
    size_t slot = ring_slot(v, local);
    lane->vertices = ts->ring_vertices + slot;
    lane->bsdfs = v->fused ? ts->ring_bsdfs + slot : NULL;
    uint32_t path = path_of(v, cp, local);
    if (v->t.light_paths && vf_pixel_traces_light_path(v, path) && light_start(v, thread, c, lane, path, local))
      return 1;
    /* ended at its light, no light paths at all, or a pixel whose block's light sub-path
     * another pixel traces (--light-path-pixels): no vertices */
    lane->local = local;
    lane->num_vertices = 0;
    light_retire(v, thread, c, cp, lane, oldest, *next);
  }
  return 0;
}

/* The chunk's splats that count, by band of the image (SPLAT_BAND rows) and in path order
 * within each band: two stable counting sorts, by path, then by band, so that each path's
 * splats keep the order they were made in. The chunk's band b is then
 * splats[band_start[b] .. band_start[b + 1]), band_start being the chunk's row of
 * vf_vcm.band_start. */
static void sort_splats(const vf_vcm *v, int thread, light_chunk *c, uint32_t chunk, uint32_t paths) {
  thread_scratch *ts = &v->scratch[thread];
  if (ts->sort_capacity < c->num_splats) {
    splat *p = realloc(ts->sort_scratch, (size_t)c->splat_capacity * sizeof *p);
    if (p == NULL) {
      c->out_of_memory = 1;
      return;
    }
    ts->sort_scratch = p;
    ts->sort_capacity = c->splat_capacity;
  }
  splat *sorted = ts->sort_scratch;
  uint32_t start[LIGHT_CHUNK + 1] = {0};
  for (uint32_t i = 0; i < c->num_splats; i++)
    if (c->splats[i].pixel != DROPPED_SPLAT) start[c->splats[i].path + 1]++;
  for (uint32_t p = 0; p < paths; p++) start[p + 1] += start[p];
  for (uint32_t i = 0; i < c->num_splats; i++)
    if (c->splats[i].pixel != DROPPED_SPLAT) sorted[start[c->splats[i].path]++] = c->splats[i];
  uint32_t n = start[paths - 1];
  uint32_t *band_start = &v->band_start[(size_t)chunk * (v->num_bands + 1)];
  memset(band_start, 0, (v->num_bands + 1) * sizeof *band_start);
  for (uint32_t i = 0; i < n; i++) band_start[sorted[i].band + 1]++;
  /* band_start[b + 1] becomes where band b begins, and after the scatter where it ends. */
  for (uint32_t b = 0, sum = 0; b < v->num_bands; b++) {
    uint32_t count = band_start[b + 1];
    band_start[b + 1] = sum;
    sum += count;
  }
  for (uint32_t i = 0; i < n; i++) {
    const splat *sp = &sorted[i];
    c->splats[band_start[sp->band + 1]++] = *sp;
  }
  c->num_splats = n;
}

/* Adds the splats of band `band` to the light image, chunk by chunk in chunk order: each
 * pixel gets its terms in the order of one pass over the paths, whatever the thread
 * count, and the bands run in parallel. */
static void splat_band_task(void *ctx, size_t band, int thread) {
  (void)thread;
  vf_vcm *v = ctx;
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

/* Traces the light sub-paths of chunk `chunk` (c, its paths cp) into its lists. */
static void trace_chunk(vf_vcm *v, int thread, uint32_t chunk, light_chunk *c, const chunk_paths *cp) {
  c->num_vertices = c->num_splats = 0;
  c->out_of_memory = 0;
  if (!v->t.light_paths) {
    /* No light sub-paths (pt): what retiring every path without a vertex and sorting no
     * splats would leave, without walking the chunk's paths through the ring. */
    for (uint32_t p = 0; p < cp->count; p++) cp->begin[p] = cp->end[p] = 0;
    memset(&v->band_start[(size_t)chunk * (v->num_bands + 1)], 0, (v->num_bands + 1) * sizeof *v->band_start);
    return;
  }
  light_lane lanes[VF_ACCEL_PACKET];
  path_state *states[VF_ACCEL_PACKET];
  uint32_t next = 0, oldest = 0, active = 0;
  for (int i = 0; i < VF_ACCEL_PACKET; i++) {
    states[i] = &lanes[i].s;
    if (light_refill(v, thread, c, cp, &lanes[i], &next, &oldest)) active |= 1u << i;
  }
  while (active) {
    vf_hit hits[VF_ACCEL_PACKET];
    int lane_of[VF_ACCEL_PACKET], m;
    uint32_t found = vf_wavefront_trace(v, thread, states, active, lane_of, &m, hits);
    prefetch_shading(v, hits, found, m);
    for (int k = 0; k < m; k++) {
      light_lane *lane = &lanes[lane_of[k]];
      /* Through media a ray that leaves the scene may still scatter on its way. */
      int hit_k = (int)(found >> k & 1u);
      if ((hit_k || v->has_media) && light_bounce(v, thread, c, lane, hit_k ? &hits[k] : NULL)) continue;
      light_retire(v, thread, c, cp, lane, &oldest, next);
      if (!light_refill(v, thread, c, cp, lane, &next, &oldest)) active &= ~(1u << lane_of[k]);
    }
    /* Lanes left idle by a full ring start again once it has drained (a rare event: the
     * ring holds many times the paths of the lanes). */
    if (next < cp->count && active != (1u << VF_ACCEL_PACKET) - 1u)
      for (int i = 0; i < VF_ACCEL_PACKET; i++)
        if (!(active >> i & 1u) && light_refill(v, thread, c, cp, &lanes[i], &next, &oldest)) active |= 1u << i;
  }
  resolve_splats(v, thread, c);
  sort_splats(v, thread, c, chunk, cp->count);
}

static void light_task(void *ctx, size_t task, int thread) {
  vf_vcm *v = ctx;
  uint32_t begin = (uint32_t)task * LIGHT_CHUNK;
  uint32_t count = begin + LIGHT_CHUNK < v->num_pixels ? LIGHT_CHUNK : v->num_pixels - begin;
  chunk_paths cp = {begin, count, count, v->path_begin + begin, v->path_end + begin};
  trace_chunk(v, thread, (uint32_t)task, &v->chunks[task], &cp);
}

void vf_light_pass_tile(vf_vcm *v, int thread, const camera_tile *tile) {
  thread_scratch *ts = &v->scratch[thread];
  light_chunk *c = &v->chunks[tile->index];
  /* The thread's lists, lent to the tile: its splats stay in the chunk until the light
   * image is made, its vertices and BSDFs serve only the tile's camera sub-paths. */
  c->vertices = ts->tile_vertices;
  c->bsdfs = ts->tile_bsdfs;
  c->vertex_capacity = ts->tile_capacity;
  chunk_paths cp = {tile->y0 * (uint32_t)v->camera.width + tile->x0, tile->width, tile->width * tile->height,
                    ts->tile_begin, ts->tile_end};
  trace_chunk(v, thread, tile->index, c, &cp);
  ts->tile_vertices = c->vertices;
  ts->tile_bsdfs = c->bsdfs;
  ts->tile_capacity = c->vertex_capacity;
  c->vertices = NULL; /* num_vertices stays, for the iteration's count */
  c->bsdfs = NULL;
  c->vertex_capacity = 0;
}

int vf_light_pass_finish(vf_vcm *v) {
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
  vf_pool_run(v->pool, v->num_bands, splat_band_task, v); /* the light image, band by band */
  return VF_OK;
}

int vf_light_pass_run(vf_vcm *v) {
  vf_pool_run(v->pool, v->num_chunks, light_task, v);
  return vf_light_pass_finish(v);
}
