/* Whole-scene import: a glTF 2.0 or OBJ+MTL file (anything Assimp reads) brought into the
 * scene with its meshes, materials, cameras and lights (docs/SCENES.md, "import").
 *
 * The JSON field "import" lists the files; a model file given to vf_scene_load is loaded
 * through the same field, from the JSON text vf_scene_model_text writes, so a farm job
 * carries that text and ships exactly the files the load reads (files.h).
 *
 * Each mesh instance of the node hierarchy becomes one shape with its own material; a
 * material named like one of the JSON's "materials" is replaced by it. Cameras and lights
 * take their node's world transform. Everything the file asks for that vcmfarm cannot do
 * becomes a note (vf_scene_note) naming the file. */
#include "import.h"

#include "../../common/error.h"
#include "assimp_api.h"
#include "fields.h"
#include "gltf.h"
#include "mesh.h"
#include "shapes.h"

#include <assimp/cimport.h>
#include <assimp/material.h>
#include <assimp/scene.h>
#include <cjson/cJSON.h>

#include <ctype.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* Width of the image a file's camera gets when the scene does not set a resolution; the
 * height follows the camera's aspect ratio. */
#define IMPORT_WIDTH 1280

typedef struct {
  vf_import_file f;
  const vf_affine *root;  /* the entry's "transform" */
  int json_materials;     /* materials [0, json_materials) are the JSON's: they override by name */
  int *material_of;       /* aiMaterial index -> scene material, -1 not made yet */
  vf_vec3 *emission_of;   /* aiMaterial index -> its emission */
  int *interior_of;       /* aiMaterial index -> the medium inside its meshes (glTF's KHR_materials_volume), -1 none */
  vf_mesh_tally tally;
  int took_camera;        /* this file gave the scene its camera */
  float kd_ks_largest;    /* f.kd_ks_largest points here */
  int photometric;        /* the entry's "light_units": "photometric" (import_light) */
  vf_name_index json_names; /* of materials [0, json_materials) */
} import_state;

/* Lumens per watt of 555 nm light: KHR_lights_punctual's candela over Blender's W/sr. */
#define VF_LUMINOUS_EFFICACY 683.0

/* ---- materials ------------------------------------------------------------------------------- */

