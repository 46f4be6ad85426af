#include "camera.h"

#include <math.h>

void vf_camera_init(vf_camera *cam, const vf_camera_desc *desc, int width, int height) {
  cam->position = desc->position;
  cam->forward = vf_normalize(desc->forward);
  cam->right = vf_normalize(vf_cross(cam->forward, desc->up));
  cam->up = vf_cross(cam->right, cam->forward);
  /* A mirrored image: the same rays, the raster's x reversed (ray generation and the
   * projection onto the raster both read right). */
  if (desc->mirror) cam->right = vf_neg(cam->right);
  cam->width = width;
  cam->height = height;
  if (desc->view_width > 0.0f) {
    cam->pixel_size = desc->view_width / (float)width;
    cam->image_plane_distance = 0.0f;
    cam->lens_radius = 0.0f;
    cam->focus_distance = 0.0f;
    return;
  }
  cam->pixel_size = 0.0f;
  float half = 0.5f * desc->vertical_fov_degrees * (3.14159265358979f / 180.0f);
  cam->image_plane_distance = 0.5f * (float)height / tanf(half);
  cam->lens_radius = desc->aperture > 0.0f ? desc->aperture : 0.0f;
  cam->focus_distance = cam->lens_radius > 0.0f ? desc->focus_distance : 0.0f;
}
