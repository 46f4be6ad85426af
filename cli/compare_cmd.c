/* errors and diff: an image against a reference, as figures and as a picture.
 *
 * diff renders the false-colour image into a cairo surface pixel by pixel, draws the
 * legend with cairo's toy text API, and streams the PNG through the same atomic-file
 * writer as every other output (exr_util.h), so a failed or killed diff leaves no partial
 * file. The colour map is a diverging blue-white-red one (ColorBrewer RdBu, white at
 * zero), interpolated in sRGB like its published stops. */
#include "compare_cmd.h"

#include "options.h"
#include "../common/error.h"
#include "cairo_api.h"
#include "../common/exr_util.h"
#include "film_cmd.h"
#include "../common/image.h"
#include "../common/metrics.h"

#include <cjson/cJSON.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* Reads both inputs, which must have the same size; a and b are written only on success. */
static int read_pair(const char *path_a, const char *path_b, vf_image *a, vf_image *b, int *a_film, int *b_film) {
  vf_image ia = {0}, ib = {0};
  int err = vf_reference_read(path_a, &ia, a_film);
  if (err != VF_OK) return err;
  if ((err = vf_reference_read(path_b, &ib, b_film)) != VF_OK) goto fail;
  if (ia.width != ib.width || ia.height != ib.height) {
    err = vf_error_set(VF_EMISMATCH, "sizes differ: %s is %dx%d, %s is %dx%d", path_a, ia.width, ia.height, path_b,
                       ib.width, ib.height);
    goto fail;
  }
  *a = ia;
  *b = ib;
  return VF_OK;
fail:
  vf_image_destroy(&ib);
  vf_image_destroy(&ia);
  return err;
}

/* ---- errors ---- */

static const char errors_usage[] =
    "usage: vcmfarm errors IMAGE REF [--window x,y,w,h] [--json]\n"
    "\n"
    "Error of IMAGE against the reference REF, per channel (R, G, B) and over all three:\n"
    "  rmse    = sqrt(mean((I - R)^2))\n"
    "  rel_mse = mean((I - R)^2 / (R^2 + 0.01))\n"
    "  mae     = mean(|I - R|)\n"
    "Each input is a film (its mean is used) or any RGB EXR; sizes must match. Pixels that\n"
    "are NaN or Inf in either input are skipped and counted.\n"
    "\n"
    "  -w, --window x,y,w,h  compare only this rectangle (x, y from the top left)\n"
    "  -j, --json            print one JSON object instead of a table\n"
    "  -h, --help            this text\n"
    "\n"
    "Exit status: 0 done, 1 failure, 2 bad input.\n";

/* "x,y,w,h": four whole numbers separated by commas, nothing else. */
static int parse_window(const char *text, vf_window *out) {
  long v[4];
  const char *p = text;
  for (int i = 0; i < 4; i++) {
    char *end;
    if (!((*p >= '0' && *p <= '9') || *p == '-')) goto bad;
    v[i] = strtol(p, &end, 10);
    if (end == p || v[i] < -65536 || v[i] > 65536 || *end != (i < 3 ? ',' : '\0')) goto bad;
    p = end + (i < 3);
  }
  *out = (vf_window){(int)v[0], (int)v[1], (int)v[2], (int)v[3]};
  return VF_OK;
bad:
  return vf_error_set(VF_EUSAGE, "--window: '%s' is not x,y,width,height", text);
}

static cJSON *channel_object(const double *per_channel, double all) {
  cJSON *o = cJSON_CreateObject();
  if (o == NULL) return NULL;
  static const char *const names[3] = {"R", "G", "B"};
  for (int c = 0; c < 3; c++) cJSON_AddNumberToObject(o, names[c], per_channel[c]);
  cJSON_AddNumberToObject(o, "all", all);
  return o;
}

