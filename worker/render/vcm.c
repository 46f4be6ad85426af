/* Set-up of the renderer (scene analysis, `auto`, the techniques of each algorithm) and
 * one iteration as its three phases: vcm.h. The phases are light_pass.c, vertex_merging.c
 * (the grid) and camera_pass.c, or for bpt the fused pass of fused_pass.c; the MIS scheme
 * that weights their techniques is mis.h. */
#include "vcm.h"

#include "../../common/allocation.h"
#include "../../common/clock.h"
#include "../../common/error.h"
#include "camera_pass.h"
#include "fused_pass.h"
#include "light_pass.h"
#include "merge_pipeline.h"
#include "pixel_radius.h"
#include "segment.h"
#include "single_stage.h"
#include "surface.h"
#include "vcm_internal.h"
#include "vertex_merging.h"
#include "volume_merging.h"

#include <math.h>
#include <stdlib.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif
#include <string.h>

/* ---------------------------------------------------------------------------------------- */
/* The iteration                                                                             */

double vf_vcm_merge_radius(const vf_vcm *v, uint64_t iteration) {
  double i = (double)iteration + 1.0;
  return v->settings.radius_factor * v->scene_radius * sqrt(pow(i, v->settings.alpha - 1.0));
}

static void setup_iteration(vf_vcm *v, uint64_t iteration) {
  v->iteration = iteration;
  double r = vf_vcm_merge_radius(v, iteration);
  /* n_VM / n_VC * pi r^2 (eq. 20), n_VC = 1: n_VM is n_light, one per pixel by default, one
   * per block of pixels sharing a light sub-path (--light-path-pixels) */
  double eta = M_PI * r * r * (double)v->num_light_paths;
  v->radius_exact = r;
  v->merge.radius = (float)r;
  v->merge.radius_sq = (float)(r * r);
  v->merge.vm_normalization = (float)(1.0 / eta);
  v->merge.merges = v->t.vertex_merging;
  vf_algorithm a = v->settings.algorithm;
  v->vc_in_weights = a == VF_ALGO_VCM || a == VF_ALGO_UPG || a == VF_ALGO_BPT;
  v->vm_in_weights = a == VF_ALGO_VCM || a == VF_ALGO_UPG || a == VF_ALGO_BPM;
  v->merge.mis.beta = (float)v->settings.mis_beta;
  v->merge.mis.vm_weight = v->vm_in_weights ? vf_mis_h(&v->merge.mis, (float)eta) : 0.0f;
  v->merge.mis.vc_weight = v->vc_in_weights ? vf_mis_h(&v->merge.mis, (float)(1.0 / eta)) : 0.0f;
  /* With a radius per pixel the grid serves the largest (pixel_radius.h). */
  v->grid_radius = v->pixel_scale ? (float)(r * (double)v->pixel_scale_max) : v->merge.radius;
  v->merge.mis.light_paths = (float)v->num_light_paths;
  v->merge.mis.pt = v->settings.algorithm == VF_ALGO_PT;
  /* A merge in a medium over one on a surface: eta_m / eta_s = (4/3) pi r^3 / (pi r^2). */
  v->medium_merge = v->has_media && v->t.vertex_merging ? vf_mis_h(&v->merge.mis, (float)(4.0 * r / 3.0)) : 0.0f;
}

static void add_counts(const vf_vcm *v, vf_vcm_stats *stats) {
  for (int t = 0; t < vf_pool_threads(v->pool); t++) {
    stats->rays += v->stats[t].rays;
    stats->nonfinite += v->stats[t].nonfinite;
    const vf_upg_counts *u = &v->stats[t].upg;
    stats->upg_gatherings += u->gatherings;
    stats->upg_trials += u->trials;
    stats->upg_rays += u->rays;
    stats->upg_truncated += u->truncated;
    stats->upg_bound_exceeded += u->bound_exceeded;
    stats->upg_fallbacks += v->stats[t].upg_fallbacks;
  }
  stats->light_vertices += v->num_vertices;
}

int vf_vcm_set_allocation(vf_vcm *v, const uint8_t *samples) {
  if (v->settings.pilot == 0) return vf_error_set(VF_EINVAL, "an allocation of camera sub-paths needs a pilot");
  int err = vf_allocation_validate(samples, v->num_pixels, "allocation");
  if (err != VF_OK) return vf_error_set(VF_EINVAL, "%s", vf_error_detail(err));
  if ((err = vf_allocation_check_algorithm(samples, v->num_pixels, v->settings.algorithm, "allocation")) != VF_OK)
    return err;
  if (v->samples == NULL && (v->samples = malloc(v->num_pixels)) == NULL) return VF_ENOMEM;
  memcpy(v->samples, samples, v->num_pixels);
  return VF_OK;
}

