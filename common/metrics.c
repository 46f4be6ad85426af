#include "metrics.h"

#include "error.h"

#include <math.h>
#include <stddef.h>

int vf_metrics_compute(const float *image, const float *reference, int width, int height, const vf_window *window,
                       vf_error_metrics *out) {
  vf_window w = window ? *window : (vf_window){0, 0, width, height};
  if (w.width <= 0 || w.height <= 0 || w.x < 0 || w.y < 0 || w.x > width - w.width || w.y > height - w.height)
    return vf_error_set(VF_EINVAL, "window %d,%d,%d,%d is empty or outside the %dx%d image", w.x, w.y, w.width,
                        w.height, width, height);
  double se[3] = {0}, rel[3] = {0}, abs_err[3] = {0}, sum_i = 0.0, sum_r = 0.0;
  uint64_t used = 0, skipped = 0;
  for (int y = w.y; y < w.y + w.height; y++)
    for (int x = w.x; x < w.x + w.width; x++) {
      size_t p = 3 * ((size_t)y * width + x);
      const float *a = &image[p], *r = &reference[p];
      if (!(isfinite(a[0]) && isfinite(a[1]) && isfinite(a[2]) && isfinite(r[0]) && isfinite(r[1]) && isfinite(r[2]))) {
        skipped++;
        continue;
      }
      for (int c = 0; c < 3; c++) {
        double d = (double)a[c] - (double)r[c];
        se[c] += d * d;
        rel[c] += d * d / ((double)r[c] * r[c] + 0.01);
        abs_err[c] += fabs(d);
        sum_i += a[c];
        sum_r += r[c];
      }
      used++;
    }
  vf_error_metrics m = {{0}, {0}, {0}, 0, 0, 0, 0, 0, used, skipped};
  if (used > 0) {
    double n = (double)used;
    for (int c = 0; c < 3; c++) {
      m.rmse[c] = sqrt(se[c] / n);
      m.rel_mse[c] = rel[c] / n;
      m.mae[c] = abs_err[c] / n;
    }
    m.rmse_all = sqrt((se[0] + se[1] + se[2]) / (3.0 * n));
    m.rel_mse_all = (rel[0] + rel[1] + rel[2]) / (3.0 * n);
    m.mae_all = (abs_err[0] + abs_err[1] + abs_err[2]) / (3.0 * n);
    m.mean_image = sum_i / (3.0 * n);
    m.mean_reference = sum_r / (3.0 * n);
  }
  *out = m;
  return VF_OK;
}
