/* The scene description: camera, shapes with materials and emission, lights, and the
 * render settings the scene asks for. Independent of Embree (worker/render/accel.h builds the
 * ray-tracing structures from it) so it can be hashed, validated and shipped.
 *
 * Scenes come from a JSON file (docs/SCENES.md) whose meshes are loaded through Assimp, a
 * model file, or a built-in name: load.h is the entry point. All geometry is stored in
 * world space: per-shape transforms are applied at load. */
#ifndef VF_SCENE_H
#define VF_SCENE_H

#include "../../common/image.h"
#include "../../common/settings.h"
#include "../../common/vec3.h"
#include "material.h"
#include "medium.h"
#include "texture.h"

#include <stddef.h>
#include <stdint.h>

/* A perspective camera (a pinhole or a thin lens) or an orthographic one. An orthographic
 * camera's rays all travel along forward, from the points of a view plane through
 * position, perpendicular to forward, view_width wide (scene units) and as high as the
 * image's aspect ratio makes it; it has no field of view and no lens. */
typedef struct {
  vf_vec3 position;
  vf_vec3 forward; /* unit */
  vf_vec3 up;      /* unit, orthogonal to forward */
  float vertical_fov_degrees; /* perspective: in (0, 180); orthographic: 0 */
  float aperture;       /* thin lens: radius of the lens, >= 0; 0 is a pinhole */
  float focus_distance; /* thin lens: distance along forward of the plane in focus, > 0 when aperture > 0 */
  float view_width;     /* > 0: orthographic, the view's width in scene units; 0: perspective */
  int mirror;           /* 1: the image mirrored left to right, its right along up x forward (else forward x up) */
} vf_camera_desc;

typedef enum { VF_SHAPE_MESH, VF_SHAPE_SPHERE } vf_shape_kind;

typedef struct {
  vf_shape_kind kind;
  char name[64];    /* from the file, else the mesh file name or "shapes[i]"; not hashed */
  int material;     /* index into vf_scene.materials; < 0: none, an index-matched medium
                     * boundary that every ray passes straight through (only with an interface) */
  vf_vec3 emission; /* emitted radiance, on the side a triangle faces (counter-clockwise
                     * winding, right-hand rule) and outward from a sphere; zero: not a light */
  /* VF_SHAPE_MESH: world-space triangles, at least one; degenerate ones may occur in inline
   * meshes (not in emitters, whose total area is > 0; mesh files have theirs skipped). A mirroring transform has already had its winding
   * reversed, so fronts are the fronts of the file. Arrays owned by the scene. */
  uint32_t num_vertices, num_triangles;
  float *positions;  /* 3 per vertex */
  uint32_t *indices; /* 3 per triangle */
  /* Optional per-vertex attributes (NULL: absent), world space like the positions:
   * normals: 3 per vertex, unit, the shading normals interpolated across each triangle
   *   (absent: the triangle's geometric normal, a faceted surface);
   * uvs: 2 per vertex, texture coordinates (s, t) with t = 0 the top row of an image
   *   (glTF's convention; OBJ's v is flipped to it at load);
   * tangents: 4 per vertex, a unit tangent along increasing s and in w the sign of the
   *   bitangent (glTF's TANGENT); absent with a normal map: derived from the uvs. */
  float *normals;
  float *uvs;
  float *uvs1;       /* 2 per vertex: the second uv set (glTF's TEXCOORD_1), as uvs; NULL: absent */
  float *colors;     /* 3 per vertex: linear RGB in [0, 1] multiplying the material's base colour
                      * (or diffuse) at the point (glTF's COLOR_0, its alpha ignored); NULL: absent */
  float *tangents;
  /* VF_SHAPE_SPHERE */
  vf_vec3 center;
  float radius;
  /* Media (medium.h): whether the shape bounds a medium region, and the media inside and
   * outside it (indices into vf_scene.media; -1: vacuum). Without an interface both are
   * -1 and crossing the surface changes no medium. Set by the loader: interior from the
   * file ("interior", or vacuum for a closed refracting shape in a scene with media),
   * exterior from the shapes that contain this one. */
  int interface;
  int interior, exterior;
} vf_shape;

/* A point light, or a spot light (is_spot): a point light whose intensity is that of the
 * axis inside the inner cone, falls off smoothly to zero at the outer cone and is zero
 * beyond (KHR_lights_punctual's spot). Both are "punctual": a delta in position. */
typedef struct {
  vf_vec3 position;
  vf_vec3 intensity; /* radiant intensity, W/sr per channel (a spot's on its axis) */
  int is_spot;
  vf_vec3 direction; /* spot: unit axis, the way the light shines */
  float inner_cone_angle, outer_cone_angle; /* spot: half-angles in radians, 0 <= inner < outer <= pi/2 */
} vf_point_light_desc;