void vf_vcm_set_pilot_phase(vf_vcm *v, int on) {
  v->pilot_phase = on && v->settings.pilot > 0;
  v->settings.seed = v->pilot_phase ? vf_allocation_seed(v->job_seed) : v->job_seed;
}

int vf_vcm_pilot_phase(const vf_vcm *v) { return v->pilot_phase; }

int vf_vcm_iteration(vf_vcm *v, uint64_t iteration, float *camera_rgb, float *light_rgb, vf_vcm_stats *stats) {
  v->allocated = v->settings.pilot > 0 && !v->pilot_phase;
  if (v->allocated && v->samples == NULL)
    return vf_error_set(VF_EINVAL, "iteration %llu needs the allocation of camera sub-paths that the pilot of %d "
                        "iterations decides, and none is set", (unsigned long long)iteration, v->settings.pilot);
  setup_iteration(v, iteration);
  v->camera_rgb = camera_rgb;
  v->light_rgb = light_rgb;
  int threads = vf_pool_threads(v->pool);
  for (int t = 0; t < threads; t++) v->stats[t] = (thread_stats){0};

  if (v->single_stage) {
    /* vcm in one pass, merging with the light vertices of the iteration before
     * (single_stage.c). */
    int err = vf_single_stage_iteration(v, stats);
    if (err != VF_OK) return err;
    add_counts(v, stats);
    return VF_OK;
  }

  if (v->fused) {
    /* bpt, which connects but never merges: phases 1 and 3 as one pass over the camera
     * tiles, each tracing its pixels' light sub-paths just before their camera sub-paths,
     * which connect to those vertices while they are in cache; no grid needs them all at
     * once (fused_pass.c). Then the light image. */
    double t0 = vf_seconds_now();
    vf_fused_pass_run(v);
    double t1 = vf_seconds_now();
    int err = vf_light_pass_finish(v);
    if (err != VF_OK) return err;
    double t2 = vf_seconds_now(), light = 0.0;
    for (int t = 0; t < threads; t++) light += v->stats[t].light_seconds;
    light /= threads; /* the tiles' light sub-paths, as a share of the pass's wall time */
    if (light > t1 - t0) light = t1 - t0;
    stats->light_seconds += light + (t2 - t1);
    stats->camera_seconds += t1 - t0 - light;
    add_counts(v, stats);
    return VF_OK;
  }

  /* 1. Light sub-paths, their vertices and their projections onto the camera (light_pass.c). */
  double t0 = vf_seconds_now();
  int err = vf_light_pass_run(v);
  if (err != VF_OK) return err;

  double t1 = vf_seconds_now();
  /* 2. The range-search grid, only when vertex merging (vertex_merging.c, hashgrid.c). */
  if (v->t.vertex_merging && v->num_vertices > 0 &&
      (err = vf_vertex_merging_build_grid(v, v->chunks, v->chunk_shift)) != VF_OK)
    return err;
  if (v->t.vertex_merging && v->has_media && (err = vf_volume_merging_build(v)) != VF_OK) return err;

  double t2 = vf_seconds_now();
  /* 3. Camera sub-paths, vertex merging included (camera_pass.c). */
  vf_camera_pass_run(v);
  if (v->t.vertex_merging) vf_vertex_merging_release(v);
  double t3 = vf_seconds_now();
  stats->light_seconds += t1 - t0;
  stats->grid_seconds += t2 - t1;
  stats->camera_seconds += t3 - t2;
  add_counts(v, stats);
  return VF_OK;
}

/* ---------------------------------------------------------------------------------------- */
/* Set-up                                                                                    */

static void choose_techniques(vf_vcm *v) {
  techniques *t = &v->t;
  memset(t, 0, sizeof *t);
  switch (v->settings.algorithm) {
  case VF_ALGO_VCM:
  case VF_ALGO_UPG:
    t->light_paths = t->camera_paths = t->light_to_camera = t->emission = t->light_sample = 1;
    t->connection = t->vertex_merging = 1;
    break;
  case VF_ALGO_BPT:
    t->light_paths = t->camera_paths = t->light_to_camera = t->emission = t->light_sample = t->connection = 1;
    break;
  case VF_ALGO_PT: t->camera_paths = t->emission = t->light_sample = 1; break;
  case VF_ALGO_LT: t->light_paths = t->light_to_camera = t->lt = 1; break;
  case VF_ALGO_PPM:
    t->light_paths = t->camera_paths = t->emission = t->vertex_merging = t->ppm = 1;
    t->emission_specular_only = 1;
    break;
  case VF_ALGO_BPM:
    t->light_paths = t->camera_paths = t->emission = t->vertex_merging = 1;
    t->emission_specular_only = 1;
    break;
  default: break;
  }
  t->store_vertices = t->connection || t->vertex_merging;
}

