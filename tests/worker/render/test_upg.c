/* Tests of unbiased photon gathering's estimator of 1/p_acc (worker/render/photon_gathering.h)
 * against probability, never against numbers from an earlier run. A source point L sits at
 * the origin: a light vertex's BSDF for a fixed incoming direction, or a light's own point.
 * The target is a disc of radius r around x with unit normal n_x, and a tentative direction
 * lands when its ray from L meets the disc: a geometric stand-in for "the first hit lies
 * within r of x" that needs no scene, and that lies inside the ball vf_upg_cone bounds. Then
 *     p_acc = integral over the disc of density(w(y)) |n_x . w(y)| / |y - L|^2 dA,
 * which quadrature computes apart from any sampler (Gauss-Legendre panels in the radius, the
 * trapezoid rule in the angle, where it converges fastest for a periodic integrand; refined
 * until it settles, its last change taken as its error). The cases:
 * 0. the quadrature equals the closed forms of p_acc where there are some (lights' points,
 *    discs facing them);
 * 1. the mean of vf_upg_inverse_acceptance's estimates, trials uniform in vf_upg_cone's cone
 *    accepted against vf_upg_bound, is 1/p_acc within K_Z standard errors, for each lobe
 *    (Lambertian, Phong, GGX conductor, rough dielectric on both sides and from both sides,
 *    glTF, shading normals) and the lights' own points (area, point, spot), with targets near,
 *    far and very far (a narrow cone), on a lobe's peak and off it, and around L (the cone is
 *    then the whole sphere);
 * 2. so is the mean of vf_upg_inverse_acceptance_draws, whose trials are the BSDF's own
 *    sampler (roulette, lobe, direction): an independent algorithm, wherever p_acc is large
 *    enough for it to be affordable;
 * 3. the bound excludes nothing: no direction the BSDF samples, nor any direction of
 *    positive density, has a density above vf_upg_bound of a cone that contains it; and the
 *    estimator's bound_exceeded count stays zero through case 1;
 * 4. the comparisons have power: each of 1 and 2 would reject its mean scaled by 1 + BIAS,
 *    and a bound of half the size trips bound_exceeded and a mean that is rejected.
 * Every BSDF is set up in storage filled with 0xff bytes beforehand, so that a bound that
 * read a field its BSDF's set-up leaves alone would show it. Random numbers come from
 * vf_rng_for_path(SEED, case, configuration, VF_STREAM_TEST) (bsdf_cases.h). */
#include "check.h"
#include "bsdf_cases.h"

#include "common/rng.h"
#include "common/vec3.h"
#include "worker/render/bsdf.h"
#include "worker/render/light.h"
#include "worker/render/photon_gathering.h"
#include "worker/render/sampling.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

/* Standard errors a mean may stray: a two-sided normal tail of 6.3e-5 per comparison, about
 * 1.5% for the ~230 of cases 1 and 2 together (with fixed seeds, a pass stays a pass). */
#define K_Z 4.0
/* The relative bias each comparison must be able to detect (case 4). */
#define BIAS 0.05
/* Gatherings per configuration: a mean's relative standard error is about
 * sqrt((1 - p_acc / p_b) / GATHERINGS), 0.7%, so a bias of BIAS is some 7 of them. */
#define GATHERINGS 20000
/* Case 2 costs 1 / p_acc trials per gathering: it runs where p_acc is at least this. */
#define DRAWS_MIN_P_ACC 0.02
/* Quadrature: level k has 64 << k angles and 8 << k panels of QUAD_NODES radii; it stops
 * at the first level from QUAD_MIN_LEVEL whose change is below QUAD_SETTLED relative. */
#define QUAD_MIN_LEVEL 2
#define QUAD_MAX_LEVEL 4
#define QUAD_SETTLED 1e-6
#define QUAD_NODES 8
/* Where the integrand jumps inside the disc (the spot's cone, a shading normal's fold) the
 * rule converges only like its spacing and its last change may understate its error: the
 * closed forms hold the quadrature to this relative error there, under a third of a mean's
 * relative standard error, and to QUAD_SMOOTH_TOL where the integrand is smooth. */
#define QUAD_JUMP_TOL 2e-3
#define QUAD_SMOOTH_TOL 1e-6

/* One random stream per case, after those of the BSDF tests. */
enum { CASE_UPG_ESTIMATE = CASE_LIMIT + 1, CASE_UPG_DRAWS, CASE_UPG_BOUND, CASE_UPG_HALF_BOUND };

/* ---- sources ---- */

typedef enum { SOURCE_VERTEX, SOURCE_AREA, SOURCE_POINT, SOURCE_SPOT } source_kind;

typedef struct {
  const char *name;
  source_kind kind;
  vf_material material; /* SOURCE_VERTEX */
  double fix_deg;       /* fix's angle to the geometric normal (vertices) */
  int back;             /* fix on the back of the geometric normal: leaving a dielectric */
  double shading_deg;   /* > 0: the shading normal leans this far from the geometric one */
  /* Sharp lobes: only targets away from L (build_configs), where neither the quadrature
   * nor the trials per gathering depend on resolving the lobe's peak from nearby. */
  int far_only;
  /* Dielectrics: no target around L, nor near the normal on the reflection side
   * (build_configs says why); the roughest glass has them. */
  int not_around;
} source_case;

