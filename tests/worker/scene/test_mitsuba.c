/* Mitsuba 3 XML scenes (worker/scene/mitsuba.c, xml.c, mitsuba_props.c, mitsuba_bsdf.c):
 * every mapping of docs/SCENES.md "Mitsuba 3 scenes" field by field on the small files of
 * tests/scenes/mitsuba/, bad files refused naming file, element and reason (exit status 2
 * through the command line), and a Cornell box written as Mitsuba XML and as a JSON scene
 * loading the same content and rendering the same image within statistical error. */
#include "check.h"
#include "../render/render_util.h"
#include "common/error.h"
#include "common/file.h"
#include "common/image.h"
#include "worker/scene/job_scene.h"
#include "worker/scene/load.h"
#include "worker/scene/scene.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <zlib.h>

#define DIR VF_SOURCE_DIR "/tests/scenes/mitsuba/"
#define PI 3.14159265358979323846

static double deg(double r) { return r * 180.0 / PI; }
static double rad(double d) { return d * PI / 180.0; }

#define CHECK_VEC(v, X, Y, Z, tol)                                                                 \
  do {                                                                                             \
    CHECK_NEAR((v).x, (X), (tol));                                                                 \
    CHECK_NEAR((v).y, (Y), (tol));                                                                 \
    CHECK_NEAR((v).z, (Z), (tol));                                                                 \
  } while (0)

static vf_scene *load(const char *path, const char *camera) {
  vf_scene *s = NULL;
  int err = vf_scene_load_camera(path, camera, &s);
  if (err != VF_OK) printf("  load %s: %s\n", path, vf_error_detail(err));
  CHECK_INT_EQ(err, VF_OK);
  return s;
}

static char temp_dir[512] = "";

/* A scene text written to a temporary file; returns its path (static buffer). */
static const char *write_temp(const char *name, const char *text) {
  static char path[1024];
  char *dir = temp_dir;
  if (!dir[0]) CHECK_INT_EQ(vf_file_temp_dir("vcmfarm-test-mitsuba", dir, sizeof temp_dir), VF_OK);
  snprintf(path, sizeof path, "%s/%s", dir, name);
  FILE *f = fopen(path, "w");
  CHECK(f != NULL);
  if (f) {
    fputs(text, f);
    fclose(f);
  }
  return path;
}

static void test_perspective_from_lookat_fov_along_x_and_max_depth(void) {
  vf_scene *s = load(DIR "camera.xml", NULL);
  if (!s) return;
  CHECK_VEC(s->camera.position, 1, 2, 3, 1e-6);
  CHECK_VEC(s->camera.forward, 0, 0, -1, 1e-6);
  CHECK_VEC(s->camera.up, 0, 1, 0, 1e-6);
  /* fov 60 along x of an 80x40 film: tan(v/2) = tan(30 deg) / 2 */
  CHECK_NEAR(s->camera.vertical_fov_degrees, deg(2 * atan(tan(rad(30)) / 2)), 1e-4);
  CHECK_INT_EQ(s->settings.width, 80);
  CHECK_INT_EQ(s->settings.height, 40);
  CHECK(s->camera.aperture == 0 && s->camera.view_width == 0);
  /* max_depth -1: the documented cap of 64 segments */
  CHECK_INT_EQ(s->settings.max_path_length, 64);
  CHECK(s->settings_given & VF_SET_MAX_PATH_LENGTH);
  CHECK_STR_CONTAINS(s->notes, "max_depth -1 (unlimited) is 64 path segments");
  CHECK_STR_CONTAINS(s->notes, "the first of 3 sensors is rendered");
  /* the point light and the sphere */
  CHECK_INT_EQ(s->num_point_lights, 1);
  CHECK_VEC(s->point_lights[0].position, 0, 3, 0, 0);
  CHECK_VEC(s->point_lights[0].intensity, 10, 20, 30, 0);
  CHECK_INT_EQ(s->num_shapes, 1);
  CHECK(s->shapes[0].kind == VF_SHAPE_SPHERE && s->shapes[0].radius == 0.5f);
  /* Mitsuba's default BSDF: diffuse 0.5 */
  CHECK_VEC(s->materials[s->shapes[0].material].diffuse, 0.5, 0.5, 0.5, 0);
  vf_scene_destroy(s);
}

/* Mean images of render_iterations (camera + light image, RGB averaged). */
typedef struct {
  int width, height, n;
  double *sum;
} image_sum;
static void add_image(void *ctx, int i, const float *cam, const float *light) {
  image_sum *a = ctx;
  (void)i;
  for (int p = 0; p < a->width * a->height; p++)
    a->sum[p] += (cam[3 * p] + cam[3 * p + 1] + cam[3 * p + 2] + light[3 * p] + light[3 * p + 1] + light[3 * p + 2]) / 3.0;
  a->n++;
}

/* The sensor whose to_world mirrors (mirrored.xml, <scale x="-1"/> before the lookat):
 * the same position, view and up as the plain one, the image reversed left to right as
 * Mitsuba's mapping of camera space makes it (+x to the image's left, so the lamp at world
 * -x lands on the right), by camera rays (pt) and by light tracing's projection (lt) alike. */
static void test_mirroring_sensor_mirrors_the_image(void) {
  vf_scene *plain = load(DIR "mirrored.xml", "plain"), *mirrored = load(DIR "mirrored.xml", "mirrored");
  if (plain == NULL || mirrored == NULL) goto done;
  CHECK_INT_EQ(plain->camera.mirror, 0);
  CHECK_INT_EQ(mirrored->camera.mirror, 1);
  CHECK_VEC(mirrored->camera.position, 0, 0, 5, 1e-6);
  CHECK_VEC(mirrored->camera.forward, 0, 0, -1, 1e-6);
  CHECK_VEC(mirrored->camera.up, 0, 1, 0, 1e-6);
  CHECK(mirrored->notes == NULL || strstr(mirrored->notes, "mirror") == NULL); /* rendered as it is: no note */
  CHECK(memcmp(plain->hash, mirrored->hash, 32) != 0);
  enum { W = 32, H = 16 };
  double left[3], right[3];
  const vf_algorithm algorithms[3] = {VF_ALGO_PT, VF_ALGO_PT, VF_ALGO_LT};
  for (int k = 0; k < 3; k++) {
    vf_scene *s = k == 0 ? plain : mirrored;
    vf_settings st = s->settings;
    st.algorithm = algorithms[k];
    st.sampler = VF_SAMPLER_INDEPENDENT;
    st.seed = 5 + (uint64_t)k;
    static double sum[W * H];
    memset(sum, 0, sizeof sum);
    image_sum a = {W, H, 0, sum};
    CHECK_INT_EQ(st.width, W);
    vf_vcm_stats stats = {0};
    CHECK_INT_EQ(render_iterations(s, &st, 2, 0, 16, add_image, &a, &stats), VF_OK);
    left[k] = right[k] = 0;
    for (int y = 0; y < H; y++)
      for (int x = 0; x < W; x++) *(x < W / 2 ? &left[k] : &right[k]) += sum[y * W + x] / a.n;
  }
  /* The lamp, 1 x 1 at distance 5 under a 60-degree fov across 32 pixels, covers about
   * (32 / (2 tan 30 deg 5))^2 = 30 pixels of radiance 1. */
  CHECK(left[0] > 20 && left[0] < 40 && right[0] == 0);
  for (int k = 1; k < 3; k++) {
    CHECK(right[k] > 20 && right[k] < 40 && left[k] == 0);
    CHECK_NEAR(right[k], left[0], 0.05 * left[0]);
  }
done:
  vf_scene_destroy(plain);
  vf_scene_destroy(mirrored);
}

/* A conductor's bitmap eta and k (Mitsuba's textured conductor): eta_texture and k_texture
 * of a unit eta and k, the texels being the values; rendered on a cube (a mesh with texture
 * coordinates), a uniform gold map gives the
 * image of gold's constants (and not of Fresnel 1), within statistical error; a texture
 * that is not a bitmap is refused naming the element. */
