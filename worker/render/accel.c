#include "accel.h"

#include "../../common/error.h"
#include "embree_api.h"
#include "surface.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Scenes with a few spheres (SPHERES_APART or fewer: the Cornell family's balls) trace them
 * apart from the meshes. Embree keeps each kind of primitive in an acceleration structure
 * of its own and traces a ray through one after the other, the meshes' first, then the
 * spheres' with the ray's tfar shortened to the mesh hit; in a box of a few dozen
 * triangles its sphere structure cost as much as the triangles' (a packet of 8 closest-hit
 * rays: 3,400 Embree instructions without the spheres, 6,250 with two; occlusion: 510 and
 * 1,980). So the meshes are one Embree scene and the spheres another, traced one after the
 * other as Embree traced the one scene. The spheres' scene sees only the rays that may
 * reach a sphere before their mesh hit (`reaches`, four lanes at a time) and whose answer
 * is not certain without it (sphere_answer: a ray that clearly misses every sphere, or
 * clearly hits one, away from its silhouette and from the ray's ends, is answered here).
 * Both tests keep margins a hundred times wider than their own and Embree's float
 * rounding, so that a ray answered here is one Embree's sphere kernel answers the same way;
 * hits, of packets and single rays, are those of the one scene bit for bit. */
#define SPHERES_APART 8

/* A sphere as `reaches` tests it. */
struct sphere_bound {
  float cx, cy, cz, r2; /* centre; squared radius with reaches' margin */
  float r, inv_2r;      /* radius, 1 / (2 radius) (sphere_answer) */
  unsigned shape;       /* its shape, and Embree geometry ID */
};

struct vf_accel {
  const vf_embree_api *rtc; /* Embree's functions (embree_api.h) */
  RTCDevice device;
  RTCScene scene;   /* every shape; the meshes alone when `spheres` is set */
  RTCScene spheres; /* the spheres apart (see SPHERES_APART), or NULL */
  int num_bounds;
  struct sphere_bound bounds[SPHERES_APART];
  const vf_scene *source; /* borrowed: positions and spheres for hit reconstruction */
  float scale;            /* bounding-sphere radius, for ray offsets */
  unsigned char *interpolated; /* per shape: vf_surface_interpolated */
  struct cutout *cutouts;      /* per shape: what its filter functions read */
};

/* A cut-out mesh's filter functions' user data. */
struct cutout {
  const vf_scene *scene;
  const vf_shape *shape;
};

/* Embree's filter for hits on a cut-out mesh (closest hit and occlusion): hits in a hole
 * are refused, and the ray goes on. */
static void cutout_filter(const struct RTCFilterFunctionNArguments *args) {
  const struct cutout *c = args->geometryUserPtr;
  for (unsigned i = 0; i < args->N; i++) {
    if (args->valid[i] == 0) continue;
    /* RTCHitN is N-wide structure-of-arrays Ng_x, Ng_y, Ng_z, u, v, primID, ...; Embree's
     * accessors for it (rtcore_ray.h) are C++ only. */
    const float *f = (const float *)args->hit;
    const unsigned *w = (const unsigned *)args->hit;
    unsigned prim = w[5 * args->N + i];
    float u = f[3 * args->N + i], v = f[4 * args->N + i];
    if (!vf_surface_covered(c->scene, c->shape, prim, u, v)) args->valid[i] = 0;
  }
}

static void device_error(void *user, enum RTCError code, const char *msg) {
  (void)user;
  vf_error_set(VF_EEMBREE, "Embree error %d: %s", (int)code, msg ? msg : "");
}

static int add_mesh(vf_accel *a, const vf_shape *s, unsigned id) {
  RTCGeometry g = a->rtc->rtcNewGeometry(a->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  if (g == NULL) return VF_EEMBREE;
  /* Embree reads vertex buffers with 16-byte loads: the new buffer it allocates is padded. */
  float *v = a->rtc->rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                     s->num_vertices);
  uint32_t *idx = a->rtc->rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t),
                                          s->num_triangles);
  if (v == NULL || idx == NULL) {
    a->rtc->rtcReleaseGeometry(g);
    return VF_EEMBREE;
  }
  memcpy(v, s->positions, (size_t)s->num_vertices * 3 * sizeof(float));
  memcpy(idx, s->indices, (size_t)s->num_triangles * 3 * sizeof(uint32_t));
  if (s->material >= 0 && a->source->materials[s->material].alpha_cutoff > 0.0f) {
    a->cutouts[id] = (struct cutout){a->source, s};
    a->rtc->rtcSetGeometryUserData(g, &a->cutouts[id]);
    a->rtc->rtcSetGeometryIntersectFilterFunction(g, cutout_filter);
    a->rtc->rtcSetGeometryOccludedFilterFunction(g, cutout_filter);
  }
  a->rtc->rtcCommitGeometry(g);
  a->rtc->rtcAttachGeometryByID(a->scene, g, id);
  a->rtc->rtcReleaseGeometry(g);
  return VF_OK;
}