static int print_json(const char *image, int image_film, const char *ref, int ref_film, int width, int height,
                      const vf_window *w, const vf_error_metrics *m) {
  cJSON *root = cJSON_CreateObject(), *win = cJSON_CreateObject();
  cJSON *rmse = channel_object(m->rmse, m->rmse_all), *rel = channel_object(m->rel_mse, m->rel_mse_all),
        *mae = channel_object(m->mae, m->mae_all);
  char *text = NULL;
  if (root == NULL || win == NULL || rmse == NULL || rel == NULL || mae == NULL) goto fail;
  cJSON_AddStringToObject(root, "image", image);
  cJSON_AddStringToObject(root, "image_kind", image_film ? "film" : "image");
  cJSON_AddStringToObject(root, "reference", ref);
  cJSON_AddStringToObject(root, "reference_kind", ref_film ? "film" : "image");
  cJSON_AddNumberToObject(root, "width", width);
  cJSON_AddNumberToObject(root, "height", height);
  cJSON_AddNumberToObject(win, "x", w->x);
  cJSON_AddNumberToObject(win, "y", w->y);
  cJSON_AddNumberToObject(win, "width", w->width);
  cJSON_AddNumberToObject(win, "height", w->height);
  cJSON_AddItemToObject(root, "window", win);
  win = NULL;
  cJSON_AddNumberToObject(root, "pixels", (double)m->pixels);
  cJSON_AddNumberToObject(root, "skipped", (double)m->skipped);
  cJSON_AddNumberToObject(root, "mean_image", m->mean_image);
  cJSON_AddNumberToObject(root, "mean_reference", m->mean_reference);
  cJSON_AddItemToObject(root, "rmse", rmse);
  cJSON_AddItemToObject(root, "rel_mse", rel);
  cJSON_AddItemToObject(root, "mae", mae);
  rmse = rel = mae = NULL;
  if ((text = cJSON_PrintUnformatted(root)) == NULL) goto fail;
  printf("%s\n", text);
  cJSON_free(text);
  cJSON_Delete(root);
  return VF_OK;
fail:
  cJSON_Delete(mae);
  cJSON_Delete(rel);
  cJSON_Delete(rmse);
  cJSON_Delete(win);
  cJSON_Delete(root);
  return vf_error_set(VF_ENOMEM, "out of memory for the JSON output");
}

static void print_table(const char *image, int image_film, const char *ref, int ref_film, int width, int height,
                        const vf_window *w, const vf_error_metrics *m) {
  printf("image      %s (%s, %dx%d)\n", image, image_film ? "film" : "image", width, height);
  printf("reference  %s (%s, %dx%d)\n", ref, ref_film ? "film" : "image", width, height);
  printf("window     %d,%d,%d,%d: %llu %s compared, %llu skipped (non-finite)\n", w->x, w->y, w->width, w->height,
         (unsigned long long)m->pixels, vf_cli_plural(m->pixels, "pixel", "pixels"), (unsigned long long)m->skipped);
  printf("mean       image %.9g, reference %.9g\n", m->mean_image, m->mean_reference);
  printf("%-10s %15s %15s %15s %15s\n", "", "R", "G", "B", "all");
  printf("%-10s %15.9g %15.9g %15.9g %15.9g\n", "rmse", m->rmse[0], m->rmse[1], m->rmse[2], m->rmse_all);
  printf("%-10s %15.9g %15.9g %15.9g %15.9g\n", "rel_mse", m->rel_mse[0], m->rel_mse[1], m->rel_mse[2],
         m->rel_mse_all);
  printf("%-10s %15.9g %15.9g %15.9g %15.9g\n", "mae", m->mae[0], m->mae[1], m->mae[2], m->mae_all);
}

int vf_cmd_errors(int argc, char **argv) {
  static const struct option options[] = {{"window", required_argument, 0, 'w'},
                                          {"json", no_argument, 0, 'j'},
                                          {"help", no_argument, 0, 'h'},
                                          {0, 0, 0, 0}};
  vf_window window = {0, 0, 0, 0};
  int have_window = 0, json = 0, err = VF_OK, c;
  vf_error_clear();
  optind = 0;
  while ((c = vf_cli_getopt(argc, argv, "w:jh", options)) != -1) {
    switch (c) {
    case 'w':
      err = parse_window(optarg, &window);
      have_window = 1;
      break;
    case 'j': json = 1; break;
    case 'h': fputs(errors_usage, stdout); return VF_EXIT_OK;
    default:
      return vf_cli_bad_option("errors");
    }
    if (err != VF_OK) return vf_cli_fail("errors", err);
  }
  if (optind != argc - 2) return vf_cli_usage_error("errors", "expected IMAGE and REF");
  const char *image_path = argv[optind], *ref_path = argv[optind + 1];
  vf_image image = {0}, ref = {0};
  int image_film = 0, ref_film = 0;
  vf_error_metrics m;
  if ((err = read_pair(image_path, ref_path, &image, &ref, &image_film, &ref_film)) != VF_OK) goto done;
  if (!have_window) window = (vf_window){0, 0, image.width, image.height};
  if ((err = vf_metrics_compute(image.rgb, ref.rgb, image.width, image.height, &window, &m)) != VF_OK) goto done;
  if (json)
    err = print_json(image_path, image_film, ref_path, ref_film, image.width, image.height, &window, &m);
  else
    print_table(image_path, image_film, ref_path, ref_film, image.width, image.height, &window, &m);
  if (fflush(stdout) != 0) err = vf_error_set(VF_EIO, "cannot write the results to standard output");
done:
  vf_image_destroy(&ref);
  vf_image_destroy(&image);
  return err == VF_OK ? VF_EXIT_OK : vf_cli_fail("errors", err);
}

