#include "accel.h"

#include "../common/error.h"

#include <embree3/rtcore.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

struct vf_accel {
  RTCDevice device;
  RTCScene scene;
  const vf_scene *source; /* borrowed: positions and spheres for hit reconstruction */
  float scale;            /* bounding-sphere radius, for ray offsets */
};

static void device_error(void *user, enum RTCError code, const char *msg) {
  (void)user;
  vf_error_set(VF_EEMBREE, "Embree error %d: %s", (int)code, msg ? msg : "");
}

static int add_mesh(vf_accel *a, const vf_shape *s, unsigned id) {
  RTCGeometry g = rtcNewGeometry(a->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  if (g == NULL) return VF_EEMBREE;
  /* Embree reads vertex buffers with 16-byte loads: the new buffer it allocates is padded. */
  float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                     s->num_vertices);
  uint32_t *idx = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t),
                                          s->num_triangles);
  if (v == NULL || idx == NULL) {
    rtcReleaseGeometry(g);
    return VF_EEMBREE;
  }
  memcpy(v, s->positions, (size_t)s->num_vertices * 3 * sizeof(float));
  memcpy(idx, s->indices, (size_t)s->num_triangles * 3 * sizeof(uint32_t));
  rtcCommitGeometry(g);
  rtcAttachGeometryByID(a->scene, g, id);
  rtcReleaseGeometry(g);
  return VF_OK;
}

static int add_sphere(vf_accel *a, const vf_shape *s, unsigned id) {
  RTCGeometry g = rtcNewGeometry(a->device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
  if (g == NULL) return VF_EEMBREE;
  float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), 1);
  if (v == NULL) {
    rtcReleaseGeometry(g);
    return VF_EEMBREE;
  }
  v[0] = s->center.x;
  v[1] = s->center.y;
  v[2] = s->center.z;
  v[3] = s->radius;
  rtcCommitGeometry(g);
  rtcAttachGeometryByID(a->scene, g, id);
  rtcReleaseGeometry(g);
  return VF_OK;
}

int vf_accel_create(const vf_scene *scene, vf_accel **out) {
  vf_accel *a = calloc(1, sizeof *a);
  if (a == NULL) return VF_ENOMEM;
  a->source = scene;
  vf_vec3 center;
  vf_scene_bounding_sphere(scene, &center, &a->scale);
  if (!(a->scale > 0.0f)) a->scale = 1.0f; /* a single point or sphere of radius 0: any unit */
  a->device = rtcNewDevice("threads=1,set_affinity=0");
  if (a->device == NULL) {
    free(a);
    return vf_error_set(VF_EEMBREE, "cannot create the Embree device (error %d)", (int)rtcGetDeviceError(NULL));
  }
  rtcSetDeviceErrorFunction(a->device, device_error, NULL);
  a->scene = rtcNewScene(a->device);
  if (a->scene == NULL) goto fail;
  /* Robust mode: watertight edges, or about 1.5e-4 of the rays leaving the inside of a
   * closed mesh escape between its triangles (tests/test_accel.c fails without it).
   * Low build quality (the Morton builder): with robust mode, measured faster to trace than
   * medium or high on our scenes (Embree 3.13, bench_embree, one thread: cornell 10.1
   * against 7.4 Mrays/s, the 115k-triangle knot 5.0 against 4.4), and within 7% either way
   * of medium on tube meshes of 240k, 600k and 2.4M triangles; the build is cheaper too. */
  rtcSetSceneBuildQuality(a->scene, RTC_BUILD_QUALITY_LOW);
  rtcSetSceneFlags(a->scene, RTC_SCENE_FLAG_ROBUST);
  for (int i = 0; i < scene->num_shapes; i++) {
    const vf_shape *s = &scene->shapes[i];
    int err = s->kind == VF_SHAPE_SPHERE ? add_sphere(a, s, (unsigned)i) : add_mesh(a, s, (unsigned)i);
    if (err != VF_OK) goto fail;
  }
  rtcCommitScene(a->scene);
  if (rtcGetDeviceError(a->device) != RTC_ERROR_NONE) goto fail;
  *out = a;
  return VF_OK;
fail:
  vf_accel_destroy(a);
  return vf_error_set(VF_EEMBREE, "cannot build the Embree scene");
}

