/* Participating media in scenes (worker/scene/media.c, interfaces.c, vdb.cpp): the JSON
 * fields, every refusal naming file and field, interfaces and exteriors of nested shapes,
 * closedness and winding, VDB grids written with OpenVDB itself (vdb_fixtures.cpp), glTF's
 * KHR_materials_volume, the media built-ins, farm jobs shipping grid files, and the hash. */
#include "check.h"
#include "common/blob.h"
#include "common/error.h"
#include "vdb_fixtures.h"
#include "worker/scene/job_scene.h"
#include "worker/scene/load.h"
#include "worker/scene/scene.h"
#include "worker/scene/vdb.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <signal.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

static char dir[64];

static void path_of(char *out, size_t n, const char *name) { snprintf(out, n, "%s/%s", dir, name); }

static void write_text(const char *name, const char *text) {
  char p[256];
  path_of(p, sizeof p, name);
  FILE *f = fopen(p, "wb");
  CHECK(f != NULL);
  if (f == NULL) return;
  fputs(text, f);
  fclose(f);
}

/* ---- scene text ------------------------------------------------------------------------------ */

/* A growable JSON text. */
typedef struct {
  char text[65536];
  size_t len;
} scene_text;

static void put(scene_text *t, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void put(scene_text *t, const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  int w = vsnprintf(t->text + t->len, sizeof t->text - t->len, fmt, ap);
  va_end(ap);
  CHECK(w >= 0 && (size_t)w < sizeof t->text - t->len);
  if (w > 0 && (size_t)w < sizeof t->text - t->len) t->len += (size_t)w;
}

/* The 12 triangles of the box [lo, hi], corners numbered x + 2y + 4z, facing outwards (or
 * inwards); `drop` triangles left off the end (an open box). */
static const int box_triangles[36] = {0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5, 0, 1, 5, 0, 5, 4,
                                      2, 6, 7, 2, 7, 3, 0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6};

static void put_box_mesh(scene_text *t, const double lo[3], const double hi[3], int inwards, int drop) {
  put(t, "\"positions\": [");
  for (int v = 0; v < 8; v++)
    put(t, "%s%g, %g, %g", v ? ", " : "", v & 1 ? hi[0] : lo[0], v & 2 ? hi[1] : lo[1], v & 4 ? hi[2] : lo[2]);
  put(t, "], \"indices\": [");
  for (int i = 0; i < 36 - 3 * drop; i += 3)
    put(t, "%s%d, %d, %d", i ? ", " : "", box_triangles[i], box_triangles[i + (inwards ? 2 : 1)],
        box_triangles[i + (inwards ? 1 : 2)]);
  put(t, "]");
}

/* The head of a scene: camera, materials (white, glass, light) and `media` (an object's
 * members), `extra` top-level members; then shapes are added and end_scene closes it. */
static void begin_scene(scene_text *t, const char *media, const char *extra) {
  t->len = 0;
  put(t, "{\"camera\": {\"position\": [0, 0, 10], \"target\": [0, 0, 0], \"fov\": 40},\n"
         " \"materials\": {\"white\": {\"diffuse\": [0.5, 0.5, 0.5]}, \"glass\": {\"dielectric\": [1, 1, 1], \"ior\": 1.5},"
         " \"light\": {}},\n");
  if (media) put(t, " \"media\": {%s},\n", media);
  if (extra) put(t, " %s,\n", extra);
  put(t, " \"shapes\": [{\"type\": \"sphere\", \"name\": \"lamp\", \"material\": \"light\", \"center\": [0, 20, 0], "
         "\"radius\": 1, \"emission\": [1, 1, 1]}");
}

static void end_scene(scene_text *t, const char *name) {
  put(t, "]}\n");
  write_text(name, t->text);
}

static vf_scene *load_ok(const char *name) {
  char p[256];
  path_of(p, sizeof p, name);
  vf_scene *s = NULL;
  int err = vf_scene_load(p, &s);
  if (err != VF_OK) CHECK_FAIL_("loading %s: %s", name, vf_error_detail(err));
  return s;
}

/* Loads name expecting code `code` and a detail containing `expected`. */
static void load_fails(const char *name, int code, const char *expected) {
  char p[256];
  path_of(p, sizeof p, name);
  vf_scene *s = NULL;
  vf_error_clear();
  int err = vf_scene_load(p, &s);
  if (err != code) CHECK_FAIL_("%s: code %d (%s), expected %d (%s)", name, err, vf_error_detail(err), code, vf_strerror(code));
  CHECK(s == NULL);
  if (err != VF_OK) CHECK_STR_CONTAINS(vf_error_detail(err), expected);
  vf_scene_destroy(s);
}

static const vf_shape *shape_named(const vf_scene *s, const char *name) {
  for (int i = 0; i < s->num_shapes; i++)
    if (strcmp(s->shapes[i].name, name) == 0) return &s->shapes[i];
  CHECK_FAIL_("no shape named '%s'", name);
  return NULL;
}

static int medium_named(const vf_scene *s, const char *name) {
  for (int i = 0; i < s->num_media; i++)
    if (strcmp(s->media[i].name, name) == 0) return i;
  CHECK_FAIL_("no medium named '%s'", name);
  return -2;
}

/* Six times the signed volume a closed mesh encloses: positive when it faces outwards. */
static double signed_volume6(const vf_shape *s) {
  double v = 0.0;
  for (uint32_t t = 0; t < s->num_triangles; t++) {
    const float *a = &s->positions[3 * s->indices[3 * t]], *b = &s->positions[3 * s->indices[3 * t + 1]],
                *c = &s->positions[3 * s->indices[3 * t + 2]];
    v += a[0] * ((double)b[1] * c[2] - (double)b[2] * c[1]) - a[1] * ((double)b[0] * c[2] - (double)b[2] * c[0]) +
         a[2] * ((double)b[0] * c[1] - (double)b[1] * c[0]);
  }
  return v;
}

/* ---- fields ------------------------------------------------------------------------------- */

static void test_media_fields_are_read(void) {
  scene_text t;
  begin_scene(&t,
              "\"haze\": {\"sigma_a\": 0.25, \"sigma_s\": [0.5, 1, 2], \"g\": 0.4},"
              " \"ink\": {\"sigma_a\": [1, 2, 3]}, \"cloud\": {\"sigma_s\": 3, \"g\": -0.5}",
              "\"medium\": \"haze\"");
  put(&t, ", {\"type\": \"sphere\", \"name\": \"ink ball\", \"material\": \"glass\", \"interior\": \"ink\", "
          "\"center\": [0, 0, 0], \"radius\": 1}");
  put(&t, ", {\"type\": \"mesh\", \"name\": \"cloud box\", \"interior\": \"cloud\", ");
  put_box_mesh(&t, (const double[]){3, 3, 3}, (const double[]){4, 4, 4}, 0, 0);
  put(&t, "}");
  end_scene(&t, "fields.json");
  vf_scene *s = load_ok("fields.json");
  if (s == NULL) return;
  CHECK_INT_EQ(s->num_media, 3);
  int haze = medium_named(s, "haze"), ink = medium_named(s, "ink"), cloud = medium_named(s, "cloud");
  CHECK_INT_EQ(s->medium, haze);
  const vf_medium *m = &s->media[haze];
  CHECK_NEAR(m->sigma_a.x, 0.25, 0); CHECK_NEAR(m->sigma_a.y, 0.25, 0); CHECK_NEAR(m->sigma_a.z, 0.25, 0);
  CHECK_NEAR(m->sigma_s.x, 0.5, 0); CHECK_NEAR(m->sigma_s.y, 1, 0); CHECK_NEAR(m->sigma_s.z, 2, 0);
  CHECK_NEAR(m->g, 0.4f, 0);
  CHECK(m->grid == NULL);
  m = &s->media[ink];
  CHECK_NEAR(m->sigma_a.z, 3, 0);
  CHECK(vf_is_zero(m->sigma_s)); /* absent: 0 */
  CHECK_NEAR(m->g, 0, 0);        /* absent: isotropic */
  m = &s->media[cloud];
  CHECK(vf_is_zero(m->sigma_a));
  CHECK_NEAR(m->sigma_s.y, 3, 0);
  CHECK_NEAR(m->g, -0.5f, 0);
  const vf_shape *ball = shape_named(s, "ink ball"), *box = shape_named(s, "cloud box"), *lamp = shape_named(s, "lamp");
  if (ball && box && lamp) {
    CHECK_INT_EQ(ball->interior, ink);
    CHECK_INT_EQ(ball->interface, 1);
    CHECK(ball->material >= 0);
    CHECK_INT_EQ(box->material, -1); /* index-matched */
    CHECK_INT_EQ(box->interior, cloud);
    CHECK_INT_EQ(box->interface, 1);
    CHECK_INT_EQ(lamp->interface, 0); /* a diffuse emitter bounds no medium */
    CHECK_INT_EQ(lamp->interior, -1);
    CHECK_INT_EQ(lamp->exterior, -1);
  }
  vf_scene_destroy(s);
}

/* ---- refusals ---------------------------------------------------------------------------- */

static void test_bad_media_are_refused_naming_file_and_field(void) {
  static const struct {
    const char *media, *extra, *shape, *detail;
    int code;
  } cases[] = {
      {NULL, NULL, "{\"type\": \"sphere\", \"material\": \"glass\", \"interior\": \"fog\", \"center\": [0, 0, 0], \"radius\": 1}",
       "bad.json: shapes[1].interior: unknown medium 'fog' (the scene has no \"media\")", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1}", "\"medium\": \"smog\"", NULL, "bad.json: medium: unknown medium 'smog'", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1}", "\"medium\": 3", NULL, "bad.json: medium: expected a medium's name", VF_ESCENE},
      {"\"fog\": {\"sigma_a\": -0.5}", NULL, NULL, "bad.json: media.fog.sigma_a: must be >= 0", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": [1, -1, 1]}", NULL, NULL, "bad.json: media.fog.sigma_s: must be >= 0", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1e999}", NULL, NULL, "bad.json: media.fog.sigma_s: not a finite number", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": \"thick\"}", NULL, NULL, "bad.json: media.fog.sigma_s: expected a number or [r, g, b]", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1, \"g\": 1}", NULL, NULL, "bad.json: media.fog.g: the phase function's asymmetry must be in (-1, 1)", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1, \"g\": -1.5}", NULL, NULL, "bad.json: media.fog.g: the phase function's asymmetry must be in (-1, 1)", VF_ESCENE},
      {"\"fog\": {\"g\": 0.5}", NULL, NULL, "bad.json: media.fog: needs 'sigma_a' or 'sigma_s'", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1, \"albedo\": 0.5}", NULL, NULL, "bad.json: media.fog.albedo: unknown field", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1, \"density\": {\"file\": \"missing.vdb\"}}", NULL, NULL,
       "bad.json: media.fog.density.file: missing.vdb: cannot open", VF_ENOENT},
      {"\"fog\": {\"sigma_s\": 1, \"density\": {\"file\": \"grid.vdb\", \"res\": 3}}", NULL, NULL,
       "bad.json: media.fog.density.res: unknown field", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1, \"density\": {\"file\": \"grid.vdb\", \"scale\": 0}}", NULL, NULL,
       "bad.json: media.fog.density.scale: must be > 0", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1, \"density\": {\"file\": \"grid.vdb\", \"box\": {\"min\": [0, 0, 0], \"max\": [1, 1, 1]}, "
       "\"transform\": {\"translate\": [1, 0, 0]}}}", NULL, NULL, "bad.json: media.fog.density: give 'box' or 'transform', not both", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1, \"density\": {\"file\": \"grid.vdb\", \"box\": {\"min\": [0, 0, 0], \"max\": [1, 0, 1]}}}", NULL, NULL,
       "bad.json: media.fog.density.box: 'min' must be below 'max'", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1, \"density\": {\"file\": \"grid.vdb\", \"transform\": {\"rotate\": {\"axis\": [0, 1, 0], \"degrees\": 30}}}}",
       NULL, NULL, "bad.json: media.fog.density.transform: a density grid stays axis-aligned", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1, \"density\": {\"file\": \"grid.vdb\", \"grid\": \"heat\"}}", NULL, NULL,
       "bad.json: media.fog.density.file: grid.vdb: no grid named 'heat' (the file has 'density')", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1, \"density\": {\"file\": \"damaged.vdb\"}}", NULL, NULL,
       "bad.json: media.fog.density.file: damaged.vdb: not a readable VDB file", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1, \"density\": {\"file\": \"truncated.vdb\"}}", NULL, NULL,
       "bad.json: media.fog.density.file: truncated.vdb: not a readable VDB file", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1, \"density\": {\"file\": \"huge.vdb\"}}", NULL, NULL,
       "bad.json: media.fog.density.file: huge.vdb: grid 'density' spans 1001 x 1001 x 1001 voxels, more than the", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1, \"density\": {\"file\": \"double.vdb\"}}", NULL, NULL,
       "bad.json: media.fog.density.file: double.vdb: grid 'density' holds double values: a density grid must hold floats", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1, \"density\": {\"file\": \"rotated.vdb\"}}", NULL, NULL,
       "bad.json: media.fog.density.file: rotated.vdb: grid 'density' has a", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1, \"density\": {\"file\": \"negative.vdb\"}}", NULL, NULL,
       "bad.json: media.fog.density.file: negative.vdb: grid 'density' has density -1 at voxel", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1, \"density\": {\"file\": \"background.vdb\"}}", NULL, NULL,
       "bad.json: media.fog.density.file: background.vdb: grid 'density' has background 0.5", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1}", NULL, "{\"type\": \"mesh\", \"interior\": \"fog\", OPEN_BOX}",
       "bad.json: shapes[1] (shapes[1]): has an interior but is not closed (3 edges are not shared by exactly two triangles)", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1}", NULL, "{\"type\": \"mesh\", \"interior\": \"fog\", TWISTED_BOX}",
       "bad.json: shapes[1] (shapes[1]): has an interior but is inconsistently wound", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1}", NULL, "{\"type\": \"sphere\", \"interior\": \"fog\", \"emission\": [1, 1, 1], \"center\": [0, 0, 0], \"radius\": 1}",
       "bad.json: shapes[1].emission: an index-matched boundary (a shape without 'material') cannot emit", VF_ESCENE},
      {"\"fog\": {\"sigma_s\": 1}", NULL, "{\"type\": \"sphere\", \"center\": [0, 0, 0], \"radius\": 1}",
       "bad.json: shapes[1]: missing field 'material' (only a shape with an 'interior' may have none", VF_ESCENE},
  };
  /* The grid files the cases name. */
  char p[256];
  const int lo[3] = {0, 0, 0}, dims[3] = {4, 3, 2};
  const double scale[3] = {1, 1, 1}, translate[3] = {0, 0, 0};
  static const struct {
    const char *file;
    int kind;
  } grids[] = {{"grid.vdb", VDB_FIXTURE_GOOD},         {"huge.vdb", VDB_FIXTURE_HUGE},
               {"double.vdb", VDB_FIXTURE_DOUBLE},     {"rotated.vdb", VDB_FIXTURE_ROTATED},
               {"negative.vdb", VDB_FIXTURE_NEGATIVE}, {"background.vdb", VDB_FIXTURE_BACKGROUND}};
  for (size_t i = 0; i < sizeof grids / sizeof grids[0]; i++) {
    path_of(p, sizeof p, grids[i].file);
    CHECK_INT_EQ(vdb_fixture_write(p, grids[i].kind, "density", lo, dims, scale, translate), 0);
  }
  write_text("damaged.vdb", "this is not a VDB file, only text that claims a .vdb name\n");
  { /* the good file cut in half */
    path_of(p, sizeof p, "grid.vdb");
    FILE *f = fopen(p, "rb");
    static unsigned char bytes[1 << 16];
    size_t n = f ? fread(bytes, 1, sizeof bytes, f) : 0;
    if (f) fclose(f);
    CHECK(n > 64);
    path_of(p, sizeof p, "truncated.vdb");
    f = fopen(p, "wb");
    if (f) fwrite(bytes, 1, n / 2, f), fclose(f);
  }
  for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
    scene_text t;
    begin_scene(&t, cases[i].media, cases[i].extra);
    if (cases[i].shape) {
      const char *open = strstr(cases[i].shape, "OPEN_BOX"), *twisted = strstr(cases[i].shape, "TWISTED_BOX");
      const char *mark = open ? open : twisted;
      if (mark) {
        put(&t, ", %.*s", (int)(mark - cases[i].shape), cases[i].shape);
        scene_text box = {.len = 0};
        put_box_mesh(&box, (const double[]){-1, -1, -1}, (const double[]){1, 1, 1}, 0, open ? 1 : 0);
        if (twisted) { /* one triangle turned: every edge still shared by two, three run the same way */
          char *last = strrchr(box.text, '[');
          (void)last;
          char *tail = strstr(box.text, "4, 7, 6]");
          CHECK(tail != NULL);
          if (tail) memcpy(tail, "4, 6, 7]", 8);
        }
        put(&t, "%s%s", box.text, mark + strlen(open ? "OPEN_BOX" : "TWISTED_BOX"));
      } else {
        put(&t, ", %s", cases[i].shape);
      }
    }
    end_scene(&t, "bad.json");
    load_fails("bad.json", cases[i].code, cases[i].detail);
  }
}