#define GLASS(r) .dielectric = RGB(1.0f, 1.0f, 1.0f), .ior = 1.5f, .roughness = r

static const source_case SOURCES[] = {
    {"lambert", SOURCE_VERTEX, {.diffuse = RGB(0.8f, 0.5f, 0.2f)}, .fix_deg = 30.0},
    {"phong5", SOURCE_VERTEX, {.glossy = RGB(0.9f, 0.7f, 0.5f), .phong_exponent = 5.0f}, .fix_deg = 45.0},
    {"phong50", SOURCE_VERTEX, {.glossy = RGB(0.9f, 0.7f, 0.5f), .phong_exponent = 50.0f}, .fix_deg = 45.0},
    {"phong200", SOURCE_VERTEX, {.glossy = RGB(0.9f, 0.7f, 0.5f), .phong_exponent = 200.0f}, .fix_deg = 45.0},
    {"diffuse+phong20", SOURCE_VERTEX,
     {.diffuse = RGB(0.3f, 0.3f, 0.3f), .glossy = RGB(0.5f, 0.4f, 0.6f), .phong_exponent = 20.0f}, .fix_deg = 60.0},
    {"ggx r0.2", SOURCE_VERTEX, {.conductor = RGB(0.9f, 0.8f, 0.7f), .roughness = 0.2f}, .fix_deg = 45.0},
    {"ggx r0.6", SOURCE_VERTEX, {.conductor = RGB(0.9f, 0.8f, 0.7f), .roughness = 0.6f}, .fix_deg = 60.0},
    {"glass1.5 r0.3 in", SOURCE_VERTEX, {GLASS(0.3f)}, .fix_deg = 45.0, .not_around = 1},
    {"glass1.5 r0.3 out", SOURCE_VERTEX, {GLASS(0.3f)}, .fix_deg = 25.0, .back = 1, .not_around = 1},
    /* beyond the critical angle (41.8 deg): only microfacets tilted towards fix refract */
    {"glass1.5 r0.3 out tir", SOURCE_VERTEX, {GLASS(0.3f)}, .fix_deg = 55.0, .back = 1, .not_around = 1},
    {"glass1.5 r0.2 in", SOURCE_VERTEX, {.dielectric = RGB(0.9f, 0.8f, 0.7f), .ior = 1.5f, .roughness = 0.2f},
     .fix_deg = 20.0, .not_around = 1},
    {"glass1.5 r0.6 in", SOURCE_VERTEX, {GLASS(0.6f)}, .fix_deg = 10.0},
    {"glass1.5 r0.6 out", SOURCE_VERTEX, {GLASS(0.6f)}, .fix_deg = 15.0, .back = 1},
    {"gltf plastic", SOURCE_VERTEX,
     {.gltf = 1, .base_color = RGB(0.8f, 0.3f, 0.2f), .metallic = 0.0f, .roughness = 0.4f}, .fix_deg = 45.0},
    {"gltf metal", SOURCE_VERTEX,
     {.gltf = 1, .base_color = RGB(0.95f, 0.65f, 0.3f), .metallic = 1.0f, .roughness = 0.3f}, .fix_deg = 30.0},
    {"gltf half-metal", SOURCE_VERTEX,
     {.gltf = 1, .base_color = RGB(0.5f, 0.7f, 0.9f), .metallic = 0.5f, .roughness = 0.7f}, .fix_deg = 70.0},
    {"gltf specular colour", SOURCE_VERTEX,
     {.gltf = 1, .base_color = RGB(0.6f, 0.5f, 0.4f), .metallic = 0.3f, .roughness = 0.35f, .specular_set = 1,
      .specular = 0.6f, .specular_f0 = RGB(0.2f, 0.06f, 1.5f)},
     .fix_deg = 50.0},
    {"shading diffuse+phong20", SOURCE_VERTEX,
     {.diffuse = RGB(0.3f, 0.3f, 0.3f), .glossy = RGB(0.5f, 0.4f, 0.6f), .phong_exponent = 20.0f}, .fix_deg = 40.0,
     .shading_deg = 20.0},
    {"shading diffuse+ggx r0.4", SOURCE_VERTEX,
     {.diffuse = RGB(0.3f, 0.2f, 0.1f), .conductor = RGB(0.6f, 0.6f, 0.6f), .roughness = 0.4f}, .fix_deg = 60.0,
     .shading_deg = 15.0},
    {"shading glass1.5 r0.3", SOURCE_VERTEX, {GLASS(0.3f)}, .fix_deg = 35.0, .shading_deg = 12.0, .not_around = 1},
    {"area light", SOURCE_AREA, .fix_deg = 0.0},
    {"point light", SOURCE_POINT, .fix_deg = 0.0},
    {"spot light", SOURCE_SPOT, .fix_deg = 0.0},
    /* sharp lobes, where the rounding of the bound's cosines and angles counts */
    {"phong1e4", SOURCE_VERTEX, {.glossy = RGB(0.9f, 0.7f, 0.5f), .phong_exponent = 1e4f}, .fix_deg = 45.0,
     .far_only = 1},
    {"ggx r0.05", SOURCE_VERTEX, {.conductor = RGB(0.9f, 0.8f, 0.7f), .roughness = 0.05f}, .fix_deg = 45.0,
     .far_only = 1},
    {"glass1.5 r0.05 in", SOURCE_VERTEX, {GLASS(0.05f)}, .fix_deg = 45.0, .far_only = 1},
    {"glass1.5 r0.05 out", SOURCE_VERTEX, {GLASS(0.05f)}, .fix_deg = 25.0, .back = 1, .far_only = 1},
    /* alpha 1: GGX's D is flat, the edge of the bound's two cases */
    {"ggx r1", SOURCE_VERTEX, {.conductor = RGB(0.9f, 0.8f, 0.7f), .roughness = 1.0f}, .fix_deg = 80.0},
};
enum { SOURCE_COUNT = sizeof SOURCES / sizeof SOURCES[0] };

