/* The cairo functions the command line's drawings call (plot.c, compare_cmd.c), as a table
 * that the module libvf_cairo.so (cairo_module.c) fills with cairo's own: cairo, and the
 * font and X11 libraries it links, are loaded by the commands that draw (`plot`, `diff`),
 * when they draw, not by every command (common/module.h). Members have the names and
 * types of cairo's functions; a call `cairo->cairo_stroke(cr)` is cairo's. */
#ifndef VF_CLI_CAIRO_API_H
#define VF_CLI_CAIRO_API_H

#include "../common/module.h"

#include <cairo.h>

/* Changed whenever the list changes (a module of another version is refused by name). */
#define VF_CAIRO_API_VERSION 1
#define VF_CAIRO_MODULE_FILE "libvf_cairo.so"

#define VF_CAIRO_FUNCTIONS(X) \
  X(cairo_arc) X(cairo_clip) X(cairo_create) X(cairo_destroy) X(cairo_fill) X(cairo_fill_preserve) \
  X(cairo_image_surface_create) X(cairo_image_surface_get_data) X(cairo_image_surface_get_stride) \
  X(cairo_line_to) X(cairo_move_to) X(cairo_paint) X(cairo_pattern_add_color_stop_rgb) \
  X(cairo_pattern_create_linear) X(cairo_pattern_destroy) X(cairo_rectangle) X(cairo_restore) \
  X(cairo_rotate) X(cairo_save) X(cairo_select_font_face) X(cairo_set_dash) X(cairo_set_font_size) \
  X(cairo_set_line_width) X(cairo_set_source) X(cairo_set_source_rgb) X(cairo_show_text) \
  X(cairo_status) X(cairo_status_to_string) X(cairo_stroke) X(cairo_surface_destroy) \
  X(cairo_surface_flush) X(cairo_surface_mark_dirty) X(cairo_surface_write_to_png_stream) \
  X(cairo_text_extents) X(cairo_translate)

typedef struct {
  vf_module_head head; /* VF_CAIRO_API_VERSION, sizeof(vf_cairo_api) */
  VF_CAIRO_FUNCTIONS(VF_MODULE_MEMBER)
} vf_cairo_api;

/* cairo's functions, the module loaded on the first call (thread-safe); NULL when it
 * cannot be, with VF_EMODULE set, its detail "LABEL: why" (the file to draw). */
const vf_cairo_api *vf_cairo_load(const char *label);
/* The same, for code that draws: every drawing starts with a successful vf_cairo_load, so
 * the table is there. */
const vf_cairo_api *vf_cairo(void);

#endif