/* ---- interfaces and nesting ------------------------------------------------------------------- */

/* Scene medium C around a box of medium B around a ball of medium A; a clear glass ball in
 * B (vacuum inside); an open wall and a diffuse ball bound nothing. */
static void test_nested_interfaces_take_the_innermost_container(void) {
  scene_text t;
  begin_scene(&t, "\"A\": {\"sigma_a\": 1}, \"B\": {\"sigma_s\": 2}, \"C\": {\"sigma_s\": 0.1}", "\"medium\": \"C\"");
  put(&t, ", {\"type\": \"mesh\", \"name\": \"box B\", \"material\": \"glass\", \"interior\": \"B\", ");
  put_box_mesh(&t, (const double[]){-3, -3, -3}, (const double[]){3, 3, 3}, 0, 0);
  put(&t, "}, {\"type\": \"mesh\", \"name\": \"outer box\", \"interior\": \"C\", ");
  put_box_mesh(&t, (const double[]){-5, -5, -5}, (const double[]){5, 5, 6}, 0, 0); /* C again: a boundary of C in C */
  put(&t, "}, {\"type\": \"sphere\", \"name\": \"ball A\", \"material\": \"glass\", \"interior\": \"A\", \"center\": [1, 0, 0], "
          "\"radius\": 1}");
  put(&t, ", {\"type\": \"sphere\", \"name\": \"clear ball\", \"material\": \"glass\", \"center\": [-1.5, 1, 0], \"radius\": 0.5}");
  put(&t, ", {\"type\": \"sphere\", \"name\": \"diffuse ball\", \"material\": \"white\", \"center\": [-1.5, -1.5, 0], \"radius\": 0.5}");
  put(&t, ", {\"type\": \"mesh\", \"name\": \"wall\", \"material\": \"glass\", \"positions\": [7, 0, 0, 8, 0, 0, 8, 1, 0], "
          "\"indices\": [0, 1, 2]}");
  put(&t, ", {\"type\": \"sphere\", \"name\": \"far ball A\", \"material\": \"glass\", \"interior\": \"A\", \"center\": [20, 0, 0], "
          "\"radius\": 1}");
  end_scene(&t, "nested.json");
  vf_scene *s = load_ok("nested.json");
  if (s == NULL) return;
  int a = medium_named(s, "A"), b = medium_named(s, "B"), c = medium_named(s, "C");
  const vf_shape *box = shape_named(s, "box B"), *outer = shape_named(s, "outer box"), *ball = shape_named(s, "ball A"),
                 *clear = shape_named(s, "clear ball"), *diffuse = shape_named(s, "diffuse ball"),
                 *wall = shape_named(s, "wall"), *far = shape_named(s, "far ball A");
  if (box && outer && ball && clear && diffuse && wall && far) {
    CHECK_INT_EQ(ball->interface, 1); CHECK_INT_EQ(ball->interior, a); CHECK_INT_EQ(ball->exterior, b);
    CHECK_INT_EQ(box->interface, 1); CHECK_INT_EQ(box->interior, b); CHECK_INT_EQ(box->exterior, c);
    CHECK_INT_EQ(outer->interface, 1); CHECK_INT_EQ(outer->interior, c); CHECK_INT_EQ(outer->exterior, c);
    CHECK_INT_EQ(clear->interface, 1); CHECK_INT_EQ(clear->interior, -1); CHECK_INT_EQ(clear->exterior, b);
    CHECK_INT_EQ(diffuse->interface, 0); CHECK_INT_EQ(diffuse->interior, -1); CHECK_INT_EQ(diffuse->exterior, -1);
    CHECK_INT_EQ(wall->interface, 0); CHECK_INT_EQ(wall->exterior, -1); /* refracting but open: no region */
    CHECK_INT_EQ(far->interface, 1); CHECK_INT_EQ(far->exterior, c);    /* outside everything: the scene's */
  }
  vf_scene_destroy(s);

  /* Without media a glass ball is no interface: scenes without media are as they were. */
  begin_scene(&t, NULL, NULL);
  put(&t, ", {\"type\": \"sphere\", \"name\": \"clear ball\", \"material\": \"glass\", \"center\": [0, 0, 0], \"radius\": 1}");
  end_scene(&t, "plain.json");
  s = load_ok("plain.json");
  if (s == NULL) return;
  CHECK_INT_EQ(s->num_media, 0);
  CHECK_INT_EQ(s->medium, -1);
  for (int i = 0; i < s->num_shapes; i++) {
    CHECK_INT_EQ(s->shapes[i].interface, 0);
    CHECK_INT_EQ(s->shapes[i].interior, -1);
    CHECK_INT_EQ(s->shapes[i].exterior, -1);
  }
  vf_scene_destroy(s);
}