static void test_textured_conductor_eta_and_k(void) {
  static const float gold_eta[3] = {0.1431189557f, 0.3749570432f, 1.4424785571f},
                     gold_k[3] = {3.9831604247f, 2.3857207478f, 1.6032152899f};
  vf_image eta = {0}, k = {0};
  CHECK_INT_EQ(vf_image_alloc(&eta, 2, 2), VF_OK);
  CHECK_INT_EQ(vf_image_alloc(&k, 2, 2), VF_OK);
  for (int p = 0; p < 4; p++)
    for (int ch = 0; ch < 3; ch++) eta.rgb[3 * p + ch] = gold_eta[ch], k.rgb[3 * p + ch] = gold_k[ch];
  char path[1024];
  snprintf(path, sizeof path, "%s", write_temp("gold_eta.exr", ""));
  CHECK_INT_EQ(vf_image_write_exr(path, &eta), VF_OK);
  snprintf(path, sizeof path, "%s", write_temp("gold_k.exr", ""));
  CHECK_INT_EQ(vf_image_write_exr(path, &k), VF_OK);
  vf_image_destroy(&eta);
  vf_image_destroy(&k);
  static const char head[] =
      "<scene version=\"3.0.0\"><integrator type=\"path\"><integer name=\"max_depth\" value=\"3\"/></integrator>"
      "<sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/><transform name=\"to_world\">"
      "<lookat origin=\"0, 0, 4\" target=\"0, 0, 0\" up=\"0, 1, 0\"/></transform>"
      "<film type=\"hdrfilm\"><integer name=\"width\" value=\"24\"/><integer name=\"height\" value=\"24\"/></film></sensor>"
      "<emitter type=\"constant\"><rgb name=\"radiance\" value=\"1\"/></emitter>"
      "<shape type=\"cube\"><transform name=\"to_world\"><rotate x=\"1\" y=\"1\" angle=\"35\"/></transform>"
      "<bsdf type=\"roughconductor\"><float name=\"alpha\" value=\"0.2\"/>"
      "<string name=\"distribution\" value=\"ggx\"/>";
  char xml[2][2048];
  snprintf(xml[0], sizeof xml[0], "%s<texture type=\"bitmap\" name=\"eta\"><string name=\"filename\" value=\"gold_eta.exr\"/>"
           "</texture><texture type=\"bitmap\" name=\"k\"><string name=\"filename\" value=\"gold_k.exr\"/></texture>"
           "</bsdf></shape></scene>", head);
  snprintf(xml[1], sizeof xml[1], "%s<string name=\"material\" value=\"Au\"/></bsdf></shape></scene>", head);
  vf_scene *textured = load(write_temp("textured_gold.xml", xml[0]), NULL);
  vf_scene *constant = load(write_temp("constant_gold.xml", xml[1]), NULL);
  enum { BLOCKS = 4, NB = BLOCKS * BLOCKS, ITERATIONS = 64 };
  double mean[3][NB], se[3][NB];
  if (textured == NULL || constant == NULL) goto done;
  {
    const vf_material *m = &textured->materials[textured->shapes[0].material];
    CHECK_VEC(m->conductor_eta, gold_eta[0], gold_eta[1], gold_eta[2], 1e-6);
    CHECK_VEC(m->conductor_k, gold_k[0], gold_k[1], gold_k[2], 1e-6);
    CHECK_STR_CONTAINS(textured->notes, "<texture type=\"bitmap\" name=\"eta\">");
    CHECK_STR_CONTAINS(textured->notes, "a textured eta is rendered as the mean of its texels (0.143119, 0.374957, 1.44248)");
    CHECK_STR_CONTAINS(textured->notes, "a textured k is rendered as the mean of its texels");
    vf_scene *fresnel_one = NULL;
    for (int v = 0; v < 3; v++) {
      vf_scene *s = v == 0 ? textured : constant;
      if (v == 2) { /* the same cube without the Fresnel factor: the comparison can tell */
        fresnel_one = load(write_temp("fresnel_one.xml", xml[1]), NULL);
        if (fresnel_one == NULL) break;
        vf_material *f = &fresnel_one->materials[fresnel_one->shapes[0].material];
        f->conductor_eta = f->conductor_k = vf_vec3_splat(0.0f);
        s = fresnel_one;
      }
      vf_settings st = s->settings;
      st.algorithm = VF_ALGO_PT;
      st.sampler = VF_SAMPLER_INDEPENDENT;
      st.seed = 31 + (uint64_t)v;
      vf_vcm_stats stats = {0};
      CHECK_INT_EQ(render_block_estimates(s, &st, 2, ITERATIONS, BLOCKS, mean[v], se[v], &stats), VF_OK);
    }
    CHECK(blocks_agree("gold", "textured", "constant", mean[0], se[0], mean[1], se[1], NB));
    if (fresnel_one != NULL)
      CHECK(!blocks_agree("gold", "textured", "Fresnel 1", mean[0], se[0], mean[2], se[2], NB));
    vf_scene_destroy(fresnel_one);
  }
  /* Not a bitmap: refused naming the element. */
  {
    char bad[2048];
    snprintf(bad, sizeof bad, "%s<texture type=\"checkerboard\" name=\"k\"/><rgb name=\"eta\" value=\"0.2\"/>"
             "</bsdf></shape></scene>", head);
    vf_scene *b = NULL;
    int err = vf_scene_load(write_temp("bad_k.xml", bad), &b);
    CHECK(err < 0 && b == NULL);
    CHECK_STR_CONTAINS(vf_error_detail(err), "<texture type=\"checkerboard\" name=\"k\">: a textured k must be a bitmap");
  }
done:
  vf_scene_destroy(textured);
  vf_scene_destroy(constant);
}

/* principled: glTF's metallic-roughness model of its base colour, metallic and roughness,
 * and its clear coat as the JSON's clear-coat fields: weight 0.25 clearcoat, GGX alpha
 * lerp(0.1, 0.001, clearcoat_gloss); both approximations noted; out of range refused. */
static void test_principled_with_its_clear_coat(void) {
  static const char head[] =
      "<scene version=\"3.0.0\"><sensor type=\"perspective\"><transform name=\"to_world\">"
      "<lookat origin=\"0, 0, 4\" target=\"0, 0, 0\" up=\"0, 1, 0\"/></transform></sensor>"
      "<emitter type=\"constant\"/><shape type=\"sphere\"><bsdf type=\"principled\">"
      "<rgb name=\"base_color\" value=\"0.6, 0.2, 0.1\"/><float name=\"metallic\" value=\"0.3\"/>"
      "<float name=\"roughness\" value=\"0.4\"/>";
  char xml[1024];
  snprintf(xml, sizeof xml, "%s<float name=\"clearcoat\" value=\"0.8\"/><float name=\"clearcoat_gloss\" value=\"0.5\"/>"
           "</bsdf></shape></scene>", head);
  vf_scene *s = load(write_temp("principled.xml", xml), NULL);
  if (s != NULL) {
    const vf_material *m = &s->materials[s->shapes[0].material];
    CHECK(m->gltf);
    CHECK_VEC(m->base_color, 0.6, 0.2, 0.1, 1e-7);
    CHECK_NEAR(m->metallic, 0.3, 1e-7);
    CHECK_NEAR(m->roughness, 0.4, 1e-7);
    CHECK_NEAR(m->clearcoat, 0.2, 1e-7);
    CHECK_NEAR(m->clearcoat_roughness, sqrt(0.1 + (0.001 - 0.1) * 0.5), 1e-7);
    CHECK_STR_CONTAINS(s->notes, "principled's clear coat (GTR1, weight 0.25 clearcoat, added over the rest) is approximated");
    CHECK(strstr(s->notes, "'clearcoat'") == NULL); /* read, not noted as unsupported */
  }
  vf_scene_destroy(s);
  snprintf(xml, sizeof xml, "%s</bsdf></shape></scene>", head);
  s = load(write_temp("principled_plain.xml", xml), NULL);
  if (s != NULL) {
    CHECK_NEAR(s->materials[s->shapes[0].material].clearcoat, 0, 0);
    CHECK(strstr(s->notes, "clear coat") == NULL);
  }
  vf_scene_destroy(s);
  snprintf(xml, sizeof xml, "%s<float name=\"clearcoat\" value=\"1.5\"/></bsdf></shape></scene>", head);
  vf_scene *b = NULL;
  int err = vf_scene_load(write_temp("principled_bad.xml", xml), &b);
  CHECK(err < 0 && b == NULL);
  CHECK_STR_CONTAINS(vf_error_detail(err), "<bsdf type=\"principled\">: clearcoat and clearcoat_gloss must lie in [0, 1]");
}

