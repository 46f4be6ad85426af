#include "plot.h"

#include "options.h"
#include "../common/error.h"
#include "cairo_api.h"
#include "../common/exr_util.h"
#include "../common/settings.h"

#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MARGIN_LEFT 80.0
#define MARGIN_RIGHT 24.0
#define MARGIN_TOP 40.0
#define MARGIN_BOTTOM 56.0

static const unsigned char palette[VF_PLOT_COLORS][3] = {
    {31, 119, 180}, {214, 39, 40}, {44, 160, 44}, {255, 127, 14},
    {148, 103, 189}, {140, 86, 75}, {227, 119, 194}, {23, 190, 207},
};

void vf_plot_color(int i, unsigned char rgb[3]) { memcpy(rgb, palette[(unsigned)i % VF_PLOT_COLORS], 3); }

typedef struct {
  double time, iterations, error;
  uint32_t run;
} point;

typedef struct {
  point *points; /* owned */
  size_t count;
  int uses_reference; /* error is RMSE against a reference (else the estimate) */
  char label[160];
} curve;

/* Points of one film: its log, with the reference RMSE when any entry has one. */
static int film_curve(const vf_film *film, curve *c) {
  const vf_convergence_log *log = &film->convergence;
  c->uses_reference = 0;
  for (size_t i = 0; i < log->count; i++)
    if (isfinite(log->entries[i].rmse) && log->entries[i].rmse > 0) c->uses_reference = 1;
  c->points = malloc((log->count + 1) * sizeof *c->points);
  if (c->points == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  c->count = 0;
  for (size_t i = 0; i < log->count; i++) {
    const vf_convergence_entry *e = &log->entries[i];
    point p = {e->wall_seconds, (double)e->iterations, c->uses_reference ? e->rmse : e->estimated_rmse, e->run};
    c->points[c->count++] = p;
  }
  if (log->count == 0) {
    point p = {film->render_seconds, (double)vf_iterset_count(&film->iterations), vf_film_estimate_rmse(film), 0};
    c->points[c->count++] = p;
  }
  return VF_OK;
}

static int drawable(double v) { return isfinite(v) && v > 0; }

typedef struct {
  double x0, y0, w, h;        /* plot area in pixels */
  double lx0, lx1, ly0, ly1;  /* log10 range of the axes, whole decades */
} frame;

static double px(const frame *f, double v) { return f->x0 + (log10(v) - f->lx0) / (f->lx1 - f->lx0) * f->w; }
static double py(const frame *f, double v) { return f->y0 + f->h - (log10(v) - f->ly0) / (f->ly1 - f->ly0) * f->h; }

static void decade_label(int k, char *buf, size_t n) {
  if (k >= -3 && k <= 4) snprintf(buf, n, "%g", pow(10.0, k));
  else snprintf(buf, n, "1e%d", k);
}

static void text_at(cairo_t *cr, double x, double y, const char *s, double align_x, double align_y) {
  const vf_cairo_api *cairo = vf_cairo();
  cairo_text_extents_t ext;
  cairo->cairo_text_extents(cr, s, &ext);
  cairo->cairo_move_to(cr, x - ext.width * align_x - ext.x_bearing, y - ext.height * align_y - ext.y_bearing);
  cairo->cairo_show_text(cr, s);
}

static void draw_axes(cairo_t *cr, const frame *f, const char *title, const char *xlabel, const char *ylabel) {
  const vf_cairo_api *cairo = vf_cairo();
  cairo->cairo_set_line_width(cr, 1.0);
  for (int axis = 0; axis < 2; axis++) {
    double lo = axis ? f->ly0 : f->lx0, hi = axis ? f->ly1 : f->lx1;
    for (int k = (int)lo; k <= (int)hi; k++)
      for (int m = 1; m <= 9 && (m == 1 || k < (int)hi); m++) {
        double v = m * pow(10.0, k);
        double pos = axis ? py(f, v) : px(f, v), tick = m == 1 ? 6.0 : 3.0;
        if (m == 1) { /* grid line at each decade */
          cairo->cairo_set_source_rgb(cr, 0.88, 0.88, 0.88);
          if (axis) cairo->cairo_move_to(cr, f->x0, pos), cairo->cairo_line_to(cr, f->x0 + f->w, pos);
          else cairo->cairo_move_to(cr, pos, f->y0), cairo->cairo_line_to(cr, pos, f->y0 + f->h);
          cairo->cairo_stroke(cr);
        }
        cairo->cairo_set_source_rgb(cr, 0, 0, 0);
        if (axis) cairo->cairo_move_to(cr, f->x0, pos), cairo->cairo_line_to(cr, f->x0 + tick, pos);
        else cairo->cairo_move_to(cr, pos, f->y0 + f->h), cairo->cairo_line_to(cr, pos, f->y0 + f->h - tick);
        cairo->cairo_stroke(cr);
        if (m == 1) {
          char label[32];
          decade_label(k, label, sizeof label);
          if (axis) text_at(cr, f->x0 - 6, pos, label, 1.0, 0.5);
          else text_at(cr, pos, f->y0 + f->h + 6, label, 0.5, 0.0);
        }
      }
  }
  cairo->cairo_set_source_rgb(cr, 0, 0, 0);
  cairo->cairo_rectangle(cr, f->x0, f->y0, f->w, f->h);
  cairo->cairo_stroke(cr);
  text_at(cr, f->x0 + f->w / 2, f->y0 + f->h + 36, xlabel, 0.5, 0.0);
  text_at(cr, f->x0 + f->w / 2, f->y0 - 14, title, 0.5, 1.0);
  cairo->cairo_save(cr);
  cairo->cairo_translate(cr, f->x0 - 58, f->y0 + f->h / 2);
  cairo->cairo_rotate(cr, -M_PI / 2);
  text_at(cr, 0, 0, ylabel, 0.5, 0.5);
  cairo->cairo_restore(cr);
}

static void draw_curve(cairo_t *cr, const frame *f, const curve *c, int index, int by_iterations, int dashed) {
  const vf_cairo_api *cairo = vf_cairo();
  unsigned char rgb[3];
  vf_plot_color(index, rgb);
  cairo->cairo_set_source_rgb(cr, rgb[0] / 255.0, rgb[1] / 255.0, rgb[2] / 255.0);
  cairo->cairo_set_line_width(cr, 2.0);
  static const double dash[] = {6.0, 4.0};
  cairo->cairo_set_dash(cr, dash, dashed ? 2 : 0, 0);
  int pen_down = 0;
  uint32_t run = 0;
  for (size_t i = 0; i < c->count; i++) {
    const point *p = &c->points[i];
    double xv = by_iterations ? p->iterations : p->time;
    if (!drawable(xv) || !drawable(p->error)) {
      pen_down = 0;
      continue;
    }
    double x = px(f, xv), y = py(f, p->error);
    if (pen_down && p->run == run) cairo->cairo_line_to(cr, x, y);
    else cairo->cairo_move_to(cr, x, y);
    pen_down = 1;
    run = p->run;
  }
  cairo->cairo_stroke(cr);
  cairo->cairo_set_dash(cr, NULL, 0, 0);
  for (size_t i = 0; i < c->count; i++) { /* markers, so that single points show */
    const point *p = &c->points[i];
    double xv = by_iterations ? p->iterations : p->time;
    if (!drawable(xv) || !drawable(p->error)) continue;
    cairo->cairo_arc(cr, px(f, xv), py(f, p->error), 2.5, 0, 2 * M_PI);
    cairo->cairo_fill(cr);
  }
}

static void draw_legend(cairo_t *cr, const frame *f, const curve *curves, int n) {
  const vf_cairo_api *cairo = vf_cairo();
  double width = 0, line = 16;
  for (int i = 0; i < n; i++) {
    cairo_text_extents_t ext;
    cairo->cairo_text_extents(cr, curves[i].label, &ext);
    width = fmax(width, ext.x_advance);
  }
  double bx = f->x0 + f->w - width - 48, by = f->y0 + 8;
  cairo->cairo_set_source_rgb(cr, 1, 1, 1);
  cairo->cairo_rectangle(cr, bx, by, width + 40, n * line + 8);
  cairo->cairo_fill_preserve(cr);
  cairo->cairo_set_source_rgb(cr, 0.6, 0.6, 0.6);
  cairo->cairo_set_line_width(cr, 1.0);
  cairo->cairo_stroke(cr);
  for (int i = 0; i < n; i++) {
    unsigned char rgb[3];
    vf_plot_color(i, rgb);
    cairo->cairo_set_source_rgb(cr, rgb[0] / 255.0, rgb[1] / 255.0, rgb[2] / 255.0);
    cairo->cairo_rectangle(cr, bx + 6, by + 6 + i * line + 4, 22, 6); /* whole pixels: exact colour */
    cairo->cairo_fill(cr);
    cairo->cairo_set_source_rgb(cr, 0, 0, 0);
    text_at(cr, bx + 34, by + 4 + i * line + line / 2, curves[i].label, 0.0, 0.5);
  }
}

/* Whole decades around [lo, hi], at least one. */
static void decades(double lo, double hi, double *l0, double *l1) {
  *l0 = floor(log10(lo));
  *l1 = ceil(log10(hi));
  if (*l1 <= *l0) *l1 = *l0 + 1;
}

typedef struct {
  vf_atomic_file file;
  uint64_t offset;
  int err;
} png_sink;

static cairo_status_t write_png_bytes(void *closure, const unsigned char *data, unsigned int length) {
  png_sink *sink = closure;
  if ((sink->err = vf_atomic_pwrite(&sink->file, data, length, sink->offset)) != VF_OK) return CAIRO_STATUS_WRITE_ERROR;
  sink->offset += length;
  return CAIRO_STATUS_SUCCESS;
}

static void make_labels(const vf_film *const *films, const char *const *names, int n, curve *curves) {
  for (int i = 0; i < n; i++) {
    vf_settings s;
    const char *algo = vf_settings_parse(&s, films[i]->settings_text) == VF_OK ? vf_algorithm_name(s.algorithm) : "?";
    int shared = 0;
    for (int j = 0; j < n; j++) {
      vf_settings t;
      if (j != i && vf_settings_parse(&t, films[j]->settings_text) == VF_OK && strcmp(vf_algorithm_name(t.algorithm), algo) == 0)
        shared = 1;
    }
    const char *base = names && names[i] ? strrchr(names[i], '/') : NULL;
    base = base ? base + 1 : (names ? names[i] : NULL);
    if (shared && base) snprintf(curves[i].label, sizeof curves[i].label, "%s (%.120s)", algo, base);
    else snprintf(curves[i].label, sizeof curves[i].label, "%s", algo);
  }
}

int vf_plot_write(const char *path, const vf_film *const *films, const char *const *names, int n, vf_plot_x x) {
  if (path == NULL || films == NULL || n < 1) return vf_error_set(VF_EINVAL, "vf_plot_write: nothing to plot");
  const vf_cairo_api *cairo = vf_cairo_load(path);
  if (cairo == NULL) return VF_EMODULE;
  int err = VF_OK, panels = x == VF_PLOT_BOTH ? 2 : 1, any_reference = 0, any_estimate = 0;
  curve *curves = calloc((size_t)n, sizeof *curves);
  cairo_surface_t *surface = NULL;
  cairo_t *cr = NULL;
  png_sink sink = {{0}, 0, VF_OK};
  if (curves == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  for (int i = 0; i < n && err == VF_OK; i++) err = film_curve(films[i], &curves[i]);
  if (err != VF_OK) goto cleanup;
  make_labels(films, names, n, curves);

  /* Axis ranges over every drawable point. */
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {0, 0, 0}; /* time, iterations, error */
  for (int i = 0; i < n; i++)
    for (size_t k = 0; k < curves[i].count; k++) {
      const point *p = &curves[i].points[k];
      double v[3] = {p->time, p->iterations, p->error};
      if (!drawable(p->error)) continue;
      for (int a = 0; a < 3; a++)
        if (drawable(v[a])) lo[a] = fmin(lo[a], v[a]), hi[a] = fmax(hi[a], v[a]);
      if (curves[i].uses_reference) any_reference = 1;
      else any_estimate = 1;
    }
  int need_time = x != VF_PLOT_ITERATIONS, need_iterations = x != VF_PLOT_TIME;
  if (!isfinite(lo[2]) || (need_time && !isfinite(lo[0])) || (need_iterations && !isfinite(lo[1]))) {
    err = vf_error_set(VF_EINVAL, "nothing to plot: no film has an error value (a log entry or at least 2 iterations)");
    goto cleanup;
  }
  const char *ylabel = any_reference && any_estimate ? "RMSE vs reference (solid), estimated RMSE (dashed)"
                       : any_reference             ? "RMSE vs reference"
                                                   : "estimated RMSE (no reference)";

  surface = cairo->cairo_image_surface_create(CAIRO_FORMAT_RGB24, VF_PLOT_PANEL_WIDTH * panels, VF_PLOT_HEIGHT);
  cr = cairo->cairo_create(surface);
  if (cairo->cairo_status(cr) != CAIRO_STATUS_SUCCESS) {
    err = vf_error_set(VF_ENOMEM, "cairo: %s", cairo->cairo_status_to_string(cairo->cairo_status(cr)));
    goto cleanup;
  }
  cairo->cairo_set_source_rgb(cr, 1, 1, 1);
  cairo->cairo_paint(cr);
  cairo->cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo->cairo_set_font_size(cr, 12.0);
  frame last = {0};
  for (int panel = 0; panel < panels; panel++) {
    int by_iterations = x == VF_PLOT_ITERATIONS || (x == VF_PLOT_BOTH && panel == 1);
    frame f = {panel * VF_PLOT_PANEL_WIDTH + MARGIN_LEFT, MARGIN_TOP, VF_PLOT_PANEL_WIDTH - MARGIN_LEFT - MARGIN_RIGHT,
               VF_PLOT_HEIGHT - MARGIN_TOP - MARGIN_BOTTOM, 0, 1, 0, 1};
    decades(lo[by_iterations], hi[by_iterations], &f.lx0, &f.lx1);
    decades(lo[2], hi[2], &f.ly0, &f.ly1);
    draw_axes(cr, &f, by_iterations ? "error against iterations" : "error against render time",
              by_iterations ? "iterations" : "wall-clock render time [s]", ylabel);
    cairo->cairo_save(cr);
    cairo->cairo_rectangle(cr, f.x0, f.y0, f.w, f.h);
    cairo->cairo_clip(cr);
    for (int i = 0; i < n; i++)
      draw_curve(cr, &f, &curves[i], i, by_iterations, any_reference && !curves[i].uses_reference);
    cairo->cairo_restore(cr);
    last = f;
  }
  draw_legend(cr, &last, curves, n);
  cairo->cairo_surface_flush(surface);

  if ((err = vf_atomic_open(&sink.file, path)) != VF_OK) goto cleanup;
  cairo_status_t st = cairo->cairo_surface_write_to_png_stream(surface, write_png_bytes, &sink);
  if (st != CAIRO_STATUS_SUCCESS) {
    err = sink.err != VF_OK ? sink.err : vf_error_set(VF_EIO, "%s: cairo: %s", path, cairo->cairo_status_to_string(st));
    vf_atomic_abort(&sink.file);
    goto cleanup;
  }
  err = vf_atomic_commit(&sink.file);
cleanup:
  if (cr) cairo->cairo_destroy(cr);
  if (surface) cairo->cairo_surface_destroy(surface);
  for (int i = 0; i < n; i++) free(curves[i].points);
  free(curves);
  return err;
}

static const char usage[] =
    "usage: vcmfarm plot FILM... -o PLOT.png [--x time|iterations|both] [-q]\n"
    "\n"
    "Plots each film's error against wall-clock render time and against iterations,\n"
    "log-log, one labelled curve per film (its algorithm; plus its file name when two films\n"
    "share one). The error is the RMSE against the reference where the film's convergence\n"
    "log has it (render/continue --reference), else the estimate without a reference.\n"
    "\n"
    "  -o, --output PLOT.png  the PNG to write (atomically)\n"
    "  -x, --x AXIS           time, iterations, or both (default: two panels)\n"
    "  -q, --quiet            no line saying what was written\n"
    "  -h, --help             this text\n"
    "\n"
    "Exit status: 0 done, 1 failure while writing, 2 bad input (nothing is written).\n";

int vf_cmd_plot(int argc, char **argv) {
  static const struct option options[] = {
      {"output", required_argument, 0, 'o'}, {"x", required_argument, 0, 'x'}, {"quiet", no_argument, 0, 'q'},
      {"help", no_argument, 0, 'h'},         {0, 0, 0, 0}};
  const char *output = NULL;
  vf_plot_x axis = VF_PLOT_BOTH;
  int quiet = 0, c;
  optind = 0; /* 0: getopt starts again from scratch (glibc), forgetting the last argv */
  while ((c = vf_cli_getopt(argc, argv, "o:x:qh", options)) != -1) {
    switch (c) {
    case 'o': output = optarg; break;
    case 'q': quiet = 1; break;
    case 'x':
      if (strcmp(optarg, "time") == 0) axis = VF_PLOT_TIME;
      else if (strcmp(optarg, "iterations") == 0) axis = VF_PLOT_ITERATIONS;
      else if (strcmp(optarg, "both") == 0) axis = VF_PLOT_BOTH;
      else return vf_cli_fail("plot", vf_error_set(VF_EUSAGE, "--x: '%s' is not time, iterations or both", optarg));
      break;
    case 'h': fputs(usage, stdout); return VF_EXIT_OK;
    default:
      return vf_cli_bad_option("plot");
    }
  }
  if (optind >= argc) return vf_cli_usage_error("plot", "expected at least one FILM");
  if (output == NULL) return vf_cli_usage_error("plot", "missing -o PLOT.png");
  int n = argc - optind, err = vf_cli_extension("-o", output, ".png", "a PNG image");
  if (err != VF_OK) return vf_cli_fail("plot", err);
  vf_film **films = calloc((size_t)n, sizeof *films);
  if (films == NULL) return vf_cli_fail("plot", VF_ENOMEM);
  for (int i = 0; i < n && err == VF_OK; i++) err = vf_film_read(argv[optind + i], &films[i]);
  if (err == VF_OK)
    err = vf_plot_write(output, (const vf_film *const *)films, (const char *const *)(argv + optind), n, axis);
  if (err == VF_OK && !quiet)
    fprintf(stderr, "wrote %s: error against %s of %d %s\n", output,
            axis == VF_PLOT_TIME ? "time" : axis == VF_PLOT_ITERATIONS ? "iterations" : "time and iterations", n,
            vf_cli_plural((unsigned long long)n, "film", "films"));
  for (int i = 0; i < n; i++) vf_film_destroy(films[i]);
  free(films);
  return err == VF_OK ? VF_EXIT_OK : vf_cli_fail("plot", err);
}