typedef struct {
  int has_specular, has_glossy, has_diffuse;
} material_kinds;

static material_kinds scene_kinds(const vf_scene *sc) {
  material_kinds k = {0, 0, 0};
  for (int i = 0; i < sc->num_materials; i++) {
    unsigned kinds = vf_material_kinds(&sc->materials[i]);
    if (kinds & VF_KIND_SPECULAR) k.has_specular = 1;
    if (kinds & VF_KIND_GLOSSY) k.has_glossy = 1;
    if (kinds & VF_KIND_DIFFUSE) k.has_diffuse = 1;
  }
  return k;
}

static void analyse_scene(vf_vcm *v) {
  material_kinds k = scene_kinds(v->scene);
  v->has_specular = k.has_specular;
  v->has_glossy = k.has_glossy;
  v->has_diffuse = k.has_diffuse;
}

/* --algorithm auto: the cheapest technique set that covers the scene's light transport
 * (docs/BENCHMARKS.md, "Time against error", has the measurements behind each branch).
 *
 * - Specular surfaces next to diffuse or glossy ones: SDS paths can exist. Of our
 *   techniques only vertex merging samples them when they start at a point or directional light
 *   (paper sec. 6.1, "Limitations"), and with area lights connections see them only
 *   through chance emission hits: vcm.
 * - Otherwise every path has two consecutive non-specular vertices somewhere, so the
 *   unbiased techniques reach all of them and vertex merging adds only a higher-variance
 *   duplicate of what connections already sample (its weight shrinks to nothing as the
 *   radius does). Of the unbiased sets, path tracing with light sampling reached every
 *   error target first on all such scenes of the suite (diffuse, knot, sharp glossy up to
 *   exponent 5000): light sub-paths cost more per iteration than they save: pt.
 * The choice reads only the scene's materials, so it is a pure function of scene and
 * settings: every worker and every `continue` makes the same one, and films keep "auto"
 * in their settings text. It cannot tell how much light the SDS paths carry: with area
 * lights in view of the light sampler (`cornell`) pt would be faster than the vcm chosen. */
/* Whether the scene has a light at infinity: a directional light, a background or an
 * environment map (upg cannot join a light vertex to their points). */
static int has_infinite_light(const vf_scene *sc) {
  return sc->num_directional_lights > 0 || !vf_is_zero(sc->background) || sc->envmap.width > 0;
}

/* --algorithm auto-unbiased: among the unbiased algorithms, the one for the scene
 * (docs/BENCHMARKS.md, "Unbiased photon gathering", has the measurements behind it).
 * - Delta lobes: upg would merge, as vcm does, the light vertices that neither side can
 *   join (a caustic seen through glass), so it is not unbiased there: bpt, whose emission
 *   hits and connections reach specular chains. Caustics from a point or directional light
 *   seen through a delta lobe no unbiased technique samples at all.
 * - A light at infinity: upg merges its first light vertices as vcm does: pt.
 * - Glossy surfaces without delta lobes: upg, unbiased here, gathers glossy transport
 *   sooner than pt.
 * - Otherwise (diffuse only): pt, as auto. */
static vf_algorithm auto_unbiased(const vf_scene *sc, material_kinds k, const char **why) {
  if (k.has_specular) {
    *why = sc->num_point_lights > 0 || sc->num_directional_lights > 0
               ? "delta lobes: upg would merge caustics as vcm; caustics of point and directional lights seen through "
                 "them no unbiased technique samples"
               : "delta lobes: upg would merge caustics as vcm; bpt reaches specular chains by emission hits";
    return VF_ALGO_BPT;
  }
  if (has_infinite_light(sc)) {
    *why = "a light at infinity, whose first light vertices upg merges as vcm: pt";
    return VF_ALGO_PT;
  }
  if (k.has_glossy) {
    *why = "glossy surfaces, no delta lobes and finite lights: upg gathers without bias";
    return VF_ALGO_UPG;
  }
  *why = "diffuse surfaces only: light sampling suffices";
  return VF_ALGO_PT;
}

/* Whether some medium of the scene scatters (one that only absorbs adds no vertex). */
static int scene_scatters_in_media(const vf_scene *sc) {
  for (int i = 0; i < sc->num_media; i++) {
    vf_vec3 s = sc->media[i].sigma_s;
    if (s.x > 0.0f || s.y > 0.0f || s.z > 0.0f) return 1;
  }
  return 0;
}