static void test_thinlens_and_orthographic_sensors_by_id_and_index(void) {
  vf_scene *s = load(DIR "camera.xml", "lens");
  if (s) {
    CHECK_NEAR(s->camera.vertical_fov_degrees, 45, 1e-4); /* fov along y of a square film */
    CHECK_NEAR(s->camera.aperture, 0.1, 1e-7);
    CHECK_NEAR(s->camera.focus_distance, 4, 1e-7);
    CHECK_VEC(s->camera.position, 0, 0, 5, 1e-6);
    CHECK_INT_EQ(s->settings.width, 64);
    vf_scene_destroy(s);
  }
  s = load(DIR "camera.xml", "2");
  if (s) {
    /* to_world = lookat x scale(3, 3): the view spans x in [-3, 3] */
    CHECK_NEAR(s->camera.view_width, 6, 1e-5);
    CHECK_VEC(s->camera.position, 0, 5, 0, 1e-6);
    CHECK_VEC(s->camera.forward, 0, -1, 0, 1e-6);
    CHECK_VEC(s->camera.up, 0, 0, -1, 1e-6);
    CHECK_INT_EQ(s->settings.width, 32);
    CHECK_INT_EQ(s->settings.height, 16);
    vf_scene_destroy(s);
  }
  vf_scene *none = NULL;
  CHECK_INT_EQ(vf_scene_load_camera(DIR "camera.xml", "7", &none), VF_ESCENE);
  CHECK_STR_CONTAINS(vf_error_detail(VF_ESCENE), "no sensor '7' (it has 3)");
}

/* Mitsuba's parse_fov for each fov_axis on an 80x40 film (aspect 2), as vertical fov. */
static void test_fov_axis_x_y_diagonal_smaller_larger_and_focal_length(void) {
  const double t = tan(rad(30)), aspect = 2;
  const struct {
    const char *axis;
    double vertical;
  } cases[] = {
      {"x", deg(2 * atan(t / aspect))},
      {"y", 60},
      {"diagonal", deg(2 * atan(t * 40 / sqrt(80.0 * 80 + 40 * 40)))},
      {"smaller", 60},                        /* the film's smaller side is y */
      {"larger", deg(2 * atan(t / aspect))},  /* its larger x */
      {"focal", deg(2 * atan(sqrt(36.0 * 36 + 24 * 24) / 100 * 40 / sqrt(80.0 * 80 + 40 * 40)))}, /* 50 mm */
  };
  for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
    char text[1024];
    int focal = strcmp(cases[i].axis, "focal") == 0;
    snprintf(text, sizeof text,
             "<scene version=\"3.0.0\"><sensor type=\"perspective\">%s%s%s"
             "<film type=\"hdrfilm\"><integer name=\"width\" value=\"80\"/><integer name=\"height\" value=\"40\"/></film>"
             "</sensor><shape type=\"sphere\"/><emitter type=\"constant\"/></scene>",
             focal ? "" : "<float name=\"fov\" value=\"60\"/><string name=\"fov_axis\" value=\"", focal ? "" : cases[i].axis,
             focal ? "" : "\"/>");
    vf_scene *s = load(write_temp("fov.xml", text), NULL);
    if (!s) continue;
    printf("  fov_axis %-8s vertical %.5f (expected %.5f)\n", cases[i].axis, s->camera.vertical_fov_degrees,
           cases[i].vertical);
    CHECK_NEAR(s->camera.vertical_fov_degrees, cases[i].vertical, 1e-4);
    vf_scene_destroy(s);
  }
}

static double triangle_normal_dot(const vf_shape *m, uint32_t t, vf_vec3 toward) {
  const float *p = m->positions;
  const uint32_t *ix = m->indices + 3 * t;
  vf_vec3 a = vf_vec3_make(p[3 * ix[0]], p[3 * ix[0] + 1], p[3 * ix[0] + 2]);
  vf_vec3 b = vf_vec3_make(p[3 * ix[1]], p[3 * ix[1] + 1], p[3 * ix[1] + 2]);
  vf_vec3 c = vf_vec3_make(p[3 * ix[2]], p[3 * ix[2] + 1], p[3 * ix[2] + 2]);
  vf_vec3 n = vf_cross(vf_sub(b, a), vf_sub(c, a));
  vf_vec3 centroid = vf_scale(vf_add(vf_add(a, b), c), 1.0f / 3);
  return vf_dot(n, vf_sub(centroid, toward));
}

static double mesh_area(const vf_shape *m) {
  double area = 0;
  for (uint32_t t = 0; t < m->num_triangles; t++) {
    const uint32_t *ix = m->indices + 3 * t;
    const float *a = m->positions + 3 * ix[0], *b = m->positions + 3 * ix[1], *c = m->positions + 3 * ix[2];
    vf_vec3 n = vf_cross(vf_vec3_make(b[0] - a[0], b[1] - a[1], b[2] - a[2]), vf_vec3_make(c[0] - a[0], c[1] - a[1], c[2] - a[2]));
    area += 0.5 * vf_length(n);
  }
  return area;
}

static void test_shapes_and_transforms_composed_in_order(void) {
  vf_scene *s = load(DIR "shapes.xml", NULL);
  if (!s) return;
  CHECK_INT_EQ(s->num_shapes, 6);
  CHECK_INT_EQ(s->num_materials, 1);
  /* cube: scale x 2, then rotate 90 about z, then translate x 1 */
  const vf_shape *cube = &s->shapes[0];
  CHECK_INT_EQ(cube->num_vertices, 24); /* Mitsuba's: four per face, with uvs */
  CHECK_INT_EQ(cube->num_triangles, 12);
  const float *p = cube->positions;
  CHECK_VEC(vf_vec3_make(p[21], p[22], p[23]), 0, 2, 1, 1e-5); /* (1, 1, 1) -> (2, 1, 1) -> (-1, 2, 1) -> (0, 2, 1) */
  CHECK_VEC(vf_vec3_make(p[9], p[10], p[11]), 2, -2, -1, 1e-5); /* (-1, -1, -1) */
  CHECK(cube->uvs != NULL && cube->uvs[0] == 0 && cube->uvs[1] == 1 && cube->uvs[4] == 1 && cube->uvs[5] == 0);
  for (uint32_t t = 0; t < 12; t++) CHECK(triangle_normal_dot(cube, t, vf_vec3_make(1, 0, 0)) > 0); /* faces out */
  /* rectangle moved by a matrix, its normal flipped to -z */
  const vf_shape *rect = &s->shapes[1];
  CHECK_INT_EQ(rect->num_triangles, 2);
  CHECK_VEC(vf_vec3_make(rect->positions[0], rect->positions[1], rect->positions[2]), 4, -1, 0, 0);
  for (uint32_t t = 0; t < 2; t++) CHECK(triangle_normal_dot(rect, t, vf_vec3_make(5, 0, 1)) > 0); /* faces -z */
  /* Mitsuba's rectangle uvs: (0, 0) at (-1, -1), (1, 1) at (1, 1) */
  CHECK(rect->uvs != NULL);
  if (rect->uvs) {
    CHECK(rect->uvs[0] == 0 && rect->uvs[1] == 0 && rect->uvs[4] == 1 && rect->uvs[5] == 1);
    CHECK_VEC(vf_vec3_make(rect->positions[6], rect->positions[7], rect->positions[8]), 6, 1, 0, 0);
  }
  CHECK(s->shapes[2].uvs == NULL); /* the disk has none */
  /* disk of radius 2 facing +z, emitting */
  const vf_shape *disk = &s->shapes[2];
  CHECK_NEAR(mesh_area(disk), PI * 4, PI * 4 * 2e-4);
  CHECK_VEC(disk->emission, 1, 2, 3, 0);
  CHECK(triangle_normal_dot(disk, 0, vf_vec3_make(0, 0, -1)) > 0);
  /* sphere: centre (1, 0, 0) scaled by 2 and moved up 1; radius 0.5 x 2 */
  CHECK(s->shapes[3].kind == VF_SHAPE_SPHERE);
  CHECK_VEC(s->shapes[3].center, 2, 1, 0, 1e-6);
  CHECK_NEAR(s->shapes[3].radius, 1, 1e-6);
  /* mesh files through Assimp, with to_world */
  CHECK(s->shapes[4].kind == VF_SHAPE_MESH && s->shapes[4].num_triangles >= 1);
  for (uint32_t v = 0; v < s->shapes[4].num_vertices; v++) CHECK_NEAR(s->shapes[4].positions[3 * v + 2], -3, 1e-6);
  /* flip_normals on the PLY: its triangles' winding reversed against the file's */
  vf_scene *plain = NULL;
  CHECK_INT_EQ(vf_scene_load(VF_SOURCE_DIR "/tests/scenes/good/meshes.json", &plain), VF_OK);
  const vf_shape *tri = &s->shapes[4];
  CHECK(tri->indices[1] != tri->indices[2]);
  int compared = 0;
  for (int i = 0; plain != NULL && i < plain->num_shapes; i++)
    if (plain->shapes[i].kind == VF_SHAPE_MESH && plain->shapes[i].num_vertices == tri->num_vertices &&
        plain->shapes[i].num_triangles == tri->num_triangles && strstr(plain->shapes[i].name, "tri") != NULL) {
      CHECK_INT_EQ(plain->shapes[i].indices[1], tri->indices[2]);
      CHECK_INT_EQ(plain->shapes[i].indices[2], tri->indices[1]);
      compared++;
    }
  CHECK_INT_EQ(compared, 1);
  vf_scene_destroy(plain);
  CHECK(s->shapes[5].num_triangles >= 1);
  CHECK_STR_CONTAINS(s->notes, "the disk is a polygon of 256 triangles");
  CHECK(strstr(s->shapes[0].name, "cube") != NULL);
  vf_scene_destroy(s);
}

