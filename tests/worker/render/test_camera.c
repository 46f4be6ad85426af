/* The camera, pinhole, thin lens and orthographic (worker/render/camera.h): raster and
 * direction invert each other through any lens point, points in focus land where the
 * pinhole sees them, the direction density given a lens point is the inverse Jacobian of
 * raster -> direction and integrates to the image's pixel count, lens points are uniform
 * on the disk; the orthographic camera's rays and links invert each other and its density
 * integrates to the pixel count over any plane; and the camera fields of a scene are
 * validated. */
#include "check.h"
#include "common/error.h"
#include "common/rng.h"
#include "worker/render/camera.h"
#include "worker/scene/scene.h"
#include "worker/scene/json.h"
#include "worker/scene/builtin.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { W = 160, H = 120 };

/* A camera looking along (0.2, -0.3, -1) from (0.5, 1, 4): no axis is a coordinate axis. */
static vf_camera camera_with_lens(float aperture, float focus_distance) {
  vf_camera_desc d = {vf_vec3_make(0.5f, 1.0f, 4.0f), vf_normalize(vf_vec3_make(0.2f, -0.3f, -1.0f)),
                      vf_vec3_make(0, 1, 0), 50.0f, aperture, focus_distance, 0.0f, 0};
  vf_vec3 up = vf_sub(d.up, vf_scale(d.forward, vf_dot(d.up, d.forward)));
  d.up = vf_normalize(up);
  vf_camera cam;
  vf_camera_init(&cam, &d, W, H);
  return cam;
}

/* The ray through raster (x, y) from a lens point, followed to any depth, projects back to
 * (x, y) from the same lens point; the point at the focus distance is the pinhole's. */
static void test_rays_and_raster_invert_each_other(void) {
  vf_rng rng = vf_rng_for_path(1, 0, 0, VF_STREAM_TEST);
  const float apertures[] = {0.0f, 0.05f, 0.4f};
  for (int a = 0; a < 3; a++) {
    vf_camera cam = camera_with_lens(apertures[a], 3.0f);
    double max_dev = 0.0, max_focus_dev = 0.0;
    for (int i = 0; i < 2000; i++) {
      float x = vf_rng_float(&rng) * W, y = vf_rng_float(&rng) * H;
      vf_vec3 lens = cam.position, d;
      if (cam.lens_radius > 0.0f) {
        float u1 = vf_rng_float(&rng), u2 = vf_rng_float(&rng);
        lens = vf_camera_lens_point(&cam, u1, u2);
        d = vf_camera_lens_direction(&cam, lens, x, y);
      } else {
        d = vf_camera_direction(&cam, x, y);
      }
      float depth = 0.5f + 8.0f * vf_rng_float(&rng);
      vf_vec3 p = vf_add(lens, vf_scale(d, depth / vf_dot(d, cam.forward)));
      float rx = -1.0f, ry = -1.0f;
      if (vf_camera_raster(&cam, lens, p, &rx, &ry)) max_dev = fmax(max_dev, fmax(fabs(rx - x), fabs(ry - y)));
      else if (x > 0.01f && y > 0.01f && x < W - 0.01f && y < H - 0.01f) max_dev = INFINITY;
      if (cam.lens_radius > 0.0f) {
        /* In focus: every lens point's ray meets the pinhole's at the focus distance. */
        vf_vec3 pinhole = vf_camera_direction(&cam, x, y);
        vf_vec3 a_focus = vf_add(lens, vf_scale(d, cam.focus_distance / vf_dot(d, cam.forward)));
        vf_vec3 b_focus = vf_add(cam.position, vf_scale(pinhole, cam.focus_distance / vf_dot(pinhole, cam.forward)));
        max_focus_dev = fmax(max_focus_dev, vf_length(vf_sub(a_focus, b_focus)));
      }
    }
    printf("  aperture %.2f: max raster round-trip error %.2e px, max distance of the rays in focus %.2e\n",
           apertures[a], max_dev, max_focus_dev);
    CHECK(max_dev < 2e-3);
    CHECK(max_focus_dev < 1e-5);
  }
}

/* The pinhole's raster function is the lens one with the lens at the centre; points behind
 * the lens plane are not on the image. */