/* The scene material of aiMaterial k: made on first use, or the JSON's of the same name. */
static int material_for(const parse_ctx *c, import_state *st, unsigned k, int *out) {
  vf_scene *s = c->scene;
  if (k >= st->f.ai->mNumMaterials) return vf_scene_fail(c, VF_EMESH, st->f.what, "a mesh names a missing material");
  if (st->material_of[k] >= 0) {
    *out = st->material_of[k];
    return VF_OK;
  }
  /* An override replaces the file's material whole, emission included: the file's is not
   * read, so its textures need not exist. */
  struct aiString name;
  int j = -1;
  if (vf_assimp()->aiGetMaterialString(st->f.ai->mMaterials[k], AI_MATKEY_NAME, &name) == aiReturn_SUCCESS && name.length > 0)
    j = vf_name_index_find(&st->json_names, name.data);
  if (j < 0) {
    vf_material m;
    int err = vf_scene_import_material(c, &st->f, k, &m, &st->emission_of[k], &st->interior_of[k]);
    if (err < 0) return err;
    vf_material *grown = realloc(s->materials, (size_t)(s->num_materials + 1) * sizeof *grown);
    if (grown == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
    s->materials = grown;
    s->materials[j = s->num_materials++] = m;
  }
  *out = st->material_of[k] = j;
  return VF_OK;
}

/* ---- shapes ---------------------------------------------------------------------------------- */

static int add_shape(vf_scene *s, vf_shape **out) {
  vf_shape *grown = realloc(s->shapes, (size_t)(s->num_shapes + 1) * sizeof *grown);
  if (grown == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  s->shapes = grown;
  *out = memset(&s->shapes[s->num_shapes++], 0, sizeof *grown); /* zero: safe to destroy */
  return VF_OK;
}

/* One shape per (node, mesh) of the hierarchy: instances of a mesh are shapes of their own. */
static int import_instance(void *user, const struct aiNode *node, unsigned mesh_index, const vf_affine *world) {
  import_state *st = user;
  const parse_ctx *c = st->f.c;
  const struct aiMesh *mesh = st->f.ai->mMeshes[mesh_index];
  vf_affine a;
  vf_shape *s = NULL;
  int material = 0, err;
  if (mesh->mNumVertices == 0 && st->f.gltf.uses_draco &&
      (err = vf_scene_note(c, "%s: a Draco-compressed mesh was not decoded (Assimp without Draco): not rendered",
                           st->f.file)) < 0)
    return err;
  if (vf_scene_mesh_triangles(mesh) == 0) return VF_OK; /* points and lines only: not a surface */
  if ((err = material_for(c, st, mesh->mMaterialIndex, &material)) < 0) return err;
  a = *world; /* the walk started from the entry's transform */
  if ((err = add_shape(c->scene, &s)) < 0) return err;
  s->kind = VF_SHAPE_MESH;
  s->material = material;
  if ((err = vf_scene_append_mesh(c, st->f.what, mesh, mesh_index, &a, s, &st->tally)) < 0) return err;
  const char *name = mesh->mName.length ? mesh->mName.data : node->mName.data;
  snprintf(s->name, sizeof s->name, "%.63s", name[0] ? name : st->f.file); /* names only name: cut is fine */
  s->emission = st->emission_of[mesh->mMaterialIndex];
  s->interior = st->interior_of[mesh->mMaterialIndex]; /* kept only if the mesh is closed (interfaces.c) */
  s->exterior = -1;
  /* An emitter without area would have infinite radiance per unit power. */
  if (!vf_is_zero(s->emission) && !(vf_scene_mesh_area(s) > 0.0)) {
    s->emission = vf_vec3_splat(0.0f);
    if ((err = vf_scene_note(c, "%s: emissive meshes without area do not emit", st->f.file)) < 0) return err;
  }
  if (mesh->mTextureCoords[2] != NULL &&
      (err = vf_scene_note(c, "%s: meshes with more than two uv sets: sets 0 and 1 are read", st->f.file)) < 0)
    return err;
  return VF_OK;
}

/* ---- cameras ----------------------------------------------------------------------------------- */

/* The first node named `name`, depth first; with `meshless`, the first that holds no mesh. */
static const struct aiNode *find_node(const struct aiNode *n, const struct aiString *name, int meshless, int depth) {
  if (n == NULL || depth > 256) return NULL;
  if (n->mName.length == name->length && memcmp(n->mName.data, name->data, name->length) == 0 &&
      (!meshless || n->mNumMeshes == 0))
    return n;
  for (unsigned i = 0; i < n->mNumChildren; i++) {
    const struct aiNode *found = find_node(n->mChildren[i], name, meshless, depth + 1);
    if (found) return found;
  }
  return NULL;
}

/* The world transform of the node named `name` (a camera's or light's: Assimp names them
 * by their node), after the entry's. A mesh's node may carry the same name: a node
 * without a mesh of that name is the camera's or light's, else the first of that name. */
static void world_of(const import_state *st, const struct aiString *name, vf_affine *out) {
  vf_affine node;
  const struct aiNode *n = find_node(st->f.ai->mRootNode, name, 1, 0);
  if (n == NULL) n = find_node(st->f.ai->mRootNode, name, 0, 0);
  if (n != NULL) vf_scene_node_world(n, &node);
  else vf_affine_identity(&node);
  vf_affine_mul(st->root, &node, out);
}

static vf_vec3 vec_of(const double d[3]) { return vf_vec3_make((float)d[0], (float)d[1], (float)d[2]); }

/* Assimp marks an orthographic camera by a zero field of view and its half width in
 * mOrthographicWidth (glTF's xmag; mAspect is xmag / ymag). */
static int is_orthographic(const struct aiCamera *cam) { return cam->mOrthographicWidth > 0.0f; }
static int is_perspective(const struct aiCamera *cam) {
  return cam->mHorizontalFOV > 0.0f && cam->mOrthographicWidth == 0.0f;
}

/* Sets the scene's camera, and the resolution its aspect ratio asks for unless the scene
 * gives one. */
static int take_resolution(vf_scene *s, double aspect, vf_camera_desc d) {
  s->camera = d;
  if (!(s->settings_given & VF_SET_RESOLUTION)) {
    double h = aspect > 0.0 ? IMPORT_WIDTH / aspect : IMPORT_WIDTH * 9.0 / 16.0;
    s->settings.width = IMPORT_WIDTH;
    s->settings.height = (int)fmin(fmax(floor(h + 0.5), 1.0), 65536.0);
    s->settings_given |= VF_SET_RESOLUTION;
  }
  return VF_OK;
}

/* The camera's view into the scene's camera, and the resolution its aspect ratio asks for. */
static int take_camera(const parse_ctx *c, const import_state *st, unsigned index) {
  const struct aiCamera *cam = st->f.ai->mCameras[index];
  vf_scene *s = c->scene;
  vf_affine w;
  world_of(st, &cam->mName, &w);
  /* Assimp 5.2.5's glTF reader copies the node's translation into mPosition as well,
   * although the node's transform holds it: a glTF camera sits at its node's origin. */
  double p[3] = {cam->mPosition.x, cam->mPosition.y, cam->mPosition.z}, wp[3];
  if (st->f.gltf_file) p[0] = p[1] = p[2] = 0.0;
  double l[3] = {cam->mLookAt.x, cam->mLookAt.y, cam->mLookAt.z}, wl[3];
  double u[3] = {cam->mUp.x, cam->mUp.y, cam->mUp.z}, wu[3];
  vf_affine_point(&w, p, wp);
  vf_affine_vector(&w, l, wl);
  vf_affine_vector(&w, u, wu);
  vf_camera_desc d = {.position = vec_of(wp)};
  vf_vec3 up = vec_of(wu);
  if (!vf_scene_unit(vec_of(wl), &d.forward)) return vf_scene_fail(c, VF_ESCENE, st->f.what, "camera %u has no viewing direction", index);
  vf_vec3 up_orth = vf_sub(up, vf_scale(d.forward, vf_dot(up, d.forward)));
  if (!(vf_length(up_orth) > 1e-4f * vf_length(up)) || !vf_scene_unit(up_orth, &d.up))
    return vf_scene_fail(c, VF_ESCENE, st->f.what, "camera %u: up is zero or parallel to the viewing direction", index);
  double aspect = cam->mAspect > 0.0f && isfinite(cam->mAspect) ? cam->mAspect : 0.0, fov;
  if (is_orthographic(cam)) {
    /* The half width is a length in the camera node's space: the node's scale applies. */
    double half[3] = {cam->mOrthographicWidth, 0.0, 0.0}, world_half[3];
    vf_affine_vector(&w, half, world_half);
    d.view_width = (float)(2.0 * sqrt(world_half[0] * world_half[0] + world_half[1] * world_half[1] +
                                      world_half[2] * world_half[2]));
    if (!(d.view_width > 0.0f && isfinite(d.view_width)))
      return vf_scene_fail(c, VF_ESCENE, st->f.what, "camera %u: orthographic width %g is not a positive length", index,
                           d.view_width);
    return take_resolution(s, aspect, d);
  }
  /* Assimp 5.2.5's glTF reader stores yfov x aspect in mHorizontalFOV (not the half angle
   * other readers store, as aiCamera documents): each is undone as it was made. */
  if (st->f.gltf_file) fov = cam->mHorizontalFOV / (aspect > 0.0 ? aspect : 1.0);
  else fov = 2.0 * atan(tan(cam->mHorizontalFOV) / (aspect > 0.0 ? aspect : 1.0));
  d.vertical_fov_degrees = (float)(fov * 180.0 / M_PI);
  if (!(d.vertical_fov_degrees > 0.0f && d.vertical_fov_degrees < 180.0f))
    return vf_scene_fail(c, VF_ESCENE, st->f.what, "camera %u: vertical field of view %g degrees is not in (0, 180)",
                         index, d.vertical_fov_degrees);
  return take_resolution(s, aspect, d);
}

/* The list of the file's cameras for an error: "0 'Main', 1 'Top'". */
static void camera_names(const struct aiScene *ai, char *out, size_t n) {
  size_t used = 0;
  out[0] = '\0';
  for (unsigned i = 0; i < ai->mNumCameras && used + 1 < n; i++) {
    int w = snprintf(out + used, n - used, "%s%u '%s'", i ? ", " : "", i, ai->mCameras[i]->mName.data);
    if (w < 0) break;
    used += (size_t)w;
  }
}

/* A camera selection: a name, else a whole number as an index. */
static int select_camera(const parse_ctx *c, const import_state *st, const cJSON *sel, const char *path) {
  const struct aiScene *ai = st->f.ai;
  char names[1024];
  long index = -1;
  if (cJSON_IsString(sel)) {
    for (unsigned i = 0; i < ai->mNumCameras && index < 0; i++)
      if (strcmp(ai->mCameras[i]->mName.data, sel->valuestring) == 0) index = i;
    char *end;
    if (index < 0 && isdigit((unsigned char)sel->valuestring[0])) {
      long k = strtol(sel->valuestring, &end, 10);
      if (*end == '\0') index = k < (long)ai->mNumCameras ? k : -2;
    }
  } else if (cJSON_IsNumber(sel) && sel->valuedouble >= 0 && sel->valuedouble == floor(sel->valuedouble)) {
    index = sel->valuedouble < ai->mNumCameras ? (long)sel->valuedouble : -2;
  } else {
    return vf_scene_fail(c, VF_ESCENE, path, "expected a camera name or index, found %s", vf_scene_kind(sel));
  }
  if (index < 0) {
    camera_names(ai, names, sizeof names);
    char what[64];
    if (cJSON_IsString(sel)) snprintf(what, sizeof what, "'%.40s'", sel->valuestring);
    else snprintf(what, sizeof what, "%g", sel->valuedouble);
    if (ai->mNumCameras == 0) return vf_scene_fail(c, VF_ESCENE, path, "no camera %s: %s has no camera", what, st->f.file);
    return vf_scene_fail(c, VF_ESCENE, path, "no camera %s in %s (its cameras: %s)", what, st->f.file, names);
  }
  if (!is_perspective(ai->mCameras[index]) && !is_orthographic(ai->mCameras[index]))
    return vf_scene_fail(c, VF_ESCENE, path, "camera %ld '%s' of %s has neither a field of view nor a width", index,
                         ai->mCameras[index]->mName.data, st->f.file);
  return take_camera(c, st, (unsigned)index);
}

/* ---- lights ------------------------------------------------------------------------------------ */

static int grow_lights(void **p, int count, size_t size) {
  void *q = realloc(*p, (size_t)(count + 1) * size);
  if (q == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  *p = q;
  return VF_OK;
}

/* A spot's cone: glTF's are half-angles, as Assimp's glTF reader copies them; Assimp's
 * documented convention (other readers) is the full angle. */
static int spot_cone(const parse_ctx *c, const import_state *st, const struct aiLight *l, vf_point_light_desc *d) {
  double k = st->f.gltf_file ? 1.0 : 0.5, inner = k * l->mAngleInnerCone, outer = k * l->mAngleOuterCone;
  int err;
  if (!(outer > 0.0)) return vf_scene_fail(c, VF_ESCENE, st->f.what, "spot light '%s' has no cone", l->mName.data);
  if (outer > M_PI / 2) {
    if ((err = vf_scene_note(c, "%s: spot cones wider than 90 degrees are narrowed to 90", st->f.file)) < 0) return err;
    outer = M_PI / 2;
  }
  if (!(inner >= 0.0)) inner = 0.0;
  if (inner >= outer) inner = 0.999 * outer; /* a hard edge; the falloff needs inner < outer */
  d->inner_cone_angle = (float)inner;
  d->outer_cone_angle = (float)outer;
  return VF_OK;
}

/* KHR_lights_punctual's intensities are photometric (candela, lux), and
 * KHR_materials_emissive_strength's emission is read as written. By default (Blender's
 * reading: its glTF importer and exporter, and Cycles) a point or spot light of I candela
 * has the radiant intensity I / 683 W/sr, the luminous efficacy of 555 nm light, and a
 * directional light's lux are its irradiance in W/m^2 as written (Blender's sun strength).
 * The "photometric" reading of an import entry reads candela as written too, both kinds
 * of light then in photometric units (docs/SCENES.md, "Light units"). */
static int import_light(const parse_ctx *c, const import_state *st, const struct aiLight *l) {
  vf_scene *s = c->scene;
  vf_affine w;
  world_of(st, &l->mName, &w);
  vf_vec3 color = vf_vec3_make(l->mColorDiffuse.r, l->mColorDiffuse.g, l->mColorDiffuse.b);
  if (st->f.gltf_file && !st->photometric && (l->mType == aiLightSource_POINT || l->mType == aiLightSource_SPOT))
    color = vf_scale(color, (float)(1.0 / VF_LUMINOUS_EFFICACY));
  if (!(vf_min_component(color) >= 0.0f && vf_max_component(color) <= FLT_MAX))
    return vf_scene_fail(c, VF_ESCENE, st->f.what, "light '%s' has a negative or non-finite intensity", l->mName.data);
  double p[3] = {l->mPosition.x, l->mPosition.y, l->mPosition.z}, dir[3] = {l->mDirection.x, l->mDirection.y, l->mDirection.z};
  double wp[3], wd[3];
  vf_affine_point(&w, p, wp);
  vf_affine_vector(&w, dir, wd);
  int err;
  if (l->mType == aiLightSource_POINT || l->mType == aiLightSource_SPOT) {
    if ((err = grow_lights((void **)&s->point_lights, s->num_point_lights, sizeof *s->point_lights)) < 0) return err;
    vf_point_light_desc d = {.position = vec_of(wp), .intensity = color};
    if (l->mType == aiLightSource_SPOT) {
      d.is_spot = 1;
      if (!vf_scene_unit(vec_of(wd), &d.direction))
        return vf_scene_fail(c, VF_ESCENE, st->f.what, "spot light '%s' has no direction", l->mName.data);
      if ((err = spot_cone(c, st, l, &d)) < 0) return err;
    }
    s->point_lights[s->num_point_lights++] = d;
  } else if (l->mType == aiLightSource_DIRECTIONAL) {
    if ((err = grow_lights((void **)&s->directional_lights, s->num_directional_lights, sizeof *s->directional_lights)) < 0)
      return err;
    vf_directional_light_desc d = {.irradiance = color};
    if (!vf_scene_unit(vec_of(wd), &d.direction))
      return vf_scene_fail(c, VF_ESCENE, st->f.what, "directional light '%s' has no direction", l->mName.data);
    s->directional_lights[s->num_directional_lights++] = d;
  } else {
    return vf_scene_note(c, "%s: ambient and area lights are not supported: ignored", st->f.file);
  }
  return VF_OK;
}

/* ---- one "import" entry ------------------------------------------------------------------------ */

/* Whether the scene is the model file itself (vf_scene_model_text): messages then name the
 * file alone, without the JSON field a user never wrote. */
static int is_model_scene(const parse_ctx *c, const char *file) {
  size_t n = strlen(c->label), k = strlen(file);
  return strcmp(c->label, file) == 0 || (n > k && c->label[n - k - 1] == '/' && strcmp(c->label + n - k, file) == 0);
}

static int import_contents(const parse_ctx *c, import_state *st, const cJSON *camera_sel, const char *camera_path,
                           int take_first_camera) {
  const struct aiScene *ai = st->f.ai;
  int err;
  if ((err = vf_scene_walk_nodes(c, st->f.what, ai, st->root, import_instance, st)) < 0) return err;
  if ((err = vf_scene_note_dropped(c, st->f.file, &st->tally)) < 0) return err;
  if (st->kd_ks_largest > 0.0f &&
      (err = vf_scene_note(c, "%s: materials with Kd + Ks above 1 are scaled down to 1 (the largest sum: %g)",
                           st->f.file, (double)st->kd_ks_largest)) < 0)
    return err;
  int punctual_before = c->scene->num_point_lights;
  for (unsigned i = 0; i < ai->mNumLights; i++)
    if ((err = import_light(c, st, ai->mLights[i])) < 0) return err;
  int emits = 0;
  for (unsigned k = 0; k < ai->mNumMaterials; k++) emits |= st->material_of[k] >= 0 && !vf_is_zero(st->emission_of[k]);
  if (st->f.gltf_file && emits && c->scene->num_point_lights > punctual_before &&
      (err = vf_scene_note(c, "%s: light units: %s", st->f.file,
                           st->photometric ? "punctual lights in candela beside emission as written (photometric)"
                                           : "punctual lights in W/sr = candela / 683 beside emission as written "
                                             "(Blender's reading)")) < 0)
    return err;
  if (camera_sel != NULL) {
    if ((err = select_camera(c, st, camera_sel, camera_path)) < 0) return err;
    st->took_camera = 1;
  }
  for (unsigned i = 0; take_first_camera && !st->took_camera && i < ai->mNumCameras; i++)
    if (is_perspective(ai->mCameras[i]) || is_orthographic(ai->mCameras[i])) {
      if ((err = take_camera(c, st, i)) < 0) return err;
      st->took_camera = 1;
    }
  if (ai->mNumAnimations > 0 && (err = vf_scene_note(c, "%s: animations are ignored: the scene is rendered at rest",
                                                     st->f.file)) < 0)
    return err;
  return VF_OK;
}

static int import_entry(const parse_ctx *c, const cJSON *j, int index, int json_materials, int *camera_wanted,
                        int selects_here) {
  static const char *const fields[] = {"file", "transform", "camera", "light_units", NULL};
  char path[PATH_LEN], fpath[PATH_LEN], cpath[PATH_LEN], what[PATH_LEN + 80], dir[PATH_LEN];
  const char *file;
  const cJSON *tj, *camera_sel = NULL;
  vf_affine root;
  int err;
  vf_scene_join_index(path, "import", index);
  if ((err = vf_scene_check_object(c, j, path, fields)) < 0) return err;
  if ((err = vf_scene_string_field(c, j, path, "file", REQUIRED, &file)) < 0) return err;
  vf_affine_identity(&root);
  if (vf_scene_member(c, j, path, "transform", OPTIONAL, &tj) &&
      (err = vf_scene_parse_transform(c, tj, vf_scene_join(cpath, path, "transform"), &root)) < 0)
    return err;
  const char *units = "blender";
  if ((err = vf_scene_string_field(c, j, path, "light_units", OPTIONAL, &units)) < 0) return err;
  if (strcmp(units, "blender") != 0 && strcmp(units, "photometric") != 0)
    return vf_scene_fail(c, VF_ESCENE, vf_scene_join(cpath, path, "light_units"),
                         "expected \"blender\" or \"photometric\", found '%s'", units);
  int model = is_model_scene(c, file);
  vf_scene_join(cpath, path, "camera");
  if (vf_scene_member(c, j, path, "camera", OPTIONAL, &camera_sel) && !*camera_wanted)
    return vf_scene_fail(c, VF_ESCENE, cpath, "the scene has a 'camera' already");
  if (model) snprintf(cpath, sizeof cpath, "--camera");
  snprintf(what, sizeof what, "%s (%s)", path, file);
  vf_scene_join(fpath, path, "file");
  const char *slash = strrchr(file, '/');
  snprintf(dir, sizeof dir, "%.*s", slash ? (int)(slash - file) : 0, file);
  import_state st = {.f = {.c = c, .file = file, .what = model ? NULL : what, .dir = dir,
                           .gltf_file = vf_gltf_is_gltf(file)},
                     .root = &root, .json_materials = json_materials, .photometric = units[0] == 'p'};
  st.f.kd_ks_largest = &st.kd_ks_largest;
  if ((err = vf_scene_import_file(c, file, model ? NULL : fpath, st.f.what, &st.f.ai)) < 0) return err;
  if (st.f.gltf_file) err = vf_gltf_read_info(c, file, st.f.what, &st.f.gltf);
  unsigned nm = st.f.ai->mNumMaterials;
  st.material_of = malloc((nm ? nm : 1) * sizeof *st.material_of);
  st.emission_of = calloc(nm ? nm : 1, sizeof *st.emission_of);
  st.interior_of = malloc((nm ? nm : 1) * sizeof *st.interior_of);
  if (err == VF_OK && (st.material_of == NULL || st.emission_of == NULL || st.interior_of == NULL))
    err = vf_error_set(VF_ENOMEM, "out of memory");
  if (err == VF_OK) err = vf_name_index_build(c->scene, json_materials, &st.json_names);
  for (unsigned k = 0; err == VF_OK && k < nm; k++) st.material_of[k] = st.interior_of[k] = -1;
  int take_first = *camera_wanted && selects_here < 0;
  if (err == VF_OK)
    err = import_contents(c, &st, selects_here == index ? camera_sel : NULL, cpath, take_first);
  if (err == VF_OK && st.took_camera) *camera_wanted = 0;
  vf_name_index_release(&st.json_names);
  free(st.material_of);
  free(st.emission_of);
  free(st.interior_of);
  vf_gltf_info_release(&st.f.gltf);
  vf_assimp()->aiReleaseImport(st.f.ai);
  return err;
}

int vf_scene_parse_imports(const parse_ctx *c, const cJSON *j, int json_materials, int *camera_wanted) {
  if (!cJSON_IsArray(j) || cJSON_GetArraySize(j) == 0)
    return vf_scene_fail(c, VF_ESCENE, "import", "expected a non-empty array of objects");
  int i = 0, selects = -1, err;
  const cJSON *e;
  /* At most one entry chooses the scene's camera; without one, the first file that has a
   * perspective camera gives its first. */
  cJSON_ArrayForEach(e, j) {
    if (cJSON_IsObject(e) && cJSON_HasObjectItem(e, "camera")) {
      if (selects >= 0)
        return vf_scene_fail(c, VF_ESCENE, "import", "only one entry may choose the camera (entries %d and %d do)",
                             selects, i);
      selects = i;
    }
    i++;
  }
  i = 0;
  cJSON_ArrayForEach(e, j) {
    if ((err = import_entry(c, e, i++, json_materials, camera_wanted, selects)) < 0) return err;
  }
  return VF_OK;
}

/* ---- what a scene without a camera or a light gets ----------------------------------------------- */

/* The side a default camera looks from: the axis (+z, glTF's front, then +x, then +y on a
 * tie) along which the bounds' projection has the largest area, so that a model flat in
 * some plane is seen face on (a polygon in a plane x = const rendered blank from +z). */
static int default_view_side(vf_vec3 extent, vf_vec3 *from, vf_vec3 *up, const char **name) {
  const double area[3] = {(double)extent.x * extent.y, (double)extent.z * extent.y, (double)extent.x * extent.z};
  int side = 0; /* 0: +z, 1: +x, 2: +y */
  for (int k = 1; k < 3; k++)
    if (area[k] > area[side]) side = k;
  *up = vf_vec3_make(0.0f, 1.0f, 0.0f);
  if (side == 0) { /* from the front, a little above, as a person looks at a model */
    vf_scene_unit(vf_vec3_make(0.0f, 0.3f, 1.0f), from);
    *name = "+z";
  } else if (side == 1) {
    vf_scene_unit(vf_vec3_make(1.0f, 0.3f, 0.0f), from);
    *name = "+x";
  } else { /* from above, the image's up along -z (the model's back) */
    *from = vf_vec3_make(0.0f, 1.0f, 0.0f);
    *up = vf_vec3_make(0.0f, 0.0f, -1.0f);
    *name = "+y";
  }
  return side;
}

int vf_scene_default_camera(const parse_ctx *c) {
  vf_scene *s = c->scene;
  vf_vec3 center, from, up;
  float radius;
  const char *side;
  vf_scene_compute_bounds(s);
  vf_scene_bounding_sphere(s, &center, &radius);
  if (!(radius > 0.0f)) radius = 1.0f;
  default_view_side(vf_sub(s->bounds_max, s->bounds_min), &from, &up, &side);
  /* Far enough that the bounding sphere fits the 40-degree vertical field of view. */
  const float fov = 40.0f;
  float distance = 1.1f * radius / sinf(0.5f * fov * (float)(M_PI / 180.0));
  s->camera = (vf_camera_desc){.position = vf_add(center, vf_scale(from, distance)), .vertical_fov_degrees = fov};
  vf_scene_unit(vf_scale(from, -1.0f), &s->camera.forward);
  vf_scene_unit(vf_sub(up, vf_scale(s->camera.forward, vf_dot(up, s->camera.forward))), &s->camera.up);
  if (!(s->settings_given & VF_SET_RESOLUTION)) {
    s->settings.width = IMPORT_WIDTH;
    s->settings.height = IMPORT_WIDTH * 9 / 16;
    s->settings_given |= VF_SET_RESOLUTION;
  }
  return vf_scene_note(c, "no camera: a default camera looks at the scene's bounds from %s, the side of their largest "
                          "projected area (fov 40 degrees)", side);
}

/* The mean of a colour texture's RGB over its texels, 8-bit texels decoded from sRGB as the
 * emission slot decodes them (a texture's mean over a surface whose uvs cover it once). */
static double texture_mean(const vf_texture *t) {
  const size_t n = (size_t)t->width * t->height, ch = (size_t)t->channels, colour = ch < 3 ? 1 : 3;
  double sum = 0.0, lut[256];
  for (int v = 0; v < 256; v++) {
    double c = v / 255.0;
    lut[v] = c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
  }
  for (size_t i = 0; i < n; i++)
    for (size_t k = 0; k < colour; k++)
      sum += t->is_float ? ((const float *)t->texels)[i * ch + k] : lut[((const uint8_t *)t->texels)[i * ch + k]];
  return sum / ((double)n * (double)colour);
}

/* A shape's mean emitted radiance (RGB mean): its emission scaled by its emission
 * texture's mean. */
static double emitted_radiance(const vf_scene *s, const vf_shape *sh) {
  double l = (sh->emission.x + sh->emission.y + sh->emission.z) / 3.0;
  if (sh->material < 0) return l; /* an index-matched boundary: it never emits */
  const vf_texture_slot *ts = &s->materials[sh->material].textures[VF_TEXTURE_EMISSION];
  if (l > 0.0 && ts->texture > 0) l *= texture_mean(&s->textures[ts->texture - 1]);
  return l;
}

static vf_vec3 corner(const vf_shape *sh, uint32_t t, int k) {
  const float *p = &sh->positions[3 * (size_t)sh->indices[3 * (size_t)t + k]];
  return vf_vec3_make(p[0], p[1], p[2]);
}

/* Up to this many triangles of the emitters and of the other surfaces, evenly strided, go
 * into the estimate below: 4096 x 4096 distance computations, a few tens of milliseconds. */
#define DIM_SAMPLES 4096

/* The radiance a white Lambertian surface would reach, on average over the scene's
 * non-emitting triangles (their centroids, weighted by area), from its emitting triangles
 * seen as small one-sided Lambertian sources (L A cos_e cos_r / (pi d^2) each, occlusion
 * ignored) and emitting spheres as points of their power. *power gets the emitters' total. */
static double dim_level(const vf_scene *s, double *power) {
  uint64_t emitting = 0, receiving = 0;
  *power = 0.0;
  for (int i = 0; i < s->num_shapes; i++) {
    const vf_shape *sh = &s->shapes[i];
    if (sh->kind != VF_SHAPE_MESH) continue;
    if (emitted_radiance(s, sh) > 0.0) emitting += sh->num_triangles;
    else receiving += sh->num_triangles;
  }
  uint64_t e_stride = emitting / DIM_SAMPLES + 1, r_stride = receiving / DIM_SAMPLES + 1, e_index = 0, r_index = 0;
  double weighted = 0.0, area_sum = 0.0;
  for (int i = 0; i < s->num_shapes; i++) { /* the emitters' power, exactly */
    const vf_shape *sh = &s->shapes[i];
    double l = emitted_radiance(s, sh);
    if (l <= 0.0) continue;
    *power += sh->kind == VF_SHAPE_SPHERE ? M_PI * l * 4.0 * M_PI * (double)sh->radius * sh->radius
                                          : M_PI * l * vf_scene_mesh_area(sh);
  }
  for (int ri = 0; ri < s->num_shapes; ri++) {
    const vf_shape *rs = &s->shapes[ri];
    if (rs->kind != VF_SHAPE_MESH || emitted_radiance(s, rs) > 0.0) continue;
    for (uint32_t rt = 0; rt < rs->num_triangles; rt++, r_index++) {
      if (r_index % r_stride != 0) continue;
      vf_vec3 a = corner(rs, rt, 0), b = corner(rs, rt, 1), c = corner(rs, rt, 2);
      vf_vec3 n = vf_cross(vf_sub(b, a), vf_sub(c, a)), p = vf_scale(vf_add(vf_add(a, b), c), 1.0f / 3.0f);
      double area = 0.5 * vf_length(n), irradiance = 0.0;
      if (!(area > 0.0)) continue;
      n = vf_scale(n, 0.5f / (float)area);
      e_index = 0;
      for (int ei = 0; ei < s->num_shapes; ei++) {
        const vf_shape *es = &s->shapes[ei];
        double l = emitted_radiance(s, es);
        if (l <= 0.0) continue;
        if (es->kind == VF_SHAPE_SPHERE) {
          vf_vec3 d = vf_sub(es->center, p);
          double d2 = vf_dot(d, d), power_e = M_PI * l * 4.0 * M_PI * (double)es->radius * es->radius;
          if (d2 > 0.0) irradiance += power_e / (4.0 * M_PI * d2) * fabs(vf_dot(n, d)) / sqrt(d2);
          continue;
        }
        for (uint32_t et = 0; et < es->num_triangles; et++, e_index++) {
          if (e_index % e_stride != 0) continue;
          vf_vec3 ea = corner(es, et, 0), eb = corner(es, et, 1), ec = corner(es, et, 2);
          vf_vec3 en = vf_cross(vf_sub(eb, ea), vf_sub(ec, ea)); /* twice the area, along the emitting side */
          vf_vec3 d = vf_sub(p, vf_scale(vf_add(vf_add(ea, eb), ec), 1.0f / 3.0f));
          double d2 = vf_dot(d, d), cos_e_area = vf_dot(en, d) * 0.5; /* area x cos_e x |d| */
          if (!(d2 > 0.0) || cos_e_area <= 0.0) continue;
          double cos_r = fabs(vf_dot(n, d)) / sqrt(d2);
          /* the strided triangles stand for e_stride each */
          irradiance += (double)e_stride * l * cos_e_area / sqrt(d2) * cos_r / d2;
        }
      }
      weighted += area * irradiance;
      area_sum += area;
    }
  }
  return area_sum > 0.0 ? weighted / area_sum / M_PI : INFINITY;
}

int vf_scene_dim_emitters(const parse_ctx *c, int may_light) {
  vf_scene *s = c->scene;
  if (s->num_point_lights > 0 || s->num_directional_lights > 0 || !vf_is_zero(s->background) || s->envmap.width > 0)
    return VF_OK;
  double power, level = dim_level(s, &power);
  if (!(power > 0.0) || level >= VF_DIM_LIGHT_LEVEL) return VF_OK;
  if (may_light) { /* as glTF viewers show such files: under a sky, the emitters showing too */
    s->background = vf_vec3_splat(1.0f);
    return vf_scene_note(c, "dim emitters: the only lights are emissive surfaces of %.3g W in all, whose light reaches "
                            "the other surfaces at a radiance of about %.2g on a white surface (below %g): the scene "
                            "is also lit by a white background of radiance 1 (a \"lights\" field, or --background 0, "
                            "keeps the emitters alone)",
                         power, level, VF_DIM_LIGHT_LEVEL);
  }
  return vf_scene_note(c, "warning: the image will be dark: the only lights are emissive surfaces of %.3g W in all, "
                          "whose light reaches the other surfaces at a radiance of about %.2g on a white surface "
                          "(below %g; most of it leaves the scene or meets nothing): the emitters show, little else "
                          "does (add lights or a \"background\")",
                       power, level, VF_DIM_LIGHT_LEVEL);
}

int vf_scene_default_light(const parse_ctx *c) {
  c->scene->background = vf_vec3_splat(1.0f);
  return vf_scene_note(c, "no light: the scene is lit by a white background of radiance 1");
}
