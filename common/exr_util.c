#include "exr_util.h"

#include "error.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* Tiles larger than this are refused while parsing the header: a damaged tile descriptor
 * would otherwise size every per-chunk buffer. Real files use 32..512. */
#define MAX_TILE_SIDE 16384
/* Smallest possible bytes per chunk: its offset-table entry plus its header (scanline:
 * y and size; tile: four ints and size). A file shorter than count * this is truncated,
 * and refusing it early keeps a damaged header from sizing allocations. */
#define MIN_SCANLINE_CHUNK_BYTES 16
#define MIN_TILE_CHUNK_BYTES 28

/* OpenEXRCore reports through a callback rather than a return string; the first message
 * since the last clear is the root cause, later ones are consequences. Per thread because
 * the callback runs on the thread that hit the error. */
static _Thread_local char exr_message[256];

static void capture_error(exr_const_context_t ctxt, exr_result_t code, const char *msg) {
  (void)ctxt;
  if (exr_message[0] != '\0') return;
  snprintf(exr_message, sizeof exr_message, "%s", msg ? msg : exr_get_default_error_message(code));
  /* Messages quote names from damaged headers: keep control bytes out of our details. */
  for (char *p = exr_message; *p; p++)
    if ((unsigned char)*p < 0x20 || (unsigned char)*p >= 0x7f) *p = '?';
}

/* Forgets messages that did not end in an error (header warnings in lenient mode). */
static void clear_message(void) { exr_message[0] = '\0'; }

int vf_exr_error(const char *path, exr_result_t rv, const char *what) {
  const char *msg = exr_message[0] ? exr_message : exr_get_default_error_message(rv);
  int err = vf_error_set(VF_EEXR, "%s: %s (%s)", path, what, msg);
  clear_message();
  return err;
}

/* ---- reading ---- */

int vf_exr_open(const char *path, vf_exr_in *in) {
  struct stat st;
  if (stat(path, &st) != 0) {
    if (errno == ENOENT) return vf_error_set(VF_ENOENT, "%s: no such file", path);
    return vf_error_set(VF_EIO, "%s: %s", path, strerror(errno));
  }
  if (!S_ISREG(st.st_mode)) return vf_error_set(VF_EEXR, "%s: not a regular file", path);

  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  init.error_handler_fn = capture_error;
  init.max_image_width = VF_EXR_MAX_SIDE;
  init.max_image_height = VF_EXR_MAX_SIDE;
  init.max_tile_width = MAX_TILE_SIDE;
  init.max_tile_height = MAX_TILE_SIDE;
  /* A damaged chunk table is an error for us, not something to search the file for. */
  init.flags = EXR_CONTEXT_FLAG_DISABLE_CHUNK_RECONSTRUCTION;

  exr_context_t ctx = NULL;
  clear_message();
  exr_result_t rv = exr_start_read(&ctx, path, &init);
  if (rv != EXR_ERR_SUCCESS) return vf_exr_error(path, rv, "not a readable EXR file");

  int err = VF_OK, parts = 0;
  exr_storage_t storage;
  exr_attr_box2i_t dw;
  int32_t chunks = 0;
  if ((rv = exr_get_count(ctx, &parts)) != EXR_ERR_SUCCESS) {
    err = vf_exr_error(path, rv, "cannot count parts");
    goto fail;
  }
  if (parts != 1) {
    err = vf_error_set(VF_EEXR, "%s: multi-part file (%d parts) is not supported", path, parts);
    goto fail;
  }
  if ((rv = exr_get_storage(ctx, 0, &storage)) != EXR_ERR_SUCCESS) {
    err = vf_exr_error(path, rv, "cannot read storage type");
    goto fail;
  }
  if (storage != EXR_STORAGE_SCANLINE && storage != EXR_STORAGE_TILED) {
    err = vf_error_set(VF_EEXR, "%s: deep data is not supported", path);
    goto fail;
  }
  if ((rv = exr_get_data_window(ctx, 0, &dw)) != EXR_ERR_SUCCESS) {
    err = vf_exr_error(path, rv, "cannot read data window");
    goto fail;
  }
  int64_t w = (int64_t)dw.max.x - dw.min.x + 1, h = (int64_t)dw.max.y - dw.min.y + 1;
  if (w < 1 || h < 1 || w > VF_EXR_MAX_SIDE || h > VF_EXR_MAX_SIDE || w * h > VF_EXR_MAX_PIXELS) {
    err = vf_error_set(VF_EEXR, "%s: data window %lldx%lld is empty or too large (at most %lld pixels)", path,
                       (long long)w, (long long)h, (long long)VF_EXR_MAX_PIXELS);
    goto fail;
  }
  if ((rv = exr_get_chunk_count(ctx, 0, &chunks)) != EXR_ERR_SUCCESS) {
    err = vf_exr_error(path, rv, "cannot compute the chunk count");
    goto fail;
  }
  if (chunks < 1) {
    err = vf_error_set(VF_EEXR, "%s: %d chunks", path, (int)chunks);
    goto fail;
  }
  int64_t min_bytes =
      (int64_t)chunks * (storage == EXR_STORAGE_TILED ? MIN_TILE_CHUNK_BYTES : MIN_SCANLINE_CHUNK_BYTES);
  if ((int64_t)st.st_size < min_bytes) {
    err = vf_error_set(VF_EEXR, "%s: file of %lld bytes is too short for its %d chunks (truncated?)", path,
                       (long long)st.st_size, (int)chunks);
    goto fail;
  }
  clear_message();
  in->ctx = ctx;
  in->path = path;
  in->width = (int)w;
  in->height = (int)h;
  in->min_x = dw.min.x;
  in->min_y = dw.min.y;
  in->tiled = storage == EXR_STORAGE_TILED;
  return VF_OK;
fail:
  exr_finish(&ctx);
  return err;
}