static void test_points_behind_the_lens_are_off_the_image(void) {
  vf_camera cam = camera_with_lens(0.2f, 2.0f);
  float x, y;
  vf_vec3 behind = vf_sub(cam.position, vf_scale(cam.forward, 1.0f));
  CHECK(!vf_camera_raster(&cam, cam.position, behind, &x, &y));
  vf_vec3 lens = vf_add(cam.position, vf_scale(cam.right, 0.1f));
  CHECK(!vf_camera_raster(&cam, lens, vf_add(lens, vf_scale(cam.right, 1.0f)), &x, &y));
  CHECK(vf_camera_raster(&cam, lens, vf_add(cam.position, vf_scale(cam.forward, 2.0f)), &x, &y));
  CHECK_NEAR(x, 0.5 * W, 1e-3); /* on the axis in focus: the image's centre from any lens point */
  CHECK_NEAR(y, 0.5 * H, 1e-3);
}

/* Given a lens point, raster -> direction is a smooth map with raster density 1 per pixel,
 * so the solid-angle density is 1 / |d_x x d_y|, the inverse of the solid angle a unit of
 * raster area covers: vf_camera_pdf_w must be that, through the lens centre or off it. */
static void test_direction_density_is_the_inverse_jacobian(void) {
  vf_rng rng = vf_rng_for_path(2, 0, 0, VF_STREAM_TEST);
  vf_camera cam = camera_with_lens(0.3f, 2.5f);
  double max_rel = 0.0;
  for (int i = 0; i < 500; i++) {
    float x = 1.0f + vf_rng_float(&rng) * (W - 2), y = 1.0f + vf_rng_float(&rng) * (H - 2);
    float u1 = vf_rng_float(&rng), u2 = vf_rng_float(&rng);
    vf_vec3 lens = vf_camera_lens_point(&cam, u1, u2);
    const float h = 0.25f;
    vf_vec3 dx = vf_scale(vf_sub(vf_camera_lens_direction(&cam, lens, x + h, y), vf_camera_lens_direction(&cam, lens, x - h, y)),
                          0.5f / h);
    vf_vec3 dy = vf_scale(vf_sub(vf_camera_lens_direction(&cam, lens, x, y + h), vf_camera_lens_direction(&cam, lens, x, y - h)),
                          0.5f / h);
    double jacobian = vf_length(vf_cross(dx, dy));
    double pdf = vf_camera_pdf_w(&cam, vf_camera_lens_direction(&cam, lens, x, y));
    max_rel = fmax(max_rel, fabs(pdf * jacobian - 1.0));
  }
  printf("  |pdf_w * solid angle per pixel - 1| at most %.2e\n", max_rel);
  CHECK(max_rel < 2e-3);
}

/* Integrated over the directions a lens point sees the image through, the density gives
 * the number of pixels (it is per unit of raster area): uniform directions on the sphere,
 * each weighted by 4 pi pdf_w where it lands on the image. */
static void test_direction_density_integrates_to_the_pixel_count(void) {
  vf_rng rng = vf_rng_for_path(3, 0, 0, VF_STREAM_TEST);
  vf_camera cam = camera_with_lens(0.3f, 2.5f);
  vf_vec3 lens = vf_camera_lens_point(&cam, 0.8f, 0.3f);
  const int n = 400000;
  double sum = 0.0, sum2 = 0.0;
  for (int i = 0; i < n; i++) {
    vf_vec3 d = vf_sample_uniform_sphere(vf_rng_float(&rng), vf_rng_float(&rng));
    float x, y;
    double v = 0.0;
    if (vf_camera_raster(&cam, lens, vf_add(lens, d), &x, &y)) v = 4.0 * M_PI * vf_camera_pdf_w(&cam, d);
    sum += v;
    sum2 += v * v;
  }
  double mean = sum / n, se = sqrt((sum2 / n - mean * mean) / n);
  printf("  integral of pdf_w over the image's directions: %.1f +- %.1f, pixels %d\n", mean, se, W * H);
  CHECK_NEAR(mean, (double)W * H, 5.0 * se);
}