typedef struct {
  vf_vec3 direction;  /* unit, the direction the light travels (from the sun towards the scene) */
  vf_vec3 irradiance; /* irradiance on a surface facing the sun, per channel */
} vf_directional_light_desc;

/* Bits of vf_scene.settings_given: which settings the scene file sets explicitly. */
enum {
  VF_SET_ALGORITHM = 1u << 0,
  VF_SET_MAX_PATH_LENGTH = 1u << 1,
  VF_SET_RADIUS_FACTOR = 1u << 2,
  VF_SET_ALPHA = 1u << 3,
  VF_SET_SEED = 1u << 4,
  VF_SET_RESOLUTION = 1u << 5,
  VF_SET_SAMPLER = 1u << 6,
  VF_SET_MIS_BETA = 1u << 7,
  VF_SET_GATHER = 1u << 8,
  VF_SET_RADIUS = 1u << 9,
};

typedef struct {
  char source[512]; /* file path, or "builtin:NAME" */
  vf_texture *textures; /* what vf_texture_slot.texture indexes (minus one) */
  int num_textures;
  /* What the scene's files ask for that vcmfarm does not do (an unsupported extension, a
   * texture transform, ...), one line each ending in '\n', each kind once; NULL: nothing.
   * The command line prints it at load; it is not part of the hash. */
  char *notes;
  vf_camera_desc camera;
  vf_material *materials;
  int num_materials;
  vf_shape *shapes;
  int num_shapes;
  vf_point_light_desc *point_lights;
  int num_point_lights;
  vf_directional_light_desc *directional_lights;
  int num_directional_lights;
  vf_vec3 background;     /* constant background radiance; zero = none */
  vf_image envmap;        /* latitude-longitude radiance map, +y up, top row first, pixel
                           * for direction d at u = 0.5 + atan2(d.x, -d.z) / 2pi,
                           * v = acos(d.y) / pi (docs/SCENES.md); width 0 = none */
  vf_vec3 envmap_scale;   /* multiplies the map; zero when there is no map */
  /* With envmap_rotated, the map turned: a world direction d is looked up as the map's own
   * direction R^T d, R = envmap_rotation (rows; a rotation, det +1). Without it R is the
   * identity and the array unused (zero). */
  int envmap_rotated;
  float envmap_rotation[3][3];
  /* Render settings: defaults (vf_settings_default, resolution from the scene) overridden
   * by the scene's "render" object; settings_given says which the file set. */
  vf_medium *media;       /* owned; what vf_scene.medium and vf_shape.interior/exterior index */
  int num_media;
  int medium;             /* the medium around everything (the camera's, unless inside a
                           * shape with an interface): an index into media, -1 vacuum */
  vf_settings settings;
  unsigned settings_given;
  uint8_t hash[32];       /* BLAKE2b-256 of the loaded content (see vf_scene_hash) */
  vf_vec3 bounds_min, bounds_max; /* of all shapes */
} vf_scene;

/* Frees the scene and everything it owns; NULL is a no-op. */
void vf_scene_destroy(vf_scene *scene);

/* Scales the whole scene, camera and lights by factor about the origin so that the exact
 * image is unchanged: point-light intensities grow with factor^2, radiances and directional
 * irradiances stay, media coefficients shrink by 1/factor and grid boxes move with the shapes. Recomputes bounds and hash. For numerical stress tests (issue 5). */
int vf_scene_scale(vf_scene *scene, double factor);

/* Bounding sphere of all shapes: center of the bounding box and half its diagonal. */
void vf_scene_bounding_sphere(const vf_scene *scene, vf_vec3 *center, float *radius);

/* Recomputes scene->hash from the content (camera, materials, shapes, lights, environment,
 * media with their grids' samples, interiors and the scene's medium, settings the file set), in a canonical order: equal content gives equal hashes. Names,
 * the source path and the JSON layout are not part of it; material order is. Call it after
 * changing a loaded scene. */
void vf_scene_hash(vf_scene *scene);
/* Lower-case hex of the hash into out (65 bytes with the NUL). */
void vf_scene_hash_hex(const vf_scene *scene, char out[65]);

/* Sets the scene's bounds from its shapes. */
void vf_scene_compute_bounds(vf_scene *scene);

/* The largest coordinate magnitude a scene may have, in world space after every transform
 * (vertices, sphere bounds, the camera, point lights). Embree asserts that ray origins
 * stay below 1.8e18 and the renderer squares distances in floats (3.4e38 at most): 1e15
 * keeps both with a wide margin. docs/SCENES.md states it. */
#define VF_SCENE_MAX_COORDINATE 1e15f

/* Refuses (VF_ESCENE naming the scene, what and where) a scene with a coordinate beyond
 * VF_SCENE_MAX_COORDINATE: the renderer could not trace it. */
int vf_scene_check_extent(const vf_scene *scene, const char *label);

#endif