vf_algorithm vf_vcm_auto_algorithm(const vf_scene *scene, vf_algorithm requested, const char **reason) {
  material_kinds k = scene_kinds(scene);
  const char *why;
  vf_algorithm a;
  if (requested == VF_ALGO_AUTO_UNBIASED) {
    a = auto_unbiased(scene, k, &why);
  } else if (k.has_specular && scene_scatters_in_media(scene)) {
    why = "a scattering medium and specular surfaces: volumetric caustics, which merging in media renders";
    a = VF_ALGO_VCM;
  } else if (k.has_specular && (k.has_diffuse || k.has_glossy)) {
    why = "specular next to non-specular surfaces: SDS paths possible";
    a = VF_ALGO_VCM;
  } else {
    why = k.has_specular ? "only specular surfaces: emission hits along specular chains suffice"
                         : "no specular surfaces, so no SDS paths: light sampling suffices";
    a = VF_ALGO_PT;
  }
  if (reason) *reason = why;
  return a;
}

static vf_algorithm resolve_auto(vf_vcm *v) { return vf_vcm_auto_algorithm(v->scene, v->requested, &v->auto_reason); }

vf_algorithm vf_vcm_algorithm(const vf_vcm *v) { return v->settings.algorithm; }

void vf_vcm_limit_simd(vf_vcm *v) { v->vertex_merging_avx512 = 0; }

const char *vf_vcm_merge_simd(const vf_vcm *v) {
#ifdef VF_MERGE_PIPELINE
  return v->vertex_merging_avx512 ? "AVX-512" : "SSE2";
#else
  return "no SIMD (the reference query, vertex_merging.c)";
#endif
}

/* Triangles, shapes shaded from their barycentrics, textures and the memory they take. */
static void describe_geometry(const vf_scene *sc, FILE *out) {
  uint64_t triangles = 0;
  int spheres = 0, interpolated = 0;
  for (int i = 0; i < sc->num_shapes; i++) {
    const vf_shape *sh = &sc->shapes[i];
    if (sh->kind == VF_SHAPE_SPHERE) spheres++;
    else triangles += sh->num_triangles;
    interpolated += vf_surface_interpolated(sc, sh);
  }
  size_t texels = 0;
  for (int i = 0; i < sc->num_textures; i++) texels += vf_texture_bytes(&sc->textures[i]);
  fprintf(out, "geometry: %llu triangle%s, %d sphere%s, %d shape%s with vertex normals or textures; %d texture%s (%.1f MiB)\n",
          (unsigned long long)triangles, triangles == 1 ? "" : "s", spheres, spheres == 1 ? "" : "s", interpolated,
          interpolated == 1 ? "" : "s", sc->num_textures, sc->num_textures == 1 ? "" : "s",
          (double)texels / (1024.0 * 1024.0));
}

static float pixel_scale_min(const vf_vcm *v) {
  float m = v->pixel_scale_max;
  for (uint32_t i = 0; i < v->num_pixels; i++) m = v->pixel_scale[i] < m ? v->pixel_scale[i] : m;
  return m;
}