/* A box of separate faces (each with its own vertices, as files have them at seams) is
 * closed; one wound inside-out is turned to face outwards, with a note. */
static void test_closed_meshes_joined_by_position_and_turned_outwards(void) {
  scene_text t;
  begin_scene(&t, "\"fog\": {\"sigma_s\": 1}", NULL);
  put(&t, ", {\"type\": \"mesh\", \"name\": \"faces\", \"interior\": \"fog\", \"positions\": [");
  for (int tri = 0; tri < 12; tri++)
    for (int k = 0; k < 3; k++) {
      int v = box_triangles[3 * tri + k];
      put(&t, "%s%d, %d, %d", tri || k ? ", " : "", v & 1 ? 1 : -1, v & 2 ? 1 : -1, v & 4 ? 1 : -1);
    }
  put(&t, "], \"indices\": [");
  for (int i = 0; i < 36; i++) put(&t, "%s%d", i ? ", " : "", i);
  put(&t, "]}, {\"type\": \"mesh\", \"name\": \"inside out\", \"interior\": \"fog\", ");
  put_box_mesh(&t, (const double[]){4, 4, 4}, (const double[]){5, 5, 5}, 1, 0);
  put(&t, "}");
  end_scene(&t, "closed.json");
  vf_scene *s = load_ok("closed.json");
  if (s == NULL) return;
  const vf_shape *faces = shape_named(s, "faces"), *turned = shape_named(s, "inside out");
  if (faces && turned) {
    CHECK_INT_EQ(faces->interface, 1);
    CHECK_NEAR(signed_volume6(faces), 6 * 8.0, 1e-9);
    CHECK_INT_EQ(turned->interface, 1);
    CHECK_NEAR(signed_volume6(turned), 6 * 1.0, 1e-9); /* was -6 as written */
    CHECK_STR_CONTAINS(s->notes, "inside out: a medium boundary wound inside-out (facing inwards): turned to face outwards");
  }
  vf_scene_destroy(s);
}