/* The spot's outer and inner half-angles. */
#define SPOT_OUTER_DEG 30.0
#define SPOT_INNER_DEG 20.0

typedef struct {
  const source_case *sc;
  vf_bsdf bsdf;
  vf_light light;
  vf_upg_source src;
  dvec up;        /* vertices: the shading normal on fix's side; area: the normal; spot: the axis */
  dvec mirror;    /* vertices: fix mirrored about up */
  dvec refracted; /* vertices: fix refracted through up (or a microfacet), when refracts */
  int refracts, beyond_critical, ok;
} source;

static source sources[SOURCE_COUNT];

static double rad(double deg) { return deg * PI_D / 180.0; }

/* A unit direction at angle deg from unit n, towards azimuth phi about it. */
static dvec lean(dvec n, double deg, double phi) {
  dframe f = dframe_around(n);
  return dframe_dir(&f, rad(deg), phi);
}

/* Sets up source i in place (its vf_upg_source points into it). */
static void build_source(int i) {
  source *s = &sources[i];
  const source_case *sc = &SOURCES[i];
  memset(s, 0, sizeof *s);
  s->sc = sc;
  dvec n = dnormalize(dmake(0.3, -0.5, 0.81)); /* off every axis: the frames are not trivial */
  switch (sc->kind) {
  case SOURCE_VERTEX: {
    vf_vec3 normal, fix;
    dvec up;
    make_fix(rad(sc->fix_deg), 0.7, !sc->back, &normal, &fix, &up);
    s->up = sc->shading_deg > 0.0 ? lean(up, sc->shading_deg, 2.0) : up;
    vf_bsdf_lobes lobes;
    vf_bsdf_lobes_of(&sc->material, &lobes);
    memset(&s->bsdf, 0xff, sizeof s->bsdf);
    if (sc->shading_deg > 0.0) s->ok = vf_bsdf_setup_shading(&s->bsdf, &sc->material, &lobes, normal, fv(s->up), fix);
    else s->ok = vf_bsdf_setup(&s->bsdf, &sc->material, &lobes, normal, fix);
    s->src = (vf_upg_source){&s->bsdf, NULL, vf_vec3_splat(0.0f)};
    dvec dfix = dv(fix);
    s->mirror = dreflect(dfix, s->up);
    /* Fix refracted about the (shading) normal, Walter et al. 2007 eq. 40; beyond the
     * critical angle about a microfacet leaning towards fix, 30 degrees from it. */
    double eta = s->bsdf.eta, ci = ddot(dfix, s->up);
    dvec m = s->up;
    s->refracts = !vf_is_zero(sc->material.dielectric);
    s->beyond_critical = s->refracts && (1.0 - ci * ci) / (eta * eta) >= 1.0;
    if (s->beyond_critical) {
      double tilt = acos(ci) - rad(30.0);
      dvec towards = dnormalize(dsub(dfix, dscale(s->up, ci)));
      m = dadd(dscale(s->up, cos(tilt)), dscale(towards, sin(tilt)));
      ci = ddot(dfix, m);
    }
    double sin_t2 = (1.0 - ci * ci) / (eta * eta);
    if (s->refracts) s->refracted = dnormalize(dsub(dscale(m, ci / eta - sqrt(1.0 - sin_t2)), dscale(dfix, 1.0 / eta)));
    break;
  }
  case SOURCE_AREA:
    s->light.kind = VF_LIGHT_AREA_MESH;
    s->up = n;
    s->src = (vf_upg_source){NULL, &s->light, fv(n)};
    s->ok = 1;
    break;
  case SOURCE_POINT:
    s->light.kind = VF_LIGHT_POINT;
    s->up = n;
    s->src = (vf_upg_source){NULL, &s->light, vf_vec3_splat(0.0f)};
    s->ok = 1;
    break;
  case SOURCE_SPOT: {
    /* the fields light.c's set-up of a spot writes, from the same definitions */
    double outer = rad(SPOT_OUTER_DEG), inner = rad(SPOT_INNER_DEG), omc = 2.0 * sin(0.5 * outer) * sin(0.5 * outer);
    s->up = dnormalize(dmake(0.2, 0.4, -0.89));
    s->light.kind = VF_LIGHT_SPOT;
    s->light.direction = fv(s->up);
    s->light.frame = vf_frame_from_normal(s->light.direction);
    s->light.cos_outer = (float)cos(outer);
    s->light.falloff_scale = (float)(1.0 / (cos(inner) - cos(outer)));
    s->light.one_minus_cos_outer = (float)omc;
    s->light.cone_pdf_w = (float)(1.0 / (2.0 * PI_D * omc));
    s->light.is_delta = s->light.is_finite = 1;
    s->src = (vf_upg_source){NULL, &s->light, vf_vec3_splat(0.0f)};
    s->ok = 1;
    break;
  }
  }
}

