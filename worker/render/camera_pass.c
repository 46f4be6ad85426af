/* Phase 3 of an iteration, the camera sub-paths: camera_pass.h. */
#include "camera_pass.h"

#include "../../common/allocation.h"
#include "../../common/sampler.h"
#include "vcm_internal.h"
#include "gathering_pass.h"
#include "pixel_radius.h"
#include "segment.h"
#include "vertex_merging.h"
#include "volume_merging.h"
#include "wavefront.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Camera sub-paths are traced in square tiles (CAMERA_TILE): neighbouring pixels query
 * neighbouring grid cells at their first hit, so a tile reuses what its previous rows
 * brought into cache. */

/* pt's camera sub-paths play no Russian roulette before vertex PT_ROULETTE_VERTEX. The
 * roulette of every other sub-path (continuation = the BSDF's largest albedo, SmallVCM's
 * rule) is part of the densities both directions of the MIS recursion use, so it must be
 * a property of the vertex alone. pt weighs a path by forward densities only (its light
 * sample against its BSDF sample, each taken where the vertex is), so there the
 * continuation may depend on the depth: the first bounces, whose future carries most of
 * the indirect light, always go on, and the variance that a roulette there adds to all of
 * it is saved for the cost of longer paths (docs/BENCHMARKS.md, "Error slopes"). The
 * density of the BSDF sample, which the weights read, carries the continuation it was
 * drawn with. */
#define PT_ROULETTE_VERTEX 3
static inline void pt_roulette(const vf_vcm *v, vf_bsdf *b, const path_state *s) {
  if (v->merge.mis.pt && s->path_length < PT_ROULETTE_VERTEX) b->continuation = 1.0f;
}

/* s = 0: radiance of a light found by the camera sub-path, weighted. */
static vf_vec3 emission_weighted(const vf_vcm *v, const vf_light *l, const path_state *s, vf_vec3 radiance,
                                 float direct_pdf, float emission_pdf) {
  if (vf_is_zero(radiance)) return radiance;
  if (s->path_length == 1) return radiance; /* seen directly: no other technique can */
  if (v->t.emission_specular_only) return s->specular_path ? radiance : vf_vec3_splat(0.0f);
  float w = vf_mis_weight_emission(&s->mis, &s->merge->mis, direct_pdf * l->pick_probability, emission_pdf * l->pick_probability);
  return vf_scale(radiance, w);
}

/* Adds the camera sub-paths' waiting contributions to their pixels, in the order they
 * arose, once the queued shadow rays are traced: those whose ray was blocked are left out. */
static void resolve_deferred(vf_vcm *v, int thread) {
  thread_scratch *ts = &v->scratch[thread];
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
  thread_scratch *ts = &v->scratch[thread];
  if (ts->num_pending == DEFERRED_MAX) resolve_deferred(v, thread);
  ts->pending[ts->num_pending] = (deferred){value, tile_pixel, 0};
  return ts->num_pending++;
}

/* A contribution without a shadow ray, in its turn. */
static void defer_unshadowed(vf_vcm *v, int thread, vf_vec3 value, uint32_t tile_pixel) {
  if (!vf_is_zero(value)) defer(v, thread, value, tile_pixel);
}

/* After queue_segment or queue_direction for an entry: traces the packet when full. */
static void packet_queued(vf_vcm *v, int thread) {
  if (v->scratch[thread].packet.n == VF_ACCEL_PACKET) resolve_deferred(v, thread);
}