/* Lens points are uniform on the disk of the aperture's radius, in the lens plane. */
static void test_lens_points_are_uniform_on_the_disk(void) {
  vf_rng rng = vf_rng_for_path(4, 0, 0, VF_STREAM_TEST);
  vf_camera cam = camera_with_lens(0.25f, 2.0f);
  const int n = 100000;
  double r2 = 0.0, max_r = 0.0, max_depth = 0.0, mean_x = 0.0;
  for (int i = 0; i < n; i++) {
    vf_vec3 p = vf_sub(vf_camera_lens_point(&cam, vf_rng_float(&rng), vf_rng_float(&rng)), cam.position);
    r2 += vf_length_sq(p);
    max_r = fmax(max_r, vf_length(p));
    max_depth = fmax(max_depth, fabs(vf_dot(p, cam.forward)));
    mean_x += vf_dot(p, cam.right);
  }
  printf("  mean r^2 %.6f (uniform: %.6f), max r %.6f\n", r2 / n, 0.25 * 0.25 / 2, max_r);
  CHECK_NEAR(r2 / n, 0.25 * 0.25 / 2, 5.0 * 0.25 * 0.25 / sqrt(12.0 * n));
  CHECK(max_r <= 0.25 * (1 + 1e-6));
  CHECK(max_depth < 1e-6);
  CHECK_NEAR(mean_x / n, 0.0, 5.0 * 0.25 / 2 / sqrt((double)n));
}

/* The lens fields of a scene: a negative aperture or a focus distance <= 0 are refused
 * naming the field (the command line exits 2 on VF_ESCENE); the focus distance defaults
 * to the target's and is required without one. */
static vf_scene *camera_scene(const char *camera, int *err) {
  char text[1024];
  snprintf(text, sizeof text,
           "{\"camera\": {%s}, \"materials\": {\"m\": {\"diffuse\": [0.5, 0.5, 0.5]}},"
           " \"shapes\": [{\"type\": \"sphere\", \"material\": \"m\", \"center\": [0, 0, 0], \"radius\": 1}],"
           " \"lights\": [{\"type\": \"point\", \"position\": [0, 3, 0], \"intensity\": [1, 1, 1]}]}",
           camera);
  vf_scene *s = NULL;
  *err = vf_scene_parse(text, strlen(text), "lens.json", ".", NULL, 0, &s);
  return s;
}

static void test_lens_fields_are_validated(void) {
  static const struct {
    const char *camera, *message;
  } cases[] = {
      {"\"position\": [0, 0, 4], \"target\": [0, 0, 0], \"fov\": 40, \"aperture\": -0.1",
       "lens.json: camera.aperture: the lens radius must be >= 0, found -0.1"},
      {"\"position\": [0, 0, 4], \"target\": [0, 0, 0], \"fov\": 40, \"aperture\": 0.1, \"focus_distance\": 0",
       "lens.json: camera.focus_distance: must be > 0, found 0"},
      {"\"position\": [0, 0, 4], \"target\": [0, 0, 0], \"fov\": 40, \"focus_distance\": -2",
       "lens.json: camera.focus_distance: must be > 0, found -2"},
      {"\"position\": [0, 0, 4], \"forward\": [0, 0, -1], \"fov\": 40, \"aperture\": 0.1",
       "lens.json: camera: missing field 'focus_distance' (or 'target')"},
      {"\"position\": [0, 0, 4], \"target\": [0, 0, 0], \"fov\": 40, \"aperture\": \"wide\"",
       "lens.json: camera.aperture: expected a number, found a string"},
  };
  for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
    int err;
    vf_scene *s = camera_scene(cases[i].camera, &err);
    CHECK(s == NULL);
    CHECK_INT_EQ(err, VF_ESCENE);
    CHECK_STR_CONTAINS(vf_error_detail(err), cases[i].message);
    vf_scene_destroy(s);
  }
  int err;
  vf_scene *s = camera_scene("\"position\": [0, 0, 4], \"target\": [0, 0, 1], \"fov\": 40, \"aperture\": 0.1", &err);
  CHECK_INT_EQ(err, VF_OK);
  if (s != NULL) {
    CHECK_NEAR(s->camera.aperture, 0.1, 1e-7);
    CHECK_NEAR(s->camera.focus_distance, 3.0, 0.0);
  }
  vf_scene_destroy(s);
  s = camera_scene("\"position\": [0, 0, 4], \"target\": [0, 0, 0], \"fov\": 40", &err);
  CHECK_INT_EQ(err, VF_OK);
  if (s != NULL) CHECK_NEAR(s->camera.aperture, 0.0, 0.0); /* a pinhole by default */
  vf_scene_destroy(s);
}