static void build_sources(void) {
  static int built;
  if (built) return;
  for (int i = 0; i < SOURCE_COUNT; i++) build_source(i);
  built = 1;
}

/* ---- targets ---- */

typedef struct {
  dvec x, n;
  double r;
} disc;

/* The disc at distance d along unit aim, of radius r, its normal leaning tilt_deg from -aim. */
static disc disc_at(dvec aim, double d, double r, double tilt_deg) {
  return (disc){dscale(aim, d), tilt_deg > 0.0 ? lean(dscale(aim, -1.0), tilt_deg, 1.3) : dscale(aim, -1.0), r};
}

/* Whether the ray from L (the origin) along dir meets the disc: vf_upg_lands. */
static int lands_on_disc(void *ctx, vf_vec3 dir) {
  const disc *t = ctx;
  dvec d = dv(dir);
  double denom = ddot(t->n, d);
  if (denom == 0.0) return 0;
  double s = ddot(t->n, t->x) / denom;
  if (!(s > 0.0)) return 0;
  dvec off = dsub(dscale(d, s), t->x);
  return ddot(off, off) <= t->r * t->r;
}

/* Gauss-Legendre nodes and weights on [-1, 1], 8 points. */
static const double GL_X[QUAD_NODES] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290,
                                        -0.1834346424956498, 0.1834346424956498,  0.5255324099163290,
                                        0.7966664774136267,  0.9602898564975363};
static const double GL_W[QUAD_NODES] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873,
                                        0.3626837833783620, 0.3626837833783620, 0.3137066458778873,
                                        0.2223810344533745, 0.1012285362903763};

/* p_acc by quadrature at one level: y = x + rho (cos phi s + sin phi t) over the disc. */
static double disc_integral(const vf_upg_source *src, const disc *t, int level) {
  int angles = 64 << level, panels = 8 << level;
  dframe f = dframe_around(t->n);
  double dphi = 2.0 * PI_D / angles, h = t->r / panels, sum = 0.0;
  for (int i = 0; i < angles; i++) {
    double phi = (i + 0.5) * dphi;
    dvec e = dadd(dscale(f.s, cos(phi)), dscale(f.t, sin(phi)));
    for (int p = 0; p < panels; p++) {
      for (int g = 0; g < QUAD_NODES; g++) {
        double rho = (p + 0.5 + 0.5 * GL_X[g]) * h, w = 0.5 * h * GL_W[g];
        dvec y = dadd(t->x, dscale(e, rho));
        double dist2 = ddot(y, y), dist = sqrt(dist2);
        dvec dir = dscale(y, 1.0 / dist);
        double density = vf_upg_density(src, fv(dir));
        if (density > 0.0) sum += w * rho * density * fabs(ddot(t->n, dir)) / dist2;
      }
    }
  }
  return sum * dphi;
}

/* ---- configurations ---- */

typedef struct {
  int source;
  char label[40];
  disc target;
  double p_acc, p_err; /* quadrature, and its last change */
} gathering_config;

enum { CONFIG_MAX = 256 };
static gathering_config configs[CONFIG_MAX];
static int config_count;

static void add_config(int source_index, const char *label, disc t) {
  if (config_count == CONFIG_MAX) {
    CHECK_FAIL_("more than %d configurations", CONFIG_MAX);
    return;
  }
  gathering_config *c = &configs[config_count++];
  c->source = source_index;
  snprintf(c->label, sizeof c->label, "%s", label);
  c->target = t;
  const vf_upg_source *src = &sources[source_index].src;
  double prev = disc_integral(src, &t, 0), q = prev;
  int level = 1;
  for (; level <= QUAD_MAX_LEVEL; level++) {
    q = disc_integral(src, &t, level);
    double change = fabs(q - prev);
    prev = q;
    c->p_err = change;
    if (level >= QUAD_MIN_LEVEL && change <= QUAD_SETTLED * q) break;
  }
  c->p_acc = q;
}

/* p turned away from the plane of up and p by deg: off a lobe's peak, sideways. */
static dvec sideways(dvec p, dvec up, double deg) {
  dvec w = dnormalize(dcross(up, p));
  return dnormalize(dadd(dscale(p, cos(rad(deg))), dscale(w, sin(rad(deg)))));
}