static int add_sphere(vf_accel *a, RTCScene scene, const vf_shape *s, unsigned id) {
  RTCGeometry g = a->rtc->rtcNewGeometry(a->device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
  if (g == NULL) return VF_EEMBREE;
  float *v = a->rtc->rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), 1);
  if (v == NULL) {
    a->rtc->rtcReleaseGeometry(g);
    return VF_EEMBREE;
  }
  v[0] = s->center.x;
  v[1] = s->center.y;
  v[2] = s->center.z;
  v[3] = s->radius;
  a->rtc->rtcCommitGeometry(g);
  a->rtc->rtcAttachGeometryByID(scene, g, id);
  a->rtc->rtcReleaseGeometry(g);
  return VF_OK;
}

static vf_module embree = VF_MODULE_INIT(VF_EMBREE_MODULE_FILE, "Embree ray tracing", VF_EMBREE_API_VERSION,
                                         sizeof(vf_embree_api));

int vf_accel_create(const vf_scene *scene, vf_accel **out) {
  const vf_embree_api *rtc = vf_module_get(&embree, "cannot trace rays");
  if (rtc == NULL) return VF_EMODULE;
  vf_accel *a = calloc(1, sizeof *a);
  if (a == NULL) return VF_ENOMEM;
  a->rtc = rtc;
  a->source = scene;
  a->interpolated = calloc((size_t)scene->num_shapes + 1, 1);
  a->cutouts = calloc((size_t)scene->num_shapes + 1, sizeof *a->cutouts);
  if (a->interpolated == NULL || a->cutouts == NULL) {
    vf_accel_destroy(a);
    return VF_ENOMEM;
  }
  for (int i = 0; i < scene->num_shapes; i++) a->interpolated[i] = (unsigned char)vf_surface_interpolated(scene, &scene->shapes[i]);
  vf_vec3 center;
  vf_scene_bounding_sphere(scene, &center, &a->scale);
  if (!(a->scale > 0.0f)) a->scale = 1.0f; /* a single point or sphere of radius 0: any unit */
  /* Embree's kernels are capped at AVX2 (8-wide packets). Its kernels for each instruction
   * set find hits that differ in their last bits, enough for the films of an AVX-512 and an
   * AVX2 machine to differ visibly, and a farm's machines must agree to the bit: with the
   * cap every x86 machine with AVX2, AVX-512 or not, runs the same kernels. It is also the
   * faster choice on Intel's server cores, where 512-bit code lowers the clock of
   * everything around it while Embree's own rate stays the same (docs/BENCHMARKS.md,
   * "Embree's kernels capped at AVX2"). */
  a->device = a->rtc->rtcNewDevice("threads=1,set_affinity=0,max_isa=avx2");
  if (a->device == NULL) {
    vf_accel_destroy(a);
    return vf_error_set(VF_EEMBREE, "cannot create the Embree device (error %d)", (int)a->rtc->rtcGetDeviceError(NULL));
  }
  a->rtc->rtcSetDeviceErrorFunction(a->device, device_error, NULL);
  a->scene = a->rtc->rtcNewScene(a->device);
  if (a->scene == NULL) goto fail;
  /* Robust mode: watertight edges, or some of the rays leaving the inside of a closed mesh
   * escape between its triangles (tests/worker/render/test_accel.c fails without it). Low build quality
   * (the Morton builder): with robust mode, faster to trace than medium or high on our
   * scenes and as fast as medium on large meshes, and the build is cheaper too
   * (docs/BENCHMARKS.md, "Raw Embree rate"). */
  a->rtc->rtcSetSceneBuildQuality(a->scene, RTC_BUILD_QUALITY_LOW);
  a->rtc->rtcSetSceneFlags(a->scene, RTC_SCENE_FLAG_ROBUST);
  int num_spheres = 0;
  for (int i = 0; i < scene->num_shapes; i++) num_spheres += scene->shapes[i].kind == VF_SHAPE_SPHERE;
  if (num_spheres > 0 && num_spheres <= SPHERES_APART) {
    a->spheres = a->rtc->rtcNewScene(a->device);
    if (a->spheres == NULL) goto fail;
    a->rtc->rtcSetSceneBuildQuality(a->spheres, RTC_BUILD_QUALITY_LOW);
    a->rtc->rtcSetSceneFlags(a->spheres, RTC_SCENE_FLAG_ROBUST);
  }
  for (int i = 0; i < scene->num_shapes; i++) {
    const vf_shape *s = &scene->shapes[i];
    int err = s->kind == VF_SHAPE_SPHERE ? add_sphere(a, a->spheres ? a->spheres : a->scene, s, (unsigned)i)
                                         : add_mesh(a, s, (unsigned)i);
    if (err != VF_OK) goto fail;
    if (s->kind == VF_SHAPE_SPHERE && a->spheres) {
      /* Embree decides a hit from the squared distance of the centre to the ray's line
       * against the squared radius, in float: errors of a few units in the last place of
       * the centre's distance c from the origin, relative 1e-6 of r c at most, as are
       * those of the test (reaches). The margin, 1% of r^2 plus 1e-5 c^2 (added there),
       * is thousands of times wider. */
      float r = s->radius;
      a->bounds[a->num_bounds++] = (struct sphere_bound){s->center.x, s->center.y, s->center.z, 1.01f * r * r, r,
                                                           0.5f / r, (unsigned)i};
    }
  }
  a->rtc->rtcCommitScene(a->scene);
  if (a->spheres) a->rtc->rtcCommitScene(a->spheres);
  if (a->rtc->rtcGetDeviceError(a->device) != RTC_ERROR_NONE) goto fail;
  *out = a;
  return VF_OK;
fail:
  vf_accel_destroy(a);
  return vf_error_set(VF_EEMBREE, "cannot build the Embree scene");
}

