/* Comparing images: the subcommands errors and diff (docs/TOOLS.md).
 *
 * Both take two inputs, each a film (its mean is compared) or any RGB EXR that
 * vf_image_read_exr accepts (vf_reference_read in film_tools.h), and refuse inputs of
 * different sizes, naming both sizes. The calling convention, exit statuses and the
 * nothing-written-on-bad-input rule are those of film_tools.h. */
#ifndef VF_COMPARE_CMD_H
#define VF_COMPARE_CMD_H

/* vcmfarm errors IMAGE REF [--window x,y,w,h] [--json]: RMSE, relative MSE and mean
 * absolute error of IMAGE against REF per channel and overall (metrics.h), with the
 * pixels compared and skipped (non-finite), on stdout as text or as one JSON object. */
int vf_cmd_errors(int argc, char **argv);

/* vcmfarm diff A B -o DIFF.png [--scale S] [-q]: a false-colour PNG of the per-pixel relative
 * difference of luminance, (Y_A - Y_B) / (|Y_B| + 0.01), blue negative, white zero, red
 * positive, clamped at +-S (default: the 99th percentile of |difference|); pixels where
 * either input is non-finite are black. The PNG is the image (W x H) above a legend
 * naming the quantity and the range: it is max(W, VF_DIFF_MIN_WIDTH) wide and
 * H + VF_DIFF_LEGEND_HEIGHT high, the image centred horizontally. */
int vf_cmd_diff(int argc, char **argv);

#define VF_DIFF_MIN_WIDTH 480
#define VF_DIFF_LEGEND_HEIGHT 76

#endif
