/* The scene model (scene.h): bounds, the extent check, scaling, the content hash,
 * destruction. Loading is load.c; parsing json.c, mesh files mesh.c, built-in scenes
 * builtin.c. */
#include "scene.h"

#include "../../common/error.h"

#include <sodium.h>

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void vf_scene_compute_bounds(vf_scene *s) {
  vf_vec3 lo = vf_vec3_splat(INFINITY), hi = vf_vec3_splat(-INFINITY);
  for (int i = 0; i < s->num_shapes; i++) {
    const vf_shape *sh = &s->shapes[i];
    if (sh->kind == VF_SHAPE_SPHERE) {
      vf_vec3 r = vf_vec3_splat(sh->radius);
      lo = vf_vec3_make(fminf(lo.x, sh->center.x - r.x), fminf(lo.y, sh->center.y - r.y), fminf(lo.z, sh->center.z - r.z));
      hi = vf_vec3_make(fmaxf(hi.x, sh->center.x + r.x), fmaxf(hi.y, sh->center.y + r.y), fmaxf(hi.z, sh->center.z + r.z));
      continue;
    }
    for (uint32_t v = 0; v < sh->num_vertices; v++) {
      const float *p = &sh->positions[3 * v];
      lo = vf_vec3_make(fminf(lo.x, p[0]), fminf(lo.y, p[1]), fminf(lo.z, p[2]));
      hi = vf_vec3_make(fmaxf(hi.x, p[0]), fmaxf(hi.y, p[1]), fmaxf(hi.z, p[2]));
    }
  }
  s->bounds_min = lo;
  s->bounds_max = hi;
}

static int beyond(float v) { return !(fabsf(v) <= VF_SCENE_MAX_COORDINATE); }
static int beyond3(vf_vec3 v) { return beyond(v.x) || beyond(v.y) || beyond(v.z); }

int vf_scene_check_extent(const vf_scene *s, const char *label) {
  const char *what = NULL;
  int index = -1;
  for (int i = 0; i < s->num_shapes && what == NULL; i++) {
    const vf_shape *sh = &s->shapes[i];
    if (sh->kind == VF_SHAPE_SPHERE) {
      if (beyond3(sh->center) || beyond(sh->radius) || beyond(fabsf(sh->center.x) + sh->radius) ||
          beyond(fabsf(sh->center.y) + sh->radius) || beyond(fabsf(sh->center.z) + sh->radius))
        what = "shapes", index = i;
      continue;
    }
    for (uint32_t k = 0; k < 3 * sh->num_vertices; k++)
      if (beyond(sh->positions[k])) {
        what = "shapes", index = i;
        break;
      }
  }
  if (what == NULL && beyond3(s->camera.position)) what = "camera.position";
  if (what == NULL && (beyond(s->camera.aperture) || beyond(s->camera.focus_distance))) what = "camera (lens)";
  if (what == NULL && beyond(s->camera.view_width)) what = "camera.width";
  for (int i = 0; i < s->num_point_lights && what == NULL; i++)
    if (beyond3(s->point_lights[i].position)) what = "lights", index = i;
  for (int i = 0; i < s->num_media && what == NULL; i++) /* a grid's box, named by the medium's index */
    if (s->media[i].grid != NULL && (beyond3(s->media[i].grid->box_min) || beyond3(s->media[i].grid->box_max)))
      what = "media (a density grid's box)", index = i;
  if (what == NULL) return VF_OK;
  if (index >= 0)
    return vf_error_set(VF_ESCENE, "%s: %s[%d]: a coordinate beyond %g in world space: the renderer cannot trace it "
                        "(scale the scene down)", label, what, index, (double)VF_SCENE_MAX_COORDINATE);
  return vf_error_set(VF_ESCENE, "%s: %s: a coordinate beyond %g in world space: the renderer cannot trace it", label,
                      what, (double)VF_SCENE_MAX_COORDINATE);
}