void vf_accel_destroy(vf_accel *a) {
  if (a == NULL) return;
  if (a->scene) a->rtc->rtcReleaseScene(a->scene);
  if (a->spheres) a->rtc->rtcReleaseScene(a->spheres);
  if (a->device) a->rtc->rtcReleaseDevice(a->device);
  free(a->interpolated);
  free(a->cutouts);
  free(a);
}

/* Whether the ray from (ox, oy, oz) along (dx, dy, dz), t in [0, tfar], can come within
 * sphere b (with its margin): 0 only where Embree's sphere kernel finds no hit. A sphere
 * wholly behind the origin or beyond tfar is out of reach. For single rays; packet_reach
 * does the same four lanes at a time. */
static inline int reaches(const struct sphere_bound *b, float ox, float oy, float oz, float dx, float dy, float dz,
                          float tfar) {
  float cx = b->cx - ox, cy = b->cy - oy, cz = b->cz - oz;
  float dd = dx * dx + dy * dy + dz * dz, cc = cx * cx + cy * cy + cz * cz;
  float r2dd = (b->r2 + 1e-5f * cc) * dd;
  /* The squared distance of the centre to the line, |c x d|^2 / |d|^2, against r2. */
  float px = cy * dz - cz * dy, py = cz * dx - cx * dz, pz = cx * dy - cy * dx;
  float along = cx * dx + cy * dy + cz * dz; /* the centre's distance along the line, times |d| */
  float beyond = along - tfar * dd;           /* -inf for tfar = inf */
  int line = px * px + py * py + pz * pz <= r2dd;
  int behind = along < 0.0f && along * along > r2dd;
  int past = beyond > 0.0f && beyond * beyond > r2dd;
  return line & !behind & !past;
}

static inline int may_reach_sphere(const vf_accel *a, vf_vec3 org, vf_vec3 dir, float tfar) {
  int any = 0;
  for (int k = 0; k < a->num_bounds; k++) any |= reaches(&a->bounds[k], org.x, org.y, org.z, dir.x, dir.y, dir.z, tfar);
  return any;
}