/* ---- VDB grids ----------------------------------------------------------------------------------- */

static void test_vdb_grid_round_trip_and_placement(void) {
  const int lo[3] = {-1, 2, 3}, dims[3] = {4, 3, 2};
  const double scale[3] = {0.5, 0.25, 2.0}, translate[3] = {1, -2, 0.5};
  char p[256];
  path_of(p, sizeof p, "smoke.vdb");
  CHECK_INT_EQ(vdb_fixture_write(p, VDB_FIXTURE_GOOD, "density", lo, dims, scale, translate), 0);
  vf_density_grid g;
  int err = vf_vdb_read_grid(p, "smoke.vdb", "density", &g);
  if (err != VF_OK) {
    CHECK_FAIL_("reading: %s", vf_error_detail(err));
    return;
  }
  CHECK_INT_EQ(g.nx, dims[0]); CHECK_INT_EQ(g.ny, dims[1]); CHECK_INT_EQ(g.nz, dims[2]);
  /* The voxels' box: index bounds -+ 0.5 through the file's transform. */
  const float box_lo[3] = {g.box_min.x, g.box_min.y, g.box_min.z}, box_hi[3] = {g.box_max.x, g.box_max.y, g.box_max.z};
  for (int a = 0; a < 3; a++) {
    CHECK_NEAR(box_lo[a], scale[a] * (lo[a] - 0.5) + translate[a], 1e-6);
    CHECK_NEAR(box_hi[a], scale[a] * (lo[a] + dims[a] - 0.5) + translate[a], 1e-6);
  }
  double largest = 0.0;
  size_t i = 0;
  for (int k = 0; k < dims[2]; k++)
    for (int j = 0; j < dims[1]; j++)
      for (int x = 0; x < dims[0]; x++, i++) {
        double expected = vdb_fixture_value(lo[0] + x, lo[1] + j, lo[2] + k);
        CHECK_NEAR(g.density[i], expected, 1e-6);
        largest = fmax(largest, expected);
      }
  CHECK_NEAR(g.max_density, largest, 1e-6);
  CHECK_STR_CONTAINS(g.source, "smoke.vdb");
  free(g.density);

  /* Our writer's file reads back to the same grid (the built-ins' path). */
  vf_density_grid made = {.nx = 3, .ny = 2, .nz = 2, .box_min = vf_vec3_make(-1, 0, 2), .box_max = vf_vec3_make(2, 1, 6)};
  float samples[12] = {0, 1, 2, 3, 0, 0.5f, 0.25f, 7, 0, 0, 1, 0};
  made.density = samples;
  void *bytes = NULL;
  size_t size = 0;
  CHECK_INT_EQ(vf_vdb_write_grid_memory(&made, "density", &bytes, &size), VF_OK);
  err = vf_vdb_read_grid_memory(bytes, size, "made.vdb", "density", &g);
  CHECK_INT_EQ(err, VF_OK);
  if (err == VF_OK) {
    CHECK_INT_EQ(g.nx, 3); CHECK_INT_EQ(g.ny, 2); CHECK_INT_EQ(g.nz, 2);
    for (int s = 0; s < 12; s++) CHECK_NEAR(g.density[s], samples[s], 0);
    CHECK_NEAR(g.box_min.x, -1, 1e-6); CHECK_NEAR(g.box_max.z, 6, 1e-6); CHECK_NEAR(g.max_density, 7, 0);
    free(g.density);
  }
  free(bytes);

  /* In a scene: scaled, placed by the file, by a box, and by a transform. */
  scene_text t;
  begin_scene(&t,
              "\"file\": {\"sigma_s\": 1, \"density\": {\"file\": \"smoke.vdb\", \"scale\": 2}},"
              " \"boxed\": {\"sigma_s\": 1, \"density\": {\"file\": \"smoke.vdb\", \"grid\": \"density\", "
              "\"box\": {\"min\": [0, 0, 0], \"max\": [4, 3, 2]}}},"
              " \"moved\": {\"sigma_s\": 1, \"density\": {\"file\": \"smoke.vdb\", "
              "\"transform\": {\"scale\": [2, 1, 1], \"translate\": [10, 0, 0]}}}",
              "\"medium\": \"file\"");
  end_scene(&t, "grids.json");
  vf_scene *s = load_ok("grids.json");
  if (s == NULL) return;
  const vf_medium *file = &s->media[medium_named(s, "file")], *boxed = &s->media[medium_named(s, "boxed")],
                  *moved = &s->media[medium_named(s, "moved")];
  CHECK(file->grid && boxed->grid && moved->grid);
  if (file->grid && boxed->grid && moved->grid) {
    CHECK_NEAR(file->grid->density[5], 2 * vdb_fixture_value(lo[0] + 1, lo[1] + 1, lo[2]), 1e-5);
    CHECK_NEAR(file->grid->max_density, 2 * largest, 1e-5);
    CHECK_NEAR(file->grid->box_min.y, scale[1] * (lo[1] - 0.5) + translate[1], 1e-6);
    CHECK_NEAR(boxed->grid->box_min.x, 0, 0); CHECK_NEAR(boxed->grid->box_max.y, 3, 0);
    CHECK_NEAR(boxed->grid->density[5], vdb_fixture_value(lo[0] + 1, lo[1] + 1, lo[2]), 1e-6);
    CHECK_NEAR(moved->grid->box_min.x, 2 * (scale[0] * (lo[0] - 0.5) + translate[0]) + 10, 1e-5);
    CHECK_NEAR(moved->grid->box_max.x, 2 * (scale[0] * (lo[0] + dims[0] - 0.5) + translate[0]) + 10, 1e-5);
    CHECK_NEAR(moved->grid->box_min.z, file->grid->box_min.z, 0);
  }
  vf_scene_destroy(s);
}

