/* Built-in scenes: the Cornell box family (with the benchmark suite's SDS, diffuse-only and
 * glossy members, a spot light, a thin lens, microfacet materials and three with
 * participating media: fog, smoke and tinted glass), the white furnace and
 * the 100k-triangle knot.
 *
 * Each one is written out as JSON in the documented format (docs/SCENES.md) and parsed by
 * vf_scene_parse, so a built-in is validated, bounded and hashed exactly like a file, and
 * `cornell` is a worked example of the format. The text is assembled with single quotes
 * (readable in C) that become double quotes before parsing.
 *
 * The knot is generated here, serialised as a binary little-endian PLY in memory and handed
 * to the parser as an in-memory file, so the Assimp mesh path is exercised by every run;
 * cornell-smoke's density grid likewise, as a VDB file through OpenVDB (vdb.h). */
#include "builtin.h"

#include "../../common/error.h"
#include "json.h"
#include "vdb.h"

#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const builtin_names[] = {"cornell", "cornell-point", "cornell-sun", "cornell-env",
                                            "furnace", "knot", "cornell-bulb", "cornell-diffuse",
                                            "cornell-glossy", "cornell-spot", "cornell-dof", "cornell-rough",
                                            "cornell-ortho", "corridor", "cornell-fog", "cornell-smoke",
                                            "cornell-tinted", NULL};

const char *const *vf_scene_builtin_names(void) { return builtin_names; }

/* ---- growable text ----------------------------------------------------------------------- */

typedef struct {
  char *data;
  size_t len, cap;
  int oom; /* sticky: one check at the end instead of one per append */
} text_buf;