/* The same view as camera_with_lens, orthographic, VIEW_WIDTH wide. */
static const float VIEW_WIDTH = 2.5f;
static vf_camera orthographic_camera(void) {
  vf_camera_desc d = {vf_vec3_make(0.5f, 1.0f, 4.0f), vf_normalize(vf_vec3_make(0.2f, -0.3f, -1.0f)),
                      vf_vec3_make(0, 1, 0), 0.0f, 0.0f, 0.0f, VIEW_WIDTH, 0};
  d.up = vf_normalize(vf_sub(d.up, vf_scale(d.forward, vf_dot(d.up, d.forward))));
  vf_camera cam;
  vf_camera_init(&cam, &d, W, H);
  return cam;
}

/* Every ray of the orthographic camera travels along forward from its point of the view
 * plane; the plane is VIEW_WIDTH wide and W/H as high, centred on the position; any point
 * of a ray, at any depth, links back to the ray's raster position and its origin, along
 * -forward, at the depth's distance. Points behind the plane are not linked. */
static void test_orthographic_rays_and_links_invert_each_other(void) {
  vf_rng rng = vf_rng_for_path(5, 0, 0, VF_STREAM_TEST);
  vf_camera cam = orthographic_camera();
  double max_dev = 0.0, max_end = 0.0, max_dir = 0.0, max_dist = 0.0;
  for (int i = 0; i < 2000; i++) {
    float x = vf_rng_float(&rng) * W, y = vf_rng_float(&rng) * H, depth = 0.1f + 8.0f * vf_rng_float(&rng);
    vf_vec3 o = vf_camera_view_point(&cam, x, y);
    vf_camera_link link;
    vf_vec3 p = vf_add(o, vf_scale(cam.forward, depth));
    if (!vf_camera_link_point(&cam, cam.position, p, &link)) {
      if (x > 0.01f && y > 0.01f && x < W - 0.01f && y < H - 0.01f) max_dev = INFINITY;
      continue;
    }
    max_dev = fmax(max_dev, fmax(fabs(link.x - x), fabs(link.y - y)));
    max_end = fmax(max_end, vf_length(vf_sub(link.end, o)));
    max_dir = fmax(max_dir, vf_length(vf_add(link.to_camera, cam.forward)));
    max_dist = fmax(max_dist, fabs(link.dist - depth));
    CHECK(!vf_camera_link_point(&cam, cam.position, vf_sub(o, vf_scale(cam.forward, depth)), &link));
  }
  printf("  max raster round-trip error %.2e px, end %.2e, direction %.2e, distance %.2e\n", max_dev, max_end,
         max_dir, max_dist);
  CHECK(max_dev < 2e-3);
  CHECK(max_end < 1e-5 && max_dir < 1e-6 && max_dist < 1e-5);
  /* The corners of the image are the corners of the view's rectangle. */
  vf_vec3 span = vf_sub(vf_camera_view_point(&cam, (float)W, 0.0f), vf_camera_view_point(&cam, 0.0f, (float)H));
  CHECK_NEAR(vf_dot(span, cam.right), VIEW_WIDTH, 1e-5);
  CHECK_NEAR(vf_dot(span, cam.up), VIEW_WIDTH * H / W, 1e-5);
  CHECK_NEAR(vf_length(vf_sub(vf_camera_view_point(&cam, 0.5f * W, 0.5f * H), cam.position)), 0.0, 1e-6);
}

/* The camera's area density of a linked point, integrated over a plane at any depth and
 * tilt, gives the number of pixels (one unit of density per pixel, as the perspective
 * camera's): points uniform on a square of the plane larger than the view, weighted by
 * the square's area times the density where they link to the image. */
