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

/* Unit direction through raster position (x, y), x right and y down from the top left. */
vf_vec3 vf_camera_direction(const vf_camera *cam, float x, float y);

/* Raster position of a world point; returns 0 when it is behind the camera or off the image. */
int vf_camera_raster(const vf_camera *cam, vf_vec3 point, float *x, float *y);

/* Solid-angle density of generating the unit world direction d through the image. */
static inline float vf_camera_pdf_w(const vf_camera *cam, vf_vec3 d) {
  float c = vf_dot(d, cam->forward);
  return cam->image_plane_distance * cam->image_plane_distance / (c * c * c);
}

#endif