/* The distance to sphere s along org + t dir: the root of |org + t dir - center| = radius
 * nearest to Embree's t_embree, solved in double. Embree's own t is good to a few parts in
 * a million and differs between its single-ray and packet kernels; this one is exact to
 * float rounding whichever kernel found the hit, so a ray gives the same hit either way. */
static float sphere_root(const vf_shape *s, vf_vec3 org, vf_vec3 dir, float t_embree) {
  /* Products of floats are exact in double: the only rounding is in the sums. */
  double ox = (double)org.x - s->center.x, oy = (double)org.y - s->center.y, oz = (double)org.z - s->center.z;
  double a = (double)dir.x * dir.x + (double)dir.y * dir.y + (double)dir.z * dir.z;
  double b = ox * dir.x + oy * dir.y + oz * dir.z;
  double c = ox * ox + oy * oy + oz * oz - (double)s->radius * s->radius;
  double disc = b * b - a * c;
  double root = sqrt(disc > 0.0 ? disc : 0.0);
  /* The two roots without cancellation: q = -(b + sign(b) root), t = q / a and c / q. */
  double q = b < 0.0 ? root - b : -(b + root);
  double t0 = q / a, t1 = q != 0.0 ? c / q : t0;
  double t = fabs(t0 - t_embree) <= fabs(t1 - t_embree) ? t0 : t1;
  return t > 0.0 ? (float)t : t_embree; /* a root behind the origin: keep Embree's */
}

/* Where a root lies for Embree, for t in [0, tfar] (tfar INFINITY: no end), all three
 * scaled by |dir|^2 (root_dd = t |dir|^2, tfar_dd = tfar |dir|^2): ROOT_IN or ROOT_OUT when
 * it is farther from the ends than tol_dd plus tfar's own rounding, else ROOT_UNSURE. */
enum { ROOT_UNSURE, ROOT_OUT, ROOT_IN };
static inline int root_place(float root_dd, float tol_dd, float tfar_dd) {
  if (root_dd < -tol_dd) return ROOT_OUT;
  if (!(root_dd > tol_dd)) return ROOT_UNSURE;
  if (isinf(tfar_dd)) return ROOT_IN;
  float end_tol = tol_dd + 1e-5f * tfar_dd;
  return root_dd < tfar_dd - end_tol ? ROOT_IN : root_dd > tfar_dd + end_tol ? ROOT_OUT : ROOT_UNSURE;
}

/* What Embree's sphere kernel answers for the ray org + t dir, t in [0, tfar], against the
 * spheres of a, where the answer is certain: SPHERES_MISS, or SPHERES_HIT with the sphere
 * hit first in *shape and in *t its root (Embree's t differs from it in the last bits
 * only, so that sphere_root chooses the same root from either); SPHERES_UNSURE for a ray
 * that grazes a sphere, has a root near 0 or tfar (rays leaving or ending on a sphere), or
 * two hits close together. The margins are a hundred times the rounding of this float
 * arithmetic and of Embree's (a few parts in a million of the distances): the line's
 * squared distance to the centre against r^2 within 1% of r^2 plus 1e-5 of the centre's
 * squared distance c^2, roots within 1e-4 (c^2 + r^2) / 2r >= 1e-4 c of the ends. Without
 * a division per sphere: distances along the ray are kept times |dir|^2. */