void vf_vcm_describe(const vf_vcm *v, FILE *out) {
  const techniques *t = &v->t;
  int area = 0, point = 0, spot = 0, directional = 0;
  for (int i = 0; i < v->lights->count; i++) {
    vf_light_kind k = v->lights->lights[i].kind;
    area += k == VF_LIGHT_AREA_MESH || k == VF_LIGHT_AREA_SPHERE;
    point += k == VF_LIGHT_POINT;
    spot += k == VF_LIGHT_SPOT;
    directional += k == VF_LIGHT_DIRECTIONAL;
  }
  int sds = v->has_specular && (v->has_diffuse || v->has_glossy);
  char surfaces[64];
  snprintf(surfaces, sizeof surfaces, "%s%s%s%s%s", v->has_diffuse ? "diffuse" : "",
           v->has_diffuse && v->has_glossy ? " " : "", v->has_glossy ? "glossy" : "",
           (v->has_diffuse || v->has_glossy) && v->has_specular ? " " : "", v->has_specular ? "specular" : "");
  fprintf(out, "scene: %d area, %d point, %d spot, %d directional light(s)%s; %s surfaces; SDS paths %s\n", area,
          point, spot, directional, v->lights->environment >= 0 ? ", environment" : "",
          surfaces[0] ? surfaces : "no scattering", sds ? "possible" : "impossible");
  if (v->camera.pixel_size > 0.0f)
    fprintf(out, "camera: orthographic, %g wide\n", v->camera.pixel_size * (float)v->camera.width);
  if (v->pixel_scale)
    fprintf(out, "merge radius: per pixel, from %.3g to %.3g times the global one by the pixels' footprints\n",
            pixel_scale_min(v), v->pixel_scale_max);
  if (v->camera.lens_radius > 0.0f)
    fprintf(out, "camera: thin lens of radius %g, in focus at %g\n", v->camera.lens_radius, v->camera.focus_distance);
  describe_geometry(v->scene, out);
  if (v->scene->num_media > 0) {
    int gridded = 0;
    for (int i = 0; i < v->scene->num_media; i++) gridded += v->scene->media[i].grid != NULL;
    fprintf(out, "participating media: %d, %d heterogeneous%s\n", v->scene->num_media, gridded,
            v->scene->medium >= 0 ? "; the scene is in one" : "");
  }
  fprintf(out, "rays: Embree's %s kernels\n", vf_accel_kernels());
  if (vf_algorithm_is_auto(v->requested))
    fprintf(out, "%s: %s (%s)\n", vf_algorithm_name(v->requested), vf_algorithm_name(v->settings.algorithm),
            v->auto_reason);
  fprintf(out,
          "techniques (%s): emission hits %s, light sampling %s, light tracing %s, connections %s, merging %s\n",
          vf_algorithm_name(v->settings.algorithm), t->emission ? (t->emission_specular_only ? "specular paths" : "on") : "off",
          t->light_sample ? "on" : "off", t->light_to_camera ? "on" : "off", t->connection ? "on" : "off",
          t->vertex_merging ? (t->ppm ? "first diffuse vertex" : "on") : "off");
  if (v->upg) {
    int infinite = has_infinite_light(v->scene);
    fprintf(out, "gathering (upg): from the %s's side where both sides can; light vertices neither can join ",
            vf_gather_name(v->settings.gather));
    if (v->has_specular || infinite)
      fprintf(out, "(%s%s%s) are merged as vcm merges them, biased, and counted\n",
              v->has_specular ? "ideal specular choices on both sides" : "", v->has_specular && infinite ? "; " : "",
              infinite ? "first vertices of lights at infinity seen from a lens-adjacent vertex" : "");
    else
      fprintf(out, "do not exist in this scene (no delta lobes, no lights at infinity): unbiased\n");
    if (v->has_media)
      fprintf(out, "gathering in media: at medium vertices too, every join with its transmittance and every "
                   "tentative direction a free flight sampled as the sub-paths sample it%s\n",
              v->has_specular ? "; volumetric caustics seen directly from the lens are merged as vcm merges them" : "");
  } else if (t->vertex_merging) {
    fprintf(out, "merging tests its candidates with %s\n", vf_vcm_merge_simd(v));
  }
  if (v->single_stage)
    fprintf(out, "single-stage (--vcm-stages 1): one pass over the camera tiles; camera sub-paths merge with the "
                 "light vertices of the iteration before, the first of a range traces them again\n");
  if (v->settings.light_path_pixels > 1 && t->light_paths)
    fprintf(out, "light sub-paths (--light-path-pixels %d): one per block of %ux%u pixels, %u an iteration\n",
            v->settings.light_path_pixels, 1u << v->light_block_w, 1u << v->light_block_h, v->num_light_paths);
  fprintf(out, "skipped: %s%s%s%s\n", t->store_vertices ? "" : "light-vertex storage, ",
          t->vertex_merging ? "" : "range-search grid, ", v->lights->environment >= 0 ? "" : "environment lookups, ",
          "connections at specular vertices, shadow rays for zero contributions");
  if (t->vertex_merging && sds == 0 && v->settings.algorithm == VF_ALGO_VCM)
    fprintf(out, "note: no specular surfaces, so merging only adds to paths connections already cover\n");
}

/* The axis-aligned box of shape sh. */
static void shape_box(const vf_shape *sh, vf_vec3 *lo, vf_vec3 *hi) {
  if (sh->kind == VF_SHAPE_SPHERE) {
    *lo = vf_sub(sh->center, vf_vec3_splat(sh->radius));
    *hi = vf_add(sh->center, vf_vec3_splat(sh->radius));
    return;
  }
  *lo = vf_vec3_splat(INFINITY);
  *hi = vf_vec3_splat(-INFINITY);
  for (uint32_t k = 0; k < sh->num_vertices; k++) {
    vf_vec3 p = vf_vec3_make(sh->positions[3 * k], sh->positions[3 * k + 1], sh->positions[3 * k + 2]);
    *lo = vf_vec3_make(fminf(lo->x, p.x), fminf(lo->y, p.y), fminf(lo->z, p.z));
    *hi = vf_vec3_make(fmaxf(hi->x, p.x), fmaxf(hi->y, p.y), fmaxf(hi->z, p.z));
  }
}