void vf_exr_close(vf_exr_in *in) {
  if (in == NULL || in->ctx == NULL) return;
  exr_finish(&in->ctx);
  in->ctx = NULL;
}

int vf_exr_has_channel(const vf_exr_in *in, const char *name) {
  const exr_attr_chlist_t *list = NULL;
  if (exr_get_channels(in->ctx, 0, &list) != EXR_ERR_SUCCESS || list == NULL) return 0;
  for (int i = 0; i < list->num_channels; i++)
    if (list->entries[i].name.str && strcmp(list->entries[i].name.str, name) == 0) return 1;
  return 0;
}

/* Checks that every wanted channel exists, is unsubsampled and of a known type. */
static int check_channels(const vf_exr_in *in, int n, const char *const *names) {
  const exr_attr_chlist_t *list = NULL;
  exr_result_t rv = exr_get_channels(in->ctx, 0, &list);
  if (rv != EXR_ERR_SUCCESS || list == NULL) return vf_exr_error(in->path, rv, "cannot read the channel list");
  for (int k = 0; k < n; k++) {
    const exr_attr_chlist_entry_t *e = NULL;
    for (int i = 0; i < list->num_channels && e == NULL; i++)
      if (list->entries[i].name.str && strcmp(list->entries[i].name.str, names[k]) == 0) e = &list->entries[i];
    if (e == NULL) return vf_error_set(VF_EEXR, "%s: missing channel %s", in->path, names[k]);
    if (e->x_sampling != 1 || e->y_sampling != 1)
      return vf_error_set(VF_EEXR, "%s: channel %s is subsampled (%dx%d), which is not supported", in->path,
                          names[k], e->x_sampling, e->y_sampling);
    if (e->pixel_type != EXR_PIXEL_UINT && e->pixel_type != EXR_PIXEL_HALF && e->pixel_type != EXR_PIXEL_FLOAT)
      return vf_error_set(VF_EEXR, "%s: channel %s has unknown pixel type %d", in->path, names[k],
                          (int)e->pixel_type);
  }
  return VF_OK;
}