enum { SPHERES_UNSURE, SPHERES_MISS, SPHERES_HIT };
static int sphere_answer(const vf_accel *a, vf_vec3 org, vf_vec3 dir, float tfar, unsigned *shape, float *t) {
  float dd = vf_dot(dir, dir);
  if (!(dd > 0.0f) || !(tfar >= 0.0f)) return SPHERES_UNSURE;
  float len = sqrtf(dd), tfar_dd = tfar * dd, best = INFINITY, best_tol = 0.0f;
  unsigned best_shape = 0;
  for (int k = 0; k < a->num_bounds; k++) {
    const struct sphere_bound *b = &a->bounds[k];
    vf_vec3 o = vf_vec3_make(org.x - b->cx, org.y - b->cy, org.z - b->cz);
    float oo = vf_dot(o, o), slack = 0.01f * b->r * b->r + 1e-5f * oo;
    float perp_dd = vf_length_sq(vf_cross(o, dir)); /* the line's squared distance to the centre, times dd */
    if (perp_dd > (b->r * b->r + slack) * dd) continue;
    if (!(perp_dd < (b->r * b->r - slack) * dd)) return SPHERES_UNSURE; /* grazing */
    float mid = -vf_dot(o, dir), half = sqrtf(b->r * b->r * dd - perp_dd);
    float tol = 1e-4f * ((oo + b->r * b->r) * b->inv_2r + b->r) * len;
    float root = mid - half;
    int place = root_place(root, tol, tfar_dd);
    if (place == ROOT_OUT) { /* Embree's first hit is the far root when the near one is out */
      root = mid + half;
      place = root_place(root, tol, tfar_dd);
    }
    if (place == ROOT_UNSURE) return SPHERES_UNSURE;
    if (place == ROOT_OUT) continue;
    if (fabsf(root - best) <= tol + best_tol) return SPHERES_UNSURE;
    if (root < best) best = root, best_tol = tol, best_shape = b->shape;
  }
  if (isinf(best)) return SPHERES_MISS;
  *shape = best_shape;
  *t = best / dd;
  return SPHERES_HIT;
}

#define VF_UNLIKELY_HIT(x) __builtin_expect(!!(x), 0)

/* Fills *hit from what Embree reported for the ray org + t dir; 0 for a degenerate hit. */
static inline __attribute__((always_inline)) int complete_hit(const vf_accel *a, vf_vec3 org, vf_vec3 dir, float t,
                                                              unsigned geom, unsigned prim, float u, float v,
                                                              vf_vec3 ng, vf_hit *hit) {
  const vf_shape *s = &a->source->shapes[geom];
  hit->t = t;
  hit->shape = geom;
  hit->primitive = prim;
  if (s->kind == VF_SHAPE_SPHERE) {
    t = hit->t = sphere_root(s, org, dir, t);
    vf_vec3 p = vf_add(org, vf_scale(dir, t));
    vf_vec3 n = vf_normalize(vf_sub(p, s->center));
    hit->normal = n;
    /* Project back onto the sphere: removes the error of org + t dir along the normal. */
    hit->position = vf_add(s->center, vf_scale(n, s->radius));
    return 1;
  }
  const uint32_t *tri = &s->indices[3 * (size_t)prim];
  const float *p0 = &s->positions[3 * (size_t)tri[0]];
  const float *p1 = &s->positions[3 * (size_t)tri[1]];
  const float *p2 = &s->positions[3 * (size_t)tri[2]];
  float w = 1.0f - u - v;
  hit->position = vf_vec3_make(w * p0[0] + u * p1[0] + v * p2[0], w * p0[1] + u * p1[1] + v * p2[1],
                               w * p0[2] + u * p1[2] + v * p2[2]);
  hit->u = u;
  hit->v = v;
  if (VF_UNLIKELY_HIT(a->interpolated[geom])) {
    /* Our own normal, which a light vertex rebuilt from the triangle gets again. */
    hit->normal = vf_surface_triangle_normal(s, prim);
    return !vf_is_zero(hit->normal);
  }
  float len = vf_length(ng);
  if (!(len > 0.0f)) return 0; /* degenerate triangle: Embree should not report it */
  hit->normal = vf_scale(ng, 1.0f / len);
  return 1;
}

int vf_accel_intersect(const vf_accel *a, vf_vec3 org, vf_vec3 dir, float tfar, vf_hit *hit) {
  struct RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  struct RTCRayHit rh;
  rh.ray.org_x = org.x;
  rh.ray.org_y = org.y;
  rh.ray.org_z = org.z;
  rh.ray.dir_x = dir.x;
  rh.ray.dir_y = dir.y;
  rh.ray.dir_z = dir.z;
  rh.ray.tnear = 0.0f;
  rh.ray.tfar = tfar;
  rh.ray.time = 0.0f;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  a->rtc->rtcIntersect1(a->scene, &ctx, &rh);
  if (a->spheres && may_reach_sphere(a, org, dir, rh.ray.tfar)) {
    unsigned shape;
    float t;
    int answer = sphere_answer(a, org, dir, rh.ray.tfar, &shape, &t);
    if (answer == SPHERES_HIT) {
      rh.ray.tfar = t;
      rh.hit.geomID = shape;
      rh.hit.primID = 0;
    } else if (answer == SPHERES_UNSURE) {
      a->rtc->rtcIntersect1(a->spheres, &ctx, &rh);
    }
  }
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return 0;
  /* org and dir as Embree holds them (it writes only tfar and the hit): reading them back
   * keeps the arguments from living across the call in stack slots, whose reloads GCC
   * fuses into loads that straddle two stores and miss store forwarding, which cost more
   * than the rest of this function on every ray. */
  return complete_hit(a, vf_vec3_make(rh.ray.org_x, rh.ray.org_y, rh.ray.org_z),
                      vf_vec3_make(rh.ray.dir_x, rh.ray.dir_y, rh.ray.dir_z), rh.ray.tfar, rh.hit.geomID,
                      rh.hit.primID, rh.hit.u, rh.hit.v, vf_vec3_make(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z), hit);
}