/* A farm job ships the grid file by content hash, and the worker's load from the blobs
 * hashes as the directory's. */
static void test_job_scene_ships_the_grid_file(void) {
  const int lo[3] = {0, 0, 0}, dims[3] = {3, 3, 3};
  const double scale[3] = {0.1, 0.1, 0.1}, translate[3] = {0, 0, 0};
  char p[256], stage[256];
  path_of(p, sizeof p, "job.vdb");
  CHECK_INT_EQ(vdb_fixture_write(p, VDB_FIXTURE_GOOD, "density", lo, dims, scale, translate), 0);
  scene_text t;
  begin_scene(&t, "\"fog\": {\"sigma_s\": 1, \"density\": {\"file\": \"job.vdb\"}}", "\"medium\": \"fog\"");
  end_scene(&t, "job.json");
  path_of(p, sizeof p, "job.json");
  path_of(stage, sizeof stage, "stage");
  char cmd[300];
  snprintf(cmd, sizeof cmd, "mkdir -p '%s'", stage);
  CHECK_INT_EQ(system(cmd), 0);
  vf_blob_table files;
  memset(&files, 0, sizeof files);
  vf_scene *s = NULL;
  int err = vf_job_scene_collect(p, t.text, t.len, stage, &files, &s);
  if (err != VF_OK) CHECK_FAIL_("collect: %s", vf_error_detail(err));
  CHECK(vf_blob_table_find(&files, "job.vdb") != NULL);
  if (s != NULL) {
    CHECK(s->media[0].grid != NULL);
    vf_scene *direct = load_ok("job.json");
    if (direct) CHECK(memcmp(direct->hash, s->hash, 32) == 0);
    vf_scene_destroy(direct);
  }
  vf_scene_destroy(s);
  vf_blob_table_clear(&files);
}

/* ---- glTF's KHR_materials_volume ------------------------------------------------------------------ */