/* Decodes one chunk into planar float scratch (n planes of w*h) and hands it to store. */
static int decode_chunk(vf_exr_in *in, const exr_chunk_info_t *cinfo, int x0, int y0, int w, int h, int n,
                        const char *const *names, float *scratch, vf_exr_store_fn store, void *user) {
  char where[64];
  snprintf(where, sizeof where, "corrupt chunk at pixel (%d, %d)", x0, y0);
  if (cinfo->width != w || cinfo->height != h)
    return vf_error_set(VF_EEXR, "%s: %s: chunk is %dx%d, expected %dx%d", in->path, where, cinfo->width,
                        cinfo->height, w, h);
  exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
  clear_message();
  exr_result_t rv = exr_decoding_initialize(in->ctx, 0, cinfo, &dec);
  if (rv != EXR_ERR_SUCCESS) {
    exr_decoding_destroy(in->ctx, &dec);
    return vf_exr_error(in->path, rv, where);
  }
  size_t plane = (size_t)w * (size_t)h;
  for (int c = 0; c < dec.channel_count; c++) {
    exr_coding_channel_info_t *ch = &dec.channels[c];
    /* Channels we do not want all decode into one throwaway plane (index n): the 3.1
     * unpackers write through a NULL decode_to_ptr instead of skipping the channel. */
    int k = 0;
    while (k < n && (ch->channel_name == NULL || strcmp(ch->channel_name, names[k]) != 0)) k++;
    if (ch->width < 0 || ch->height < 0 || ch->width > w || ch->height > h || (k < n && (ch->width != w || ch->height != h))) {
      exr_decoding_destroy(in->ctx, &dec);
      return vf_error_set(VF_EEXR, "%s: %s: channel %s is %dx%d", in->path, where,
                          ch->channel_name ? ch->channel_name : "?", ch->width, ch->height);
    }
    ch->decode_to_ptr = (uint8_t *)(scratch + (size_t)k * plane);
    ch->user_data_type = EXR_PIXEL_FLOAT;
    ch->user_bytes_per_element = 4;
    ch->user_pixel_stride = 4;
    ch->user_line_stride = 4 * w;
  }
  rv = exr_decoding_choose_default_routines(in->ctx, 0, &dec);
  if (rv == EXR_ERR_SUCCESS) rv = exr_decoding_run(in->ctx, 0, &dec);
  exr_decoding_destroy(in->ctx, &dec);
  if (rv != EXR_ERR_SUCCESS) return vf_exr_error(in->path, rv, where);

  const float *planes[64];
  for (int k = 0; k < n; k++) planes[k] = scratch + (size_t)k * plane;
  return store(user, x0, y0, w, h, planes);
}

int vf_exr_read_channels(vf_exr_in *in, int n, const char *const *names, vf_exr_store_fn store, void *user) {
  if (n < 1 || n > 64) return vf_error_set(VF_EINVAL, "%s: cannot read %d channels at once", in->path, n);
  int err = check_channels(in, n, names);
  if (err != VF_OK) return err;

  /* Chunk geometry: whole-width bands for scanline files, level-0 tiles otherwise. */
  int32_t cw, chh;
  exr_result_t rv;
  if (in->tiled) {
    uint32_t tx, ty;
    exr_tile_level_mode_t lm;
    exr_tile_round_mode_t rm;
    if ((rv = exr_get_tile_descriptor(in->ctx, 0, &tx, &ty, &lm, &rm)) != EXR_ERR_SUCCESS)
      return vf_exr_error(in->path, rv, "cannot read the tile description");
    if (tx < 1 || ty < 1 || tx > MAX_TILE_SIDE || ty > MAX_TILE_SIDE)
      return vf_error_set(VF_EEXR, "%s: tile size %ux%u is not sane", in->path, tx, ty);
    cw = (int32_t)tx < in->width ? (int32_t)tx : in->width;
    chh = (int32_t)ty < in->height ? (int32_t)ty : in->height;
  } else {
    int32_t lines = 0;
    if ((rv = exr_get_scanlines_per_chunk(in->ctx, 0, &lines)) != EXR_ERR_SUCCESS)
      return vf_exr_error(in->path, rv, "cannot read scanlines per chunk");
    if (lines < 1 || lines > 256) return vf_error_set(VF_EEXR, "%s: %d scanlines per chunk", in->path, lines);
    cw = in->width;
    chh = lines < in->height ? lines : in->height;
  }
  /* n wanted planes and one throwaway plane for the other channels */
  float *scratch = malloc((size_t)(n + 1) * (size_t)cw * (size_t)chh * sizeof *scratch);
  if (scratch == NULL) return vf_error_set(VF_ENOMEM, "%s: out of memory for a %dx%d chunk", in->path, cw, chh);

  exr_chunk_info_t cinfo;
  if (in->tiled) {
    int32_t tw = 0, th = 0;
    if ((rv = exr_get_tile_sizes(in->ctx, 0, 0, 0, &tw, &th)) != EXR_ERR_SUCCESS) {
      err = vf_exr_error(in->path, rv, "cannot read the level-0 tile size");
      goto done;
    }
    if (tw < 1 || th < 1) {
      err = vf_error_set(VF_EEXR, "%s: level-0 tile size %dx%d", in->path, tw, th);
      goto done;
    }
    for (int ty = 0; err == VF_OK && (int64_t)ty * th < in->height; ty++) {
      for (int tx = 0; err == VF_OK && (int64_t)tx * tw < in->width; tx++) {
        int x0 = tx * tw, y0 = ty * th;
        int w = in->width - x0 < tw ? in->width - x0 : tw;
        int h = in->height - y0 < th ? in->height - y0 : th;
        if (w > cw || h > chh) {
          err = vf_error_set(VF_EEXR, "%s: inconsistent tile size", in->path);
          break;
        }
        clear_message();
        if ((rv = exr_read_tile_chunk_info(in->ctx, 0, tx, ty, 0, 0, &cinfo)) != EXR_ERR_SUCCESS) {
          char what[64];
          snprintf(what, sizeof what, "cannot locate tile (%d, %d)", tx, ty);
          err = vf_exr_error(in->path, rv, what);
          break;
        }
        err = decode_chunk(in, &cinfo, x0, y0, w, h, n, names, scratch, store, user);
      }
    }
  } else {
    for (int y0 = 0; err == VF_OK && y0 < in->height; y0 += chh) {
      int h = in->height - y0 < chh ? in->height - y0 : chh;
      clear_message();
      if ((rv = exr_read_scanline_chunk_info(in->ctx, 0, in->min_y + y0, &cinfo)) != EXR_ERR_SUCCESS) {
        char what[64];
        snprintf(what, sizeof what, "cannot locate the chunk of scanline %d", in->min_y + y0);
        err = vf_exr_error(in->path, rv, what);
        break;
      }
      if (cinfo.start_y != in->min_y + y0) {
        err = vf_error_set(VF_EEXR, "%s: chunk for scanline %d starts at %d", in->path, in->min_y + y0, cinfo.start_y);
        break;
      }
      err = decode_chunk(in, &cinfo, 0, y0, cw, h, n, names, scratch, store, user);
    }
  }
done:
  free(scratch);
  return err;
}