/* s = 1: next-event estimation, added to tile_pixel if the light is visible. */
static void light_sample(vf_vcm *v, int thread, const vf_hit *hit, const vf_bsdf *b, const path_state *s,
                         vf_sampler *sampler, uint32_t vertex_dims, uint32_t tile_pixel) {
  vf_vec3 zero = vf_vec3_splat(0.0f);
  const vf_light *l = vf_lights_pick(v->lights, vf_sampler_1d(sampler, vf_dim_at(vertex_dims, VF_DIM_NEE_LIGHT)));
  /* A delta light (point, spot, directional) has one point to offer and leaves the numbers
   * unused: they are drawn only where drawing them moves the later ones. */
  float rnd[2] = {0.0f, 0.0f};
  uint32_t point_pair = vf_dim_at(vertex_dims, VF_DIM_NEE_POINT);
  if (!l->is_delta || vf_sampler_in_order(sampler, point_pair)) vf_sampler_2d(sampler, point_pair, rnd);
  vf_vec3 dir, lp, ln;
  float dist, direct_pdf, emission_pdf, cos_at_light;
  vf_vec3 radiance = vf_light_illuminate(v->lights, l, hit->position, rnd, &dir, &dist, &lp, &ln, &direct_pdf,
                                         &emission_pdf, &cos_at_light);
  if (vf_is_zero(radiance) || !(direct_pdf > 0.0f)) return;
  if (__builtin_expect(v->infinite_dark, 0) && !l->is_finite) return; /* extinguished on its way */
  float cos_to_light, bsdf_pdf, bsdf_rev_pdf;
  vf_vec3 f = vf_bsdf_evaluate(b, dir, &cos_to_light, &bsdf_pdf, &bsdf_rev_pdf);
  if (vf_is_zero(f)) return;
  if (l->is_delta) bsdf_pdf = 0.0f; /* a delta light cannot be hit by a sampled direction */
  float pick = l->pick_probability;
  float w;
  if (__builtin_expect(v->has_media, 0)) {
    /* Through media: the transmittance, and the segment's distance densities in the
     * weight (segment.h). Through index-matched boundaries the walk traces the segment
     * itself; else only the occlusion remains, queued as any shadow ray's. */
    float fwd_light, rev_vertex;
    int medium = vf_medium_leaving(v, hit, dir, s->medium);
    vf_vec3 q = isinf(dist) ? dir : lp, nq = l->is_delta ? zero : ln;
    float density = vf_segment_vertex_density(v, hit);
    int traced;
    vf_vec3 tr = vf_segment_connection(v, thread, medium, hit->position, hit->normal, density, q, nq, 1.0f, isinf(dist),
                                       sampler, &fwd_light, &rev_vertex, &traced);
    if (vf_is_zero(tr)) return;
    w = vf_mis_weight_light_sample_at(&s->mis, &s->merge->mis, bsdf_pdf * fwd_light, bsdf_rev_pdf, direct_pdf * pick,
                                      emission_pdf * pick, cos_to_light * rev_vertex, cos_at_light,
                                      s->merge->mis.vm_weight * (vf_hit_in_medium(hit) ? v->medium_merge : 1.0f));
    f = vf_mul(f, tr);
    if (traced) {
      defer_unshadowed(v, thread, vf_mul(s->throughput, vf_scale(vf_mul(radiance, f), w * cos_to_light / (pick * direct_pdf))),
                       tile_pixel);
      return;
    }
  } else {
    w = vf_mis_weight_light_sample(&s->mis, &s->merge->mis, bsdf_pdf, bsdf_rev_pdf, direct_pdf * pick,
                                   emission_pdf * pick, cos_to_light, cos_at_light);
  }
  vf_vec3 contrib = vf_scale(vf_mul(radiance, f), w * cos_to_light / (pick * direct_pdf));
  if (vf_is_zero(contrib)) return;
  int entry = defer(v, thread, vf_mul(s->throughput, contrib), tile_pixel);
  shadow_packet *pk = &v->scratch[thread].packet;
  if (isinf(dist))
    queue_direction(v, pk, entry, hit->position, hit->normal, dir);
  else
    queue_segment(v, pk, entry, hit->position, hit->normal, lp, l->is_delta ? zero : ln); /* punctual: no surface */
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
 * light sub-path, added to tile_pixel if the two see each other. The light vertex's BSDF is
 * `kept` where the fused pass kept it, else set up through the cache. */
static void connect_vertices(vf_vcm *v, int thread, const vf_hit *hit, const vf_bsdf *b, const path_state *s,
                             const light_vertex *lv, const vf_bsdf *kept, uint32_t i, light_bsdf_cache *cache,
                             uint32_t tile_pixel, vf_sampler *sampler) {
  vf_vec3 d = vf_sub(lv->position, hit->position);
  float dist2 = vf_length_sq(d);
  if (!(dist2 > 0.0f)) return;
  float dist = sqrtf(dist2);
  d = vf_scale(d, 1.0f / dist);
  float cos_camera, camera_pdf, camera_rev_pdf;
  vf_vec3 fc = vf_bsdf_evaluate(b, d, &cos_camera, &camera_pdf, &camera_rev_pdf);
  if (vf_is_zero(fc)) return;
  vf_bsdf scratch;
  const vf_bsdf *lb = kept ? kept : light_bsdf(v, cache, i, lv, &scratch);
  float cos_light, light_pdf, light_rev_pdf;
  vf_vec3 fl = vf_bsdf_evaluate(lb, vf_neg(d), &cos_light, &light_pdf, &light_rev_pdf);
  if (vf_is_zero(fl)) return;
  /* Each side's density of sampling the other vertex, in area measure there. */
  float camera_pdf_a = camera_pdf * cos_light / dist2;
  float light_pdf_a = light_pdf * cos_camera / dist2;
  float w;
  if (__builtin_expect(v->has_media, 0)) {
    /* Through media: the transmittance, and the distance densities of both ends; the
     * walk through index-matched boundaries traces the segment itself, else only its
     * occlusion remains, queued as any shadow ray's (light_sample). */
    int light_in_medium = vertex_in_medium(lv);
    float fwd_light, rev_camera;
    int medium = vf_medium_leaving(v, hit, d, s->medium);
    float camera_density = vf_segment_vertex_density(v, hit);
    float light_density = light_in_medium ? vf_medium_density_at(&v->media[lv->at.point.primitive], lv->position) : 1.0f;
    vf_vec3 nl = normal_of_vertex(v, lv, lb);
    int traced;
    vf_vec3 tr = vf_segment_connection(v, thread, medium, hit->position, hit->normal, camera_density, lv->position, nl,
                                       light_density, 0, sampler, &fwd_light, &rev_camera, &traced);
    if (vf_is_zero(tr)) return;
    float vm = s->merge->mis.vm_weight;
    w = vf_mis_weight_connection_at(&lv->mis, &s->mis, &s->merge->mis, camera_pdf_a * fwd_light,
                                    light_pdf_a * rev_camera, light_rev_pdf, camera_rev_pdf,
                                    light_in_medium ? vm * v->medium_merge : vm,
                                    vf_hit_in_medium(hit) ? vm * v->medium_merge : vm);
    fc = vf_mul(fc, tr);
    if (traced) {
      vf_vec3 contrib = vf_scale(vf_mul(vf_mul(fc, fl), lv->throughput), w * cos_camera * cos_light / dist2);
      defer_unshadowed(v, thread, vf_mul(s->throughput, contrib), tile_pixel);
      return;
    }
  } else {
    w = vf_mis_weight_connection(&lv->mis, &s->mis, &s->merge->mis, camera_pdf_a, light_pdf_a, light_rev_pdf,
                                 camera_rev_pdf);
  }
  vf_vec3 contrib = vf_scale(vf_mul(vf_mul(fc, fl), lv->throughput), w * cos_camera * cos_light / dist2);
  if (vf_is_zero(contrib)) return;
  int entry = defer(v, thread, vf_mul(s->throughput, contrib), tile_pixel);
  queue_segment(v, &v->scratch[thread].packet, entry, hit->position, hit->normal, lv->position, normal_of_vertex(v, lv, lb));
  packet_queued(v, thread);
}

/* A slot in the queue of vertex merging queries run at the end of the tile, or NULL if
 * the queue cannot grow (the caller then merges at once). The caller writes the query
 * into the slot itself: built elsewhere and copied, its 150 bytes were written twice. */
static vertex_merging_query *queue_vertex_merging(vf_vcm *v, int thread) {
  thread_scratch *ts = &v->scratch[thread];
  if (ts->num_queries == ts->query_capacity) {
    uint32_t cap = ts->query_capacity ? 2 * ts->query_capacity : 4096;
    vertex_merging_query *p = realloc(ts->queries, (size_t)cap * sizeof *p);
    if (p == NULL) return NULL;
    ts->queries = p;
    if (v->upg) {
      gathering_prev *q = realloc(ts->query_prev, (size_t)cap * sizeof *q);
      if (q == NULL) return NULL;
      ts->query_prev = q;
    }
    ts->query_capacity = cap;
  }
  return &ts->queries[ts->num_queries++];
}


/* A camera sub-path in flight. The camera pass, like the light pass, traces
 * VF_ACCEL_PACKET of them at once as a wavefront over the tile's pixels. Its contributions
 * go to its pixel through the deferred queue and its vertex merging queries to their
 * queue, each in the path's own order, so that every pixel sums the same terms in the
 * same order as when its path was traced alone. */
typedef struct {
  path_state s;
  vf_sampler sampler;
  uint32_t pixel, tile_pixel;
  uint32_t light_tile_pixel; /* the fused pass: the tile's pixel whose light sub-path it connects to */
  light_bsdf_cache cache; /* of the light sub-path this camera sub-path connects to */
  gathering_prev prev;    /* upg: the vertex before the one being traced to */
  merge_params merge;     /* its pixel's merge radius (path_state.merge points here) */
} camera_lane;

/* Starts camera sub-path `sample` of pixel (px, py), the tile's pixel tile_pixel (tile
 * width tw), which traces k = vf_pixel_samples of them in this iteration. With an
 * allocation (common/allocation.h) the sub-path takes its point of the pixel's sequence
 * and a stream of its own, and carries 1 / k of the pixel's estimate; with k = 1 it is the
 * sub-path of a render without one. */
static void camera_start(vf_vcm *v, camera_lane *lane, uint32_t px, uint32_t py, uint32_t tile_pixel, uint32_t tw,
                         uint32_t sample) {
  uint32_t pixel = py * (uint32_t)v->camera.width + px;
  lane->pixel = pixel;
  lane->tile_pixel = tile_pixel;
  /* Its block's top-left pixel (--light-path-pixels; itself by default): tiles start at
   * multiples of CAMERA_TILE, which a block's sides divide, so it is in the tile. */
  lane->light_tile_pixel = tile_pixel - (py & ((1u << v->light_block_h) - 1u)) * tw -
                           (px & ((1u << v->light_block_w) - 1u));
  lane->cache.ready = 0;
  lane->prev.valid = 0;
  vf_merge_params_at(v, pixel, &lane->merge);
  lane->s.merge = &lane->merge;
  path_sampler_start(&lane->sampler, v->settings.sampler, v->settings.seed, v->iteration, pixel, VF_STREAM_CAMERA);
  uint32_t k = vf_pixel_samples(v, pixel);
  if (v->allocated) {
    lane->sampler.index = vf_allocation_sobol_index(v->iteration, k, sample);
    lane->sampler.index_reversed = vf_reverse_bits32(lane->sampler.index);
    lane->sampler.path = pixel + (uint64_t)sample * v->num_pixels;
  }
  float jitter[2];
  vf_sampler_2d(&lane->sampler, VF_DIM_PIXEL, jitter);
  float jx = jitter[0], jy = jitter[1];
  path_state *s = &lane->s;
  if (v->camera.lens_radius > 0.0f) {
    /* A point on the thin lens, then the ray through the raster position in focus. The
     * lens numbers come after the pixel's, and only for a lens: a pinhole's stream is
     * what it always was. */
    float u[2];
    vf_sampler_2d(&lane->sampler, VF_DIM_LENS, u);
    s->origin = vf_camera_lens_point(&v->camera, u[0], u[1]);
    s->direction = vf_camera_lens_direction(&v->camera, s->origin, (float)px + jx, (float)py + jy);
  } else if (v->camera.pixel_size > 0.0f) {
    s->origin = vf_camera_view_point(&v->camera, (float)px + jx, (float)py + jy);
    s->direction = v->camera.forward;
  } else {
    s->origin = v->camera.position;
    s->direction = vf_camera_direction(&v->camera, (float)px + jx, (float)py + jy);
  }
  s->throughput = vf_vec3_splat(1.0f / (float)k); /* W_e cos / (p(z0) pdf_w) = 1 (camera.h), over k */
  s->medium = v->camera_medium;
  s->from_medium = 0;
  s->path_length = 1;
  s->specular_path = 1;
  /* z1's quantities, tech. rep. eq. (31)-(33): p_connect / p_trace of the lens point is 1;
   * an orthographic start is an area density (sec. 5.1-5.2). */
  vf_mis_camera_start(&s->mis, &s->merge->mis, vf_camera_start_density(&v->camera, s->direction));
}

/* s > 1, t > 1: every connection of camera vertex (hit, b) to its pixel's light sub-path. */
static void connect_to_light_path(vf_vcm *v, int thread, camera_lane *lane, const vf_hit *hit, const vf_bsdf *b) {
  const path_state *s = &lane->s;
  const light_vertex *path;
  const vf_bsdf *kept = NULL;
  uint32_t first, end;
  if (v->fused) {
    const thread_scratch *ts = &v->scratch[thread];
    path = ts->tile_vertices;
    kept = ts->tile_bsdfs;
    first = ts->tile_begin[lane->light_tile_pixel];
    end = ts->tile_end[lane->light_tile_pixel];
  } else {
    uint32_t light = vf_light_path_pixel(v, lane->pixel);
    path = v->chunks[light / LIGHT_CHUNK].vertices;
    first = v->path_begin[light];
    end = v->path_end[light];
  }
  for (uint32_t i = first; i < end; i++) {
    const light_vertex *lv = &path[i];
    if (vertex_path_length(lv) + 1 + s->path_length > v->settings.max_path_length) break;
    connect_vertices(v, thread, hit, b, s, lv, kept ? &kept[i] : NULL, i - first, &lane->cache, lane->tile_pixel,
                     &lane->sampler);
  }
}

/* A camera sub-path's vertex in a medium (segment.h), reached along seg: light sampling,
 * connections, merging with the light vertices in media (volume_merging.h) and scattering
 * by the phase function; nothing emits there.
 * Returns 0 when the path ends. */
static int camera_medium_vertex(vf_vcm *v, int thread, camera_lane *lane, const vf_hit *hit, const vf_segment *seg) {
  path_state *s = &lane->s;
  vf_mis_hit_media(&s->mis, &v->merge.mis, hit->t, 1.0f, !(s->path_length == 1 && v->camera.pixel_size > 0.0f),
                   seg->fwd, seg->rev);
  if (s->path_length >= v->settings.max_path_length) return 0;
  vf_bsdf b;
  bsdf_in_medium(v, &b, hit->primitive, hit->position, vf_neg(s->direction));
  b.radiance = 1;
  pt_roulette(v, &b, s);
  uint32_t vertex_dims = vf_dim_vertex(VF_DIM_CAMERA_VERTEX, s->path_length);
  if (v->t.light_sample) light_sample(v, thread, hit, &b, s, &lane->sampler, vertex_dims, lane->tile_pixel);
  if (v->t.connection) connect_to_light_path(v, thread, lane, hit, &b);
  if (v->upg) {
    /* upg gathers the light vertices in media without bias, at once (gathering_pass.h). */
    const gathering_place here = {vf_vec3_splat(0.0f), VF_HIT_MEDIUM, (int)hit->primitive};
    vertex_merging_query q = {b, hit->position, s->throughput, s->mis, s->path_length, lane->tile_pixel, lane->pixel,
                              lane->merge};
    lane->prev.here = here;
    defer_unshadowed(v, thread, vf_gathering_estimate_medium(v, thread, &q, &lane->prev), lane->tile_pixel);
    lane->prev = (gathering_prev){b, hit->position, s->throughput, s->mis, 1, here, here};
  } else if (v->t.vertex_merging && lane->merge.merges) {
    defer_unshadowed(v, thread, vf_mul(s->throughput, vf_volume_merging_estimate(v, &b, hit->position, &s->mis,
                                                                                  s->path_length)),
                     lane->tile_pixel);
    if (v->t.ppm) return 0; /* ppm merges once, at the first vertex that is not specular */
  }
  if (!vf_wavefront_scatter(v, &b, hit, s, &lane->sampler, vertex_dims, 1)) return 0;
  s->path_length++;
  return 1;
}

/* Continues the lane's camera sub-path where its last ray ended (hit NULL: it left the
 * scene): emission, light sampling, connections, vertex merging, scattering. Returns 0 when the
 * path ends there. */
static int camera_bounce(vf_vcm *v, int thread, camera_lane *lane, const vf_hit *hit) {
  path_state *s = &lane->s;
  uint32_t tile_pixel = lane->tile_pixel;
  const int media = v->has_media;
  vf_segment seg;
  vf_hit through;
  if (__builtin_expect(media, 0)) {
    /* Through media and index-matched boundaries to the next vertex (segment.h). */
    if (hit != NULL) through = *hit;
    float u = vf_sampler_1d(&lane->sampler, vf_dim_medium(s->path_length));
    int r = vf_segment_trace(v, thread, s->medium, s->from_medium, s->origin, s->direction, hit != NULL, &through, u,
                             &lane->sampler, &seg);
    if (r == VF_SEGMENT_ENDED) return 0;
    s->throughput = vf_mul(s->throughput, seg.weight);
    s->medium = seg.medium; /* index-matched boundaries on the way may have changed it */
    if (r == VF_SEGMENT_ESCAPED) {
      if (!(seg.fwd > 0.0f) || v->infinite_dark) return 0;
      vf_mis_escape(&s->mis, &v->merge.mis, seg.fwd, seg.rev);
      hit = NULL;
    } else {
      hit = &through;
      if (vf_hit_in_medium(hit)) return camera_medium_vertex(v, thread, lane, hit, &seg);
    }
  }
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
  /* An orthographic camera's first segment has no distance factor (tech. rep. sec. 5.2). */
  int distance_factor = !(s->path_length == 1 && v->camera.pixel_size > 0.0f);
  if (__builtin_expect(media, 0))
    vf_mis_hit_media(&s->mis, &v->merge.mis, hit->t, cos_fix, distance_factor, seg.fwd, seg.rev);
  else
    vf_mis_hit(&s->mis, &v->merge.mis, hit->t, cos_fix, distance_factor);
  int light_index = v->lights->shape_light[hit->shape];
  if (light_index >= 0 && v->t.emission) {
    const vf_light *l = &v->lights->lights[light_index];
    float direct_pdf, emission_pdf;
    vf_vec3 le = vf_light_radiance_area(l, s->direction, hit->normal, &direct_pdf, &emission_pdf);
    if (__builtin_expect(l->textured | l->coated, 0))
      le = vf_mul(le, vf_light_emission_factor_toward(l, hit->primitive, hit->u, hit->v, hit->normal, vf_neg(s->direction)));
    defer_unshadowed(v, thread, vf_mul(s->throughput, emission_weighted(v, l, s, le, direct_pdf, emission_pdf)),
                     tile_pixel);
  }
  if (s->path_length >= v->settings.max_path_length) return 0;
  vf_bsdf b;
  if (!bsdf_at(v, &b, hit, vf_neg(s->direction))) return 0;
  b.radiance = 1; /* its connections and merges evaluate radiance's BTDF (worker/render/bsdf.h) */
  pt_roulette(v, &b, s);
  uint32_t vertex_dims = vf_dim_vertex(VF_DIM_CAMERA_VERTEX, s->path_length);
  if (!b.is_delta) {
    if (v->t.light_sample) light_sample(v, thread, hit, &b, s, &lane->sampler, vertex_dims, tile_pixel);
    if (v->t.connection) connect_to_light_path(v, thread, lane, hit, &b);
    if (v->t.vertex_merging && lane->merge.merges && v->num_vertices > 0) {
      vertex_merging_query *q = queue_vertex_merging(v, thread);
      if (q != NULL) {
        /* Field by field, the BSDF by the part it uses (vf_bsdf_copy): a whole vf_bsdf is
         * three times that, and the queue of a tile's queries outgrew the cache. */
        vf_bsdf_copy(&q->bsdf, &b);
        q->position = hit->position;
        q->throughput = s->throughput;
        q->mis = s->mis;
        q->path_length = s->path_length;
        q->tile_pixel = tile_pixel;
        q->pixel = lane->pixel;
        q->merge = lane->merge;
        if (v->upg) {
          gathering_prev *p = &v->scratch[thread].query_prev[q - v->scratch[thread].queries];
          *p = lane->prev;
          p->here = (gathering_place){hit->normal, hit->shape, s->medium};
        }
      } else {
        vertex_merging_query now = {b, hit->position, s->throughput, s->mis, s->path_length, tile_pixel, lane->pixel,
                                    lane->merge};
        lane->prev.here = (gathering_place){hit->normal, hit->shape, s->medium};
        vf_vec3 estimate = v->upg ? vf_gathering_estimate(v, thread, &now, &lane->prev)
                                  : vf_mul(s->throughput, vf_vertex_merging_estimate(v, &now));
        defer_unshadowed(v, thread, estimate, tile_pixel);
      }
      if (v->t.ppm) return 0;
    }
  }
  if (v->upg) {
    const gathering_place place = {hit->normal, hit->shape, s->medium};
    lane->prev = (gathering_prev){b, hit->position, s->throughput, s->mis, 1, place, place};
  }
  if (!vf_wavefront_scatter(v, &b, hit, s, &lane->sampler, vertex_dims, 1)) return 0;
  s->path_length++;
  return 1;
}

/* Traces the camera sub-paths of the tile's pixels (tile_pixel = row * tw + column), each
 * pixel's vf_pixel_samples of them one after another. */
static void trace_camera_sub_paths(vf_vcm *v, int thread, uint32_t x0, uint32_t y0, uint32_t tw, uint32_t pixels) {
  camera_lane lanes[VF_ACCEL_PACKET];
  path_state *states[VF_ACCEL_PACKET];
  /* The next sub-path to start: number `sample` of `count` of tile_pixel next, at column tx
   * and row ty of the tile (kept apart so that no pixel costs a division). */
  uint32_t width = (uint32_t)v->camera.width;
  uint32_t next = 0, tx = 0, ty = 0, active = 0, sample = 0, count = vf_pixel_samples(v, y0 * width + x0);
#define START_NEXT_SUB_PATH(lane)                                       \
  do {                                                                  \
    camera_start(v, (lane), x0 + tx, y0 + ty, next, tw, sample);        \
    if (++sample == count) {                                            \
      sample = 0;                                                       \
      if (++tx == tw) tx = 0, ty++;                                     \
      if (++next < pixels) count = vf_pixel_samples(v, (y0 + ty) * width + x0 + tx); \
    }                                                                   \
  } while (0)
  for (int i = 0; i < VF_ACCEL_PACKET; i++) {
    states[i] = &lanes[i].s;
    if (next < pixels) {
      START_NEXT_SUB_PATH(&lanes[i]);
      active |= 1u << i;
    }
  }
  while (active) {
    vf_hit hits[VF_ACCEL_PACKET];
    int lane_of[VF_ACCEL_PACKET], m;
    uint32_t found = vf_wavefront_trace(v, thread, states, active, lane_of, &m, hits);
    prefetch_shading(v, hits, found, m);
    for (int k = 0; k < m; k++) {
      int i = lane_of[k];
      if (camera_bounce(v, thread, &lanes[i], (found >> k & 1u) ? &hits[k] : NULL)) continue;
      if (next < pixels)
        START_NEXT_SUB_PATH(&lanes[i]);
      else
        active &= ~(1u << i);
    }
  }
#undef START_NEXT_SUB_PATH
}

void vf_camera_pass_run_tile(vf_vcm *v, int thread, const camera_tile *tile) {
  uint32_t width = (uint32_t)v->camera.width, tw = tile->width;
  float tile_rgb[3 * CAMERA_TILE * CAMERA_TILE];
  memset(tile_rgb, 0, 3 * sizeof(float) * tw * tile->height);
  v->scratch[thread].tile_rgb = tile_rgb;
  if (v->t.camera_paths) trace_camera_sub_paths(v, thread, tile->x0, tile->y0, tw, tw * tile->height);
  resolve_deferred(v, thread);
  vf_vertex_merging_run_tile(v, thread, tile_rgb);
  for (uint32_t y = 0; y < tile->height; y++)
    for (uint32_t x = 0; x < tw; x++) {
      const float *c = &tile_rgb[3 * (y * tw + x)];
      float *out = &v->camera_rgb[3 * ((size_t)(tile->y0 + y) * width + tile->x0 + x)];
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

uint32_t vf_camera_pass_tiles(const vf_vcm *v) {
  return ((uint32_t)v->camera.width + CAMERA_TILE - 1) / CAMERA_TILE *
         (((uint32_t)v->camera.height + CAMERA_TILE - 1) / CAMERA_TILE);
}

camera_tile vf_camera_pass_tile(const vf_vcm *v, uint32_t index) {
  uint32_t width = (uint32_t)v->camera.width, height = (uint32_t)v->camera.height;
  uint32_t tiles_x = (width + CAMERA_TILE - 1) / CAMERA_TILE;
  uint32_t x0 = index % tiles_x * CAMERA_TILE, y0 = index / tiles_x * CAMERA_TILE;
  uint32_t x1 = x0 + CAMERA_TILE < width ? x0 + CAMERA_TILE : width;
  uint32_t y1 = y0 + CAMERA_TILE < height ? y0 + CAMERA_TILE : height;
  return (camera_tile){index, x0, y0, x1 - x0, y1 - y0};
}

static void camera_task(void *ctx, size_t task, int thread) {
  vf_vcm *v = ctx;
  camera_tile tile = vf_camera_pass_tile(v, (uint32_t)task);
  vf_camera_pass_run_tile(v, thread, &tile);
}

void vf_camera_pass_run(vf_vcm *v) { vf_pool_run(v->pool, vf_camera_pass_tiles(v), camera_task, v); }