/* vf_vcm.shape_medium: the medium around each shape without an interface whose box meets
 * the box of no shape with one (no point of it lies inside a region, so the scene's medium
 * is around it), else VF_SHAPE_MEDIUM_UNKNOWN. upg's gatherings read it instead of finding
 * the medium by rays (gathering_pass.c). */
static int shape_media_setup(vf_vcm *v) {
  const vf_scene *sc = v->scene;
  int n = sc->num_shapes;
  v->shape_medium = malloc((n > 0 ? (size_t)n : 1) * sizeof *v->shape_medium);
  vf_vec3 *lo = malloc((n > 0 ? (size_t)n : 1) * sizeof *lo), *hi = malloc((n > 0 ? (size_t)n : 1) * sizeof *hi);
  int err = v->shape_medium && lo && hi ? VF_OK : VF_ENOMEM;
  for (int i = 0; i < n && err == VF_OK; i++) shape_box(&sc->shapes[i], &lo[i], &hi[i]);
  for (int i = 0; i < n && err == VF_OK; i++) {
    v->shape_medium[i] = sc->medium;
    if (sc->shapes[i].interface) continue;
    for (int j = 0; j < n; j++) {
      if (!sc->shapes[j].interface) continue;
      int apart = hi[i].x < lo[j].x || lo[i].x > hi[j].x || hi[i].y < lo[j].y || lo[i].y > hi[j].y ||
                  hi[i].z < lo[j].z || lo[i].z > hi[j].z;
      if (!apart) {
        v->shape_medium[i] = VF_SHAPE_MEDIUM_UNKNOWN;
        break;
      }
    }
  }
  free(lo);
  free(hi);
  return err;
}

/* The media of the scene, prepared, and the media the camera and the lights are in
 * (segment.h). An area light is taken to be in the medium in front of its first triangle
 * (of a sphere: outside it); lights at infinity shine from the scene's medium. */
static int media_setup(vf_vcm *v) {
  const vf_scene *sc = v->scene;
  v->camera_medium = -1;
  if (sc->num_media == 0) return VF_OK;
  if (v->settings.radius == VF_RADIUS_PER_PIXEL && v->t.vertex_merging)
    return vf_error_set(VF_EINVAL, "the scene has participating media, which a merge radius per pixel does not "
                                   "render (merging in media needs one radius); use the global radius");
  if (v->single_stage)
    return vf_error_set(VF_EINVAL, "the scene has participating media, which single-stage vcm does not render (a "
                                   "light vertex after a medium vertex carries its iteration's merge radius, and "
                                   "single-stage merges it in the next); use --vcm-stages 2");
  v->has_media = 1;
  for (int i = 0; i < sc->num_shapes; i++) v->has_boundaries |= sc->shapes[i].material < 0;
  v->media = calloc((size_t)sc->num_media, sizeof *v->media);
  v->light_medium = calloc(v->lights->count > 0 ? (size_t)v->lights->count : 1, sizeof *v->light_medium);
  if (v->media == NULL || v->light_medium == NULL) return VF_ENOMEM;
  for (int i = 0; i < sc->num_media; i++) vf_medium_prepare(&v->media[i], &sc->media[i]);
  v->camera_medium = vf_medium_at_point(v, v->camera.position);
  if (sc->medium >= 0 && sc->media[sc->medium].grid == NULL) {
    vf_vec3 st = v->media[sc->medium].sigma_t;
    v->infinite_dark = st.x > 0.0f || st.y > 0.0f || st.z > 0.0f;
  }
  for (int i = 0; i < v->lights->count; i++) {
    const vf_light *l = &v->lights->lights[i];
    int m = sc->medium;
    if (l->kind == VF_LIGHT_POINT || l->kind == VF_LIGHT_SPOT) {
      m = vf_medium_at_point(v, l->position);
    } else if (l->kind == VF_LIGHT_AREA_MESH) {
      const vf_light_triangle *t = &l->triangles[0];
      vf_vec3 c = vf_scale(vf_add(t->a, vf_add(t->b, t->c)), 1.0f / 3.0f);
      m = vf_medium_at_point(v, vf_offset_ray_origin(c, t->normal, v->offset_scale));
    } else if (l->kind == VF_LIGHT_AREA_SPHERE) {
      vf_vec3 top = vf_add(l->shape->center, vf_vec3_make(0.0f, l->shape->radius, 0.0f));
      m = vf_medium_at_point(v, vf_offset_ray_origin(top, vf_vec3_make(0.0f, 1.0f, 0.0f), v->offset_scale));
    }
    v->light_medium[i] = m;
  }
  return shape_media_setup(v);
}