static const vf_material *material(const vf_scene *s, const char *name) {
  for (int i = 0; i < s->num_materials; i++)
    if (strcmp(s->materials[i].name, name) == 0) return &s->materials[i];
  printf("  no material '%s'\n", name);
  CHECK(0);
  return NULL;
}

static void test_every_bsdf_parameter(void) {
  vf_scene *s = load(DIR "bsdfs.xml", NULL);
  if (!s) return;
  const vf_material *m;
  CHECK_INT_EQ(s->num_materials, 16);
  if ((m = material(s, "diffuse"))) CHECK_VEC(m->diffuse, 0.2, 0.4, 0.6, 1e-7);
  if ((m = material(s, "gold"))) {
    CHECK_VEC(m->conductor, 1, 1, 1, 0);
    CHECK_VEC(m->conductor_eta, 0.1431189557, 0.3749570432, 1.4424785571, 1e-7);
    CHECK_VEC(m->conductor_k, 3.9831604247, 2.3857207478, 1.6032152899, 1e-6);
    CHECK(m->roughness == 0);
  }
  if ((m = material(s, "rough-copper"))) {
    CHECK_NEAR(m->roughness, 0.3, 1e-6); /* GGX alpha 0.09 = roughness^2 */
    CHECK_VEC(m->conductor_eta, 0.2004376970, 0.9240334304, 1.1022119527, 1e-7);
  }
  if ((m = material(s, "given-eta-k"))) {
    CHECK_VEC(m->conductor, 0.9, 0.9, 0.9, 1e-7);
    CHECK_VEC(m->conductor_eta, 0.2, 0.3, 0.4, 1e-7);
    CHECK_VEC(m->conductor_k, 3, 2.5, 2, 1e-7);
    CHECK_NEAR(m->roughness, 0.5, 1e-6); /* Beckmann alpha 0.25, noted */
  }
  if ((m = material(s, "mirror"))) { /* material none: Fresnel 1 */
    CHECK_VEC(m->conductor, 1, 1, 1, 0);
    CHECK(vf_is_zero(m->conductor_eta) && vf_is_zero(m->conductor_k));
  }
  if ((m = material(s, "water"))) {
    CHECK_VEC(m->dielectric, 1, 1, 1, 0);
    CHECK_NEAR(m->ior, 1.333, 1e-6);
    CHECK(m->roughness == 0);
  }
  if ((m = material(s, "frosted"))) {
    CHECK_NEAR(m->ior, 1.5, 1e-6);
    CHECK_NEAR(m->roughness, 0.2, 1e-6);
  }
  if ((m = material(s, "sheet"))) { /* 2R / (1 + R) of R = 0.04 */
    CHECK_VEC(m->mirror, 0.08 / 1.04, 0.08 / 1.04, 0.08 / 1.04, 1e-6);
    CHECK_VEC(m->dielectric, 0.96 / 1.04, 0.96 / 1.04, 0.96 / 1.04, 1e-6);
    CHECK(m->ior == 1);
  }
  if ((m = material(s, "plastic"))) {
    CHECK(m->gltf);
    CHECK_VEC(m->base_color, 0.1, 0.2, 0.3, 1e-7);
    CHECK(m->metallic == 0 && m->roughness == 0);
  }
  if ((m = material(s, "roughplastic"))) {
    CHECK(m->gltf);
    CHECK_VEC(m->base_color, 0.5, 0.5, 0.5, 0);
    CHECK_NEAR(m->roughness, 0.4, 1e-6);
  }
  if ((m = material(s, "textured"))) {
    CHECK(m->textures[VF_TEXTURE_COLOR].texture != 0);
    CHECK_INT_EQ(m->textures[VF_TEXTURE_COLOR].wrap_s, VF_WRAP_CLAMP);
    CHECK_VEC(m->diffuse, 1, 1, 1, 0);
  }
  if ((m = material(s, "checker"))) CHECK_VEC(m->diffuse, 0.4, 0.4, 0.4, 1e-7);
  if ((m = material(s, "leaf"))) {
    CHECK(m->textures[VF_TEXTURE_ALPHA].texture != 0);
    CHECK_INT_EQ(m->alpha_channel, 0);
    CHECK(m->alpha == 1 && m->alpha_cutoff == 0.5f);
    CHECK_VEC(m->diffuse, 0.5, 0.5, 0.5, 0);
  }
  if ((m = material(s, "bumpy"))) {
    CHECK(m->textures[VF_TEXTURE_NORMAL].texture != 0);
    CHECK_VEC(m->diffuse, 0.5, 0.5, 0.5, 0);
  }
  if ((m = material(s, "hair"))) CHECK_VEC(m->diffuse, 0.5, 0.5, 0.5, 0);
  CHECK_STR_CONTAINS(s->notes, "bsdf 'hair' is not supported: rendered as diffuse grey 0.5");
  CHECK_STR_CONTAINS(s->notes, "the Beckmann distribution is rendered as GGX of the same alpha");
  CHECK_STR_CONTAINS(s->notes, "thindielectric is approximated");
  CHECK_STR_CONTAINS(s->notes, "plastic is approximated by glTF's dielectric base");
  CHECK_STR_CONTAINS(s->notes, "checkerboard is rendered as the mean of its colours");
  CHECK_STR_CONTAINS(s->notes, "<bsdf type=\"diffuse\" id=\"onesided\"> (bsdfs.xml:70): not wrapped in twosided");
  CHECK(strstr(s->notes, "id=\"diffuse\"> (bsdfs.xml:8): not wrapped") == NULL); /* it is wrapped */
  CHECK(strstr(s->notes, "raw") == NULL); /* raw is right for a normal map */
  vf_scene_destroy(s);
}

static void test_point_spot_directional_and_constant_emitters(void) {
  vf_scene *s = load(DIR "emitters.xml", NULL);
  if (!s) return;
  CHECK_INT_EQ(s->num_point_lights, 2);
  const vf_point_light_desc *point = &s->point_lights[0], *spot = &s->point_lights[1];
  CHECK(!point->is_spot);
  CHECK_VEC(point->position, 1, 2, 3, 0);
  CHECK_VEC(point->intensity, 5, 5, 5, 0);
  CHECK(spot->is_spot);
  CHECK_VEC(spot->position, 0, 4, 0, 1e-6);
  CHECK_VEC(spot->direction, 0, -1, 0, 1e-6);
  CHECK_VEC(spot->intensity, 7, 8, 9, 0);
  CHECK_NEAR(spot->inner_cone_angle, rad(20), 1e-6); /* beam_width */
  CHECK_NEAR(spot->outer_cone_angle, rad(30), 1e-6); /* cutoff_angle */
  CHECK_INT_EQ(s->num_directional_lights, 1);
  CHECK_VEC(s->directional_lights[0].direction, 0, -1, 0, 1e-6);
  CHECK_VEC(s->directional_lights[0].irradiance, 3, 3, 3, 0);
  CHECK_VEC(s->background, 0.1, 0.2, 0.3, 1e-7);
  CHECK_STR_CONTAINS(s->notes, "spot falloff: Mitsuba's is linear in angle");
  vf_scene_destroy(s);
}

/* Refused with the file, the element and the reason, by the loader and by the command line
 * with exit status 2. */