/* Near and far, on and off the peaks, and around L (distance below r: the whole sphere). */
static void build_configs(void) {
  static int built;
  if (built) return;
  built = 1;
  build_sources();
  for (int i = 0; i < SOURCE_COUNT; i++) {
    const source *s = &sources[i];
    if (!s->ok) continue;
    dvec up = s->up, down = dscale(up, -1.0);
    switch (s->sc->kind) {
    case SOURCE_VERTEX:
      /* the narrow cone: a merge radius of 2.5 mm seen from 25 m, 1e-4 rad */
      add_config(i, "mirror narrow", disc_at(s->mirror, 25.0, 0.0025, 0.0));
      add_config(i, "mirror far", disc_at(s->mirror, 25.0, 0.25, 50.0));
      if (s->sc->far_only) {
        /* 20 degrees off, Phong 1e4's density is below the smallest float */
        add_config(i, "off mirror 1deg", disc_at(sideways(s->mirror, up, 1.0), 25.0, 0.1, 30.0));
        if (s->refracts) add_config(i, "refraction narrow", disc_at(s->refracted, 25.0, 0.0025, 0.0));
        break;
      }
      add_config(i, "off mirror 20deg", disc_at(sideways(s->mirror, up, 20.0), 2.0, 0.3, 30.0));
      add_config(i, "mirror near", disc_at(s->mirror, 1.0, 0.15, 0.0));
      /* A rough dielectric's bound over a cone on the reflection side includes its
       * refraction lobe's, and over the whole sphere it is the refraction peak over
       * (1 - eta)^2: near the normal, where reflection is weak, and around L the trials
       * per gathering grow like that peak, 1 / alpha^2. Only the roughest glass has those
       * targets, and around L on its refraction side alone, to keep the run short. */
      if (!s->refracts || !s->sc->not_around) add_config(i, "normal near", disc_at(up, 1.5, 0.4, 20.0));
      if (!s->refracts) add_config(i, "normal around L", disc_at(up, 0.6, 1.0, 0.0));
      if (s->refracts) {
        add_config(i, "refraction narrow", disc_at(s->refracted, 25.0, 0.0025, 0.0));
        add_config(i, "refraction near", disc_at(s->refracted, 1.0, 0.15, 0.0));
        add_config(i, "refraction far", disc_at(s->refracted, 25.0, 0.25, 50.0));
        add_config(i, "off refraction 20deg", disc_at(sideways(s->refracted, up, 20.0), 2.0, 0.3, 30.0));
      }
      /* beyond the critical angle no microfacet refracts fix along -normal */
      if (s->refracts && !s->beyond_critical) add_config(i, "-normal near", disc_at(down, 1.5, 0.4, 20.0));
      if (s->refracts && !s->sc->not_around) add_config(i, "-normal around L", disc_at(down, 0.6, 1.0, 0.0));
      break;
    case SOURCE_AREA:
      add_config(i, "normal near", disc_at(up, 1.0, 0.2, 0.0));
      add_config(i, "normal far", disc_at(up, 25.0, 0.25, 50.0));
      add_config(i, "normal narrow", disc_at(up, 25.0, 0.0025, 0.0));
      add_config(i, "60deg near", disc_at(lean(up, 60.0, 2.0), 2.0, 0.3, 30.0));
      add_config(i, "85deg far", disc_at(lean(up, 85.0, 2.0), 20.0, 0.5, 0.0));
      add_config(i, "normal around L", disc_at(up, 0.6, 1.0, 0.0));
      break;
    case SOURCE_POINT:
      add_config(i, "near", disc_at(up, 1.0, 0.2, 0.0));
      add_config(i, "far", disc_at(lean(up, 100.0, 1.0), 25.0, 0.25, 50.0));
      add_config(i, "around L", disc_at(up, 0.6, 1.0, 30.0));
      break;
    case SOURCE_SPOT:
      add_config(i, "axis near", disc_at(up, 1.0, 0.15, 0.0));
      add_config(i, "axis far", disc_at(up, 25.0, 0.25, 50.0));
      add_config(i, "axis narrow", disc_at(up, 25.0, 0.0025, 0.0));
      add_config(i, "falloff 25deg near", disc_at(lean(up, 25.0, 2.0), 1.0, 0.1, 0.0));
      add_config(i, "across the edge", disc_at(lean(up, SPOT_OUTER_DEG, 2.0), 1.0, 0.2, 20.0));
      add_config(i, "axis around L", disc_at(up, 0.6, 1.0, 0.0));
      break;
    }
  }
}

/* The configuration of the source named `name` and the target labelled `label`. */
static const gathering_config *find_config(const char *name, const char *label) {
  for (int k = 0; k < config_count; k++)
    if (!strcmp(sources[configs[k].source].sc->name, name) && !strcmp(configs[k].label, label)) return &configs[k];
  CHECK_FAIL_("no configuration [%s, %s]", name, label);
  return NULL;
}

/* ---- 0. the quadrature against closed forms ---- */