/* ---- diff ---- */

static const char diff_usage[] =
    "usage: vcmfarm diff A B -o DIFF.png [--scale S] [-q]\n"
    "\n"
    "Writes a false-colour image of the relative difference of luminance per pixel,\n"
    "(Y_A - Y_B) / (|Y_B| + 0.01): blue where A is darker, white where equal, red where\n"
    "brighter, clamped at +-S; black where either input is NaN or Inf. A legend below\n"
    "the image names the quantity and the range. A and B are films or RGB EXRs of the\n"
    "same size.\n"
    "\n"
    "  -o, --output DIFF.png  the image to write (required, .png)\n"
    "  -s, --scale S          clamp at +-S (default: the 99th percentile of |difference|)\n"
    "  -q, --quiet            no line saying what was written\n"
    "  -h, --help             this text\n"
    "\n"
    "Exit status: 0 done, 1 failure while writing, 2 bad input (nothing is written).\n";

#define CAIRO_MAX_SIDE 32767

static double luminance(const float *rgb) { return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]; }

/* Diverging map, t in [-1, 1]: ColorBrewer RdBu stops with pure white at 0. */
static uint32_t diverging(double t) {
  static const double stops[5][3] = {{5, 48, 97}, {67, 147, 195}, {255, 255, 255}, {214, 96, 77}, {103, 0, 31}};
  double u = (fmin(fmax(t, -1.0), 1.0) + 1.0) * 2.0; /* [0, 4] */
  int i = u >= 4.0 ? 3 : (int)u;
  double f = u - i;
  uint32_t rgb = 0;
  for (int c = 0; c < 3; c++) rgb = rgb << 8 | (uint32_t)lround(stops[i][c] + f * (stops[i + 1][c] - stops[i][c]));
  return rgb;
}

static int compare_float(const void *a, const void *b) {
  float x = *(const float *)a, y = *(const float *)b;
  return (x > y) - (x < y);
}

/* Writes the relative difference per pixel into d (NAN where an input is non-finite) and
 * returns the 99th percentile of |d| over the finite pixels (0 if there are none). */
static int relative_difference(const vf_image *a, const vf_image *b, float *d, double *p99, uint64_t *nonfinite) {
  size_t n = (size_t)a->width * (size_t)a->height, used = 0;
  float *magnitudes = malloc(n * sizeof *magnitudes);
  if (magnitudes == NULL) return vf_error_set(VF_ENOMEM, "out of memory for a %dx%d difference", a->width, a->height);
  *nonfinite = 0;
  for (size_t p = 0; p < n; p++) {
    double ya = luminance(a->rgb + 3 * p), yb = luminance(b->rgb + 3 * p), v = (ya - yb) / (fabs(yb) + 0.01);
    if (!isfinite(v)) {
      d[p] = NAN;
      (*nonfinite)++;
      continue;
    }
    d[p] = (float)v;
    magnitudes[used++] = fabsf(d[p]);
  }
  *p99 = 0.0;
  if (used > 0) {
    qsort(magnitudes, used, sizeof *magnitudes, compare_float);
    size_t rank = (size_t)ceil(0.99 * (double)used); /* nearest-rank percentile */
    *p99 = magnitudes[rank > 0 ? rank - 1 : 0];
  }
  free(magnitudes);
  return VF_OK;
}

/* Sets the font size so that text fits in max_width (at most `size`) and shows it at x, y;
 * centre: x is the middle of the text. */
static void show_text(cairo_t *cr, const char *text, double x, double y, double size, double max_width, int centre) {
  const vf_cairo_api *cairo = vf_cairo();
  cairo_text_extents_t ext;
  cairo->cairo_set_font_size(cr, size);
  cairo->cairo_text_extents(cr, text, &ext);
  if (ext.x_advance > max_width && ext.x_advance > 0) {
    cairo->cairo_set_font_size(cr, size * max_width / ext.x_advance);
    cairo->cairo_text_extents(cr, text, &ext);
  }
  cairo->cairo_move_to(cr, centre ? x - ext.x_advance / 2 : x, y);
  cairo->cairo_show_text(cr, text);
}