static void test_bad_files_refused_naming_file_element_and_reason(void) {
  const struct {
    const char *file, *detail;
  } cases[] = {
      {"malformed.xml", "malformed.xml:4: malformed XML: mismatched tag"},
      {"unknown_plugin.xml", "unknown_plugin.xml:5: <emitter type=\"projector\">: emitter type 'projector' is not supported"},
      {"missing_file.xml", "missing_file.xml:4: <shape type=\"obj\">: cannot open 'no_such_mesh.obj'"},
      {"nan_value.xml", "nan_value.xml:3: <float name=\"fov\">: 'nan' is not"},
      {"unknown_default.xml", "unknown_default.xml:6: <integer value=\"$resolution\">: '$resolution' names no <default>"},
      {"envmap_scaled.xml", "envmap_scaled.xml:5: <emitter type=\"envmap\">: to_world must be a rotation"},
  };
  for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
    char path[1024], cmd[4400];
    snprintf(path, sizeof path, DIR "bad/%s", cases[i].file);
    vf_scene *s = NULL;
    int err = vf_scene_load(path, &s);
    CHECK(err < 0 && s == NULL);
    if (err < 0) CHECK_STR_CONTAINS(vf_error_detail(err), cases[i].detail);
    /* The film path is valid: the exit status is the scene's. */
    char out[1024], err_path[1024];
    snprintf(out, sizeof out, "%s", write_temp("never.exr", ""));
    remove(out);
    snprintf(err_path, sizeof err_path, "%s", write_temp("stderr.txt", ""));
    snprintf(cmd, sizeof cmd, "%s/vcmfarm render %s -o %s --iterations 1 2>%s", VF_BINARY_DIR, path, out, err_path);
    int status = system(cmd);
    CHECK(WIFEXITED(status));
    CHECK_INT_EQ(WEXITSTATUS(status), 2);
    uint8_t *said = NULL;
    size_t n = 0;
    CHECK_INT_EQ(vf_file_read_all(err_path, 1 << 16, &said, &n), VF_OK);
    char *text = said ? calloc(1, n + 1) : NULL;
    if (text) {
      memcpy(text, said, n);
      CHECK_STR_CONTAINS(text, cases[i].detail);
    }
    free(text);
    free(said);
  }
  /* an include that is missing names the including element */
  vf_scene *s = NULL;
  const char *p = write_temp("include.xml", "<scene version=\"3.0.0\">\n<include filename=\"gone.xml\"/>\n</scene>\n");
  CHECK_INT_EQ(vf_scene_load(p, &s), VF_ENOENT);
  CHECK_STR_CONTAINS(vf_error_detail(VF_ENOENT), "include.xml:2: <include filename=\"gone.xml\">");
  p = write_temp("loop.xml", "<scene version=\"3.0.0\">\n<include filename=\"loop.xml\"/>\n</scene>\n");
  CHECK_INT_EQ(vf_scene_load(p, &s), VF_ESCENE);
  CHECK_STR_CONTAINS(vf_error_detail(VF_ESCENE), "includes nest more than 16 deep");
}

/* null, bumpmap and an albedo above 1 (refused naming the element). */
static void test_null_bumpmap_and_albedo_above_one(void) {
  const char *xml =
      "<scene version=\"3.0.0\"><sensor type=\"perspective\"><float name=\"fov\" value=\"45\"/></sensor>"
      "<emitter type=\"constant\"/>"
      "<shape type=\"sphere\"><bsdf type=\"null\" id=\"nothing\"/></shape>"
      "<shape type=\"rectangle\"><bsdf type=\"bumpmap\" id=\"bumped\"><texture type=\"checkerboard\"/>"
      "<bsdf type=\"twosided\"><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.3\"/></bsdf></bsdf></bsdf></shape>"
      "<texture type=\"bitmap\" id=\"wood\"><string name=\"filename\" value=\"" VF_SOURCE_DIR "/tests/scenes/import/base.png\"/></texture>"
      "<shape type=\"cube\"><bsdf type=\"diffuse\" id=\"by-ref\"><ref name=\"reflectance\" id=\"wood\"/></bsdf></shape>"
      "</scene>";
  vf_scene *s = load(write_temp("null.xml", xml), NULL);
  if (s) {
    const vf_material *m = material(s, "nothing");
    if (m) CHECK(m->ior == 1 && m->dielectric.x == 1 && vf_is_zero(m->diffuse));
    if ((m = material(s, "bumped"))) CHECK_VEC(m->diffuse, 0.3, 0.3, 0.3, 1e-7);
    if ((m = material(s, "by-ref"))) CHECK(m->textures[VF_TEXTURE_COLOR].texture != 0); /* a texture by <ref> */
    CHECK_STR_CONTAINS(s->notes, "bumpmap is not supported: the wrapped BSDF is rendered without it");
    CHECK_STR_CONTAINS(s->notes, "null is a dielectric of ior 1");
    vf_scene_destroy(s);
  }
  const char *bright = "<scene version=\"3.0.0\"><sensor type=\"perspective\"><float name=\"fov\" value=\"45\"/></sensor>"
                       "<emitter type=\"constant\"/>\n<shape type=\"sphere\">\n<bsdf type=\"diffuse\">"
                       "<rgb name=\"reflectance\" value=\"0.5, 1.2, 0.5\"/></bsdf></shape></scene>";
  s = NULL;
  CHECK_INT_EQ(vf_scene_load(write_temp("bright.xml", bright), &s), VF_ESCENE);
  CHECK_STR_CONTAINS(vf_error_detail(VF_ESCENE), "bright.xml:3: <bsdf type=\"diffuse\">: reflects more than it receives (channel g: 1.2");
}

/* Texture coordinates of mesh files as Mitsuba reads them: a PLY's v as stored (t = v),
 * an OBJ's flipped (t = 1 - v), and flip_tex_coords reversing either. */
static void test_mesh_file_texture_coordinates_as_mitsuba_reads_them(void) {
  const char *xml = "<scene version=\"3.0.0\"><sensor type=\"perspective\"><float name=\"fov\" value=\"45\"/></sensor>"
                    "<emitter type=\"constant\"/>"
                    "<shape type=\"ply\"><string name=\"filename\" value=\"" VF_SOURCE_DIR "/tests/scenes/mitsuba/uv.ply\"/></shape>"
                    "<shape type=\"ply\"><string name=\"filename\" value=\"" VF_SOURCE_DIR "/tests/scenes/mitsuba/uv.ply\"/>"
                    "<boolean name=\"flip_tex_coords\" value=\"true\"/></shape></scene>";
  vf_scene *s = load(write_temp("uvply.xml", xml), NULL);
  if (!s) return;
  /* uv.ply: (0.1, 0.25), (0.2, 0.25), (0.3, 0.5) */
  CHECK(s->shapes[0].uvs != NULL && s->shapes[1].uvs != NULL);
  if (s->shapes[0].uvs && s->shapes[1].uvs) {
    CHECK_NEAR(s->shapes[0].uvs[0], 0.1, 1e-6);
    CHECK_NEAR(s->shapes[0].uvs[1], 0.25, 1e-6);
    CHECK_NEAR(s->shapes[0].uvs[5], 0.5, 1e-6);
    CHECK_NEAR(s->shapes[1].uvs[1], 0.75, 1e-6);
  }
  vf_scene_destroy(s);
}

static size_t put(uint8_t *p, uint64_t v, int n) {
  for (int i = 0; i < n; i++) p[i] = (uint8_t)(v >> (8 * i));
  return (size_t)n;
}

static size_t put_f(uint8_t *p, float f) {
  uint32_t bits;
  memcpy(&bits, &f, 4);
  return put(p, bits, 4);
}

/* A serialized file (version 4) of two meshes: a triangle, then a quad with normals and
 * texture coordinates. */