static void put(text_buf *t, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

static void put(text_buf *t, const char *fmt, ...) {
  for (int attempt = 0; attempt < 2 && !t->oom; attempt++) {
    va_list ap;
    va_start(ap, fmt);
    int w = vsnprintf(t->data ? t->data + t->len : NULL, t->data ? t->cap - t->len : 0, fmt, ap);
    va_end(ap);
    if (w < 0) t->oom = 1;
    else if (t->data && t->len + (size_t)w < t->cap) {
      t->len += (size_t)w;
      return;
    } else {
      size_t cap = 2 * (t->len + (size_t)w + 1) + 4096;
      char *grown = realloc(t->data, cap);
      if (grown == NULL) t->oom = 1;
      t->data = grown ? grown : t->data;
      t->cap = grown ? cap : t->cap;
    }
  }
}

static void put_vec3(text_buf *t, vf_vec3 v) { put(t, "[%.9g,%.9g,%.9g]", v.x, v.y, v.z); }

/* ---- quads ------------------------------------------------------------------------------- */

/* Up to six quads (the furnace cube) gathered into one mesh. */
typedef struct {
  vf_vec3 v[24];
  int num_quads;
} quad_mesh;

/* Adds the rectangle center +- u +- v, wound counter-clockwise as seen from the side
 * `facing` points to: that side is the front (and the emitting side of an emitter). */
static void add_quad(quad_mesh *q, vf_vec3 center, vf_vec3 u, vf_vec3 v, vf_vec3 facing) {
  if (vf_dot(vf_cross(u, v), facing) < 0.0f) {
    vf_vec3 tmp = u;
    u = v;
    v = tmp;
  }
  vf_vec3 *c = &q->v[4 * q->num_quads++];
  c[0] = vf_sub(vf_sub(center, u), v);
  c[1] = vf_sub(vf_add(center, u), v);
  c[2] = vf_add(vf_add(center, u), v);
  c[3] = vf_add(vf_sub(center, u), v);
}

static void put_quad_shape(text_buf *t, const char *name, const char *material, const quad_mesh *q,
                           vf_vec3 emission) {
  put(t, "{'type':'mesh','name':'%s','material':'%s',", name, material);
  if (!vf_is_zero(emission)) {
    put(t, "'emission':");
    put_vec3(t, emission);
    put(t, ",");
  }
  put(t, "'positions':[");
  for (int i = 0; i < 4 * q->num_quads; i++)
    put(t, "%s%.9g,%.9g,%.9g", i ? "," : "", q->v[i].x, q->v[i].y, q->v[i].z);
  put(t, "],'indices':[");
  for (int i = 0; i < q->num_quads; i++)
    put(t, "%s%d,%d,%d,%d,%d,%d", i ? "," : "", 4 * i, 4 * i + 1, 4 * i + 2, 4 * i, 4 * i + 2, 4 * i + 3);
  put(t, "]}");
}

static void put_wall(text_buf *t, const char *name, const char *material, vf_vec3 center, vf_vec3 u, vf_vec3 v,
                     vf_vec3 facing, vf_vec3 emission) {
  quad_mesh q = {.num_quads = 0};
  add_quad(&q, center, u, v, facing);
  put_quad_shape(t, name, material, &q, emission);
  put(t, ",");
}

/* ---- the trefoil knot -------------------------------------------------------------------- */

enum { KNOT_SEGMENTS = 720, KNOT_SIDES = 80 }; /* 2 * 720 * 80 = 115,200 triangles */

/* Centre line: the classic trefoil with its depth stretched by 2, so that at the crossings
 * the strands stay more than a tube diameter apart. */
static vf_vec3 trefoil(double t, vf_vec3 *tangent) {
  *tangent = vf_vec3_make((float)(cos(t) + 4 * cos(2 * t)), (float)(-sin(t) + 4 * sin(2 * t)),
                          (float)(-6 * cos(3 * t)));
  return vf_vec3_make((float)(sin(t) + 2 * sin(2 * t)), (float)(cos(t) - 2 * cos(2 * t)), (float)(-2 * sin(3 * t)));
}

static void put_le32(unsigned char *p, uint32_t v) {
  p[0] = (unsigned char)v, p[1] = (unsigned char)(v >> 8), p[2] = (unsigned char)(v >> 16), p[3] = (unsigned char)(v >> 24);
}

/* A tube of radius 0.12 around the trefoil, scaled so its centre line spans 0.96 and centred
 * on (0, -0.35, 0), as a binary PLY in *out (malloc'ed, caller frees). */
static int knot_ply(unsigned char **out, size_t *size) {
  const double tube_radius = 0.12, half_extent = 0.48;
  const vf_vec3 place = vf_vec3_make(0.0f, -0.35f, 0.0f);
  const uint32_t nv = KNOT_SEGMENTS * KNOT_SIDES, nt = 2 * nv;
  char header[256];
  int hl = snprintf(header, sizeof header,
                    "ply\nformat binary_little_endian 1.0\nelement vertex %u\nproperty float x\nproperty float y\n"
                    "property float z\nelement face %u\nproperty list uchar int vertex_indices\nend_header\n",
                    nv, nt);
  size_t n = (size_t)hl + 12u * nv + 13u * nt;
  unsigned char *buf = malloc(n), *p = buf + hl;
  if (buf == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  memcpy(buf, header, (size_t)hl);
  vf_vec3 lo = vf_vec3_splat(INFINITY), hi = vf_vec3_splat(-INFINITY), tangent;
  for (int i = 0; i < KNOT_SEGMENTS; i++) {
    vf_vec3 c = trefoil(2 * M_PI * i / KNOT_SEGMENTS, &tangent);
    lo = vf_vec3_make(fminf(lo.x, c.x), fminf(lo.y, c.y), fminf(lo.z, c.z));
    hi = vf_vec3_make(fmaxf(hi.x, c.x), fmaxf(hi.y, c.y), fmaxf(hi.z, c.z));
  }
  float scale = (float)half_extent / (0.5f * fmaxf(hi.x - lo.x, hi.y - lo.y));
  vf_vec3 mid = vf_scale(vf_add(lo, hi), 0.5f);
  for (int i = 0; i < KNOT_SEGMENTS; i++) {
    vf_vec3 c = vf_add(place, vf_scale(vf_sub(trefoil(2 * M_PI * i / KNOT_SEGMENTS, &tangent), mid), scale));
    /* The tangent is never parallel to z for this curve, so this frame is smooth and closes
     * up after one turn without the seam a transported frame would leave. */
    vf_vec3 tn = vf_normalize(tangent), n1 = vf_normalize(vf_cross(tn, vf_vec3_make(0, 0, 1))), n2 = vf_cross(tn, n1);
    for (int k = 0; k < KNOT_SIDES; k++) {
      double phi = 2 * M_PI * k / KNOT_SIDES;
      vf_vec3 v = vf_add(c, vf_scale(vf_add(vf_scale(n1, (float)cos(phi)), vf_scale(n2, (float)sin(phi))),
                                     (float)tube_radius));
      const float xyz[3] = {v.x, v.y, v.z};
      for (int a = 0; a < 3; a++, p += 4) {
        uint32_t bits;
        memcpy(&bits, &xyz[a], 4);
        put_le32(p, bits);
      }
    }
  }
  /* (tangent, n1, n2) is right-handed; stepping around the tube before along it keeps the
   * counter-clockwise side, the front, pointing away from the centre line. */
  for (uint32_t i = 0; i < KNOT_SEGMENTS; i++)
    for (uint32_t k = 0; k < KNOT_SIDES; k++) {
      uint32_t i1 = (i + 1) % KNOT_SEGMENTS, k1 = (k + 1) % KNOT_SIDES;
      uint32_t a = i * KNOT_SIDES + k, b = i * KNOT_SIDES + k1, c = i1 * KNOT_SIDES + k1, d = i1 * KNOT_SIDES + k;
      const uint32_t tri[2][3] = {{a, b, c}, {a, c, d}};
      for (int f = 0; f < 2; f++) {
        *p++ = 3;
        for (int e = 0; e < 3; e++, p += 4) put_le32(p, tri[f][e]);
      }
    }
  *out = buf;
  *size = n;
  return VF_OK;
}

/* ---- the smoke grid ---------------------------------------------------------------------- */

/* cornell-smoke's box, resting just above the floor, and its grid's resolution. */
static const float smoke_min[3] = {-0.55f, -0.99f, -0.55f}, smoke_max[3] = {0.55f, 0.35f, 0.55f};
enum { SMOKE_N = 64 };

static void set_axis(vf_vec3 *v, int axis, float value) {
  if (axis == 0) v->x = value;
  else if (axis == 1) v->y = value;
  else v->z = value;
}

/* A value in [0, 1) for each integer lattice point: an integer hash, so every machine
 * makes the same grid (and the scene the same hash). */
static float lattice(int x, int y, int z) {
  uint32_t h = (uint32_t)x * 73856093u ^ (uint32_t)y * 19349663u ^ (uint32_t)z * 83492791u;
  h ^= h >> 13;
  h *= 0x5bd1e995u;
  h ^= h >> 15;
  return (float)(h & 0xffffffu) / 16777216.0f;
}

static float smoothstep01(float t) { return t * t * (3.0f - 2.0f * t); }

/* Value noise in [0, 1): the lattice values blended by smoothstep weights. Arithmetic
 * only (no libm), for the same reason. */
static float value_noise(float x, float y, float z) {
  const float fx = floorf(x), fy = floorf(y), fz = floorf(z);
  const int ix = (int)fx, iy = (int)fy, iz = (int)fz;
  const float wx = smoothstep01(x - fx), wy = smoothstep01(y - fy), wz = smoothstep01(z - fz);
  float sum = 0.0f;
  for (int c = 0; c < 8; c++) {
    const int dx = c & 1, dy = (c >> 1) & 1, dz = c >> 2;
    sum += (dx ? wx : 1.0f - wx) * (dy ? wy : 1.0f - wy) * (dz ? wz : 1.0f - wz) * lattice(ix + dx, iy + dy, iz + dz);
  }
  return sum;
}

/* cornell-smoke's density, SMOKE_N^3 samples over the smoke box: a blob, (1 - r^2)^2 from
 * its centre to the box's faces, broken up by three octaves of value noise; serialised as
 * a VDB file in memory (vdb.h) for the parser, which reads it as it reads any grid file. */
static int smoke_vdb(void **data, size_t *size) {
  const size_t n = (size_t)SMOKE_N * SMOKE_N * SMOKE_N;
  float *density = malloc(n * sizeof *density), max_density = 0.0f;
  if (density == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  size_t i = 0;
  for (int z = 0; z < SMOKE_N; z++)
    for (int y = 0; y < SMOKE_N; y++)
      for (int x = 0; x < SMOKE_N; x++, i++) {
        const float p[3] = {(2.0f * (float)x + 1.0f) / SMOKE_N - 1.0f, (2.0f * (float)y + 1.0f) / SMOKE_N - 1.0f,
                            (2.0f * (float)z + 1.0f) / SMOKE_N - 1.0f};
        const float r2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2], falloff = r2 < 1.0f ? (1.0f - r2) * (1.0f - r2) : 0.0f;
        float noise = 0.0f, amplitude = 0.5f, frequency = 3.0f;
        for (int octave = 0; octave < 3; octave++, amplitude *= 0.5f, frequency *= 2.0f)
          noise += amplitude * value_noise(frequency * p[0] + 11.0f, frequency * p[1] + 23.0f, frequency * p[2] + 37.0f);
        const float d = falloff * (0.2f + 1.6f * noise);
        density[i] = d;
        max_density = d > max_density ? d : max_density;
      }
  vf_density_grid g = {.nx = SMOKE_N, .ny = SMOKE_N, .nz = SMOKE_N, .density = density, .max_density = max_density,
                       .box_min = vf_vec3_make(smoke_min[0], smoke_min[1], smoke_min[2]),
                       .box_max = vf_vec3_make(smoke_max[0], smoke_max[1], smoke_max[2])};
  int err = vf_vdb_write_grid_memory(&g, "density", data, size);
  free(density);
  return err;
}

/* ---- scenes ------------------------------------------------------------------------------ */

enum {
  WITH_AREA_LIGHT = 1 << 0,
  WITH_POINT_LIGHT = 1 << 1,
  WITH_SUN = 1 << 2,
  WITH_BACKGROUND = 1 << 3,
  WITH_KNOT = 1 << 4,
  WITH_BULB = 1 << 5, /* a small spherical lamp inside a glass sphere: all light leaves through glass */
  WITH_SPOT = 1 << 6,
  WITH_LENS = 1 << 7, /* a thin-lens camera, nearer, focused on the glass ball */
  WITH_ORTHO = 1 << 8, /* an orthographic camera whose view plane stands inside the box's opening */
  WITH_FOG = 1 << 9,   /* the scene's medium a scattering fog; the glass ball raised off the floor */
  WITH_SMOKE = 1 << 10, /* a smoke grid (generated here) in a material-less box on the floor */
  WITH_TINT = 1 << 11, /* the glass ball's interior an absorbing medium */
};

/* A member of the Cornell family: the box with its floor and back wall, two balls on the
 * floor (or none), and its lights. Materials are JSON objects in the scene format. */
typedef struct {
  const char *name;
  unsigned with;
  const char *floor_material;
  const char *back_material;            /* NULL: the white of the ceiling */
  const char *left_ball, *left_material;  /* name and material; NULL: no balls */
  const char *right_ball, *right_material;
} cornell_variant;

#define FLOOR_GLOSSY "{'diffuse':[0.45,0.45,0.45],'glossy':[0.3,0.3,0.3],'exponent':40}"
#define MIRROR "{'mirror':[0.95,0.95,0.95]}"
#define GLASS "{'dielectric':[1,1,1],'ior':1.6}"

static const cornell_variant cornells[] = {
    {"cornell", WITH_AREA_LIGHT, FLOOR_GLOSSY, NULL, "mirror", MIRROR, "glass", GLASS},
    {"cornell-point", WITH_POINT_LIGHT, FLOOR_GLOSSY, NULL, "mirror", MIRROR, "glass", GLASS},
    {"cornell-sun", WITH_SUN, FLOOR_GLOSSY, NULL, "mirror", MIRROR, "glass", GLASS},
    {"cornell-env", WITH_BACKGROUND, FLOOR_GLOSSY, NULL, "mirror", MIRROR, "glass", GLASS},
    {"knot", WITH_KNOT | WITH_AREA_LIGHT, FLOOR_GLOSSY, NULL, NULL, NULL, NULL, NULL},
    /* SDS: every light path leaves the lamp through glass, so a diffuse point is lit only
     * along L S S D, and the room seen in the mirror ball (E S D S S L) is reached by
     * neither light sampling nor connections: only by merging or by chance emission hits. */
    {"cornell-bulb", WITH_BULB, FLOOR_GLOSSY, NULL, "mirror", MIRROR, "glass", GLASS},
    /* Lambertian everywhere: no specular or glossy vertex anywhere. */
    {"cornell-diffuse", WITH_AREA_LIGHT, "{'diffuse':[0.6,0.6,0.6]}", NULL, "white ball",
     "{'diffuse':[0.75,0.75,0.75]}", "blue ball", "{'diffuse':[0.2,0.3,0.75]}"},
    /* Sharp Phong lobes on floor, back wall and balls (exponents 150 to 5000), no perfect
     * specular: SDS paths do not exist, near-SDS (glossy-diffuse-glossy) ones abound. */
    /* Microfacet lobes (worker/render/microfacet.h): a glTF plastic floor, a rough gold ball and a
     * ball of rough glass; no delta lobe anywhere, so every technique applies everywhere. */
    {"cornell-rough", WITH_AREA_LIGHT, "{'base_color':[0.5,0.5,0.5],'metallic':0,'roughness':0.5}", NULL, "gold",
     "{'conductor':[1,1,1],'eta':[0.143,0.374,1.442],'k':[3.983,2.385,1.603],'roughness':0.3}", "frosted glass",
     "{'dielectric':[1,1,1],'ior':1.5,'roughness':0.2}"},
    {"cornell-glossy", WITH_AREA_LIGHT, "{'diffuse':[0.1,0.1,0.1],'glossy':[0.8,0.8,0.8],'exponent':800}",
     "{'diffuse':[0.25,0.25,0.25],'glossy':[0.6,0.6,0.6],'exponent':150}", "chrome ball",
     "{'glossy':[0.9,0.9,0.9],'exponent':5000}", "blue glossy ball",
     "{'diffuse':[0.1,0.1,0.3],'glossy':[0.7,0.7,0.7],'exponent':200}"},
    {"cornell-spot", WITH_SPOT, FLOOR_GLOSSY, NULL, "mirror", MIRROR, "glass", GLASS},
    {"cornell-dof", WITH_LENS | WITH_AREA_LIGHT, FLOOR_GLOSSY, NULL, "mirror", MIRROR, "glass", GLASS},
    {"cornell-ortho", WITH_ORTHO | WITH_AREA_LIGHT, FLOOR_GLOSSY, NULL, "mirror", MIRROR, "glass", GLASS},
    /* Participating media (docs/SCENES.md, "Media"). A volumetric caustic: the glass ball,
     * raised, focuses the ceiling light into a cone of light in the fog below it. */
    {"cornell-fog", WITH_FOG | WITH_AREA_LIGHT, FLOOR_GLOSSY, NULL, "mirror", MIRROR, "glass", GLASS},
    {"cornell-smoke", WITH_SMOKE | WITH_AREA_LIGHT, FLOOR_GLOSSY, NULL, NULL, NULL, NULL, NULL},
    {"cornell-tinted", WITH_TINT | WITH_AREA_LIGHT, FLOOR_GLOSSY, NULL, "mirror", MIRROR, "glass", GLASS},
};

/* The media of the media members. Coefficients are per unit length; the box is 2 wide. */
#define FOG_MEDIUM "'fog':{'sigma_a':0.01,'sigma_s':0.15,'g':0.3}"
#define SMOKE_MEDIUM "'smoke':{'sigma_a':0.5,'sigma_s':6,'g':0.2,'density':{'file':'smoke.vdb','box':{'min':[%.9g,%.9g,%.9g],'max':[%.9g,%.9g,%.9g]}}}"
#define TINT_MEDIUM "'amber':{'sigma_a':[0.3,1.5,3]}"


/* The shared box: [-1,1]^3 open at z = +1, walls facing inwards. */
static void put_cornell(text_buf *t, const cornell_variant *c) {
  const vf_vec3 zero = vf_vec3_splat(0.0f), ex = vf_vec3_make(1, 0, 0), ey = vf_vec3_make(0, 1, 0),
                ez = vf_vec3_make(0, 0, 1);
  const unsigned with = c->with;
  /* The lens camera sits at the balls' height, focused on the plane of the glass ball's
   * centre: the mirror ball and the back wall blur. */
  if (with & WITH_LENS)
    put(t, "{'camera':{'position':[0,-0.35,3],'target':[0,-0.35,0],'up':[0,1,0],'fov':38,'aperture':0.1,"
           "'focus_distance':2.75,'resolution':[512,512]},");
  /* The orthographic view plane stands just inside the opening, tilted down and to the
   * left so that the floor and the red wall show: parallel rays from outside the box would
   * see its back faces. */
  else if (with & WITH_ORTHO)
    put(t, "{'camera':{'type':'orthographic','position':[0,0.05,0.95],'forward':[-0.3,-0.45,-1],'up':[0,1,0],"
           "'width':1.8,'resolution':[512,512]},");
  else
    put(t, "{'camera':{'position':[0,0,3.6],'target':[0,0,0],'up':[0,1,0],'fov':38,'resolution':[512,512]},");
  put(t, "'materials':{'white':{'diffuse':[0.75,0.75,0.75]},'red':{'diffuse':[0.75,0.15,0.15]},"
         "'green':{'diffuse':[0.15,0.75,0.15]},'floor':%s",
      c->floor_material);
  if (c->back_material) put(t, ",'back':%s", c->back_material);
  if (c->left_ball) put(t, ",'%s':%s,'%s':%s", c->left_ball, c->left_material, c->right_ball, c->right_material);
  if (with & WITH_KNOT) put(t, ",'knot':{'diffuse':[0.3,0.3,0.3],'glossy':[0.4,0.4,0.4],'exponent':80}");
  if (with & WITH_BULB) put(t, ",'bulb glass':{'dielectric':[1,1,1],'ior':1.5}");
  if (with & (WITH_AREA_LIGHT | WITH_BULB)) put(t, ",'emitter':{}"); /* black: the light only emits */
  put(t, "},");
  if (with & WITH_FOG) put(t, "'media':{" FOG_MEDIUM "},'medium':'fog',");
  if (with & WITH_SMOKE)
    put(t, "'media':{" SMOKE_MEDIUM "},", smoke_min[0], smoke_min[1], smoke_min[2], smoke_max[0], smoke_max[1],
        smoke_max[2]);
  if (with & WITH_TINT) put(t, "'media':{" TINT_MEDIUM "},");
  put(t, "'shapes':[");
  put_wall(t, "floor", "floor", vf_neg(ey), ex, ez, ey, zero);
  put_wall(t, "ceiling", "white", ey, ex, ez, vf_neg(ey), zero);
  put_wall(t, "back", c->back_material ? "back" : "white", vf_neg(ez), ex, ey, ez, zero);
  put_wall(t, "left", "red", vf_neg(ex), ey, ez, ex, zero);
  put_wall(t, "right", "green", ex, ey, ez, vf_neg(ex), zero);
  /* In the fog the glass ball hangs above the floor, so that the cone of light it focuses
   * (its focus lies about 0.47 below its centre) shows in the fog between it and the floor. */
  if (c->left_ball)
    put(t, "{'type':'sphere','name':'%s ball','material':'%s','center':[-0.45,-0.65,-0.35],'radius':0.35},"
           "{'type':'sphere','name':'%s ball','material':'%s',%s'center':%s,'radius':0.35},",
        c->left_ball, c->left_ball, c->right_ball, c->right_ball, with & WITH_TINT ? "'interior':'amber'," : "",
        with & WITH_FOG ? "[0.35,-0.05,0.15]" : "[0.45,-0.65,0.25]");
  if (with & WITH_SMOKE) { /* the smoke's index-matched boundary: a closed box facing outwards */
    quad_mesh q = {.num_quads = 0};
    vf_vec3 lo = vf_vec3_make(smoke_min[0], smoke_min[1], smoke_min[2]);
    vf_vec3 hi = vf_vec3_make(smoke_max[0], smoke_max[1], smoke_max[2]);
    vf_vec3 mid = vf_scale(vf_add(lo, hi), 0.5f), half = vf_scale(vf_sub(hi, lo), 0.5f);
    for (int axis = 0; axis < 3; axis++)
      for (int side = -1; side <= 1; side += 2) {
        vf_vec3 n = vf_vec3_splat(0.0f), u = vf_vec3_splat(0.0f), v = vf_vec3_splat(0.0f);
        set_axis(&n, axis, (float)side);
        set_axis(&u, (axis + 1) % 3, vf_vec3_get(half, (axis + 1) % 3));
        set_axis(&v, (axis + 2) % 3, vf_vec3_get(half, (axis + 2) % 3));
        add_quad(&q, vf_add(mid, vf_scale(n, vf_vec3_get(half, axis))), u, v, n);
      }
    put(t, "{'type':'mesh','name':'smoke box','interior':'smoke','positions':[");
    for (int i = 0; i < 4 * q.num_quads; i++) put(t, "%s%.9g,%.9g,%.9g", i ? "," : "", q.v[i].x, q.v[i].y, q.v[i].z);
    put(t, "],'indices':[");
    for (int i = 0; i < q.num_quads; i++)
      put(t, "%s%d,%d,%d,%d,%d,%d", i ? "," : "", 4 * i, 4 * i + 1, 4 * i + 2, 4 * i, 4 * i + 2, 4 * i + 3);
    put(t, "]},");
  }
  if (with & WITH_KNOT) put(t, "{'type':'mesh','name':'knot','material':'knot','file':'knot.ply'},");
  if (with & WITH_AREA_LIGHT)
    put_wall(t, "light", "emitter", vf_vec3_make(0, 0.98f, 0), vf_scale(ex, 0.3f), vf_scale(ez, 0.3f), vf_neg(ey),
             vf_vec3_splat(12.0f));
  /* The lamp sits off the glass sphere's centre, so the glass focuses it into caustics; its
   * power (radiance x pi x area) is about the area light's. */
  if (with & WITH_BULB)
    put(t, "{'type':'sphere','name':'bulb glass','material':'bulb glass','center':[0,0.6,0],'radius':0.25},"
           "{'type':'sphere','name':'lamp','material':'emitter','center':[0,0.66,0],'radius':0.06,"
           "'emission':[100,100,100]},");
  if (t->len > 0) t->len--; /* the last shape's comma */
  put(t, "],'lights':[");
  /* Exposures roughly match the area light's: the point light's downward hemisphere
   * carries about the area light's power (pi * 0.36 m^2 * 12). */
  if (with & WITH_POINT_LIGHT) put(t, "{'type':'point','position':[0,0.85,0],'intensity':[1.8,1.8,1.8]}");
  /* Tilted to the back so that the outer cone's edge crosses the back wall. */
  if (with & WITH_SPOT)
    put(t, "{'type':'spot','position':[0,0.9,0.2],'direction':[0,-1,-0.3],'intensity':[6,6,6],"
           "'inner_cone_angle':20,'outer_cone_angle':35}");
  if (with & WITH_SUN) {
    vf_vec3 d = vf_normalize(vf_vec3_make(-0.35f, -0.55f, -0.75f));
    put(t, "{'type':'directional','direction':[%.9g,%.9g,%.9g],'irradiance':[3,3,3]}", d.x, d.y, d.z);
  }
  if (with & WITH_BACKGROUND) put(t, "{'type':'background','radiance':[1,1,1]}");
  put(t, "]}");
}

/* The white furnace: inside a closed emitting cube of albedo 0.5 every path of L segments
 * sees 0.5 (1 + 0.5 + ... + 0.5^(L-1)) = 1 - 0.5^L, whatever the camera looks at. */
static void put_furnace(text_buf *t) {
  quad_mesh q = {.num_quads = 0};
  for (int axis = 0; axis < 3; axis++)
    for (int side = -1; side <= 1; side += 2) {
      vf_vec3 n = vf_vec3_splat(0.0f), u = vf_vec3_splat(0.0f), v = vf_vec3_splat(0.0f);
      n.x = axis == 0 ? (float)side : 0.0f, n.y = axis == 1 ? (float)side : 0.0f, n.z = axis == 2 ? (float)side : 0.0f;
      u.x = axis == 1 ? 1.0f : 0.0f, u.y = axis == 2 ? 1.0f : 0.0f, u.z = axis == 0 ? 1.0f : 0.0f;
      v = vf_cross(n, u);
      add_quad(&q, n, u, v, vf_neg(n));
    }
  put(t, "{'camera':{'position':[0,0,0],'forward':[0,0,-1],'up':[0,1,0],'fov':60,'resolution':[128,128]},"
         "'materials':{'grey':{'diffuse':[0.5,0.5,0.5]}},'shapes':[");
  put_quad_shape(t, "furnace", "grey", &q, vf_vec3_splat(0.5f));
  put(t, "],'render':{'max_path_length':64}}");
}

/* A long corridor whose visible surfaces lie from 1 to 24 away: the depth a global merge
 * radius cannot suit everywhere (--radius per-pixel, docs/BENCHMARKS.md). 2 wide, 2.5
 * high, closed at both ends, a glossy floor, a red and a white wall, six ceiling lamps
 * (0.5 x 0.5, radiance 15) spaced 4 apart, and a mirror and a glass ball near and far. The
 * camera stands 1 inside the near end, looking down the length. */
static void put_corridor(text_buf *t) {
  const vf_vec3 zero = vf_vec3_splat(0.0f), ex = vf_vec3_make(1, 0, 0), ey = vf_vec3_make(0, 1, 0),
                ez = vf_vec3_make(0, 0, 1);
  const float half_length = 12.5f, mid = -11.5f; /* z from 1 to -24 */
  put(t, "{'camera':{'position':[0.3,1.4,0],'target':[-0.1,0.9,-12],'up':[0,1,0],'fov':50,'resolution':[640,360]},"
         "'materials':{'white':{'diffuse':[0.75,0.75,0.75]},'red':{'diffuse':[0.7,0.2,0.15]},"
         "'floor':" FLOOR_GLOSSY ",'mirror':" MIRROR ",'glass':" GLASS ",'emitter':{}},'shapes':[");
  put_wall(t, "floor", "floor", vf_vec3_make(0, 0, mid), ex, vf_scale(ez, half_length), ey, zero);
  put_wall(t, "ceiling", "white", vf_vec3_make(0, 2.5f, mid), ex, vf_scale(ez, half_length), vf_neg(ey), zero);
  put_wall(t, "left", "red", vf_vec3_make(-1, 1.25f, mid), vf_scale(ey, 1.25f), vf_scale(ez, half_length), ex, zero);
  put_wall(t, "right", "white", vf_vec3_make(1, 1.25f, mid), vf_scale(ey, 1.25f), vf_scale(ez, half_length),
           vf_neg(ex), zero);
  put_wall(t, "far end", "white", vf_vec3_make(0, 1.25f, mid - half_length), ex, vf_scale(ey, 1.25f), ez, zero);
  put_wall(t, "near end", "white", vf_vec3_make(0, 1.25f, mid + half_length), ex, vf_scale(ey, 1.25f), vf_neg(ez),
           zero);
  for (int i = 0; i < 6; i++) {
    char name[16];
    snprintf(name, sizeof name, "lamp %d", i + 1);
    put_wall(t, name, "emitter", vf_vec3_make(0, 2.49f, -2.0f - 4.0f * (float)i), vf_scale(ex, 0.25f),
             vf_scale(ez, 0.25f), vf_neg(ey), vf_vec3_splat(15.0f));
  }
  put(t, "{'type':'sphere','name':'near mirror ball','material':'mirror','center':[-0.45,0.35,-3],'radius':0.35},"
         "{'type':'sphere','name':'near glass ball','material':'glass','center':[0.5,0.35,-5],'radius':0.35},"
         "{'type':'sphere','name':'far mirror ball','material':'mirror','center':[0.4,0.35,-17],'radius':0.35},"
         "{'type':'sphere','name':'far glass ball','material':'glass','center':[-0.4,0.35,-20],'radius':0.35}]}");
}

int vf_scene_builtin_load(const char *name, vf_scene **out) {
  text_buf t = {NULL, 0, 0, 0};
  unsigned char *ply = NULL;
  void *smoke = NULL;
  vf_scene_memfile files[2];
  int num_files = 0;
  char label[64];
  int err, found = strcmp(name, "furnace") == 0;
  if (found) put_furnace(&t);
  if (!found && strcmp(name, "corridor") == 0) {
    found = 1;
    put_corridor(&t);
  }
  for (size_t i = 0; !found && i < sizeof cornells / sizeof cornells[0]; i++)
    if (strcmp(name, cornells[i].name) == 0) {
      found = 1;
      put_cornell(&t, &cornells[i]);
      if (cornells[i].with & WITH_KNOT) {
        files[num_files] = (vf_scene_memfile){"knot.ply", NULL, 0};
        if ((err = knot_ply(&ply, &files[num_files].size)) < 0) goto done;
        files[num_files++].data = ply;
      }
      if (cornells[i].with & WITH_SMOKE) {
        files[num_files] = (vf_scene_memfile){"smoke.vdb", NULL, 0};
        if ((err = smoke_vdb(&smoke, &files[num_files].size)) < 0) goto done;
        files[num_files++].data = smoke;
      }
    }
  if (!found) {
    err = vf_error_set(VF_ENOENT, "no built-in scene named '%s'", name);
    goto done;
  }
  if (t.oom) {
    err = vf_error_set(VF_ENOMEM, "out of memory");
    goto done;
  }
  for (size_t i = 0; i < t.len; i++)
    if (t.data[i] == '\'') t.data[i] = '"';
  snprintf(label, sizeof label, "builtin:%s", name);
  err = vf_scene_parse(t.data, t.len, label, ".", num_files ? files : NULL, num_files, out);
done:
  free(smoke);
  free(ply);
  free(t.data);
  return err;
}