static void draw_legend(cairo_t *cr, int canvas_width, int y0, double scale, const char *scale_source,
                        uint64_t nonfinite) {
  const vf_cairo_api *cairo = vf_cairo();
  const double margin = 12, bar_top = y0 + 20, bar_height = 14, width = canvas_width - 2 * margin;
  char text[256];
  cairo->cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo->cairo_set_source_rgb(cr, 0.95, 0.95, 0.95);
  show_text(cr, "relative difference of luminance (A - B) / (|B| + 0.01): blue A < B, red A > B", margin, y0 + 14,
            11, width, 0);

  cairo_pattern_t *bar = cairo->cairo_pattern_create_linear(margin, 0, margin + width, 0);
  for (int k = 0; k <= 20; k++) {
    uint32_t rgb = diverging(-1.0 + k / 10.0);
    cairo->cairo_pattern_add_color_stop_rgb(bar, k / 20.0, (rgb >> 16) / 255.0, (rgb >> 8 & 255) / 255.0,
                                     (rgb & 255) / 255.0);
  }
  cairo->cairo_rectangle(cr, margin, bar_top, width, bar_height);
  cairo->cairo_set_source(cr, bar);
  cairo->cairo_fill(cr);
  cairo->cairo_pattern_destroy(bar);

  cairo->cairo_set_source_rgb(cr, 0.95, 0.95, 0.95);
  cairo->cairo_set_line_width(cr, 1.0);
  for (int k = -2; k <= 2; k++) {
    double x = margin + width * (k + 2) / 4.0, value = scale * k / 2.0;
    x = k == -2 ? x + 0.5 : k == 2 ? x - 0.5 : x;
    cairo->cairo_move_to(cr, x, bar_top + bar_height);
    cairo->cairo_line_to(cr, x, bar_top + bar_height + 4);
    cairo->cairo_stroke(cr);
    if (k == 0) snprintf(text, sizeof text, "0");
    else snprintf(text, sizeof text, "%+.3g", value);
    double tx = k == -2 ? fmax(x, margin + 16) : k == 2 ? fmin(x, margin + width - 16) : x;
    show_text(cr, text, tx, bar_top + bar_height + 16, 10, width / 5, 1);
  }
  snprintf(text, sizeof text, "clamped at \xc2\xb1%.3g (%s); black: non-finite (%llu %s)", scale, scale_source,
           (unsigned long long)nonfinite, vf_cli_plural(nonfinite, "pixel", "pixels"));
  show_text(cr, text, margin, y0 + 70, 11, width, 0);
}

typedef struct {
  vf_atomic_file file;
  uint64_t offset;
} png_sink;

static cairo_status_t sink_write(void *closure, const unsigned char *data, unsigned int length) {
  png_sink *sink = closure;
  if (vf_atomic_pwrite(&sink->file, data, length, sink->offset) != VF_OK) return CAIRO_STATUS_WRITE_ERROR;
  sink->offset += length;
  return CAIRO_STATUS_SUCCESS;
}

