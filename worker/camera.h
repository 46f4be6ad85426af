/* The pinhole camera: raster <-> direction, and the densities the light-tracing technique
 * (t = 1) and the camera-side MIS quantities need.
 *
 * The image plane sits at distance image_plane_distance from the pinhole, chosen so that a
 * pixel has unit area: the solid-angle density of generating direction d is then
 * image_plane_distance^2 / cos^3(theta), theta being the angle to the view axis. */
#ifndef VF_CAMERA_H
#define VF_CAMERA_H

#include "../common/vec3.h"
#include "scene.h"

typedef struct {
  vf_vec3 position, forward, right, up; /* right = forward x up; up re-orthogonalised */
  int width, height;
  float image_plane_distance;
} vf_camera;

void vf_camera_init(vf_camera *cam, const vf_camera_desc *desc, int width, int height);

/* Unit direction through raster position (x, y), x right and y down from the top left.
 * This and vf_camera_raster are inline: every camera sub-path starts with the one, every
 * light vertex is projected with the other. */
static inline vf_vec3 vf_camera_direction(const vf_camera *cam, float x, float y) {
  float px = x - 0.5f * (float)cam->width;
  float py = 0.5f * (float)cam->height - y;
  vf_vec3 d = vf_add(vf_scale(cam->forward, cam->image_plane_distance),
                     vf_add(vf_scale(cam->right, px), vf_scale(cam->up, py)));
  return vf_normalize(d);
}

/* Raster position of a world point; returns 0 when it is behind the camera or off the image. */
static inline int vf_camera_raster(const vf_camera *cam, vf_vec3 point, float *x, float *y) {
  vf_vec3 d = vf_sub(point, cam->position);
  float z = vf_dot(d, cam->forward);
  if (!(z > 0.0f)) return 0;
  float s = cam->image_plane_distance / z;
  float rx = vf_dot(d, cam->right) * s + 0.5f * (float)cam->width;
  float ry = 0.5f * (float)cam->height - vf_dot(d, cam->up) * s;
  if (!(rx >= 0.0f && ry >= 0.0f && rx < (float)cam->width && ry < (float)cam->height)) return 0;
  *x = rx;
  *y = ry;
  return 1;
}

/* Solid-angle density of generating the unit world direction d through the image. */
static inline float vf_camera_pdf_w(const vf_camera *cam, vf_vec3 d) {
  float c = vf_dot(d, cam->forward);
  return cam->image_plane_distance * cam->image_plane_distance / (c * c * c);
}

#endif