static void base64(const unsigned char *in, size_t n, char *out) {
  static const char digits[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  size_t o = 0;
  for (size_t i = 0; i < n; i += 3) {
    unsigned v = (unsigned)in[i] << 16 | (i + 1 < n ? (unsigned)in[i + 1] << 8 : 0) | (i + 2 < n ? in[i + 2] : 0);
    out[o++] = digits[v >> 18 & 63], out[o++] = digits[v >> 12 & 63];
    out[o++] = i + 1 < n ? digits[v >> 6 & 63] : '=', out[o++] = i + 2 < n ? digits[v & 63] : '=';
  }
  out[o] = '\0';
}

/* Three meshes: a closed cube and an open triangle of an absorbing glass, and a cube of a
 * thin-walled one; each node moved apart. */
static void test_gltf_volume_becomes_an_absorbing_interior(void) {
  unsigned char buffer[96 + 72 + 8];
  for (int v = 0; v < 8; v++) {
    float xyz[3] = {v & 1 ? 0.5f : -0.5f, v & 2 ? 0.5f : -0.5f, v & 4 ? 0.5f : -0.5f};
    memcpy(buffer + 12 * v, xyz, 12);
  }
  for (int i = 0; i < 36; i++) {
    unsigned short idx = (unsigned short)box_triangles[i];
    memcpy(buffer + 96 + 2 * i, &idx, 2);
  }
  const unsigned short tri[4] = {0, 1, 3, 0};
  memcpy(buffer + 168, tri, 8);
  char uri[512];
  base64(buffer, sizeof buffer, uri);
  scene_text t = {.len = 0};
  put(&t,
      "{\"asset\": {\"version\": \"2.0\"},\n"
      " \"extensionsUsed\": [\"KHR_materials_transmission\", \"KHR_materials_volume\"],\n"
      " \"scene\": 0, \"scenes\": [{\"nodes\": [0, 1, 2]}],\n"
      " \"nodes\": [{\"mesh\": 0, \"name\": \"amber cube\"}, {\"mesh\": 1, \"name\": \"sheet\", \"translation\": [3, 0, 0]},"
      " {\"mesh\": 2, \"name\": \"thin cube\", \"translation\": [-3, 0, 0]}],\n"
      " \"meshes\": [{\"name\": \"amber cube\", \"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 1, \"material\": 0}]},"
      " {\"name\": \"sheet\", \"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 2, \"material\": 0}]},"
      " {\"name\": \"thin cube\", \"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 1, \"material\": 1}]}],\n"
      " \"materials\": [{\"name\": \"Amber\", \"extensions\": {\"KHR_materials_transmission\": {\"transmissionFactor\": 1},"
      " \"KHR_materials_volume\": {\"thicknessFactor\": 0.5, \"attenuationDistance\": 2, \"attenuationColor\": [0.5, 0.25, 1]}}},"
      " {\"name\": \"Thin\", \"extensions\": {\"KHR_materials_transmission\": {\"transmissionFactor\": 1},"
      " \"KHR_materials_volume\": {\"thicknessFactor\": 0, \"attenuationDistance\": 1, \"attenuationColor\": [0.5, 0.5, 0.5]}}}],\n"
      " \"buffers\": [{\"byteLength\": %zu, \"uri\": \"data:application/octet-stream;base64,%s\"}],\n"
      " \"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": 96}, {\"buffer\": 0, \"byteOffset\": 96, \"byteLength\": 72},"
      " {\"buffer\": 0, \"byteOffset\": 168, \"byteLength\": 6}],\n"
      " \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 8, \"type\": \"VEC3\", \"min\": [-0.5, -0.5, -0.5],"
      " \"max\": [0.5, 0.5, 0.5]}, {\"bufferView\": 1, \"componentType\": 5123, \"count\": 36, \"type\": \"SCALAR\"},"
      " {\"bufferView\": 2, \"componentType\": 5123, \"count\": 3, \"type\": \"SCALAR\"}]}\n",
      sizeof buffer, uri);
  write_text("volume.gltf", t.text);
  vf_scene *s = load_ok("volume.gltf");
  if (s == NULL) return;
  CHECK_INT_EQ(s->num_media, 1); /* thin-walled Thin makes none */
  int amber = medium_named(s, "Amber");
  if (amber >= 0) {
    const vf_medium *m = &s->media[amber];
    CHECK_NEAR(m->sigma_a.x, -log(0.5) / 2, 1e-6);
    CHECK_NEAR(m->sigma_a.y, -log(0.25) / 2, 1e-6);
    CHECK_NEAR(m->sigma_a.z, 0, 0); /* a colour of 1 does not absorb */
    CHECK(vf_is_zero(m->sigma_s));
    CHECK(m->grid == NULL);
  }
  const vf_shape *cube = shape_named(s, "amber cube"), *sheet = shape_named(s, "sheet"), *thin = shape_named(s, "thin cube");
  if (cube && sheet && thin) {
    CHECK_INT_EQ(cube->interior, amber); CHECK_INT_EQ(cube->interface, 1); CHECK_INT_EQ(cube->exterior, -1);
    CHECK_INT_EQ(sheet->interior, -1); CHECK_INT_EQ(sheet->interface, 0);
    /* Thin refracts, and the scene has a medium: its closed cube bounds vacuum. */
    CHECK_INT_EQ(thin->interior, -1); CHECK_INT_EQ(thin->interface, 1);
  }
  CHECK_STR_CONTAINS(s->notes, "sheet: the mesh is not closed: its interior medium 'Amber' is ignored");
  vf_scene_destroy(s);
}

/* ---- Mitsuba 3 -------------------------------------------------------------------------------- */

/* A homogeneous medium in Mitsuba's parameters, an hg phase function, shape interiors (a
 * glass ball; a null-BSDF cube: index-matched), the sensor's medium as the scene's, and
 * what does not fit noted. */
static void test_mitsuba_homogeneous_media(void) {
  write_text("media.xml",
             "<scene version=\"3.0.0\">\n"
             "<medium type=\"homogeneous\" id=\"haze\"><rgb name=\"albedo\" value=\"0.5, 0.8, 1\"/>"
             "<float name=\"sigma_t\" value=\"2\"/><float name=\"scale\" value=\"0.5\"/>"
             "<phase type=\"hg\"><float name=\"g\" value=\"0.3\"/></phase></medium>\n"
             "<medium type=\"homogeneous\" id=\"ink\"><float name=\"albedo\" value=\"0\"/>"
             "<rgb name=\"sigma_t\" value=\"1, 2, 3\"/></medium>\n"
             "<medium type=\"heterogeneous\" id=\"cloud\"/>\n"
             "<sensor type=\"perspective\"><float name=\"fov\" value=\"45\"/><ref name=\"medium\" id=\"haze\"/></sensor>\n"
             "<emitter type=\"constant\"/>\n"
             "<shape type=\"sphere\" id=\"inkball\"><bsdf type=\"dielectric\"/><ref name=\"interior\" id=\"ink\"/>"
             "<ref name=\"exterior\" id=\"haze\"/></shape>\n"
             "<shape type=\"cube\" id=\"fogbox\"><transform name=\"to_world\"><translate x=\"5\"/></transform>"
             "<bsdf type=\"null\"/><medium type=\"homogeneous\" name=\"interior\"><float name=\"sigma_t\" value=\"4\"/>"
             "</medium></shape>\n"
             "<shape type=\"sphere\" id=\"cloudball\"><transform name=\"to_world\"><translate x=\"-5\"/></transform>"
             "<bsdf type=\"diffuse\"/><ref name=\"interior\" id=\"cloud\"/></shape>\n"
             "</scene>\n");
  vf_scene *s = load_ok("media.xml");
  if (s == NULL) return;
  int haze = medium_named(s, "haze"), ink = medium_named(s, "ink");
  CHECK_INT_EQ(s->num_media, 3); /* haze, ink and the cube's inline medium; not the heterogeneous cloud */
  CHECK_INT_EQ(s->medium, haze);
  if (haze >= 0 && ink >= 0) {
    const vf_medium *m = &s->media[haze];
    /* sigma_t' = 0.5 x 2 = 1: sigma_s = albedo, sigma_a = 1 - albedo */
    CHECK_NEAR(m->sigma_s.x, 0.5, 1e-6); CHECK_NEAR(m->sigma_s.y, 0.8, 1e-6); CHECK_NEAR(m->sigma_s.z, 1, 1e-6);
    CHECK_NEAR(m->sigma_a.x, 0.5, 1e-6); CHECK_NEAR(m->sigma_a.y, 0.2, 1e-6); CHECK_NEAR(m->sigma_a.z, 0, 1e-6);
    CHECK_NEAR(m->g, 0.3, 1e-6);
    m = &s->media[ink];
    CHECK(vf_is_zero(m->sigma_s));
    CHECK_NEAR(m->sigma_a.x, 1, 1e-6); CHECK_NEAR(m->sigma_a.z, 3, 1e-6);
    CHECK_NEAR(m->g, 0, 0); /* no phase: isotropic */
  }
  const vf_shape *ball = shape_named(s, "inkball"), *box = shape_named(s, "fogbox"), *cloud = shape_named(s, "cloudball");
  if (ball && box && cloud) {
    CHECK_INT_EQ(ball->interior, ink); CHECK_INT_EQ(ball->exterior, haze); CHECK(ball->material >= 0);
    CHECK_INT_EQ(box->material, -1); CHECK_INT_EQ(box->interface, 1); CHECK(box->interior >= 0);
    if (box->interior >= 0) CHECK_NEAR(s->media[box->interior].sigma_s.x, 0.75 * 4, 1e-5); /* albedo 0.75 by default */
    CHECK_INT_EQ(cloud->interior, -1); CHECK_INT_EQ(cloud->interface, 0);
  }
  CHECK_STR_CONTAINS(s->notes, "medium 'heterogeneous' is not supported (homogeneous only)");
  CHECK_STR_CONTAINS(s->notes, "the exterior medium is not read");
  CHECK_STR_CONTAINS(s->notes, "the sensor's medium 'haze' is the scene's medium");
  vf_scene_destroy(s);
}

/* ---- built-ins and the hash ------------------------------------------------------------------------ */

static void test_media_builtins_have_their_media(void) {
  vf_scene *s = NULL;
  CHECK_INT_EQ(vf_scene_load("cornell-fog", &s), VF_OK);
  if (s != NULL) {
    CHECK_INT_EQ(s->num_media, 1);
    CHECK_INT_EQ(s->medium, 0);
    CHECK(s->media[0].grid == NULL && s->media[0].sigma_s.x > 0.0f && s->media[0].g > 0.0f);
    const vf_shape *glass = shape_named(s, "glass ball"), *mirror = shape_named(s, "mirror ball");
    if (glass && mirror) {
      CHECK_INT_EQ(glass->interface, 1); CHECK_INT_EQ(glass->interior, -1); CHECK_INT_EQ(glass->exterior, 0);
      CHECK(glass->center.y - glass->radius > -1.0f); /* off the floor: the caustic's cone shows below it */
      CHECK_INT_EQ(mirror->interface, 0);
    }
    vf_scene_destroy(s);
  }
  s = NULL;
  CHECK_INT_EQ(vf_scene_load("cornell-smoke", &s), VF_OK);
  if (s != NULL) {
    CHECK_INT_EQ(s->num_media, 1);
    CHECK_INT_EQ(s->medium, -1);
    const vf_medium *m = &s->media[0];
    CHECK(m->grid != NULL);
    if (m->grid) {
      CHECK_INT_EQ(m->grid->nx, 64); CHECK_INT_EQ(m->grid->ny, 64); CHECK_INT_EQ(m->grid->nz, 64);
      float largest = 0.0f;
      size_t empty = 0, n = 64 * 64 * 64;
      for (size_t i = 0; i < n; i++) {
        largest = fmaxf(largest, m->grid->density[i]);
        empty += m->grid->density[i] == 0.0f;
      }
      CHECK_NEAR(m->grid->max_density, largest, 0);
      CHECK(largest > 0.5f);
      CHECK(empty > n / 4 && empty < n); /* a blob: empty corners, dense middle */
    }
    const vf_shape *box = shape_named(s, "smoke box");
    if (box) {
      CHECK_INT_EQ(box->material, -1); CHECK_INT_EQ(box->interface, 1); CHECK_INT_EQ(box->interior, 0);
      CHECK_INT_EQ(box->exterior, -1);
      CHECK(signed_volume6(box) > 0.0);
      if (m->grid) { /* the boundary is the grid's box */
        CHECK_NEAR(m->grid->box_min.y, -0.99, 1e-6); CHECK_NEAR(m->grid->box_max.x, 0.55, 1e-6);
      }
    }
    vf_scene_destroy(s);
  }
  s = NULL;
  CHECK_INT_EQ(vf_scene_load("cornell-tinted", &s), VF_OK);
  if (s != NULL) {
    CHECK_INT_EQ(s->num_media, 1);
    CHECK_INT_EQ(s->medium, -1);
    const vf_medium *m = &s->media[0];
    CHECK(vf_is_zero(m->sigma_s));
    CHECK(m->sigma_a.x < m->sigma_a.y && m->sigma_a.y < m->sigma_a.z); /* blue absorbed most: amber */
    const vf_shape *glass = shape_named(s, "glass ball");
    if (glass) {
      CHECK_INT_EQ(glass->interior, 0);
      CHECK_INT_EQ(glass->interface, 1);
      CHECK_INT_EQ(glass->exterior, -1);
    }
    vf_scene_destroy(s);
  }
}

static void hash_of(const char *media, const char *extra, uint8_t out[32]) {
  scene_text t;
  begin_scene(&t, media, extra);
  put(&t, ", {\"type\": \"sphere\", \"name\": \"ball\", \"material\": \"glass\", \"interior\": \"ink\", \"center\": [0, 0, 0], "
          "\"radius\": 1}");
  end_scene(&t, "hash.json");
  vf_scene *s = load_ok("hash.json");
  memset(out, 0, 32);
  if (s) memcpy(out, s->hash, 32);
  vf_scene_destroy(s);
}

static void test_hash_sees_media_and_only_them(void) {
  uint8_t base[32], same[32], other[32];
  hash_of("\"ink\": {\"sigma_a\": [1, 2, 3], \"g\": 0.5}", NULL, base);
  hash_of("\"ink\": {\"g\": 0.5,   \"sigma_a\": [1.0, 2, 3]}", NULL, same); /* the same content, written differently */
  CHECK(memcmp(base, same, 32) == 0);
  hash_of("\"ink\": {\"sigma_a\": [1, 2, 3.001], \"g\": 0.5}", NULL, other);
  CHECK(memcmp(base, other, 32) != 0);
  hash_of("\"ink\": {\"sigma_a\": [1, 2, 3], \"g\": 0.5, \"sigma_s\": 0.001}", NULL, other);
  CHECK(memcmp(base, other, 32) != 0);
  hash_of("\"ink\": {\"sigma_a\": [1, 2, 3], \"g\": 0.4}", NULL, other);
  CHECK(memcmp(base, other, 32) != 0);
  hash_of("\"ink\": {\"sigma_a\": [1, 2, 3], \"g\": 0.5}", "\"medium\": \"ink\"", other);
  CHECK(memcmp(base, other, 32) != 0);
  /* A renamed medium renders the same: the same hash. */
  scene_text t;
  begin_scene(&t, "\"tint\": {\"sigma_a\": [1, 2, 3], \"g\": 0.5}", NULL);
  put(&t, ", {\"type\": \"sphere\", \"name\": \"ball\", \"material\": \"glass\", \"interior\": \"tint\", \"center\": [0, 0, 0], "
          "\"radius\": 1}");
  end_scene(&t, "renamed.json");
  vf_scene *s = load_ok("renamed.json");
  if (s) CHECK(memcmp(base, s->hash, 32) == 0);
  vf_scene_destroy(s);

  /* A grid counts by its samples: a density scale changes the hash. */
  const int lo[3] = {0, 0, 0}, dims[3] = {2, 2, 2};
  const double scale[3] = {1, 1, 1}, translate[3] = {0, 0, 0};
  char p[256];
  path_of(p, sizeof p, "hash.vdb");
  CHECK_INT_EQ(vdb_fixture_write(p, VDB_FIXTURE_GOOD, "density", lo, dims, scale, translate), 0);
  hash_of("\"ink\": {\"sigma_a\": 1, \"density\": {\"file\": \"hash.vdb\"}}", NULL, base);
  hash_of("\"ink\": {\"sigma_a\": 1, \"density\": {\"file\": \"hash.vdb\", \"scale\": 1}}", NULL, same);
  hash_of("\"ink\": {\"sigma_a\": 1, \"density\": {\"file\": \"hash.vdb\", \"scale\": 1.5}}", NULL, other);
  CHECK(memcmp(base, same, 32) == 0);
  CHECK(memcmp(base, other, 32) != 0);

  /* Scaling a scene keeps its optical depths: coefficients by 1/f, grid boxes by f. */
  hash_of("\"ink\": {\"sigma_a\": 1, \"density\": {\"file\": \"hash.vdb\"}}", NULL, base);
  s = load_ok("hash.json");
  if (s == NULL) return;
  vf_vec3 box_lo = s->media[0].grid->box_min, box_hi = s->media[0].grid->box_max;
  CHECK_INT_EQ(vf_scene_scale(s, 4.0), VF_OK);
  CHECK_NEAR(s->media[0].sigma_a.x, 0.25, 0);
  CHECK_NEAR(s->media[0].grid->box_min.y, 4 * box_lo.y, 1e-6);
  CHECK_NEAR(s->media[0].grid->box_max.z, 4 * box_hi.z, 1e-6);
  CHECK(memcmp(base, s->hash, 32) != 0);
  vf_scene_destroy(s);
}

/* A process that links OpenVDB (through the scene library) can fork children that exit:
 * Debian's OpenVDB loads log4cplus, whose logging threads made every forked child hang in
 * exit() until the scene library stopped them (worker/scene/vdb.cpp). The child here reads
 * a grid first, as a forked decoder or worker would. */
static void test_forked_child_exits_after_reading_a_grid(void) {
  pid_t pid = fork();
  if (pid == 0) {
    vf_scene *s = NULL;
    int err = vf_scene_load("cornell-smoke", &s);
    vf_scene_destroy(s);
    exit(err == VF_OK ? 0 : 3);
  }
  CHECK(pid > 0);
  if (pid <= 0) return;
  int status = 0;
  pid_t done = 0;
  for (int waited_ms = 0; waited_ms < 20000 && done == 0; waited_ms += 10) {
    done = waitpid(pid, &status, WNOHANG);
    if (done == 0) nanosleep(&(struct timespec){0, 10000000}, NULL);
  }
  if (done == 0) {
    kill(pid, SIGKILL);
    waitpid(pid, &status, 0);
    CHECK_FAIL_("%s", "the forked child did not exit within 20 s");
    return;
  }
  CHECK(WIFEXITED(status));
  CHECK_INT_EQ(WEXITSTATUS(status), 0);
}

int main(void) {
  snprintf(dir, sizeof dir, "/tmp/test_media.XXXXXX");
  if (mkdtemp(dir) == NULL) {
    perror("mkdtemp");
    return 1;
  }
  RUN(test_media_fields_are_read);
  RUN(test_bad_media_are_refused_naming_file_and_field);
  RUN(test_nested_interfaces_take_the_innermost_container);
  RUN(test_closed_meshes_joined_by_position_and_turned_outwards);
  RUN(test_vdb_grid_round_trip_and_placement);
  RUN(test_job_scene_ships_the_grid_file);
  RUN(test_gltf_volume_becomes_an_absorbing_interior);
  RUN(test_mitsuba_homogeneous_media);
  RUN(test_media_builtins_have_their_media);
  RUN(test_hash_sees_media_and_only_them);
  RUN(test_forked_child_exits_after_reading_a_grid);
  char cmd[128];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
  if (system(cmd) != 0) fprintf(stderr, "could not remove %s\n", dir);
  return check_finish();
}