static const char *write_serialized(void) {
  uint8_t raw[2][512], file[2048];
  size_t n[2] = {0, 0}, at = 0;
  n[0] += put(raw[0] + n[0], 0x1000, 4);
  memcpy(raw[0] + n[0], "tri", 4), n[0] += 4;
  n[0] += put(raw[0] + n[0], 3, 8), n[0] += put(raw[0] + n[0], 1, 8);
  const float tri[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  for (int i = 0; i < 9; i++) n[0] += put_f(raw[0] + n[0], tri[i]);
  for (int i = 0; i < 3; i++) n[0] += put(raw[0] + n[0], (uint64_t)i, 4);
  n[1] += put(raw[1] + n[1], 0x1000 | 1 | 2, 4);
  memcpy(raw[1] + n[1], "quad", 5), n[1] += 5;
  n[1] += put(raw[1] + n[1], 4, 8), n[1] += put(raw[1] + n[1], 2, 8);
  const float quad[12] = {-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, uv[8] = {0, 0, 1, 0, 1, 1, 0, 1};
  for (int i = 0; i < 12; i++) n[1] += put_f(raw[1] + n[1], quad[i]);
  for (int i = 0; i < 12; i++) n[1] += put_f(raw[1] + n[1], i % 3 == 2 ? 2.0f : 0.0f); /* normals (0, 0, 2): normalised */
  for (int i = 0; i < 8; i++) n[1] += put_f(raw[1] + n[1], uv[i]);
  const uint32_t ix[6] = {0, 1, 2, 0, 2, 3};
  for (int i = 0; i < 6; i++) n[1] += put(raw[1] + n[1], ix[i], 4);
  uint64_t offsets[2];
  for (int m = 0; m < 2; m++) {
    offsets[m] = at;
    at += put(file + at, 0x041C, 2);
    at += put(file + at, 4, 2);
    uLongf z = (uLongf)(sizeof file - at);
    CHECK_INT_EQ(compress(file + at, &z, raw[m], (uLong)n[m]), Z_OK);
    at += z;
  }
  at += put(file + at, offsets[0], 8);
  at += put(file + at, offsets[1], 8);
  at += put(file + at, 2, 4);
  static char path[1024];
  snprintf(path, sizeof path, "%s", write_temp("meshes.serialized", ""));
  FILE *f = fopen(path, "wb");
  CHECK(f != NULL);
  if (f) {
    fwrite(file, 1, at, f);
    fclose(f);
  }
  return path;
}

static void test_serialized_meshes_by_index(void) {
  const char *ser = write_serialized();
  char xml[4096];
  snprintf(xml, sizeof xml,
           "<scene version=\"3.0.0\"><sensor type=\"perspective\"><float name=\"fov\" value=\"45\"/></sensor>"
           "<emitter type=\"constant\"/>"
           "<shape type=\"serialized\"><string name=\"filename\" value=\"%s\"/></shape>"
           "<shape type=\"serialized\"><string name=\"filename\" value=\"%s\"/><integer name=\"shape_index\" value=\"1\"/>"
           "<transform name=\"to_world\"><translate z=\"-2\"/></transform></shape></scene>",
           ser, ser);
  char good_xml[1024];
  snprintf(good_xml, sizeof good_xml, "%s", write_temp("ser.xml", xml));
  vf_scene *s = load(good_xml, NULL);
  if (s) {
    CHECK_INT_EQ(s->num_shapes, 2);
    CHECK_INT_EQ(s->shapes[0].num_vertices, 3);
    CHECK_INT_EQ(s->shapes[0].num_triangles, 1);
    CHECK(s->shapes[0].normals == NULL && s->shapes[0].uvs == NULL);
    const vf_shape *q = &s->shapes[1];
    CHECK_INT_EQ(q->num_vertices, 4);
    CHECK_INT_EQ(q->num_triangles, 2);
    CHECK_VEC(vf_vec3_make(q->positions[6], q->positions[7], q->positions[8]), 1, 1, -2, 0);
    CHECK(q->normals != NULL && q->uvs != NULL);
    if (q->normals) CHECK_VEC(vf_vec3_make(q->normals[0], q->normals[1], q->normals[2]), 0, 0, 1, 0);
    if (q->uvs) CHECK(q->uvs[4] == 1 && q->uvs[5] == 1 && q->uvs[7] == 1);
    CHECK_INT_EQ(q->indices[5], 3);
    vf_scene_destroy(s);
  }
  snprintf(xml, sizeof xml,
           "<scene version=\"3.0.0\"><sensor type=\"perspective\"><float name=\"fov\" value=\"45\"/></sensor>\n"
           "<shape type=\"serialized\"><string name=\"filename\" value=\"%s\"/><integer name=\"shape_index\" value=\"2\"/></shape>"
           "</scene>", ser);
  s = NULL;
  CHECK_INT_EQ(vf_scene_load(write_temp("ser_bad.xml", xml), &s), VF_EMESH);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EMESH), "ser_bad.xml: shapes[0] (");
  CHECK_STR_CONTAINS(vf_error_detail(VF_EMESH), "meshes.serialized): shape_index 2: the file has 2 meshes");
  char bogus[1024];
  snprintf(bogus, sizeof bogus, "%s", write_temp("bogus.serialized", "not a mesh at all"));
  snprintf(xml, sizeof xml,
           "<scene version=\"3.0.0\"><sensor type=\"perspective\"><float name=\"fov\" value=\"45\"/></sensor>\n"
           "<shape type=\"serialized\"><string name=\"filename\" value=\"%s\"/></shape></scene>", bogus);
  CHECK_INT_EQ(vf_scene_load(write_temp("ser_bad.xml", xml), &s), VF_EMESH);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EMESH), "bogus.serialized): not a serialized mesh");
  /* A farm job ships the file by content hash and decodes the same mesh. */
  char *text = NULL, stage[512];
  size_t len = 0;
  vf_blob_table files = {0};
  vf_scene *local = load(good_xml, NULL), *job = NULL;
  CHECK_INT_EQ(vf_scene_model_text(good_xml, NULL, &text, &len), VF_OK);
  CHECK_INT_EQ(vf_file_temp_dir("vcmfarm-test-mitsuba-stage", stage, sizeof stage), VF_OK);
  CHECK_INT_EQ(vf_job_scene_collect(good_xml, text, len, stage, &files, &job), VF_OK);
  CHECK_INT_EQ(files.count, 1);
  if (local && job) CHECK(memcmp(local->hash, job->hash, sizeof local->hash) == 0);
  vf_scene_destroy(job);
  vf_scene_destroy(local);
  vf_blob_table_clear(&files);
  vf_file_remove_tree(stage);
  free(text);
}

/* A scene of Mitsuba 0.x: camelCase names upgraded as Mitsuba 3 does. */
static void test_version_1_names_upgraded(void) {
  const char *xml =
      "<scene version=\"0.5.0\"><integrator type=\"path\"><integer name=\"maxDepth\" value=\"7\"/></integrator>"
      "<sensor type=\"perspective\"><float name=\"fov\" value=\"60\"/><string name=\"fovAxis\" value=\"y\"/>"
      "<transform name=\"toWorld\"><lookAt origin=\"0, 0, 5\" target=\"0, 0, 0\" up=\"0, 1, 0\"/></transform></sensor>"
      "<emitter type=\"constant\"/>"
      "<shape type=\"sphere\"><bsdf type=\"dielectric\" id=\"glass\"><float name=\"intIOR\" value=\"1.6\"/>"
      "<float name=\"extIOR\" value=\"1\"/></bsdf></shape>"
      "<shape type=\"rectangle\"><bsdf type=\"diffuse\" id=\"old\"><rgb name=\"diffuseReflectance\" value=\"0.25\"/></bsdf>"
      "</shape></scene>";
  vf_scene *s = load(write_temp("v05.xml", xml), NULL);
  if (!s) return;
  CHECK_INT_EQ(s->settings.max_path_length, 7);
  CHECK_NEAR(s->camera.vertical_fov_degrees, 60, 1e-4);
  CHECK_VEC(s->camera.position, 0, 0, 5, 1e-6);
  const vf_material *m;
  if ((m = material(s, "glass"))) CHECK_NEAR(m->ior, 1.6, 1e-6);
  if ((m = material(s, "old"))) CHECK_VEC(m->diffuse, 0.25, 0.25, 0.25, 0);
  CHECK_STR_CONTAINS(s->notes, "version 0.5.0: upgraded as Mitsuba 3 does");
  vf_scene_destroy(s);
}