void vf_scene_destroy(vf_scene *scene) {
  if (scene == NULL) return;
  for (int i = 0; i < scene->num_shapes; i++) {
    free(scene->shapes[i].positions);
    free(scene->shapes[i].indices);
    free(scene->shapes[i].normals);
    free(scene->shapes[i].uvs);
    free(scene->shapes[i].uvs1);
    free(scene->shapes[i].colors);
    free(scene->shapes[i].tangents);
  }
  free(scene->shapes);
  free(scene->materials);
  free(scene->point_lights);
  free(scene->directional_lights);
  for (int i = 0; i < scene->num_textures; i++) vf_texture_release(&scene->textures[i]);
  free(scene->textures);
  free(scene->notes);
  vf_image_destroy(&scene->envmap);
  for (int i = 0; i < scene->num_media; i++) vf_medium_release(&scene->media[i]);
  free(scene->media);
  free(scene);
}

void vf_medium_release(vf_medium *medium) {
  if (medium->grid != NULL) free(medium->grid->density);
  free(medium->grid);
  medium->grid = NULL;
}

int vf_scene_scale(vf_scene *s, double factor) {
  if (!(factor > 0.0) || !isfinite(factor))
    return vf_error_set(VF_EINVAL, "scene scale %g must be a positive number", factor);
  float f = (float)factor;
  for (int i = 0; i < s->num_shapes; i++) {
    vf_shape *sh = &s->shapes[i];
    for (uint32_t k = 0; k < 3 * sh->num_vertices; k++) sh->positions[k] *= f;
    sh->center = vf_scale(sh->center, f);
    sh->radius *= f;
  }
  s->camera.position = vf_scale(s->camera.position, f);
  s->camera.aperture *= f; /* a thin lens is a length, and so is its distance in focus */
  s->camera.focus_distance *= f;
  s->camera.view_width *= f;
  /* Irradiance from a point light falls with the square of the distance: its intensity
   * grows with the square of the scale. Area lights keep their radiance, directional lights
   * their irradiance, the environment its radiance: none depends on distance. */
  /* Media keep their optical depths: coefficients per unit length shrink as lengths grow,
   * and a grid's box moves with the geometry. */
  for (int i = 0; i < s->num_media; i++) {
    vf_medium *m = &s->media[i];
    m->sigma_a = vf_scale(m->sigma_a, (float)(1.0 / factor));
    m->sigma_s = vf_scale(m->sigma_s, (float)(1.0 / factor));
    if (m->grid != NULL) {
      m->grid->box_min = vf_scale(m->grid->box_min, f);
      m->grid->box_max = vf_scale(m->grid->box_max, f);
    }
  }
  for (int i = 0; i < s->num_point_lights; i++) {
    s->point_lights[i].position = vf_scale(s->point_lights[i].position, f);
    s->point_lights[i].intensity = vf_scale(s->point_lights[i].intensity, (float)(factor * factor));
  }
  int err = vf_scene_check_extent(s, s->source);
  if (err != VF_OK) return err;
  vf_scene_compute_bounds(s);
  vf_scene_hash(s);
  return VF_OK;
}

void vf_scene_bounding_sphere(const vf_scene *scene, vf_vec3 *center, float *radius) {
  *center = vf_scale(vf_add(scene->bounds_min, scene->bounds_max), 0.5f);
  *radius = 0.5f * vf_length(vf_sub(scene->bounds_max, scene->bounds_min));
}

/* ---- content hash ------------------------------------------------------------------------ */

/* The canonical serialisation: little-endian integers and IEEE-754 bit patterns (-0 folded
 * into +0), each section introduced by a NUL-terminated tag. Names and the source path are
 * left out: they do not change a single pixel, and films rendered from a renamed copy of a
 * scene must still merge. Bump the version tag whenever the layout changes. */
typedef struct {
  crypto_generichash_state state;
  unsigned char buf[4096];
  size_t n;
} hasher;

static void h_flush(hasher *h) {
  crypto_generichash_update(&h->state, h->buf, h->n);
  h->n = 0;
}

static void h_bytes(hasher *h, const void *p, size_t n) {
  if (h->n + n > sizeof h->buf) h_flush(h);
  if (n > sizeof h->buf) {
    crypto_generichash_update(&h->state, p, n);
    return;
  }
  memcpy(h->buf + h->n, p, n);
  h->n += n;
}

static void h_u64(hasher *h, uint64_t v) {
  unsigned char b[8];
  for (int i = 0; i < 8; i++) b[i] = (unsigned char)(v >> (8 * i));
  h_bytes(h, b, 8);
}