static int write_diff_png(const char *path, const vf_image *a, const float *d, double scale,
                          const char *scale_source, uint64_t nonfinite) {
  const vf_cairo_api *cairo = vf_cairo_load(path);
  if (cairo == NULL) return VF_EMODULE;
  int width = a->width > VF_DIFF_MIN_WIDTH ? a->width : VF_DIFF_MIN_WIDTH, height = a->height + VF_DIFF_LEGEND_HEIGHT;
  if (width > CAIRO_MAX_SIDE || height > CAIRO_MAX_SIDE)
    return vf_error_set(VF_EINVAL, "%s: a %dx%d difference image is beyond cairo's %d-pixel limit", path, a->width,
                        a->height, CAIRO_MAX_SIDE);
  int err = VF_OK;
  cairo_surface_t *surface = cairo->cairo_image_surface_create(CAIRO_FORMAT_RGB24, width, height);
  cairo_t *cr = cairo->cairo_create(surface);
  if (cairo->cairo_status(cr) != CAIRO_STATUS_SUCCESS) {
    err = vf_error_set(VF_ENOMEM, "%s: cannot create a %dx%d drawing: %s", path, width, height,
                       cairo->cairo_status_to_string(cairo->cairo_status(cr)));
    goto destroy;
  }
  cairo->cairo_set_source_rgb(cr, 0.15, 0.15, 0.15);
  cairo->cairo_paint(cr);
  cairo->cairo_surface_flush(surface);
  unsigned char *data = cairo->cairo_image_surface_get_data(surface);
  int stride = cairo->cairo_image_surface_get_stride(surface), x0 = (width - a->width) / 2;
  for (int y = 0; y < a->height; y++) {
    uint32_t *row = (uint32_t *)(data + (size_t)y * (size_t)stride) + x0;
    for (int x = 0; x < a->width; x++) {
      float v = d[(size_t)y * (size_t)a->width + (size_t)x];
      row[x] = isfinite(v) ? diverging(v / scale) : 0;
    }
  }
  cairo->cairo_surface_mark_dirty(surface);
  draw_legend(cr, width, a->height, scale, scale_source, nonfinite);
  if (cairo->cairo_status(cr) != CAIRO_STATUS_SUCCESS) {
    err = vf_error_set(VF_EIO, "%s: drawing failed: %s", path, cairo->cairo_status_to_string(cairo->cairo_status(cr)));
    goto destroy;
  }

  png_sink sink = {.offset = 0};
  if ((err = vf_atomic_open(&sink.file, path)) != VF_OK) goto destroy;
  cairo_status_t status = cairo->cairo_surface_write_to_png_stream(surface, sink_write, &sink);
  if (status != CAIRO_STATUS_SUCCESS) {
    /* the sink's own detail (vf_atomic_pwrite) is more precise when it failed */
    err = status == CAIRO_STATUS_WRITE_ERROR ? VF_EIO
                                              : vf_error_set(VF_EIO, "%s: cannot encode the PNG: %s", path,
                                                             cairo->cairo_status_to_string(status));
    vf_atomic_abort(&sink.file);
    goto destroy;
  }
  err = vf_atomic_commit(&sink.file);
destroy:
  cairo->cairo_destroy(cr);
  cairo->cairo_surface_destroy(surface);
  return err;
}

int vf_cmd_diff(int argc, char **argv) {
  static const struct option options[] = {{"output", required_argument, 0, 'o'},
                                          {"scale", required_argument, 0, 's'},
                                          {"quiet", no_argument, 0, 'q'},
                                          {"help", no_argument, 0, 'h'},
                                          {0, 0, 0, 0}};
  const char *output = NULL;
  double scale = 0.0;
  int scale_given = 0, quiet = 0, err = VF_OK, c;
  vf_error_clear();
  optind = 0;
  while ((c = vf_cli_getopt(argc, argv, "o:s:qh", options)) != -1) {
    switch (c) {
    case 'o': output = optarg; break;
    case 'q': quiet = 1; break;
    case 's':
      err = vf_cli_double("--scale", optarg, 1e-30, 1e30, &scale);
      scale_given = 1;
      break;
    case 'h': fputs(diff_usage, stdout); return VF_EXIT_OK;
    default:
      return vf_cli_bad_option("diff");
    }
    if (err != VF_OK) return vf_cli_fail("diff", err);
  }
  if (optind != argc - 2) return vf_cli_usage_error("diff", "expected A and B");
  if (output == NULL) return vf_cli_usage_error("diff", "missing -o DIFF.png");
  if ((err = vf_cli_extension("-o", output, ".png", "a PNG image")) != VF_OK) return vf_cli_fail("diff", err);

  vf_image a = {0}, b = {0};
  float *d = NULL;
  uint64_t nonfinite = 0;
  double p99 = 0.0;
  if ((err = read_pair(argv[optind], argv[optind + 1], &a, &b, NULL, NULL)) != VF_OK) goto done;
  if ((d = malloc((size_t)a.width * (size_t)a.height * sizeof *d)) == NULL) {
    err = vf_error_set(VF_ENOMEM, "out of memory for a %dx%d difference", a.width, a.height);
    goto done;
  }
  if ((err = relative_difference(&a, &b, d, &p99, &nonfinite)) != VF_OK) goto done;
  /* equal images have a zero percentile: any positive range shows them all white */
  const char *scale_source = "--scale";
  if (!scale_given) {
    scale = p99 > 0.0 ? p99 : 1.0;
    scale_source = p99 > 0.0 ? "99th percentile of |difference|" : "the images are equal";
  }
  if ((err = write_diff_png(output, &a, d, scale, scale_source, nonfinite)) != VF_OK) goto done;
  if (!quiet)
    fprintf(stderr, "wrote %s: %dx%d, clamped at +-%.3g (%s), %llu non-finite %s\n", output, a.width, a.height, scale,
            scale_source, (unsigned long long)nonfinite, vf_cli_plural(nonfinite, "pixel", "pixels"));
done:
  free(d);
  vf_image_destroy(&b);
  vf_image_destroy(&a);
  return err == VF_OK ? VF_EXIT_OK : vf_cli_fail("diff", err);
}