/* The Cornell box in both formats: the same content field by field. */
static void test_cornell_xml_and_json_load_the_same_content(void) {
  vf_scene *x = load(DIR "cornell.xml", NULL), *j = load(DIR "cornell.json", NULL);
  if (!x || !j) goto done;
  CHECK_VEC(x->camera.position, j->camera.position.x, j->camera.position.y, j->camera.position.z, 1e-6);
  CHECK_VEC(x->camera.forward, j->camera.forward.x, j->camera.forward.y, j->camera.forward.z, 1e-6);
  CHECK_VEC(x->camera.up, j->camera.up.x, j->camera.up.y, j->camera.up.z, 1e-6);
  CHECK_NEAR(x->camera.vertical_fov_degrees, j->camera.vertical_fov_degrees, 1e-5);
  CHECK_INT_EQ(x->settings.width, j->settings.width);
  CHECK_INT_EQ(x->settings.height, j->settings.height);
  CHECK_INT_EQ(x->settings.max_path_length, j->settings.max_path_length);
  CHECK_INT_EQ(x->settings_given, j->settings_given);
  CHECK_INT_EQ(x->num_materials, j->num_materials);
  for (int i = 0; i < x->num_materials && i < j->num_materials; i++) {
    vf_material a = x->materials[i], b = j->materials[i];
    CHECK(strcmp(a.name, b.name) == 0);
    memset(a.name, 0, sizeof a.name);
    memset(b.name, 0, sizeof b.name);
    CHECK(memcmp(&a, &b, sizeof a) == 0);
  }
  CHECK_INT_EQ(x->num_shapes, j->num_shapes);
  for (int i = 0; i < x->num_shapes && i < j->num_shapes; i++) {
    const vf_shape *a = &x->shapes[i], *b = &j->shapes[i];
    CHECK(a->kind == b->kind && a->material == b->material && strcmp(a->name, b->name) == 0);
    CHECK_VEC(a->emission, b->emission.x, b->emission.y, b->emission.z, 0);
    CHECK_INT_EQ(a->num_vertices, b->num_vertices);
    CHECK_INT_EQ(a->num_triangles, b->num_triangles);
    if (a->num_vertices == b->num_vertices)
      for (uint32_t v = 0; v < 3 * a->num_vertices; v++) CHECK_NEAR(a->positions[v], b->positions[v], 1e-6);
    CHECK((a->uvs == NULL) == (b->uvs == NULL));
    if (a->uvs && b->uvs && a->num_vertices == b->num_vertices)
      CHECK(memcmp(a->uvs, b->uvs, 2 * sizeof(float) * a->num_vertices) == 0);
    CHECK(a->normals == NULL && b->normals == NULL && a->tangents == NULL && b->tangents == NULL);
    if (a->num_triangles == b->num_triangles && a->num_triangles > 0)
      CHECK(memcmp(a->indices, b->indices, 3 * sizeof(uint32_t) * a->num_triangles) == 0);
    CHECK_VEC(a->center, b->center.x, b->center.y, b->center.z, 0);
    CHECK(a->radius == b->radius);
  }
  CHECK_INT_EQ(x->num_point_lights + x->num_directional_lights, 0);
  CHECK_INT_EQ(j->num_point_lights + j->num_directional_lights, 0);
  CHECK(vf_is_zero(x->background) && x->envmap.width == 0);
  /* ... so the content hash (camera, materials, world-space geometry, lights, the settings
   * the file set; scene.c) is the same: a farm merges films of the two. */
  char hx[65], hj[65];
  vf_scene_hash_hex(x, hx);
  vf_scene_hash_hex(j, hj);
  printf("  cornell.xml %s\n  cornell.json %s\n", hx, hj);
  CHECK(memcmp(x->hash, j->hash, sizeof x->hash) == 0);
  /* What a Mitsuba scene says beyond the content: the sampler's count, noted. */
  CHECK_STR_CONTAINS(x->notes, "sample_count 16: the number of iterations is the job's");
done:
  vf_scene_destroy(x);
  vf_scene_destroy(j);
}

/* ... and the same image: independent path-traced estimates agree block by block. */
static void test_cornell_xml_and_json_render_the_same_film(void) {
  vf_scene *x = load(DIR "cornell.xml", NULL), *j = load(DIR "cornell.json", NULL);
  enum { BLOCKS = 4, NB = BLOCKS * BLOCKS, ITERATIONS = 96 };
  double mean[2][NB], se[2][NB];
  if (!x || !j) goto done;
  for (int k = 0; k < 2; k++) {
    vf_settings s = (k ? j : x)->settings;
    s.algorithm = VF_ALGO_PT;
    s.sampler = VF_SAMPLER_INDEPENDENT;
    s.width = s.height = 32;
    s.seed = 77 + (uint64_t)k;
    vf_vcm_stats stats = {0};
    CHECK_INT_EQ(render_block_estimates(k ? j : x, &s, 2, ITERATIONS, BLOCKS, mean[k], se[k], &stats), VF_OK);
    CHECK_INT_EQ(stats.nonfinite, 0);
  }
  double max_se = 0;
  for (int b = 0; b < NB; b++) max_se = fmax(max_se, se[0][b]);
  CHECK(max_se > 0 && max_se < 0.05); /* the comparison has teeth */
  CHECK(blocks_agree("cornell", "xml", "json", mean[0], se[0], mean[1], se[1], NB));
done:
  vf_scene_destroy(x);
  vf_scene_destroy(j);
}

/* An 8x4 map E and, for vcmfarm's unturned lookup, E rolled so that the pixel Mitsuba
 * reads through to_world = rotate(y, theta) is the pixel vcmfarm reads: Mitsuba reads
 * column floor(8 (f(d) + theta / 2pi)), f(d) = atan2(d.x, -d.z) / 2pi; vcmfarm column
 * floor(8 (f(d) + 1/2)); so rolled[x] = E[x - 4 + 8 theta / 2pi]. */
static void write_maps(int quarter_turns_rolled, const char *name_e, const char *name_rolled) {
  vf_image e = {0}, r = {0};
  CHECK_INT_EQ(vf_image_alloc(&e, 8, 4), VF_OK);
  CHECK_INT_EQ(vf_image_alloc(&r, 8, 4), VF_OK);
  for (int y = 0; y < 4; y++)
    for (int x = 0; x < 8; x++)
      for (int k = 0; k < 3; k++) e.rgb[3 * (y * 8 + x) + k] = 0.1f + 0.3f * (float)((x * 3 + y * 5 + k) % 7);
  for (int y = 0; y < 4; y++)
    for (int x = 0; x < 8; x++)
      for (int k = 0; k < 3; k++) r.rgb[3 * (y * 8 + x) + k] = e.rgb[3 * (y * 8 + (x + 4 + 2 * quarter_turns_rolled) % 8) + k];
  char path[1024];
  snprintf(path, sizeof path, "%s", write_temp(name_e, ""));
  CHECK_INT_EQ(vf_image_write_exr(path, &e), VF_OK);
  snprintf(path, sizeof path, "%s", write_temp(name_rolled, ""));
  CHECK_INT_EQ(vf_image_write_exr(path, &r), VF_OK);
  vf_image_destroy(&e);
  vf_image_destroy(&r);
}

/* Mitsuba's envmap orientation: its map under to_world renders as vcmfarm's map rolled
 * to match, unturned (identity and a quarter turn about +y). */