int vf_accel_occluded(const vf_accel *a, vf_vec3 org, vf_vec3 dir, float tfar) {
  struct RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  struct RTCRay r;
  r.org_x = org.x;
  r.org_y = org.y;
  r.org_z = org.z;
  r.dir_x = dir.x;
  r.dir_y = dir.y;
  r.dir_z = dir.z;
  r.tnear = 0.0f;
  r.tfar = tfar;
  r.time = 0.0f;
  r.mask = 0xFFFFFFFFu;
  r.id = 0;
  r.flags = 0;
  a->rtc->rtcOccluded1(a->scene, &ctx, &r);
  if (r.tfar < 0.0f) return 1;
  if (a->spheres && may_reach_sphere(a, org, dir, tfar)) {
    unsigned shape;
    float t;
    int answer = sphere_answer(a, org, dir, tfar, &shape, &t);
    if (answer == SPHERES_HIT) return 1;
    if (answer == SPHERES_UNSURE) a->rtc->rtcOccluded1(a->spheres, &ctx, &r);
  }
  return r.tfar < 0.0f;
}

/* Embree's packets of 8 rays, the widest its AVX2 kernels trace natively. */
#define WIDTH 8

/* reaches for the lanes of packet r that `valid` switches on: reach[i] -1 where ray i may
 * reach a sphere of a, else 0 (Embree's values of a valid mask); whether any may. Four
 * lanes at a time with SSE2 (the same arithmetic as reaches: the mask only decides which
 * rays Embree's sphere kernel sees, and any conservative answer gives the same hits). */
static inline int packet_reach(const vf_accel *a, const struct RTCRay8 *r, const int *valid, int *reach) {
#ifdef __SSE2__
  int any = 0;
  for (int i = 0; i < WIDTH; i += 4) {
    __m128 ox = _mm_loadu_ps(&r->org_x[i]), oy = _mm_loadu_ps(&r->org_y[i]), oz = _mm_loadu_ps(&r->org_z[i]);
    __m128 dx = _mm_loadu_ps(&r->dir_x[i]), dy = _mm_loadu_ps(&r->dir_y[i]), dz = _mm_loadu_ps(&r->dir_z[i]);
    __m128 dd = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz));
    __m128 tdd = _mm_mul_ps(_mm_loadu_ps(&r->tfar[i]), dd), zero = _mm_setzero_ps();
    __m128 hit = zero;
    for (int k = 0; k < a->num_bounds; k++) {
      const struct sphere_bound *b = &a->bounds[k];
      __m128 cx = _mm_sub_ps(_mm_set1_ps(b->cx), ox), cy = _mm_sub_ps(_mm_set1_ps(b->cy), oy),
             cz = _mm_sub_ps(_mm_set1_ps(b->cz), oz);
      __m128 cc = _mm_add_ps(_mm_add_ps(_mm_mul_ps(cx, cx), _mm_mul_ps(cy, cy)), _mm_mul_ps(cz, cz));
      __m128 r2dd = _mm_mul_ps(_mm_add_ps(_mm_set1_ps(b->r2), _mm_mul_ps(_mm_set1_ps(1e-5f), cc)), dd);
      __m128 px = _mm_sub_ps(_mm_mul_ps(cy, dz), _mm_mul_ps(cz, dy)), py = _mm_sub_ps(_mm_mul_ps(cz, dx), _mm_mul_ps(cx, dz)),
             pz = _mm_sub_ps(_mm_mul_ps(cx, dy), _mm_mul_ps(cy, dx));
      __m128 pp = _mm_add_ps(_mm_add_ps(_mm_mul_ps(px, px), _mm_mul_ps(py, py)), _mm_mul_ps(pz, pz));
      __m128 along = _mm_add_ps(_mm_add_ps(_mm_mul_ps(cx, dx), _mm_mul_ps(cy, dy)), _mm_mul_ps(cz, dz));
      __m128 beyond = _mm_sub_ps(along, tdd);
      __m128 line = _mm_cmple_ps(pp, r2dd);
      __m128 behind = _mm_and_ps(_mm_cmplt_ps(along, zero), _mm_cmpgt_ps(_mm_mul_ps(along, along), r2dd));
      __m128 past = _mm_and_ps(_mm_cmpgt_ps(beyond, zero), _mm_cmpgt_ps(_mm_mul_ps(beyond, beyond), r2dd));
      hit = _mm_or_ps(hit, _mm_andnot_ps(_mm_or_ps(behind, past), line));
    }
    __m128i m = _mm_and_si128(_mm_castps_si128(hit), _mm_loadu_si128((const __m128i *)&valid[i]));
    _mm_storeu_si128((__m128i *)&reach[i], m);
    any |= _mm_movemask_ps(_mm_castsi128_ps(m));
  }
  return any;