/* ---- writing ---- */

static int64_t write_to_fd(exr_const_context_t ctxt, void *userdata, const void *buffer, uint64_t sz,
                           uint64_t offset, exr_stream_error_func_ptr_t error_cb) {
  vf_atomic_file *file = userdata;
  if (vf_atomic_pwrite(file, buffer, sz, offset) != VF_OK) {
    error_cb(ctxt, EXR_ERR_WRITE_IO, "%s", vf_error_detail(VF_EIO));
    return -1;
  }
  return (int64_t)sz;
}

int vf_exr_create(const char *path, int width, int height, int tile, int zip, int n, const char *const *names,
                  vf_exr_out *out) {
  memset(out, 0, sizeof *out);
  out->file.fd = -1;
  if (width < 1 || height < 1 || width > VF_EXR_MAX_SIDE || height > VF_EXR_MAX_SIDE || tile < 0 ||
      tile > MAX_TILE_SIDE)
    return vf_error_set(VF_EINVAL, "%s: cannot write a %dx%d image", path ? path : "(null)", width, height);
  int err = vf_atomic_open(&out->file, path);
  if (err != VF_OK) return err;

  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  init.error_handler_fn = capture_error;
  init.user_data = &out->file;
  init.write_fn = write_to_fd;
  clear_message();
  exr_result_t rv = exr_start_write(&out->ctx, path, EXR_WRITE_FILE_DIRECTLY, &init);
  if (rv != EXR_ERR_SUCCESS) {
    err = vf_exr_error(path, rv, "cannot start writing");
    goto fail;
  }
  int part = 0;
  const char *what = "cannot define the image";
  rv = exr_add_part(out->ctx, NULL, tile ? EXR_STORAGE_TILED : EXR_STORAGE_SCANLINE, &part);
  exr_compression_t compression = zip ? EXR_COMPRESSION_ZIP : EXR_COMPRESSION_NONE;
  if (rv == EXR_ERR_SUCCESS) rv = exr_initialize_required_attr_simple(out->ctx, part, width, height, compression);
  /* Level 1 keeps nearly all of the size gain of the default level 4 (144 against 141 MB
   * for a 1920x1080 film of noise) at almost twice the speed. */
  if (rv == EXR_ERR_SUCCESS && zip) rv = exr_set_zip_compression_level(out->ctx, part, 1);
  if (rv == EXR_ERR_SUCCESS && tile)
    rv = exr_set_tile_descriptor(out->ctx, part, (uint32_t)tile, (uint32_t)tile, EXR_TILE_ONE_LEVEL, EXR_TILE_ROUND_DOWN);
  for (int k = 0; rv == EXR_ERR_SUCCESS && k < n; k++)
    rv = exr_add_channel(out->ctx, part, names[k], EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
  if (rv != EXR_ERR_SUCCESS) {
    err = vf_exr_error(path, rv, what);
    goto fail;
  }
  out->width = width;
  out->height = height;
  out->tile = tile;
  return VF_OK;
fail:
  vf_exr_abort(out);
  return err;
}

/* Encodes one chunk from planar floats: planes[k] is channel names[k]. */
static int encode_chunk(vf_exr_out *out, const exr_chunk_info_t *cinfo, int n, const char *const *names,
                        float *const *planes, int w) {
  exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
  exr_result_t rv = exr_encoding_initialize(out->ctx, 0, cinfo, &enc);
  for (int c = 0; rv == EXR_ERR_SUCCESS && c < enc.channel_count; c++) {
    exr_coding_channel_info_t *ch = &enc.channels[c];
    int k = 0;
    while (k < n && strcmp(ch->channel_name, names[k]) != 0) k++;
    if (k == n) {
      rv = EXR_ERR_INVALID_ARGUMENT;
      break;
    }
    ch->encode_from_ptr = (const uint8_t *)planes[k];
    ch->user_data_type = EXR_PIXEL_FLOAT;
    ch->user_bytes_per_element = 4;
    ch->user_pixel_stride = 4;
    ch->user_line_stride = 4 * w;
  }
  if (rv == EXR_ERR_SUCCESS) rv = exr_encoding_choose_default_routines(out->ctx, 0, &enc);
  if (rv == EXR_ERR_SUCCESS) rv = exr_encoding_run(out->ctx, 0, &enc);
  exr_encoding_destroy(out->ctx, &enc);
  if (rv != EXR_ERR_SUCCESS) {
    /* our own write errors carry the better message */
    if (rv == EXR_ERR_WRITE_IO) return vf_error_set(VF_EIO, "%s", exr_message[0] ? exr_message : "write failed");
    return vf_exr_error(out->file.path, rv, "cannot encode pixels");
  }
  return VF_OK;
}

int vf_exr_write_pixels(vf_exr_out *out, int n, const char *const *names, vf_exr_fill_fn fill, void *user) {
  if (n < 1 || n > 64) return vf_error_set(VF_EINVAL, "cannot write %d channels", n);
  clear_message();
  exr_result_t rv = exr_write_header(out->ctx);
  if (rv != EXR_ERR_SUCCESS) {
    if (rv == EXR_ERR_WRITE_IO) return vf_error_set(VF_EIO, "%s", exr_message[0] ? exr_message : "write failed");
    return vf_exr_error(out->file.path, rv, "cannot write the header");
  }
  int32_t lines = 1;
  if (!out->tile && (rv = exr_get_scanlines_per_chunk(out->ctx, 0, &lines)) != EXR_ERR_SUCCESS)
    return vf_exr_error(out->file.path, rv, "cannot query scanlines per chunk");
  int cw = out->tile ? out->tile : out->width, chh = out->tile ? out->tile : lines;
  float *scratch = malloc((size_t)n * (size_t)cw * (size_t)chh * sizeof *scratch);
  if (scratch == NULL) return VF_ENOMEM;
  float *planes[64];
  int err = VF_OK;
  for (int y0 = 0; err == VF_OK && y0 < out->height; y0 += chh) {
    int h = out->height - y0 < chh ? out->height - y0 : chh;
    for (int x0 = 0; err == VF_OK && x0 < out->width; x0 += cw) {
      int w = out->width - x0 < cw ? out->width - x0 : cw;
      for (int k = 0; k < n; k++) planes[k] = scratch + (size_t)k * (size_t)w * (size_t)h;
      fill(user, x0, y0, w, h, planes);
      exr_chunk_info_t cinfo;
      rv = out->tile ? exr_write_tile_chunk_info(out->ctx, 0, x0 / cw, y0 / chh, 0, 0, &cinfo)
                      : exr_write_scanline_chunk_info(out->ctx, 0, y0, &cinfo);
      if (rv != EXR_ERR_SUCCESS) err = vf_exr_error(out->file.path, rv, "cannot start a chunk");
      else err = encode_chunk(out, &cinfo, n, names, planes, w);
    }
  }
  free(scratch);
  return err;
}

int vf_exr_commit(vf_exr_out *out) {
  clear_message();
  exr_result_t rv = exr_finish(&out->ctx);
  out->ctx = NULL;
  if (rv != EXR_ERR_SUCCESS) {
    int err = rv == EXR_ERR_WRITE_IO ? vf_error_set(VF_EIO, "%s", exr_message[0] ? exr_message : "write failed")
                                     : vf_exr_error(out->file.path, rv, "cannot finish the file");
    vf_atomic_abort(&out->file);
    return err;
  }
  return vf_atomic_commit(&out->file);
}

void vf_exr_abort(vf_exr_out *out) {
  if (out->ctx) exr_finish(&out->ctx);
  out->ctx = NULL;
  vf_atomic_abort(&out->file);
}