/* Discs facing L on the aim, whose directions form a cap of half-angle theta, cos theta =
 * d / sqrt(d^2 + r^2): a point light's uniform density gives (1 - cos theta) / 2, a spot's
 * uniform density over its cone (1 - cos theta) / (1 - cos outer) up to the whole cone, and
 * an area light's cos / pi about its normal sin^2 theta. */
static void test_quadrature_matches_closed_forms(void) {
  build_configs();
  const struct {
    const char *name, *label;
    double tol;
  } cases[] = {{"point light", "near", QUAD_SMOOTH_TOL},     {"spot light", "axis near", QUAD_SMOOTH_TOL},
               {"spot light", "axis narrow", QUAD_SMOOTH_TOL}, {"spot light", "axis around L", QUAD_JUMP_TOL},
               {"area light", "normal near", QUAD_SMOOTH_TOL}, {"area light", "normal narrow", QUAD_SMOOTH_TOL}};
  for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
    const gathering_config *c = find_config(cases[i].name, cases[i].label);
    if (!c) continue;
    const source *s = &sources[c->source];
    double d = dlength(c->target.x), r = c->target.r, cos_t = d / sqrt(d * d + r * r), exact;
    switch (s->sc->kind) {
    case SOURCE_POINT: exact = 0.5 * (1.0 - cos_t); break;
    case SOURCE_SPOT: exact = fmin(1.0, (1.0 - cos_t) / (1.0 - cos(rad(SPOT_OUTER_DEG)))); break;
    default: exact = r * r / (d * d + r * r); break;
    }
    char where[96];
    snprintf(where, sizeof where, "%s, %s", cases[i].name, cases[i].label);
    expect_near("quadrature p_acc vs closed form (rel.)", where, c->p_acc / exact, 1.0, cases[i].tol);
    printf("  %-24s %-20s p_acc %.9g closed form %.9g (rel. err %.1e, estimated %.1e)\n", cases[i].name,
           cases[i].label, c->p_acc, exact, fabs(c->p_acc / exact - 1.0), c->p_err / c->p_acc);
  }
}

/* ---- the comparison ---- */

typedef struct {
  running_mean estimate;
  double trials, rays; /* per gathering */
  uint64_t bound_exceeded;
} run_result;

/* Whether mean (of standard error se) is 1 / p_acc within K_Z standard errors and twice the
 * quadrature's error; `scale` multiplies the mean first (case 4). Writes the z-score. */
static int agrees(const gathering_config *c, double mean, double se, double scale, double *z) {
  double expected = 1.0 / c->p_acc, quad = 2.0 * c->p_err / (c->p_acc * c->p_acc);
  *z = (scale * mean - expected) / (scale * se);
  return fabs(scale * mean - expected) <= K_Z * scale * se + quad;
}

/* The checks of one run: agreement, and the power to see a bias of BIAS. */
static void compare(const gathering_config *c, const char *method, const run_result *r) {
  const source *s = &sources[c->source];
  double mean = rm_mean(&r->estimate), se = rm_se(&r->estimate), z, z_up, z_down;
  int ok = agrees(c, mean, se, 1.0, &z);
  int up = agrees(c, mean, se, 1.0 + BIAS, &z_up), down = agrees(c, mean, se, 1.0 - BIAS, &z_down);
  printf("  %-24s %-20s 1/p_acc %11.5g (quad. %.0e)  %s %11.5g  z %+5.2f  trials %8.1f  rays %6.2f", s->sc->name,
         c->label, 1.0 / c->p_acc, c->p_err / c->p_acc, method, mean, z, r->trials, r->rays);
  if (r->bound_exceeded > 0) printf("  bound exceeded %llu times", (unsigned long long)r->bound_exceeded);
  printf("\n");
  if (r->bound_exceeded > 0)
    CHECK_FAIL_("%s [%s, %s]: the density exceeded the bound in %llu of %.0f trials", method, s->sc->name, c->label,
                (unsigned long long)r->bound_exceeded, r->trials * r->estimate.n);
  if (!ok)
    CHECK_FAIL_("%s [%s, %s]: mean %.9g vs 1/p_acc %.9g: z = %.2f (quadrature rel. err %.1e)", method, s->sc->name,
                c->label, mean, 1.0 / c->p_acc, z, c->p_err / c->p_acc);
  if (up || down)
    CHECK_FAIL_("%s [%s, %s]: no power: the mean times 1 +- %.2f would pass (z %+.2f, %+.2f)", method, s->sc->name,
                c->label, BIAS, z_up, z_down);
}