static void test_envmap_orientation_matches_a_rolled_map(void) {
  write_maps(0, "env.exr", "env_roll0.exr");
  write_maps(1, "env_b.exr", "env_roll90.exr");
  const char *xml =
      "<scene version=\"3.0.0\"><integrator type=\"path\"><integer name=\"max_depth\" value=\"3\"/></integrator>"
      "<sensor type=\"perspective\"><float name=\"fov\" value=\"150\"/>"
      "<film type=\"hdrfilm\"><integer name=\"width\" value=\"32\"/><integer name=\"height\" value=\"32\"/></film>"
      "<transform name=\"to_world\"><lookat origin=\"0, 0, 0\" target=\"0.3, 0.2, -1\"/></transform></sensor>"
      "<shape type=\"sphere\"><point name=\"center\" value=\"0.4, 0, -2\"/><float name=\"radius\" value=\"0.5\"/></shape>"
      "<emitter type=\"envmap\"><string name=\"filename\" value=\"%s\"/><float name=\"scale\" value=\"2\"/>%s</emitter></scene>";
  const char *json =
      "{\"camera\": {\"position\": [0, 0, 0], \"target\": [0.3, 0.2, -1], \"fov\": 150, \"resolution\": [32, 32]},"
      " \"materials\": {\"mitsuba-default-diffuse\": {\"diffuse\": [0.5, 0.5, 0.5]}},"
      " \"shapes\": [{\"type\": \"sphere\", \"center\": [0.4, 0, -2], \"radius\": 0.5, \"material\": \"mitsuba-default-diffuse\"}],"
      " \"lights\": [{\"type\": \"environment\", \"file\": \"%s\", \"scale\": [2, 2, 2]}], \"render\": {\"max_path_length\": 3}}";
  const struct {
    const char *map, *rolled, *transform;
  } cases[] = {{"env.exr", "env_roll0.exr", ""},
               {"env_b.exr", "env_roll90.exr", "<transform name=\"to_world\"><rotate y=\"1\" angle=\"90\"/></transform>"}};
  for (int c = 0; c < 2; c++) {
    char text[2048], xml_path[1024];
    snprintf(text, sizeof text, xml, cases[c].map, cases[c].transform);
    snprintf(xml_path, sizeof xml_path, "%s", write_temp("env.xml", text));
    snprintf(text, sizeof text, json, cases[c].rolled);
    vf_scene *x = load(xml_path, NULL), *j = load(write_temp("env.json", text), NULL);
    if (x && j) {
      CHECK(x->envmap_rotated);
      if (c == 0) { /* identity to_world: the half turn about +y */
        CHECK(x->envmap_rotation[0][0] == -1 && x->envmap_rotation[1][1] == 1 && x->envmap_rotation[2][2] == -1);
      }
      CHECK(!j->envmap_rotated);
      enum { BLOCKS = 4, NB = BLOCKS * BLOCKS };
      double mean[2][NB], se[2][NB];
      for (int k = 0; k < 2; k++) {
        vf_settings s = (k ? j : x)->settings;
        s.algorithm = VF_ALGO_PT;
        s.sampler = VF_SAMPLER_INDEPENDENT;
        s.seed = 500 + (uint64_t)(2 * c + k);
        vf_vcm_stats stats = {0};
        CHECK_INT_EQ(render_block_estimates(k ? j : x, &s, 2, 64, BLOCKS, mean[k], se[k], &stats), VF_OK);
      }
      CHECK(blocks_agree(c ? "envmap 90" : "envmap", "xml", "json", mean[0], se[0], mean[1], se[1], NB));
      /* light sub-paths leave the turned map as camera paths see it: bpt and vcm agree */
      const vf_algorithm bidirectional[2] = {VF_ALGO_BPT, VF_ALGO_VCM};
      for (int a = 0; a < 2; a++) {
        double bm[NB], bse[NB];
        vf_settings bs = x->settings;
        bs.algorithm = bidirectional[a];
        bs.sampler = VF_SAMPLER_INDEPENDENT;
        bs.seed = 700 + (uint64_t)(2 * c + a);
        vf_vcm_stats bstats = {0};
        CHECK_INT_EQ(render_block_estimates(x, &bs, 2, 64, BLOCKS, bm, bse, &bstats), VF_OK);
        CHECK(blocks_agree(c ? "envmap 90" : "envmap", a ? "vcm" : "bpt", "pt", bm, bse, mean[1], se[1], NB));
      }
      /* and a map read unturned would not agree: the test can tell the orientations apart */
      x->envmap_rotated = 0;
      vf_settings s = x->settings;
      s.algorithm = VF_ALGO_PT;
      s.sampler = VF_SAMPLER_INDEPENDENT;
      s.seed = 900 + (uint64_t)c;
      vf_vcm_stats stats = {0};
      CHECK_INT_EQ(render_block_estimates(x, &s, 2, 64, BLOCKS, mean[0], se[0], &stats), VF_OK);
      int agree_unturned = blocks_agree("unturned", "xml", "json", mean[0], se[0], mean[1], se[1], NB);
      CHECK(!agree_unturned);
    }
    vf_scene_destroy(x);
    vf_scene_destroy(j);
  }
}

/* A farm job carries the JSON text and ships the files it names: submit's collection
 * loads from the stage what a local render loads. */
/* The JSON inline mesh's "uvs" that rectangles convert to: 2 per vertex, checked. */
static void test_json_inline_mesh_uvs(void) {
  vf_scene *s = NULL;
  const char *good = "{\"camera\": {\"position\": [0, 0, 3], \"target\": [0, 0, 0], \"fov\": 40},"
                     " \"materials\": {\"m\": {}}, \"shapes\": [{\"type\": \"mesh\", \"material\": \"m\","
                     " \"emission\": [1, 1, 1], \"positions\": [0, 0, 0, 1, 0, 0, 0, 1, 0], \"indices\": [0, 1, 2],"
                     " \"uvs\": [0, 0, 1, 0, 0.25, 1]}]}";
  CHECK_INT_EQ(vf_scene_load(write_temp("uvs.json", good), &s), VF_OK);
  if (s) {
    CHECK(s->shapes[0].uvs != NULL && s->shapes[0].uvs[4] == 0.25f && s->shapes[0].uvs[5] == 1);
    vf_scene_destroy(s);
  }
  const char *bad = "{\"camera\": {\"position\": [0, 0, 3], \"target\": [0, 0, 0], \"fov\": 40},"
                    " \"materials\": {\"m\": {}}, \"shapes\": [{\"type\": \"mesh\", \"material\": \"m\","
                    " \"emission\": [1, 1, 1], \"positions\": [0, 0, 0, 1, 0, 0, 0, 1, 0], \"indices\": [0, 1, 2],"
                    " \"uvs\": [0, 0, 1, 0]}]}";
  s = NULL;
  CHECK_INT_EQ(vf_scene_load(write_temp("uvs_bad.json", bad), &s), VF_ESCENE);
  CHECK_STR_CONTAINS(vf_error_detail(VF_ESCENE), "shapes[0].uvs: expected a flat array of numbers, 2 per vertex (6)");
}

static void test_farm_job_loads_what_a_local_render_loads(void) {
  char *text = NULL, stage[512];
  size_t len = 0;
  vf_blob_table files = {0};
  vf_scene *local = load(DIR "shapes.xml", NULL), *job = NULL;
  CHECK_INT_EQ(vf_scene_model_text(DIR "shapes.xml", NULL, &text, &len), VF_OK);
  CHECK_INT_EQ(vf_file_temp_dir("vcmfarm-test-mitsuba-stage", stage, sizeof stage), VF_OK);
  int err = vf_job_scene_collect(DIR "shapes.xml", text, len, stage, &files, &job);
  if (err != VF_OK) printf("  collect: %s\n", vf_error_detail(err));
  CHECK_INT_EQ(err, VF_OK);
  CHECK_INT_EQ(files.count, 2); /* the PLY and OBJ files, by content hash */
  if (local && job) CHECK(memcmp(local->hash, job->hash, sizeof local->hash) == 0);
  vf_scene_destroy(job);
  vf_scene_destroy(local);
  vf_blob_table_clear(&files);
  free(text);
  /* The mirrored sensor travels as the camera's "mirror" of the JSON a job carries. */
  text = NULL;
  job = NULL;
  local = load(DIR "mirrored.xml", "mirrored");
  CHECK_INT_EQ(vf_scene_model_text(DIR "mirrored.xml", "mirrored", &text, &len), VF_OK);
  err = text ? vf_job_scene_collect(DIR "mirrored.xml", text, len, stage, &files, &job) : VF_ESCENE;
  CHECK_INT_EQ(err, VF_OK);
  if (local && job) {
    CHECK(memcmp(local->hash, job->hash, sizeof local->hash) == 0);
    CHECK_INT_EQ(job->camera.mirror, 1);
  }
  vf_scene_destroy(job);
  vf_scene_destroy(local);
  vf_blob_table_clear(&files);
  vf_file_remove_tree(stage);
  free(text);
}

int main(void) {
  RUN(test_perspective_from_lookat_fov_along_x_and_max_depth);
  RUN(test_thinlens_and_orthographic_sensors_by_id_and_index);
  RUN(test_mirroring_sensor_mirrors_the_image);
  RUN(test_textured_conductor_eta_and_k);
  RUN(test_principled_with_its_clear_coat);
  RUN(test_fov_axis_x_y_diagonal_smaller_larger_and_focal_length);
  RUN(test_shapes_and_transforms_composed_in_order);
  RUN(test_every_bsdf_parameter);
  RUN(test_point_spot_directional_and_constant_emitters);
  RUN(test_bad_files_refused_naming_file_element_and_reason);
  RUN(test_null_bumpmap_and_albedo_above_one);
  RUN(test_version_1_names_upgraded);
  RUN(test_mesh_file_texture_coordinates_as_mitsuba_reads_them);
  RUN(test_serialized_meshes_by_index);
  RUN(test_cornell_xml_and_json_load_the_same_content);
  RUN(test_cornell_xml_and_json_render_the_same_film);
  RUN(test_json_inline_mesh_uvs);
  RUN(test_envmap_orientation_matches_a_rolled_map);
  RUN(test_farm_job_loads_what_a_local_render_loads);
  if (temp_dir[0]) vf_file_remove_tree(temp_dir);
  return check_finish();
}