void vf_accel_destroy(vf_accel *a) {
  if (a == NULL) return;
  if (a->scene) rtcReleaseScene(a->scene);
  if (a->device) rtcReleaseDevice(a->device);
  free(a);
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
  rtcIntersect1(a->scene, &ctx, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return 0;
  const vf_shape *s = &a->source->shapes[rh.hit.geomID];
  hit->t = rh.ray.tfar;
  hit->shape = rh.hit.geomID;
  hit->primitive = rh.hit.primID;
  if (s->kind == VF_SHAPE_SPHERE) {
    /* org and dir as Embree holds them (it writes only tfar and the hit): reading them
     * back keeps the arguments from living across the call in stack slots, whose
     * reloads GCC fuses into loads that straddle two stores and miss store forwarding,
     * which cost more than the rest of this function on every ray. */
    vf_vec3 o = vf_vec3_make(rh.ray.org_x, rh.ray.org_y, rh.ray.org_z);
    vf_vec3 d = vf_vec3_make(rh.ray.dir_x, rh.ray.dir_y, rh.ray.dir_z);
    vf_vec3 p = vf_add(o, vf_scale(d, rh.ray.tfar));
    vf_vec3 n = vf_normalize(vf_sub(p, s->center));
    hit->normal = n;
    /* Project back onto the sphere: removes the error of org + t dir along the normal. */
    hit->position = vf_add(s->center, vf_scale(n, s->radius));
  } else {
    const uint32_t *t = &s->indices[3 * (size_t)rh.hit.primID];
    const float *p0 = &s->positions[3 * (size_t)t[0]];
    const float *p1 = &s->positions[3 * (size_t)t[1]];
    const float *p2 = &s->positions[3 * (size_t)t[2]];
    float u = rh.hit.u, v = rh.hit.v, w = 1.0f - u - v;
    hit->position = vf_vec3_make(w * p0[0] + u * p1[0] + v * p2[0], w * p0[1] + u * p1[1] + v * p2[1],
                                 w * p0[2] + u * p1[2] + v * p2[2]);
    vf_vec3 ng = vf_vec3_make(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
    float len = vf_length(ng);
    if (!(len > 0.0f)) return 0; /* degenerate triangle: Embree should not report it */
    hit->normal = vf_scale(ng, 1.0f / len);
  }
  return 1;
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
  rtcOccluded1(a->scene, &ctx, &r);
  return r.tfar < 0.0f;
}

uint32_t vf_accel_occluded_packet(const vf_accel *a, const vf_vec3 *org, const vf_vec3 *dir, const float *tfar,
                                  int n) {
  struct RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  struct RTCRay8 r; /* aligned as Embree declares it */
  RTC_ALIGN(32) int valid[8];
  for (int i = 0; i < 8; i++) {
    int on = i < n; /* lanes past n are switched off, but still given a harmless ray */
    valid[i] = on ? -1 : 0;
    r.org_x[i] = on ? org[i].x : 0.0f;
    r.org_y[i] = on ? org[i].y : 0.0f;
    r.org_z[i] = on ? org[i].z : 0.0f;
    r.dir_x[i] = on ? dir[i].x : 0.0f;
    r.dir_y[i] = on ? dir[i].y : 0.0f;
    r.dir_z[i] = on ? dir[i].z : 1.0f;
    r.tnear[i] = 0.0f;
    r.tfar[i] = on ? tfar[i] : 0.0f;
    r.time[i] = 0.0f;
    r.mask[i] = 0xFFFFFFFFu;
    r.id[i] = 0;
    r.flags[i] = 0;
  }
  rtcOccluded8(valid, a->scene, &ctx, &r);
  uint32_t blocked = 0;
  for (int i = 0; i < n; i++) blocked |= (uint32_t)(r.tfar[i] < 0.0f) << i;
  return blocked;
}

float vf_accel_scale(const vf_accel *a) { return a->scale; }
