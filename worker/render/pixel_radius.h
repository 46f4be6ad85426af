/* A merge radius per pixel (--radius per-pixel; tech. rep. sec. 6.1).
 *
 * One global radius suits a scene whose visible surfaces lie at about one distance: where
 * the depth varies, near surfaces are blurred over many pixels and far ones get too few
 * light vertices per query. With a radius per pixel, each camera sub-path merges with a
 * radius in proportion to its pixel's footprint: the width a pixel covers at the first
 * non-specular surface its centre ray reaches (through mirrors and glass, following the
 * likelier branch), over the median footprint of the image, clamped to
 * [VF_PIXEL_RADIUS_MIN_SCALE, VF_PIXEL_RADIUS_MAX_SCALE], times the global radius r_i of
 * the iteration. The image's typical radius is thus the global one, the paper's schedule
 * applies to every pixel alike (so the consistency argument holds pixel by pixel), and the
 * scales are a pure function of scene, camera and resolution: every machine of a farm
 * computes the same ones, and every iteration remains a pure function of (seed, global
 * index, path index). An orthographic pixel covers the same width everywhere: its scale
 * is 1. A pixel whose centre ray leaves the scene, or sees only specular surfaces, gets 1.
 *
 * The MIS weights stay exact because the vertices carry the radius-free c_vc and c_vm
 * (mis.h) and every technique that samples a full path forms its weight with the radius
 * of the path's pixel: its camera sub-path's, or for light tracing (t = 1) the pixel the
 * light vertex projects to (vf_merge_params_at). The grid is built for the largest radius
 * of the iteration; each query tests its candidates against its own. */
#ifndef VF_PIXEL_RADIUS_H
#define VF_PIXEL_RADIUS_H

#include "vcm_internal.h"

#include <math.h>

/* The range of a pixel's radius over the global one. The grid's cells follow the largest
 * radius, so a query with a smaller one reads more candidates than it needs: the range
 * bounds that (docs/BENCHMARKS.md, "Per-pixel merge radius"). */
#define VF_PIXEL_RADIUS_MIN_SCALE 0.5f
#define VF_PIXEL_RADIUS_MAX_SCALE 2.0f

/* Computes v->pixel_scale and v->pixel_scale_max (the camera, accel, lobes and pool set
 * up). VF_OK, or VF_ENOMEM with nothing allocated. */
int vf_pixel_radius_create(vf_vcm *v);

/* params with merge radius r: its eta_VCM = pi r^2 n_light (eq. 20), the weights' constants
 * and the merges' normalisation. */
static inline void vf_merge_params_radius(const vf_vcm *v, double r, merge_params *out) {
  double eta = M_PI * r * r * (double)v->num_light_paths;
  out->radius = (float)r;
  out->radius_sq = (float)(r * r);
  out->vm_normalization = (float)(1.0 / eta);
  out->mis.vm_weight = v->vm_in_weights ? vf_mis_h(&out->mis, (float)eta) : 0.0f;
  out->mis.vc_weight = v->vc_in_weights ? vf_mis_h(&out->mis, (float)(1.0 / eta)) : 0.0f;
}

/* The merge parameters of pixel `pixel` in the current iteration: the global ones, or with
 * a radius per pixel that pixel's radius and its eta_VCM.
 *
 * Past a pilot, a pixel of k camera sub-paths weighs light tracing's n_light light
 * sub-paths against k camera sub-paths (common/allocation.h): its light_paths is n_light /
 * k (exact: k is a power of two), which the weights read where light tracing meets the
 * camera (mis.h, eq. 31-33 and 46-47). Its camera sub-paths merge with radius r / sqrt(k):
 * eta_VCM, the merges' count against one connection, falls by k as light tracing's does,
 * so that merging and light tracing keep the shares they have in a pixel of one camera
 * sub-path while the camera's own techniques gain the k-fold count they sample. With the
 * radius kept, merging's share against light tracing would grow k-fold, and with it the
 * kernel's bias where the two carry the same light (a caustic through rough glass); with
 * r / sqrt(k) each merge's bias falls by k and the k merges' variance is one merge's of
 * radius r. Not in a scene with participating media: a light vertex after a medium vertex
 * carries the iteration's radius (the merge in a medium weighs against a surface one by
 * 4r / 3), so merging there keeps one radius for every pixel.
 *
 * A pixel whose allocation turns merging off (VF_ALLOCATION_NO_MERGING) gets bpt's
 * weights: eta_VCM = 0, and its camera sub-paths do not merge. */
static inline void vf_merge_params_at(const vf_vcm *v, uint32_t pixel, merge_params *out) {
  *out = v->merge;
  uint32_t k = vf_pixel_samples(v, pixel);
  if (v->allocated) {
    out->mis.light_paths = v->merge.mis.light_paths / (float)k;
    if (!vf_allocation_merges(v->samples[pixel])) {
      /* bpt's weights in this pixel: no technique merges here (sec. 5.5: eta_VCM = 0). */
      out->merges = 0;
      out->mis.vm_weight = 0.0f;
      out->mis.vc_weight = 0.0f;
      return;
    }
  }
  if (!vf_vcm_radii_vary(v)) return;
  double r = v->radius_exact * (v->pixel_scale != NULL ? (double)v->pixel_scale[pixel] : 1.0);
  vf_merge_params_radius(v, vf_vcm_allocation_shrinks_radius(v) ? r / sqrt((double)k) : r, out);
}

#endif
