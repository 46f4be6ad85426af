#include "camera.h"

#include <math.h>

void vf_camera_init(vf_camera *cam, const vf_camera_desc *desc, int width, int height) {
  cam->position = desc->position;
  cam->forward = vf_normalize(desc->forward);
  cam->right = vf_normalize(vf_cross(cam->forward, desc->up));
  cam->up = vf_cross(cam->right, cam->forward);
  cam->width = width;
  cam->height = height;
  float half = 0.5f * desc->vertical_fov_degrees * (3.14159265358979f / 180.0f);
  cam->image_plane_distance = 0.5f * (float)height / tanf(half);
}

vf_vec3 vf_camera_direction(const vf_camera *cam, float x, float y) {
  float px = x - 0.5f * (float)cam->width;
  float py = 0.5f * (float)cam->height - y;
  vf_vec3 d = vf_add(vf_scale(cam->forward, cam->image_plane_distance),
                     vf_add(vf_scale(cam->right, px), vf_scale(cam->up, py)));
  return vf_normalize(d);
}

int vf_camera_raster(const vf_camera *cam, vf_vec3 point, float *x, float *y) {
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
