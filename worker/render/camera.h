/* The camera, perspective (pinhole or thin lens) or orthographic: raster <-> ray, and the
 * densities the light-tracing technique (t = 1) and the camera-side MIS quantities need.
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
 * the pinhole's expression: the lens area cancels out of every estimate.
 *
 * An orthographic camera (tech. rep. sec. 5.2) is the eye-side mirror of a directional
 * light: every ray travels along forward, from a point of the view plane through position
 * (perpendicular to forward; a pixel is a square of side pixel_size there). z0 is then a
 * direction, as y0 is for an infinite light (sec. 5.1): the camera sub-path draws its start
 * uniformly on the pixel's square (density 1 / pixel_size^2 per unit of view-plane area)
 * and projects it along forward, so z1 has the forward density
 *   p_1(z) = cos(theta_1) / pixel_size^2                                     (sec. 5.1)
 * with no distance in it: the MIS quantities' first segment takes no distance factor, and
 * d_vcm starts at n_light pixel_size^2 (vf_camera_start_density). The importance is
 * 1 / pixel_size^2 per unit of view-plane area along forward, so that a camera sub-path
 * again starts with throughput 1; a light vertex y connects to its foot on the view plane
 * (the one point whose ray reaches it) and carries W_e G / p(z0) = cos_y / pixel_size^2,
 * the same expression as p_1. No light sub-path can hit the camera in either model. */
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
  float pixel_size;     /* > 0: orthographic, a pixel's side on the view plane; 0: perspective */
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

/* The orthographic camera's ray origin for raster position (x, y): its point of the view
 * plane. Its direction is forward. */
static inline vf_vec3 vf_camera_view_point(const vf_camera *cam, float x, float y) {
  float px = (x - 0.5f * (float)cam->width) * cam->pixel_size;
  float py = (0.5f * (float)cam->height - y) * cam->pixel_size;
  return vf_add(cam->position, vf_add(vf_scale(cam->right, px), vf_scale(cam->up, py)));
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

/* The density with which a camera sub-path leaving along d starts, for its MIS
 * quantities (vf_mis_camera_start): perspective, the solid-angle density of d; orthographic,
 * the area density of the ray's origin on the view plane (see the top of the file). Its
 * first hit then takes the distance factor only when perspective. */
static inline float vf_camera_start_density(const vf_camera *cam, vf_vec3 d) {
  if (cam->pixel_size > 0.0f) return 1.0f / (cam->pixel_size * cam->pixel_size);
  return vf_camera_pdf_w(cam, d);
}

/* The camera's end of a connection from world point p (t = 1). */
typedef struct {
  vf_vec3 end;          /* z0: the lens point, or p's foot on the orthographic view plane */
  vf_vec3 to_camera;    /* unit, from p towards end */
  float dist;           /* |end - p| */
  float x, y;           /* the raster position at which the camera sees p */
  float density_scale;  /* the camera's area density of p is density_scale |cos_p| / dist_scale */
  float dist_scale;
} vf_camera_link;

/* Links world point p to the camera through lens point `lens` (ignored when
 * orthographic); 0 when p is behind the camera, its ray misses the image, or p sits on
 * the camera's end. Computed before anything is evaluated at p: a good part of the light
 * vertices lie outside the view. */
static inline int vf_camera_link_point(const vf_camera *cam, vf_vec3 lens, vf_vec3 p, vf_camera_link *out) {
  if (cam->pixel_size > 0.0f) {
    vf_vec3 rel = vf_sub(p, cam->position);
    float depth = vf_dot(rel, cam->forward);
    if (!(depth > 0.0f)) return 0;
    float s = 1.0f / cam->pixel_size;
    if (!vf_camera_raster_of(cam, rel, s, &out->x, &out->y)) return 0;
    out->end = vf_sub(p, vf_scale(cam->forward, depth));
    out->to_camera = vf_neg(cam->forward);
    out->dist = depth;
    out->density_scale = s * s;
    out->dist_scale = 1.0f;
    return 1;
  }
  vf_vec3 to_camera = vf_sub(lens, p);
  float dist = vf_length(to_camera);
  if (!(dist > 0.0f)) return 0;
  to_camera = vf_scale(to_camera, 1.0f / dist);
  if (!vf_camera_raster(cam, lens, p, &out->x, &out->y)) return 0;
  float cos_at_camera = -vf_dot(cam->forward, to_camera);
  if (!(cos_at_camera > 0.0f)) return 0;
  float image_to_camera = cam->image_plane_distance / cos_at_camera;
  out->end = lens;
  out->to_camera = to_camera;
  out->dist = dist;
  out->density_scale = image_to_camera * image_to_camera / cos_at_camera; /* image area to solid angle */
  out->dist_scale = dist * dist;
  return 1;
}

/* The camera's area density of generating the linked point, whose |cos| towards the camera
 * is cos_at_p (tech. rep. eq. 46; sec. 5.1 for the orthographic camera). */
static inline float vf_camera_link_pdf_a(const vf_camera_link *l, float cos_at_p) {
  return l->density_scale * cos_at_p / l->dist_scale;
}

#endif