#else
  int any = 0;
  for (int i = 0; i < WIDTH; i++) {
    int hit = 0;
    for (int k = 0; k < a->num_bounds; k++)
      hit |= reaches(&a->bounds[k], r->org_x[i], r->org_y[i], r->org_z[i], r->dir_x[i], r->dir_y[i], r->dir_z[i],
                     r->tfar[i]);
    reach[i] = -hit & valid[i];
    any |= reach[i];
  }
  return any;
#endif
}

/* Fills packet r and `valid` for rays org[i] + t dir[i], t in (0, tfar[i]) (tfar NULL:
 * infinity), i < n. Lanes past n are switched off but still given a harmless ray. The
 * fields that are the same for every ray are set in loops of their own, which the compiler
 * turns into vector stores, and only origins, directions and lengths lane by lane. */
static inline __attribute__((always_inline)) void packet_rays(struct RTCRay8 *r, int *valid, const vf_vec3 *org,
                                                              const vf_vec3 *dir, const float *tfar, int n) {
  for (int i = 0; i < WIDTH; i++) {
    valid[i] = i < n ? -1 : 0;
    r->tnear[i] = 0.0f;
    r->time[i] = 0.0f;
    r->mask[i] = 0xFFFFFFFFu;
    r->id[i] = 0;
    r->flags[i] = 0;
  }
  for (int i = 0; i < n; i++) {
    r->org_x[i] = org[i].x;
    r->org_y[i] = org[i].y;
    r->org_z[i] = org[i].z;
    r->dir_x[i] = dir[i].x;
    r->dir_y[i] = dir[i].y;
    r->dir_z[i] = dir[i].z;
    r->tfar[i] = tfar != NULL ? tfar[i] : INFINITY;
  }
  for (int i = n; i < WIDTH; i++) {
    r->org_x[i] = r->org_y[i] = r->org_z[i] = 0.0f;
    r->dir_x[i] = r->dir_y[i] = 0.0f;
    r->dir_z[i] = 1.0f;
    r->tfar[i] = 0.0f;
  }
}

static uint32_t occluded8(const vf_accel *a, const vf_vec3 *org, const vf_vec3 *dir, const float *tfar, int n) {
  struct RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  struct RTCRay8 r; /* aligned as Embree declares it */
  RTC_ALIGN(4 * WIDTH) int valid[WIDTH];
  packet_rays(&r, valid, org, dir, tfar, n);
  a->rtc->rtcOccluded8(valid, a->scene, &ctx, &r);
  if (a->spheres) {
    /* The rays the meshes left unblocked and a sphere may block, as one packet. */
    RTC_ALIGN(4 * WIDTH) int open[WIDTH], reach[WIDTH];
    for (int i = 0; i < WIDTH; i++) open[i] = valid[i] & -(r.tfar[i] >= 0.0f);
    if (packet_reach(a, &r, open, reach)) {
      /* Embree's sphere kernel for the lanes whose answer is not certain. */
      int unsure = 0;
      for (int i = 0; i < n; i++) {
        if (!reach[i]) continue;
        unsigned shape;
        float t;
        int answer = sphere_answer(a, org[i], dir[i], tfar[i], &shape, &t);
        if (answer == SPHERES_HIT) r.tfar[i] = -INFINITY; /* blocked, as Embree marks it */
        if (answer != SPHERES_UNSURE) reach[i] = 0;
        unsure |= reach[i];
      }
      if (unsure) a->rtc->rtcOccluded8(reach, a->spheres, &ctx, &r);
    }
  }
  uint32_t blocked = 0;
  for (int i = 0; i < n; i++) blocked |= (uint32_t)(r.tfar[i] < 0.0f) << i;
  return blocked;
}