static void h_u32(hasher *h, uint32_t v) {
  unsigned char b[4] = {(unsigned char)v, (unsigned char)(v >> 8), (unsigned char)(v >> 16), (unsigned char)(v >> 24)};
  h_bytes(h, b, 4);
}

static void h_f32(hasher *h, float f) {
  uint32_t u;
  f = f == 0.0f ? 0.0f : f;
  memcpy(&u, &f, sizeof u);
  h_u32(h, u);
}

static void h_f64(hasher *h, double d) {
  uint64_t u;
  d = d == 0.0 ? 0.0 : d;
  memcpy(&u, &d, sizeof u);
  h_u64(h, u);
}

static void h_vec3(hasher *h, vf_vec3 v) {
  h_f32(h, v.x);
  h_f32(h, v.y);
  h_f32(h, v.z);
}

static void h_tag(hasher *h, const char *tag) { h_bytes(h, tag, strlen(tag) + 1); }

void vf_scene_hash(vf_scene *s) {
  hasher h;
  h.n = 0;
  if (sodium_init() < 0) abort(); /* cannot happen once libsodium is linked; never hash garbage */
  crypto_generichash_init(&h.state, NULL, 0, sizeof s->hash);
  h_tag(&h, "vcmfarm-scene-1");
  h_tag(&h, "camera");
  h_vec3(&h, s->camera.position);
  h_vec3(&h, s->camera.forward);
  h_vec3(&h, s->camera.up);
  h_f32(&h, s->camera.vertical_fov_degrees);
  if (s->camera.aperture > 0.0f) { /* only then: pinhole scenes keep the hashes they had */
    h_tag(&h, "thin lens");
    h_f32(&h, s->camera.aperture);
    h_f32(&h, s->camera.focus_distance);
  }
  if (s->camera.view_width > 0.0f) { /* likewise: perspective scenes keep their hashes */
    h_tag(&h, "orthographic");
    h_f32(&h, s->camera.view_width);
  }
  if (s->camera.mirror) h_tag(&h, "mirrored image"); /* likewise */
  h_tag(&h, "materials");
  h_u32(&h, (uint32_t)s->num_materials);
  for (int i = 0; i < s->num_materials; i++) {
    const vf_material *m = &s->materials[i];
    h_vec3(&h, m->diffuse);
    h_vec3(&h, m->glossy);
    h_f32(&h, m->phong_exponent);
    h_vec3(&h, m->mirror);
    h_vec3(&h, m->dielectric);
    h_f32(&h, m->ior);
  }
  /* The microfacet fields, only of the materials that use them: a scene without them keeps
   * the hash it had before they existed. */
  for (int i = 0; i < s->num_materials; i++) {
    const vf_material *m = &s->materials[i];
    if (m->roughness == 0.0f && vf_is_zero(m->conductor) && vf_is_zero(m->conductor_eta) &&
        vf_is_zero(m->conductor_k) && !m->gltf)
      continue;
    h_tag(&h, "microfacet material");
    h_u32(&h, (uint32_t)i);
    h_f32(&h, m->roughness);
    h_vec3(&h, m->conductor);
    h_vec3(&h, m->conductor_eta);
    h_vec3(&h, m->conductor_k);
    h_u32(&h, (uint32_t)m->gltf);
    h_vec3(&h, m->base_color);
    h_f32(&h, m->metallic);
    if (m->specular_set) { /* KHR_materials_specular: only when given, as above */
      h_tag(&h, "specular");
      h_f32(&h, m->specular);
      h_vec3(&h, m->specular_f0);
    }
    if (m->clearcoat != 0.0f || !vf_is_zero(m->sheen_color)) { /* the layers: likewise */
      h_tag(&h, "clearcoat and sheen");
      h_f32(&h, m->clearcoat);
      h_f32(&h, m->clearcoat_roughness);
      h_f32(&h, m->clearcoat_normal_scale);
      h_vec3(&h, m->sheen_color);
      h_f32(&h, m->sheen_roughness);
    }
  }
  /* Textures and the materials' use of them, only when there are any: untextured scenes
   * keep the hashes they had before textures existed. A texture counts by the hash of its
   * file's bytes (vf_texture.hash). */
  if (s->num_textures > 0) {
    h_tag(&h, "textures");
    h_u32(&h, (uint32_t)s->num_textures);
    for (int i = 0; i < s->num_textures; i++) h_bytes(&h, s->textures[i].hash, sizeof s->textures[i].hash);
  }
  for (int i = 0; i < s->num_materials; i++) {
    const vf_material *m = &s->materials[i];
    if (!vf_material_textured(m) && m->alpha_cutoff == 0.0f) continue;
    h_tag(&h, "textured material");
    h_u32(&h, (uint32_t)i);
    /* The slots after the normal map only when used: earlier scenes keep their hashes. */
    for (int k = 0; k < VF_TEXTURE_SLOTS; k++) {
      const vf_texture_slot *ts = &m->textures[k];
      if (k > VF_TEXTURE_NORMAL && ts->texture == 0) continue;
      if (k > VF_TEXTURE_NORMAL) h_u32(&h, (uint32_t)k);
      h_u32(&h, (uint32_t)ts->texture);
      h_u32(&h, (uint32_t)ts->wrap_s);
      h_u32(&h, (uint32_t)ts->wrap_t);
      if (ts->uv_set != 0 || ts->has_transform) { /* only then, as above */
        h_tag(&h, "uv set and transform");
        h_u32(&h, (uint32_t)ts->uv_set);
        h_u32(&h, (uint32_t)ts->has_transform);
        for (int e = 0; e < 6; e++) h_f32(&h, ts->transform[e]);
      }
    }
    h_f32(&h, m->alpha);
    h_f32(&h, m->alpha_cutoff);
    h_u32(&h, (uint32_t)m->alpha_channel);
    h_f32(&h, m->normal_scale);
  }
  h_tag(&h, "shapes");
  h_u32(&h, (uint32_t)s->num_shapes);
  for (int i = 0; i < s->num_shapes; i++) {
    const vf_shape *sh = &s->shapes[i];
    h_u32(&h, (uint32_t)sh->kind);
    h_u32(&h, (uint32_t)sh->material);
    h_vec3(&h, sh->emission);
    if (sh->kind == VF_SHAPE_SPHERE) {
      h_vec3(&h, sh->center);
      h_f32(&h, sh->radius);
      continue;
    }
    h_u32(&h, sh->num_vertices);
    h_u32(&h, sh->num_triangles);
    for (uint64_t k = 0; k < 3ull * sh->num_vertices; k++) h_f32(&h, sh->positions[k]);
    for (uint64_t k = 0; k < 3ull * sh->num_triangles; k++) h_u32(&h, sh->indices[k]);
    /* Vertex attributes, each only when present (so meshes without them keep their hashes). */
    if (sh->normals != NULL) {
      h_tag(&h, "normals");
      for (uint64_t k = 0; k < 3ull * sh->num_vertices; k++) h_f32(&h, sh->normals[k]);
    }
    if (sh->uvs != NULL) {
      h_tag(&h, "uvs");
      for (uint64_t k = 0; k < 2ull * sh->num_vertices; k++) h_f32(&h, sh->uvs[k]);
    }
    if (sh->uvs1 != NULL) {
      h_tag(&h, "uvs1");
      for (uint64_t k = 0; k < 2ull * sh->num_vertices; k++) h_f32(&h, sh->uvs1[k]);
    }
    if (sh->colors != NULL) {
      h_tag(&h, "colors");
      for (uint64_t k = 0; k < 3ull * sh->num_vertices; k++) h_f32(&h, sh->colors[k]);
    }
    if (sh->tangents != NULL) {
      h_tag(&h, "tangents");
      for (uint64_t k = 0; k < 4ull * sh->num_vertices; k++) h_f32(&h, sh->tangents[k]);
    }
  }
  h_tag(&h, "lights");
  h_u32(&h, (uint32_t)s->num_point_lights);
  for (int i = 0; i < s->num_point_lights; i++) {
    h_vec3(&h, s->point_lights[i].position);
    h_vec3(&h, s->point_lights[i].intensity);
    if (s->point_lights[i].is_spot) { /* only then: point lights keep the hashes they had */
      h_tag(&h, "spot");
      h_vec3(&h, s->point_lights[i].direction);
      h_f32(&h, s->point_lights[i].inner_cone_angle);
      h_f32(&h, s->point_lights[i].outer_cone_angle);
    }
  }
  h_u32(&h, (uint32_t)s->num_directional_lights);
  for (int i = 0; i < s->num_directional_lights; i++) {
    h_vec3(&h, s->directional_lights[i].direction);
    h_vec3(&h, s->directional_lights[i].irradiance);
  }
  h_vec3(&h, s->background);
  h_tag(&h, "envmap");
  h_u32(&h, (uint32_t)s->envmap.width);
  h_u32(&h, (uint32_t)s->envmap.height);
  if (s->envmap.width > 0) {
    for (long k = 0; k < 3L * s->envmap.width * s->envmap.height; k++) h_f32(&h, s->envmap.rgb[k]);
    h_vec3(&h, s->envmap_scale);
    /* Only a turned map adds to the hash, so the hashes of unturned ones stay as they were. */
    if (s->envmap_rotated) {
      h_tag(&h, "envmap_rotation");
      for (int r = 0; r < 3; r++)
        for (int k = 0; k < 3; k++) h_f32(&h, s->envmap_rotation[r][k]);
    }
  }
  /* Media, only in scenes that have them or an interface: scenes without keep their
   * hashes. A grid counts by its samples and box (not its file's name or bytes). */
  int interfaces = 0;
  for (int i = 0; i < s->num_shapes; i++) interfaces |= s->shapes[i].interface;
  if (s->num_media > 0 || interfaces || s->medium >= 0) {
    h_tag(&h, "media");
    h_u32(&h, (uint32_t)s->num_media);
    for (int i = 0; i < s->num_media; i++) {
      const vf_medium *m = &s->media[i];
      h_vec3(&h, m->sigma_a);
      h_vec3(&h, m->sigma_s);
      h_f32(&h, m->g);
      h_u32(&h, m->grid != NULL);
      if (m->grid == NULL) continue;
      const vf_density_grid *g = m->grid;
      h_u32(&h, g->nx);
      h_u32(&h, g->ny);
      h_u32(&h, g->nz);
      h_vec3(&h, g->box_min);
      h_vec3(&h, g->box_max);
      for (uint64_t k = 0; k < (uint64_t)g->nx * g->ny * g->nz; k++) h_f32(&h, g->density[k]);
    }
    h_u32(&h, (uint32_t)s->medium);
    for (int i = 0; i < s->num_shapes; i++) {
      h_u32(&h, (uint32_t)s->shapes[i].interface);
      h_u32(&h, (uint32_t)s->shapes[i].interior);
      h_u32(&h, (uint32_t)s->shapes[i].exterior);
    }
  }
  h_tag(&h, "settings");
  h_u32(&h, s->settings_given);
  if (s->settings_given & VF_SET_ALGORITHM) h_u32(&h, (uint32_t)s->settings.algorithm);
  if (s->settings_given & VF_SET_MAX_PATH_LENGTH) h_u32(&h, (uint32_t)s->settings.max_path_length);
  if (s->settings_given & VF_SET_RADIUS_FACTOR) h_f64(&h, s->settings.radius_factor);
  if (s->settings_given & VF_SET_ALPHA) h_f64(&h, s->settings.alpha);
  if (s->settings_given & VF_SET_SEED) h_u64(&h, s->settings.seed);
  if (s->settings_given & VF_SET_MIS_BETA) h_f64(&h, s->settings.mis_beta);
  if (s->settings_given & VF_SET_GATHER) h_u32(&h, (uint32_t)s->settings.gather);
  if (s->settings_given & VF_SET_RADIUS) h_u32(&h, (uint32_t)s->settings.radius);
  if (s->settings_given & VF_SET_RESOLUTION) {
    h_u32(&h, (uint32_t)s->settings.width);
    h_u32(&h, (uint32_t)s->settings.height);
  }
  h_flush(&h);
  crypto_generichash_final(&h.state, s->hash, sizeof s->hash);
}

void vf_scene_hash_hex(const vf_scene *scene, char out[65]) {
  sodium_bin2hex(out, 65, scene->hash, sizeof scene->hash);
}
