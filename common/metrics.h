/* Error of an image against a reference, as the paper's evaluation measures it (sec. 7):
 * root-mean-square error, relative mean-square error and mean absolute error, per RGB
 * channel and over all three, over the whole image or a window of it.
 *
 *   rmse    = sqrt(mean((I - R)^2))
 *   rel_mse = mean((I - R)^2 / (R^2 + 0.01))   (0.01 keeps black pixels from dominating)
 *   mae     = mean(|I - R|)
 *
 * Non-finite pixels in either image are skipped and counted: a reference may hold NaN or
 * Inf (OpenEXR's own test images do), and an error figure must never become NaN. */
#ifndef VF_METRICS_H
#define VF_METRICS_H

#include <stdint.h>

typedef struct {
  double rmse[3], rel_mse[3], mae[3];    /* per channel */
  double rmse_all, rel_mse_all, mae_all; /* over all channels */
  double mean_image, mean_reference;     /* over all channels, of the pixels used */
  uint64_t pixels;                       /* pixels compared */
  uint64_t skipped;                      /* pixels left out: non-finite in either image */
} vf_error_metrics;

/* A rectangle of pixels: x, y from the top left, width, height. */
typedef struct {
  int x, y, width, height;
} vf_window;

/* Compares two RGB images of width x height (3 floats per pixel, top row first) over
 * window (NULL: everything). VF_EINVAL with a detail if the window is empty or outside the
 * image. *out is written only on success. */
int vf_metrics_compute(const float *image, const float *reference, int width, int height, const vf_window *window,
                       vf_error_metrics *out);

#endif