int vf_vcm_create(const vf_scene *scene, const vf_accel *accel, const vf_settings *settings, vf_pool *pool,
                  vf_vcm **out) {
  int err = VF_ENOMEM;
  vf_vcm *v = calloc(1, sizeof *v);
  if (v == NULL) return VF_ENOMEM;
  v->scene = scene;
  v->accel = accel;
  v->settings = *settings;
  v->job_seed = settings->seed;
  v->pool = pool;
  vf_camera_init(&v->camera, &scene->camera, settings->width, settings->height);
  vf_scene_bounding_sphere(scene, &v->scene_center, &v->scene_radius);
  v->offset_scale = vf_accel_scale(accel);
  v->num_pixels = (uint32_t)settings->width * (uint32_t)settings->height;
  vf_light_path_block(settings->light_path_pixels, &v->light_block_w, &v->light_block_h);
  v->num_light_paths = (((uint32_t)settings->width + (1u << v->light_block_w) - 1u) >> v->light_block_w) *
                       (((uint32_t)settings->height + (1u << v->light_block_h) - 1u) >> v->light_block_h);
  if ((uint32_t)scene->num_shapes > VERTEX_MAX_SHAPES) {
    free(v);
    return vf_error_set(VF_ESCENE, "the scene has %d shapes; the renderer handles at most %u", scene->num_shapes,
                        VERTEX_MAX_SHAPES);
  }
  analyse_scene(v);
  v->requested = settings->algorithm;
  if (vf_algorithm_is_auto(v->requested)) v->settings.algorithm = resolve_auto(v);
  choose_techniques(v);
  /* Single-stage only where vcm runs: auto that chose pt renders as pt. */
  v->single_stage = v->settings.vcm_stages == 1 && v->settings.algorithm == VF_ALGO_VCM;
  if ((err = vf_lights_create(scene, &v->lights)) != VF_OK) goto fail;
  if ((err = media_setup(v)) != VF_OK) goto fail;
  err = VF_ENOMEM;
  v->fused = (v->t.connection && !v->t.vertex_merging && v->t.light_paths && v->t.camera_paths) || v->single_stage;
  v->upg = v->settings.algorithm == VF_ALGO_UPG;
  if (v->upg && (v->origins = calloc(v->num_pixels, sizeof *v->origins)) == NULL) goto fail;
  v->num_chunks = v->fused ? vf_camera_pass_tiles(v) : (v->num_pixels + LIGHT_CHUNK - 1) / LIGHT_CHUNK;
  v->chunks = calloc(v->num_chunks, sizeof *v->chunks);
  v->band_pixels = SPLAT_BAND * (uint32_t)v->camera.width;
  v->num_bands = (v->num_pixels + v->band_pixels - 1) / v->band_pixels;
  v->band_start = calloc((size_t)v->num_chunks * (v->num_bands + 1), sizeof *v->band_start);
  if (!v->fused) { /* the fused pass keeps each tile's ranges in thread_scratch */
    v->path_begin = calloc(v->num_pixels, sizeof(uint32_t));
    v->path_end = calloc(v->num_pixels, sizeof(uint32_t));
  }
  v->segments = calloc(v->num_chunks, sizeof *v->segments);
  if (v->single_stage && (v->kept = calloc(v->num_chunks, sizeof *v->kept)) == NULL) goto fail;
  size_t threads = (size_t)vf_pool_threads(pool);
  v->stats = aligned_alloc(64, threads * sizeof *v->stats);
  if (v->stats != NULL) memset(v->stats, 0, threads * sizeof *v->stats);
  v->scratch = aligned_alloc(64, threads * sizeof *v->scratch);
  if (v->scratch != NULL) memset(v->scratch, 0, threads * sizeof *v->scratch);
  v->lobes = calloc(scene->num_materials > 0 ? (size_t)scene->num_materials : 1, sizeof *v->lobes);
  size_t shapes = scene->num_shapes > 0 ? (size_t)scene->num_shapes : 1;
  v->interpolated = calloc(shapes, sizeof *v->interpolated);
  v->shape_continuation = calloc(shapes, sizeof *v->shape_continuation);
  if (!v->chunks || !v->band_start || (!v->fused && (!v->path_begin || !v->path_end)) || !v->segments || !v->stats ||
      !v->scratch || !v->lobes || !v->interpolated || !v->shape_continuation)
    goto fail;
  for (int m = 0; m < scene->num_materials; m++) vf_bsdf_lobes_of(&scene->materials[m], &v->lobes[m]);
  for (int i = 0; i < scene->num_shapes; i++) {
    v->interpolated[i] = (unsigned char)vf_surface_interpolated(scene, &scene->shapes[i]);
    v->any_interpolated |= v->interpolated[i];
    int m = scene->shapes[i].material;
    v->shape_continuation[i] = m >= 0 ? v->lobes[m].continuation : 1.0f; /* an index-matched boundary */
  }
  v->lane_capacity = settings->max_path_length > 1 ? (uint32_t)settings->max_path_length : 1u;
  for (int t = 0; t < vf_pool_threads(pool); t++) {
    v->scratch[t].ring_vertices = aligned_alloc(64, (size_t)RETIRE_RING * v->lane_capacity * sizeof(light_vertex));
    if (v->scratch[t].ring_vertices == NULL) goto fail;
    if (v->fused && (v->scratch[t].ring_bsdfs = malloc((size_t)RETIRE_RING * v->lane_capacity * sizeof(vf_bsdf))) == NULL)
      goto fail;
    for (uint32_t i = 0; i < RETIRE_RING; i++) v->scratch[t].ring_count[i] = RING_IN_FLIGHT;
  }
  if (v->t.vertex_merging && (err = vf_hashgrid_create(&v->grid)) != VF_OK) goto fail;
  /* A radius per pixel matters only where something merges: otherwise the render is the
   * global radius's, bit for bit (the film still records the setting). */
  if (v->t.vertex_merging && v->settings.radius == VF_RADIUS_PER_PIXEL && (err = vf_pixel_radius_create(v)) != VF_OK)
    goto fail;
  v->vertex_merging_avx512 = vf_merge_pipeline_detect_avx512();
  *out = v;
  return VF_OK;
fail:
  vf_vcm_destroy(v);
  return err;
}