static void test_orthographic_density_integrates_to_the_pixel_count(void) {
  vf_rng rng = vf_rng_for_path(6, 0, 0, VF_STREAM_TEST);
  vf_camera cam = orthographic_camera();
  const vf_vec3 normals[] = {cam.forward, vf_normalize(vf_add(cam.forward, vf_scale(cam.right, 0.8f))),
                             vf_normalize(vf_sub(cam.forward, vf_scale(cam.up, 1.5f)))};
  for (int k = 0; k < 3; k++) {
    vf_frame f = vf_frame_from_normal(normals[k]);
    vf_vec3 centre = vf_add(cam.position, vf_scale(cam.forward, 3.0f + (float)k));
    const float half = 4.0f;
    const int n = 200000;
    double sum = 0.0, sum2 = 0.0;
    for (int i = 0; i < n; i++) {
      float a = (2.0f * vf_rng_float(&rng) - 1.0f) * half, b = (2.0f * vf_rng_float(&rng) - 1.0f) * half;
      vf_vec3 p = vf_add(centre, vf_add(vf_scale(f.s, a), vf_scale(f.t, b)));
      vf_camera_link link;
      double v = 0.0;
      if (vf_camera_link_point(&cam, cam.position, p, &link))
        v = 4.0 * half * half * vf_camera_link_pdf_a(&link, fabsf(vf_dot(normals[k], link.to_camera)));
      sum += v;
      sum2 += v * v;
    }
    double mean = sum / n, se = sqrt((sum2 / n - mean * mean) / n);
    printf("  plane %d: integral of the area density %.1f +- %.1f, pixels %d\n", k, mean, se, W * H);
    CHECK_NEAR(mean, (double)W * H, 5.0 * se);
  }
}

/* The orthographic camera in a scene: "type": "orthographic" with a positive width and no
 * field of view or lens; a width only for it; scaling the scene scales the width. */
static void test_orthographic_fields_are_validated(void) {
  static const struct {
    const char *camera, *message;
  } cases[] = {
      {"\"type\": \"orthographic\", \"position\": [0, 0, 4], \"target\": [0, 0, 0]",
       "ortho.json: camera: missing field 'width'"},
      {"\"type\": \"orthographic\", \"position\": [0, 0, 4], \"target\": [0, 0, 0], \"width\": 0",
       "ortho.json: camera.width: the view's width must be > 0, found 0"},
      {"\"type\": \"orthographic\", \"position\": [0, 0, 4], \"target\": [0, 0, 0], \"width\": 2, \"fov\": 40",
       "ortho.json: camera: 'fov' is for perspective cameras: an orthographic camera has none"},
      {"\"type\": \"orthographic\", \"position\": [0, 0, 4], \"target\": [0, 0, 0], \"width\": 2, \"aperture\": 0.1",
       "ortho.json: camera: 'aperture' is for perspective cameras: an orthographic camera has none"},
      {"\"position\": [0, 0, 4], \"target\": [0, 0, 0], \"fov\": 40, \"width\": 2",
       "ortho.json: camera.width: is for orthographic cameras (\"type\": \"orthographic\")"},
      {"\"type\": \"fisheye\", \"position\": [0, 0, 4], \"target\": [0, 0, 0], \"fov\": 40",
       "ortho.json: camera.type: expected \"perspective\" or \"orthographic\", found \"fisheye\""},
  };
  for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
    char text[1024];
    snprintf(text, sizeof text,
             "{\"camera\": {%s}, \"materials\": {\"m\": {\"diffuse\": [0.5, 0.5, 0.5]}},"
             " \"shapes\": [{\"type\": \"sphere\", \"material\": \"m\", \"center\": [0, 0, 0], \"radius\": 1}],"
             " \"lights\": [{\"type\": \"point\", \"position\": [0, 3, 0], \"intensity\": [1, 1, 1]}]}",
             cases[i].camera);
    vf_scene *s = NULL;
    int err = vf_scene_parse(text, strlen(text), "ortho.json", ".", NULL, 0, &s);
    CHECK(s == NULL);
    CHECK_INT_EQ(err, VF_ESCENE);
    CHECK_STR_CONTAINS(vf_error_detail(err), cases[i].message);
    vf_scene_destroy(s);
  }
  int err;
  vf_scene *s = camera_scene("\"type\": \"orthographic\", \"position\": [0, 0, 4], \"target\": [0, 0, 1], \"width\": 3", &err);
  CHECK_INT_EQ(err, VF_OK);
  if (s != NULL) {
    CHECK_NEAR(s->camera.view_width, 3.0, 0.0);
    CHECK_NEAR(s->camera.vertical_fov_degrees, 0.0, 0.0);
    uint8_t before[32];
    memcpy(before, s->hash, sizeof before);
    CHECK_INT_EQ(vf_scene_scale(s, 2.0), VF_OK);
    CHECK_NEAR(s->camera.view_width, 6.0, 0.0);
    CHECK(memcmp(before, s->hash, sizeof before) != 0);
  }
  vf_scene_destroy(s);
}

