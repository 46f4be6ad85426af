/* `vcmfarm plot`: error against time and iterations, log-log, one curve per film, drawn
 * with cairo from the films' convergence logs (common/convergence.h).
 *
 * The error of a film is its RMSE against the reference where its log holds one, else the
 * no-reference estimate; the y-axis label says which (dashed curves are estimates when
 * both kinds are on one plot). A film with an empty log is drawn as one point: its current
 * estimate. Each run of a log is its own stroke. */
#ifndef VF_PLOT_H
#define VF_PLOT_H

#include "../common/film.h"

typedef enum {
  VF_PLOT_BOTH,       /* two panels: against wall time and against iterations */
  VF_PLOT_TIME,       /* one panel: against wall time */
  VF_PLOT_ITERATIONS, /* one panel: against iterations */
} vf_plot_x;

#define VF_PLOT_PANEL_WIDTH 640
#define VF_PLOT_HEIGHT 480
#define VF_PLOT_COLORS 8

/* The colour of curve i (cycling through VF_PLOT_COLORS), 8-bit sRGB values, exactly as the
 * PNG stores them in the curve's legend swatch. */
void vf_plot_color(int i, unsigned char rgb[3]);

/* Draws films[0..n) (borrowed), labelled by the algorithm of each film's settings and, when
 * two films share an algorithm, by names[i] too (a file name; may be NULL), and writes an
 * RGB PNG of VF_PLOT_PANEL_WIDTH per panel x VF_PLOT_HEIGHT to path, atomically.
 * VF_EINVAL with a detail when no film has a point to draw, VF_EIO on write failure. */
int vf_plot_write(const char *path, const vf_film *const *films, const char *const *names, int n, vf_plot_x x);

/* vcmfarm plot FILM... -o PLOT.png: vf_plot_write, then one line on stderr saying what it
 * wrote, unless -q. */
int vf_cmd_plot(int argc, char **argv);

#endif