static uint32_t intersect8(const vf_accel *a, const vf_vec3 *org, const vf_vec3 *dir, int n, vf_hit *hits) {
  struct RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  struct RTCRayHit8 rh;
  RTC_ALIGN(4 * WIDTH) int valid[WIDTH];
  packet_rays(&rh.ray, valid, org, dir, NULL, n);
  for (int i = 0; i < WIDTH; i++) rh.hit.geomID[i] = rh.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
  a->rtc->rtcIntersect8(valid, a->scene, &ctx, &rh);
  if (a->spheres) {
    /* The rays that may reach a sphere before their mesh hit, as one packet. */
    RTC_ALIGN(4 * WIDTH) int reach[WIDTH];
    if (packet_reach(a, &rh.ray, valid, reach)) {
      /* Embree's sphere kernel for the lanes whose answer is not certain. */
      int unsure = 0;
      for (int i = 0; i < n; i++) {
        if (!reach[i]) continue;
        unsigned shape;
        float t;
        int answer = sphere_answer(a, org[i], dir[i], rh.ray.tfar[i], &shape, &t);
        if (answer == SPHERES_HIT) {
          rh.ray.tfar[i] = t;
          rh.hit.geomID[i] = shape;
          rh.hit.primID[i] = 0;
        }
        if (answer != SPHERES_UNSURE) reach[i] = 0;
        unsure |= reach[i];
      }
      if (unsure) a->rtc->rtcIntersect8(reach, a->spheres, &ctx, &rh);
    }
  }
  uint32_t found = 0;
  for (int i = 0; i < n; i++)
    if (rh.hit.geomID[i] != RTC_INVALID_GEOMETRY_ID &&
        complete_hit(a, org[i], dir[i], rh.ray.tfar[i], rh.hit.geomID[i], rh.hit.primID[i], rh.hit.u[i], rh.hit.v[i],
                     vf_vec3_make(rh.hit.Ng_x[i], rh.hit.Ng_y[i], rh.hit.Ng_z[i]), &hits[i]))
      found |= 1u << i;
  return found;
}

/* Packets of up to WIDTH rays go to Embree as one packet, larger ones as two. */
uint32_t vf_accel_occluded_packet(const vf_accel *a, const vf_vec3 *org, const vf_vec3 *dir, const float *tfar,
                                  int n) {
  if (n <= WIDTH) return occluded8(a, org, dir, tfar, n);
  return occluded8(a, org, dir, tfar, WIDTH) |
         occluded8(a, org + WIDTH, dir + WIDTH, tfar + WIDTH, n - WIDTH) << WIDTH;
}

uint32_t vf_accel_intersect_packet(const vf_accel *a, const vf_vec3 *org, const vf_vec3 *dir, int n,
                                   vf_hit *hits) {
  if (n <= WIDTH) return intersect8(a, org, dir, n, hits);
  return intersect8(a, org, dir, WIDTH, hits) | intersect8(a, org + WIDTH, dir + WIDTH, n - WIDTH, hits + WIDTH)
                                                    << WIDTH;
}

const char *vf_accel_kernels(void) {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
#define DIFFER " (no AVX2 here: hits differ from AVX2 machines' in their last bits)"
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return "AVX2";
  if (__builtin_cpu_supports("avx")) return "AVX" DIFFER;
  if (__builtin_cpu_supports("sse4.2")) return "SSE4.2" DIFFER;
  return "SSE2" DIFFER;
#undef DIFFER
#else
  return "this architecture's (hits differ from x86 machines' in their last bits)";
#endif
}

float vf_accel_scale(const vf_accel *a) { return a->scale; }