static run_result run_estimator(const gathering_config *c, float bound_scale, uint64_t test_case,
                                vf_upg_counts *counts) {
  const source *s = &sources[c->source];
  vf_vec3 axis;
  float cos_half, omc;
  vf_upg_cone(vf_vec3_splat(0.0f), fv(c->target.x), (float)c->target.r, &axis, &cos_half, &omc);
  float bound = bound_scale * vf_upg_bound(&s->src, axis, cos_half, omc);
  run_result r = {{0.0, 0.0, 0}, 0.0, 0.0, 0};
  if (!(isfinite(bound) && bound > 0.0f)) {
    CHECK_FAIL_("bound [%s, %s]: %g", s->sc->name, c->label, bound);
    return r;
  }
  vf_rng rng = test_rng(test_case, (uint64_t)(c - configs));
  disc target = c->target;
  vf_upg_counts mine = {0};
  for (int g = 0; g < GATHERINGS; g++)
    rm_add(&r.estimate, vf_upg_inverse_acceptance(&s->src, axis, cos_half, omc, bound, &rng, lands_on_disc, &target,
                                                   &mine));
  r.trials = (double)mine.trials / GATHERINGS;
  r.rays = (double)mine.rays / GATHERINGS;
  r.bound_exceeded = mine.bound_exceeded;
  counts->gatherings += mine.gatherings;
  counts->trials += mine.trials;
  counts->rays += mine.rays;
  counts->truncated += mine.truncated;
  counts->bound_exceeded += mine.bound_exceeded;
  return r;
}

/* ---- 1. the estimate with the bound ---- */

static void test_estimate_with_bound_is_inverse_acceptance(void) {
  build_configs();
  vf_upg_counts counts = {0};
  double worst_quad = 0.0;
  for (int k = 0; k < config_count; k++) {
    const gathering_config *c = &configs[k];
    worst_quad = fmax(worst_quad, c->p_err / c->p_acc);
    if (!(c->p_acc > 0.0)) {
      CHECK_FAIL_("p_acc [%s, %s] is %g: no configuration should miss its lobe", sources[c->source].sc->name,
                  c->label, c->p_acc);
      continue;
    }
    run_result r = run_estimator(c, 1.0f, CASE_UPG_ESTIMATE, &counts);
    if (r.estimate.n > 0) compare(c, "mean", &r);
  }
  /* bound_exceeded is checked per configuration (compare) */
  CHECK_INT_EQ(counts.truncated, 0);
  CHECK_INT_EQ(counts.gatherings, (long long)config_count * GATHERINGS);
  printf("  info: %d configurations, %llu gatherings, %llu trials, %llu rays, bound exceeded %llu times; worst "
         "quadrature rel. err %.1e\n",
         config_count, (unsigned long long)counts.gatherings, (unsigned long long)counts.trials,
         (unsigned long long)counts.rays, (unsigned long long)counts.bound_exceeded, worst_quad);
}

/* ---- 2. the estimate with the BSDF's own draws ---- */

static void test_estimate_with_draws_is_inverse_acceptance(void) {
  build_configs();
  int runs = 0;
  for (int k = 0; k < config_count; k++) {
    const gathering_config *c = &configs[k];
    const source *s = &sources[c->source];
    if (s->sc->kind != SOURCE_VERTEX || !(c->p_acc >= DRAWS_MIN_P_ACC)) continue;
    vf_vec3 axis;
    float cos_half, omc;
    vf_upg_cone(vf_vec3_splat(0.0f), fv(c->target.x), (float)c->target.r, &axis, &cos_half, &omc);
    vf_rng rng = test_rng(CASE_UPG_DRAWS, (uint64_t)k);
    disc target = c->target;
    vf_upg_counts counts = {0};
    run_result r = {{0.0, 0.0, 0}, 0.0, 0.0, 0};
    for (int g = 0; g < GATHERINGS; g++)
      rm_add(&r.estimate, vf_upg_inverse_acceptance_draws(&s->bsdf, axis, cos_half, &rng, lands_on_disc, &target,
                                                          &counts));
    r.trials = (double)counts.trials / GATHERINGS;
    r.rays = (double)counts.rays / GATHERINGS;
    CHECK_INT_EQ(counts.truncated, 0);
    compare(c, "draws", &r);
    runs++;
  }
  printf("  info: %d configurations with p_acc >= %g\n", runs, DRAWS_MIN_P_ACC);
  CHECK(runs >= 20);
}

/* ---- 3. the bound covers every direction of every cone ---- */

#define BOUND_DIRECTIONS 40000

/* A direction of positive density for draw i of source s: odd i (and every i of a point
 * light) uniform on the sphere, even ones from the BSDF's sampler (non-specular draws) or
 * the light's emission. Returns 0 where the draw has none. */
static int bound_direction(const source *s, vf_rng *r, int i, vf_vec3 *dir) {
  if (i % 2 == 1 || s->sc->kind == SOURCE_POINT) {
    *dir = fv(uniform_sphere_d(r));
  } else if (s->sc->kind == SOURCE_VERTEX) {
    bsdf_draw d = draw_sample(&s->bsdf, r);
    if (vf_is_zero(d.f) || (d.event & VF_BSDF_SPECULAR)) return 0;
    *dir = d.gen;
  } else {
    /* the light's emission: cosine-distributed about the area light's normal, uniform in
     * the spot's cone */
    float u1 = vf_rng_float(r), u2 = vf_rng_float(r);
    dframe f = dframe_around(s->up);
    double cos_t = s->sc->kind == SOURCE_AREA ? sqrt(1.0 - u1) : 1.0 - u1 * s->light.one_minus_cos_outer;
    *dir = fv(dframe_dir(&f, acos(fmin(1.0, cos_t)), 2.0 * PI_D * u2));
  }
  return vf_upg_density(&s->src, *dir) > 0.0f;
}