static void free_tile_lists(thread_scratch *ts) {
  free(ts->tile_vertices);
  free(ts->tile_bsdfs);
  ts->tile_vertices = NULL;
  ts->tile_bsdfs = NULL;
  ts->tile_capacity = 0;
}

void vf_vcm_trim(vf_vcm *v) {
  if (v == NULL) return;
  if (v->chunks)
    for (uint32_t c = 0; c < v->num_chunks; c++) {
      light_chunk *ch = &v->chunks[c];
      free(ch->vertices);
      free(ch->bsdfs);
      free(ch->splats);
      ch->vertices = NULL;
      ch->bsdfs = NULL;
      ch->splats = NULL;
      ch->num_vertices = ch->vertex_capacity = ch->num_splats = ch->splat_capacity = 0;
    }
  if (v->scratch)
    for (int t = 0; t < vf_pool_threads(v->pool); t++) free_tile_lists(&v->scratch[t]);
  v->num_vertices = 0;
  free(v->photons);
  v->photons = NULL;
  free(v->photon_c_vc);
  v->photon_c_vc = NULL;
  free(v->photon_source);
  v->photon_source = NULL;
  v->photon_capacity = 0;
  v->merge_points = NULL;
  vf_hashgrid_trim(v->grid);
  vf_single_stage_trim(v);
#ifdef __GLIBC__
  /* The chunks' lists are small allocations from malloc's heap, whose free pages glibc
   * keeps: handed back, or the trim would free nothing the kernel sees. */
  malloc_trim(0);
#endif
}

void vf_vcm_destroy(vf_vcm *v) {
  if (v == NULL) return;
  if (v->chunks)
    for (uint32_t c = 0; c < v->num_chunks; c++) {
      free(v->chunks[c].vertices);
      free(v->chunks[c].bsdfs);
      free(v->chunks[c].splats);
    }
  free(v->chunks);
  vf_single_stage_trim(v);
  free(v->kept);
  free(v->band_start);
  free(v->segments);
  free(v->photons);
  free(v->photon_c_vc);
  free(v->pixel_scale);
  free(v->samples);
  free(v->photon_source);
  free(v->origins);
  free(v->path_begin);
  free(v->path_end);
  if (v->scratch)
    for (int t = 0; t < vf_pool_threads(v->pool); t++) {
      free(v->scratch[t].queries);
      free(v->scratch[t].query_prev);
      free(v->scratch[t].ring_vertices);
      free(v->scratch[t].ring_bsdfs);
      free_tile_lists(&v->scratch[t]);
      free(v->scratch[t].sort_scratch);
    }
  free(v->scratch);
  free(v->stats);
  free(v->lobes);
  free(v->interpolated);
  free(v->shape_continuation);
  free(v->media);
  free(v->light_medium);
  free(v->shape_medium);
  vf_volume_merging_destroy(v);
  vf_hashgrid_destroy(v->grid);
  vf_lights_destroy(v->lights);
  free(v);
}
