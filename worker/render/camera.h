/* The camera, pinhole or thin lens: raster <-> direction, and the densities the
 * light-tracing technique (t = 1) and the camera-side MIS quantities need.
 *
 * The image plane sits at distance image_plane_distance from the lens centre, chosen so
 * that a pixel has unit area. A pinhole (lens_radius 0) generates direction d with
 * solid-angle density image_plane_distance^2 / cos^3(theta), theta being the angle to the
 * view axis.
 *
 * A thin lens of radius r picks a point z0 uniformly on its disk (area density
 * 1 / (pi r^2), the same whether a camera sub-path starts there or a light vertex is
 * connected to it: p_connect / p_trace = 1 in tech. rep. eq. 31 and 46) and sends the ray
 * through the point of the plane in focus (at focus_distance along the axis) that the
 * pinhole at the lens centre would see at the raster position. Given z0, the raster maps
 * linearly to the plane in focus, so the direction's solid-angle density is again
 * image_plane_distance^2 / cos^3(theta): vf_camera_pdf_w serves both. The importance is
 * W_e = pdf_w / (pi r^2 cos(theta)), so that a camera sub-path starts with throughput 1 and
 * a connection to a sampled lens point (t = 1) carries W_e G / p(z0) = pdf_w cos_y / d^2,
 * the pinhole's expression: the lens area cancels out of every estimate. */
#ifndef VF_CAMERA_H
#define VF_CAMERA_H

#include "../../common/vec3.h"
#include "sampling.h"
#include "../scene/scene.h"

typedef struct {
  vf_vec3 position, forward, right, up; /* right = forward x up; up re-orthogonalised */
  int width, height;
  float image_plane_distance;
  float lens_radius;    /* 0: a pinhole */
  float focus_distance; /* lens_radius > 0: distance of the plane in focus along forward */
} vf_camera;

void vf_camera_init(vf_camera *cam, const vf_camera_desc *desc, int width, int height);

/* The point of the image plane at raster (x, y), x right and y down from the top left,
 * relative to the lens centre. */
static inline vf_vec3 vf_camera_image_point(const vf_camera *cam, float x, float y) {
  float px = x - 0.5f * (float)cam->width;
  float py = 0.5f * (float)cam->height - y;
  return vf_add(vf_scale(cam->forward, cam->image_plane_distance),
                vf_add(vf_scale(cam->right, px), vf_scale(cam->up, py)));
}

/* Unit direction through raster position (x, y) from the lens centre: the pinhole's ray.
 * This and vf_camera_raster are inline: every camera sub-path starts with the one, every
 * light vertex is projected with the other. */
static inline vf_vec3 vf_camera_direction(const vf_camera *cam, float x, float y) {
  return vf_normalize(vf_camera_image_point(cam, x, y));
}

/* A point uniformly on the thin lens from two uniform numbers. */
static inline vf_vec3 vf_camera_lens_point(const vf_camera *cam, float u1, float u2) {
  float x, y;
  vf_sample_concentric_disk(u1, u2, &x, &y);
  return vf_add(cam->position, vf_add(vf_scale(cam->right, x * cam->lens_radius), vf_scale(cam->up, y * cam->lens_radius)));
}

/* Unit direction from lens point `lens` through raster position (x, y) in focus. */
static inline vf_vec3 vf_camera_lens_direction(const vf_camera *cam, vf_vec3 lens, float x, float y) {
  vf_vec3 image = vf_camera_image_point(cam, x, y);
  vf_vec3 in_focus = vf_add(cam->position, vf_scale(image, cam->focus_distance / cam->image_plane_distance));
  return vf_normalize(vf_sub(in_focus, lens));
}

/* Raster position of q, a point relative to the lens centre, with s the image-plane
 * distance over q's depth; 0 when off the image. */
static inline int vf_camera_raster_of(const vf_camera *cam, vf_vec3 q, float s, float *x, float *y) {
  float rx = vf_dot(q, cam->right) * s + 0.5f * (float)cam->width;
  float ry = 0.5f * (float)cam->height - vf_dot(q, cam->up) * s;
  if (!(rx >= 0.0f && ry >= 0.0f && rx < (float)cam->width && ry < (float)cam->height)) return 0;
  *x = rx;
  *y = ry;
  return 1;
}

/* Raster position at which lens point `lens` (the position, for a pinhole) sees a world
 * point; returns 0 when the point is behind the lens or its ray misses the image. Through
 * a thin lens it is where the ray from the lens point crosses the plane in focus, as the
 * lens centre sees that crossing. */
static inline int vf_camera_raster(const vf_camera *cam, vf_vec3 lens, vf_vec3 point, float *x, float *y) {
  if (cam->lens_radius > 0.0f) {
    vf_vec3 d = vf_sub(point, lens);
    float z = vf_dot(d, cam->forward);
    if (!(z > 0.0f)) return 0;
    vf_vec3 in_focus = vf_add(vf_sub(lens, cam->position), vf_scale(d, cam->focus_distance / z));
    return vf_camera_raster_of(cam, in_focus, cam->image_plane_distance / cam->focus_distance, x, y);
  }
  vf_vec3 d = vf_sub(point, cam->position);
  float z = vf_dot(d, cam->forward);
  if (!(z > 0.0f)) return 0;
  return vf_camera_raster_of(cam, d, cam->image_plane_distance / z, x, y);
}

/* Solid-angle density of generating the unit world direction d through the image, given
 * the lens point (see the top of the file). */
static inline float vf_camera_pdf_w(const vf_camera *cam, vf_vec3 d) {
  float c = vf_dot(d, cam->forward);
  return cam->image_plane_distance * cam->image_plane_distance / (c * c * c);
}

#endif