static void test_bound_covers_every_direction_of_a_cone(void) {
  build_sources();
  double worst_ratio_all = 0.0;
  long checked_all = 0;
  for (int i = 0; i < SOURCE_COUNT; i++) {
    const source *s = &sources[i];
    CHECK(s->ok);
    if (!s->ok) continue;
    vf_rng r = test_rng(CASE_UPG_BOUND, (uint64_t)i);
    long checked = 0, exceeded = 0, infinite = 0;
    double worst_ratio = 0.0;
    for (int k = 0; k < BOUND_DIRECTIONS; k++) {
      vf_vec3 dir;
      if (!bound_direction(s, &r, k, &dir)) continue;
      /* half-angles from 1e-4 to pi, even in log; one cone in ten the whole sphere, and the
       * axis up to the half-angle away from dir, one in five exactly at the cone's edge */
      double u = vf_rng_float(&r), theta = vf_rng_float(&r) < 0.1f ? PI_D : 1e-4 * pow(PI_D / 1e-4, u);
      double beta = theta * fmin(1.0, 1.25 * vf_rng_float(&r)), phi = 2.0 * PI_D * vf_rng_float(&r);
      dframe f = dframe_around(dnormalize(dv(dir)));
      vf_vec3 axis = fv(dframe_dir(&f, beta, phi));
      float cos_half = theta == PI_D ? -1.0f : (float)cos(theta);
      float omc = theta == PI_D ? 2.0f : (float)(2.0 * sin(0.5 * theta) * sin(0.5 * theta));
      float density = vf_upg_density(&s->src, dir), bound = vf_upg_bound(&s->src, axis, cos_half, omc);
      checked++;
      if (!isfinite(bound)) {
        infinite++;
        continue;
      }
      double ratio = density / bound;
      worst_ratio = fmax(worst_ratio, ratio);
      if (!(density <= bound) && exceeded++ < 3)
        CHECK_FAIL_("bound [%s]: density %.9g > bound %.9g (ratio %.6f) for dir (%.7f %.7f %.7f), cone half-angle "
                    "%.6g, dir %.6g from its axis",
                    s->sc->name, density, bound, ratio, dir.x, dir.y, dir.z, theta, beta);
    }
    if (exceeded > 3) CHECK_FAIL_("bound [%s]: exceeded %ld times in all", s->sc->name, exceeded);
    CHECK_INT_EQ(infinite, 0);
    expect_ge("directions checked", s->sc->name, (double)checked, BOUND_DIRECTIONS / 4);
    printf("  %-24s %6ld directions in cones, largest density / bound %.6f\n", s->sc->name, checked, worst_ratio);
    worst_ratio_all = fmax(worst_ratio_all, worst_ratio);
    checked_all += checked;
  }
  printf("  info: %ld directions, largest density / bound %.6f\n", checked_all, worst_ratio_all);
}

/* ---- 4. a wrong bound is seen ---- */

static void test_half_bound_is_detected(void) {
  build_configs();
  /* On the Lambertian lobe's peak the density is close to its bound all over the cone, so
   * half the bound caps it there and the mean comes out near twice 1/p_acc; on GGX's peak
   * the cap bites only in the middle of the lobe. */
  const char *wanted[][2] = {{"lambert", "normal near"}, {"ggx r0.2", "mirror near"}, {"spot light", "axis near"}};
  for (size_t w = 0; w < sizeof wanted / sizeof wanted[0]; w++) {
    const gathering_config *c = find_config(wanted[w][0], wanted[w][1]);
    if (!c) continue;
    vf_upg_counts counts = {0};
    run_result r = run_estimator(c, 0.5f, CASE_UPG_HALF_BOUND, &counts);
    if (r.estimate.n == 0) continue;
    double z, mean = rm_mean(&r.estimate);
    int ok = agrees(c, mean, rm_se(&r.estimate), 1.0, &z);
    printf("  %-24s %-20s half bound: 1/p_acc %11.5g  mean %11.5g  z %+7.1f  bound exceeded in %.3f of trials\n",
           wanted[w][0], wanted[w][1], 1.0 / c->p_acc, mean, z, (double)counts.bound_exceeded / counts.trials);
    if (ok) CHECK_FAIL_("half bound [%s, %s]: the mean %.9g passes as 1/p_acc %.9g", wanted[w][0], wanted[w][1], mean,
                        1.0 / c->p_acc);
    if (!(counts.bound_exceeded > 0))
      CHECK_FAIL_("half bound [%s, %s]: bound_exceeded stayed 0", wanted[w][0], wanted[w][1]);
  }
}

int main(void) {
  setvbuf(stdout, NULL, _IOLBF, 0); /* a line at a time, also into ctest's log */
  RUN(test_quadrature_matches_closed_forms);
  RUN(test_bound_covers_every_direction_of_a_cone);
  RUN(test_estimate_with_bound_is_inverse_acceptance);
  RUN(test_estimate_with_draws_is_inverse_acceptance);
  RUN(test_half_bound_is_detected);
  return check_finish();
}