/* A mirrored camera (vf_camera_desc.mirror) sees through raster (x, y) what the plain one
 * sees through (W - x, y), for a pinhole, a lens and an orthographic view alike, and its
 * rays and raster still invert each other (light tracing projects where the camera looks). */
static void test_mirrored_camera_reverses_the_raster_x(void) {
  vf_rng rng = vf_rng_for_path(9, 0, 0, VF_STREAM_TEST);
  vf_camera_desc d = {vf_vec3_make(0.5f, 1.0f, 4.0f), vf_normalize(vf_vec3_make(0.2f, -0.3f, -1.0f)),
                      vf_vec3_make(0, 1, 0), 50.0f, 0.2f, 3.0f, 0.0f, 0};
  d.up = vf_normalize(vf_sub(d.up, vf_scale(d.forward, vf_dot(d.up, d.forward))));
  for (int kind = 0; kind < 2; kind++) {
    if (kind == 1) d.vertical_fov_degrees = 0.0f, d.aperture = 0.0f, d.focus_distance = 0.0f, d.view_width = VIEW_WIDTH;
    vf_camera plain, mirrored;
    d.mirror = 0;
    vf_camera_init(&plain, &d, W, H);
    d.mirror = 1;
    vf_camera_init(&mirrored, &d, W, H);
    CHECK_NEAR(vf_dot(mirrored.up, plain.up), 1.0, 1e-6);
    CHECK_NEAR(vf_dot(mirrored.right, plain.right), -1.0, 1e-6);
    double max_dir = 0.0, max_dev = 0.0;
    for (int i = 0; i < 500; i++) {
      float x = vf_rng_float(&rng) * W, y = vf_rng_float(&rng) * H, depth = 0.5f + 6.0f * vf_rng_float(&rng);
      vf_vec3 o = mirrored.position, dir = mirrored.forward;
      if (kind == 0) {
        dir = vf_camera_direction(&mirrored, x, y);
        max_dir = fmax(max_dir, vf_length(vf_sub(dir, vf_camera_direction(&plain, (float)W - x, y))));
      } else {
        o = vf_camera_view_point(&mirrored, x, y);
        max_dir = fmax(max_dir, vf_length(vf_sub(o, vf_camera_view_point(&plain, (float)W - x, y))));
      }
      vf_vec3 p = vf_add(o, vf_scale(dir, depth / vf_dot(dir, mirrored.forward)));
      vf_camera_link link;
      if (vf_camera_link_point(&mirrored, mirrored.position, p, &link))
        max_dev = fmax(max_dev, fmax(fabs(link.x - x), fabs(link.y - y)));
      else if (x > 0.01f && y > 0.01f && x < W - 0.01f && y < H - 0.01f)
        max_dev = INFINITY;
    }
    printf("  %s: max difference from the plain camera at W - x %.2e, raster round trip %.2e px\n",
           kind ? "orthographic" : "pinhole", max_dir, max_dev);
    CHECK(max_dir < 1e-5);
    CHECK(max_dev < 2e-3);
  }
}

int main(void) {
  RUN(test_rays_and_raster_invert_each_other);
  RUN(test_points_behind_the_lens_are_off_the_image);
  RUN(test_direction_density_is_the_inverse_jacobian);
  RUN(test_direction_density_integrates_to_the_pixel_count);
  RUN(test_lens_points_are_uniform_on_the_disk);
  RUN(test_lens_fields_are_validated);
  RUN(test_orthographic_rays_and_links_invert_each_other);
  RUN(test_orthographic_density_integrates_to_the_pixel_count);
  RUN(test_orthographic_fields_are_validated);
  RUN(test_mirrored_camera_reverses_the_raster_x);
  return check_finish();
}
