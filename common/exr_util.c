#define _GNU_SOURCE /* sync_file_range */
#include "exr_util.h"

#include "error.h"
#include "pool.h"


#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

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

/* The options every read uses: our error capture and limits, no chunk table repair. */
static exr_context_initializer_t read_initializer(void) {
  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  init.error_handler_fn = capture_error;
  init.max_image_width = VF_EXR_MAX_SIDE;
  init.max_image_height = VF_EXR_MAX_SIDE;
  init.max_tile_width = MAX_TILE_SIDE;
  init.max_tile_height = MAX_TILE_SIDE;
  /* A damaged chunk table is an error for us, not something to search the file for. */
  init.flags = EXR_CONTEXT_FLAG_DISABLE_CHUNK_RECONSTRUCTION;
  return init;
}

/* Checks a started read of `size` bytes (single part, flat, sane size, long enough for its
 * chunk table) and fills in; finishes ctx on failure. */
static int check_opened(exr_context_t ctx, const char *path, int64_t size, vf_exr_in *in) {
  int err = VF_OK, parts = 0;
  exr_result_t rv;
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
  if (size < min_bytes) {
    err = vf_error_set(VF_EEXR, "%s: file of %lld bytes is too short for its %d chunks (truncated?)", path,
                       (long long)size, (int)chunks);
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

int vf_exr_open(const char *path, vf_exr_in *in) {
  struct stat st;
  if (stat(path, &st) != 0) {
    if (errno == ENOENT) return vf_error_set(VF_ENOENT, "%s: no such file", path);
    return vf_error_set(VF_EIO, "%s: %s", path, strerror(errno));
  }
  if (!S_ISREG(st.st_mode)) return vf_error_set(VF_EEXR, "%s: not a regular file", path);
  exr_context_initializer_t init = read_initializer();
  exr_context_t ctx = NULL;
  clear_message();
  exr_result_t rv = exr_start_read(&ctx, path, &init);
  if (rv != EXR_ERR_SUCCESS) return vf_exr_error(path, rv, "not a readable EXR file");
  in->memory = NULL;
  in->memory_size = 0;
  return check_opened(ctx, path, (int64_t)st.st_size, in);
}

/* OpenEXRCore's stream over a file in memory. It may ask from several threads at once
 * (chunks decode in parallel): a copy out of read-only bytes needs no lock. */
static int64_t read_memory(exr_const_context_t ctxt, void *userdata, void *buffer, uint64_t sz, uint64_t offset,
                           exr_stream_error_func_ptr_t error_cb) {
  (void)ctxt;
  (void)error_cb;
  const vf_exr_in *in = userdata;
  if (offset >= in->memory_size) return 0;
  uint64_t n = in->memory_size - offset < sz ? in->memory_size - offset : sz;
  memcpy(buffer, in->memory + offset, n);
  return (int64_t)n;
}

static int64_t memory_size(exr_const_context_t ctxt, void *userdata) {
  (void)ctxt;
  return (int64_t)((const vf_exr_in *)userdata)->memory_size;
}

int vf_exr_open_memory(const void *bytes, size_t size, const char *name, vf_exr_in *in) {
  if (size > (uint64_t)INT64_MAX) return vf_error_set(VF_EEXR, "%s: too large", name);
  exr_context_initializer_t init = read_initializer();
  /* The stream reads through `in`, which therefore stays where it is until vf_exr_close. */
  in->memory = bytes;
  in->memory_size = size;
  init.user_data = in;
  init.read_fn = read_memory;
  init.size_fn = memory_size;
  exr_context_t ctx = NULL;
  clear_message();
  exr_result_t rv = exr_start_read(&ctx, name, &init);
  if (rv != EXR_ERR_SUCCESS) return vf_exr_error(name, rv, "not a readable EXR file");
  return check_opened(ctx, name, (int64_t)size, in);
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
                        const char *const *names, uint64_t uint_mask, float *scratch, vf_exr_store_fn store,
                        void *user) {
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
    /* A channel wanted as integers is decoded as such, never through a float */
    int raw = k < n && (uint_mask >> k & 1);
    if (raw && ch->data_type != EXR_PIXEL_UINT) {
      exr_decoding_destroy(in->ctx, &dec);
      return vf_error_set(VF_EEXR, "%s: channel %s is not of type UINT", in->path, names[k]);
    }
    ch->user_data_type = raw ? EXR_PIXEL_UINT : EXR_PIXEL_FLOAT;
    ch->user_bytes_per_element = 4;
    ch->user_pixel_stride = 4;
    ch->user_line_stride = 4 * w;
  }
  rv = exr_decoding_choose_default_routines(in->ctx, 0, &dec);
  if (rv == EXR_ERR_SUCCESS) rv = exr_decoding_run(in->ctx, 0, &dec);
  exr_decoding_destroy(in->ctx, &dec);
  if (rv != EXR_ERR_SUCCESS) return vf_exr_error(in->path, rv, where);

  const float *planes[VF_EXR_MAX_CHANNELS];
  for (int k = 0; k < n; k++) planes[k] = scratch + (size_t)k * plane;
  return store(user, x0, y0, w, h, planes);
}

/* ---- chunks in parallel ---- */

/* One loop over a file's chunks on a pool of threads (common/pool.h). The first error
 * wins: its code and detail (set on the thread that hit it) are kept for the caller's
 * thread, and chunks not yet started are skipped. `turn` wakes the writers of chunks
 * encoded ahead of their turn. */
typedef struct {
  pthread_mutex_t lock;
  pthread_cond_t turn;
  size_t chunks;
  size_t next_write; /* the chunk whose turn it is to be written */
  atomic_int failed;
  int err;
  char detail[1024];
} chunk_run;

static void run_fail(chunk_run *run, int err) {
  if (!atomic_exchange(&run->failed, 1)) {
    run->err = err;
    snprintf(run->detail, sizeof run->detail, "%s", vf_error_detail(err));
  }
}

typedef struct {
  chunk_run *run;
  int (*chunk)(void *job, size_t index, int thread);
  void *job;
} chunk_loop;

static void chunk_task(void *ctx, size_t index, int thread) {
  chunk_loop *loop = ctx;
  if (atomic_load(&loop->run->failed)) return;
  int err = loop->chunk(loop->job, index, thread);
  if (err != VF_OK) {
    pthread_mutex_lock(&loop->run->lock);
    run_fail(loop->run, err);
    pthread_cond_broadcast(&loop->run->turn);
    pthread_mutex_unlock(&loop->run->lock);
  }
}

/* Calls chunk(job, i, thread) for every i in [0, chunks) on `threads` threads (thread in
 * [0, threads)), with *run (which the job may use meanwhile) set up for it; the first
 * error, with its detail, on the caller's thread. */
static int run_chunks(chunk_run *run, size_t chunks, int threads, int (*chunk)(void *, size_t, int), void *job) {
  chunk_loop loop = {run, chunk, job};
  pthread_mutex_init(&run->lock, NULL);
  pthread_cond_init(&run->turn, NULL);
  run->next_write = 0;
  atomic_init(&run->failed, 0);
  vf_pool *pool = NULL;
  if (threads > 1 && vf_pool_create(threads, &pool) == VF_OK) {
    vf_pool_run(pool, chunks, chunk_task, &loop);
    vf_pool_destroy(pool);
  } else {
    for (size_t i = 0; i < chunks; i++) chunk_task(&loop, i, 0);
  }
  pthread_cond_destroy(&run->turn);
  pthread_mutex_destroy(&run->lock);
  if (atomic_load(&run->failed)) return vf_error_set(run->err, "%s", run->detail);
  return VF_OK;
}

/* ---- reading chunks ---- */

typedef struct {
  vf_exr_in *in;
  int n;
  const char *const *names;
  uint64_t uint_mask;
  vf_exr_store_fn store;
  void *user;
  int cw, chh;      /* the largest chunk */
  int tw, th;       /* level-0 tile size (tiled files) */
  int across;       /* chunks per row of chunks */
  float **scratch;  /* per thread: n wanted planes and one throwaway plane */
} read_job;

static int read_chunk(void *ctx, size_t index, int thread) {
  read_job *j = ctx;
  vf_exr_in *in = j->in;
  exr_chunk_info_t cinfo;
  exr_result_t rv;
  char what[64];
  clear_message();
  if (in->tiled) {
    int tx = (int)(index % (size_t)j->across), ty = (int)(index / (size_t)j->across);
    int x0 = tx * j->tw, y0 = ty * j->th;
    int w = in->width - x0 < j->tw ? in->width - x0 : j->tw, h = in->height - y0 < j->th ? in->height - y0 : j->th;
    if ((rv = exr_read_tile_chunk_info(in->ctx, 0, tx, ty, 0, 0, &cinfo)) != EXR_ERR_SUCCESS) {
      snprintf(what, sizeof what, "cannot locate tile (%d, %d)", tx, ty);
      return vf_exr_error(in->path, rv, what);
    }
    return decode_chunk(in, &cinfo, x0, y0, w, h, j->n, j->names, j->uint_mask, j->scratch[thread], j->store, j->user);
  }
  int y0 = (int)index * j->chh, h = in->height - y0 < j->chh ? in->height - y0 : j->chh;
  if ((rv = exr_read_scanline_chunk_info(in->ctx, 0, in->min_y + y0, &cinfo)) != EXR_ERR_SUCCESS) {
    snprintf(what, sizeof what, "cannot locate the chunk of scanline %d", in->min_y + y0);
    return vf_exr_error(in->path, rv, what);
  }
  if (cinfo.start_y != in->min_y + y0)
    return vf_error_set(VF_EEXR, "%s: chunk for scanline %d starts at %d", in->path, in->min_y + y0, cinfo.start_y);
  return decode_chunk(in, &cinfo, 0, y0, j->cw, h, j->n, j->names, j->uint_mask, j->scratch[thread], j->store, j->user);
}

/* The chunk geometry: level-0 tiles of a tiled file, whole-width bands of a scanline file. */
static int chunk_geometry(read_job *j, size_t *chunks) {
  vf_exr_in *in = j->in;
  exr_result_t rv;
  if (in->tiled) {
    uint32_t tx, ty;
    exr_tile_level_mode_t lm;
    exr_tile_round_mode_t rm;
    int32_t tw = 0, th = 0;
    if ((rv = exr_get_tile_descriptor(in->ctx, 0, &tx, &ty, &lm, &rm)) != EXR_ERR_SUCCESS)
      return vf_exr_error(in->path, rv, "cannot read the tile description");
    if (tx < 1 || ty < 1 || tx > MAX_TILE_SIDE || ty > MAX_TILE_SIDE)
      return vf_error_set(VF_EEXR, "%s: tile size %ux%u is not sane", in->path, tx, ty);
    if ((rv = exr_get_tile_sizes(in->ctx, 0, 0, 0, &tw, &th)) != EXR_ERR_SUCCESS)
      return vf_exr_error(in->path, rv, "cannot read the level-0 tile size");
    if (tw < 1 || th < 1 || tw > (int32_t)tx || th > (int32_t)ty)
      return vf_error_set(VF_EEXR, "%s: level-0 tile size %dx%d (tiles of %ux%u)", in->path, tw, th, tx, ty);
    j->cw = tw < in->width ? tw : in->width;
    j->chh = th < in->height ? th : in->height;
    j->tw = tw;
    j->th = th;
    j->across = (in->width + tw - 1) / tw;
    *chunks = (size_t)j->across * (size_t)((in->height + th - 1) / th);
    return VF_OK;
  }
  int32_t lines = 0;
  if ((rv = exr_get_scanlines_per_chunk(in->ctx, 0, &lines)) != EXR_ERR_SUCCESS)
    return vf_exr_error(in->path, rv, "cannot read scanlines per chunk");
  if (lines < 1 || lines > 256) return vf_error_set(VF_EEXR, "%s: %d scanlines per chunk", in->path, lines);
  j->cw = in->width;
  j->chh = lines < in->height ? lines : in->height;
  j->across = 1;
  *chunks = (size_t)((in->height + j->chh - 1) / j->chh);
  return VF_OK;
}

int vf_exr_read_channels(vf_exr_in *in, int n, const char *const *names, vf_exr_store_fn store, void *user) {
  return vf_exr_read_channels_typed(in, n, names, 0, store, user);
}

int vf_exr_read_channels_typed(vf_exr_in *in, int n, const char *const *names, uint64_t uint_mask,
                               vf_exr_store_fn store, void *user) {
  if (n < 1 || n > VF_EXR_MAX_CHANNELS) return vf_error_set(VF_EINVAL, "%s: cannot read %d channels at once", in->path, n);
  int err = check_channels(in, n, names);
  if (err != VF_OK) return err;
  read_job job = {.in = in, .n = n, .names = names, .uint_mask = uint_mask, .store = store, .user = user};
  size_t chunks = 0;
  if ((err = chunk_geometry(&job, &chunks)) != VF_OK) return err;
  int threads = vf_exr_chunk_threads(chunks);
  job.scratch = calloc((size_t)threads, sizeof *job.scratch);
  size_t plane = (size_t)job.cw * (size_t)job.chh;
  for (int t = 0; job.scratch && t < threads; t++)
    if ((job.scratch[t] = malloc((size_t)(n + 1) * plane * sizeof(float))) == NULL) {
      err = vf_error_set(VF_ENOMEM, "%s: out of memory for a %dx%d chunk", in->path, job.cw, job.chh);
      break;
    }
  if (job.scratch == NULL) err = vf_error_set(VF_ENOMEM, "%s: out of memory", in->path);
  chunk_run run;
  if (err == VF_OK) err = run_chunks(&run, chunks, threads, read_chunk, &job);
  for (int t = 0; job.scratch && t < threads; t++) free(job.scratch[t]);
  free(job.scratch);
  return err;
}

/* ---- writing ---- */

/* Written bytes are handed to the disk in batches of this size as the file grows, so that
 * the fsync of the atomic write finds little left to do (it took 0.4-0.5 s for a 245 MB
 * film when everything waited for it). */
#define WRITEBACK_BATCH ((uint64_t)16 << 20)

static int64_t write_to_fd(exr_const_context_t ctxt, void *userdata, const void *buffer, uint64_t sz,
                           uint64_t offset, exr_stream_error_func_ptr_t error_cb) {
  vf_exr_out *out = userdata;
  if (vf_atomic_pwrite(&out->file, buffer, sz, offset) != VF_OK) {
    error_cb(ctxt, EXR_ERR_WRITE_IO, "%s", vf_error_detail(VF_EIO));
    return -1;
  }
  /* Chunks go out in order, so the file grows at its end; a failed hint costs nothing. */
  if (offset + sz > out->written) out->written = offset + sz;
  if (out->written - out->handed >= WRITEBACK_BATCH) {
    sync_file_range(out->file.fd, (off_t)out->handed, (off_t)(out->written - out->handed), SYNC_FILE_RANGE_WRITE);
    out->handed = out->written;
  }
  return (int64_t)sz;
}

int vf_exr_create(const char *path, int width, int height, int tile, vf_exr_compression compression, int n,
                  const char *const *names, vf_exr_out *out) {
  return vf_exr_create_typed(path, width, height, tile, compression, n, names, 0, out);
}

int vf_exr_create_typed(const char *path, int width, int height, int tile, vf_exr_compression compression, int n,
                        const char *const *names, uint64_t uint_mask, vf_exr_out *out) {
  memset(out, 0, sizeof *out);
  out->file.fd = -1;
  if (width < 1 || height < 1 || width > VF_EXR_MAX_SIDE || height > VF_EXR_MAX_SIDE || tile < 0 ||
      tile > MAX_TILE_SIDE || n < 1 || n > VF_EXR_MAX_CHANNELS)
    return vf_error_set(VF_EINVAL, "%s: cannot write a %dx%d image of %d channels", path ? path : "(null)", width,
                        height, n);
  int err = vf_atomic_open(&out->file, path);
  if (err != VF_OK) return err;

  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  init.error_handler_fn = capture_error;
  init.user_data = out;
  init.write_fn = write_to_fd;
  clear_message();
  exr_result_t rv = exr_start_write(&out->ctx, path, EXR_WRITE_FILE_DIRECTLY, &init);
  if (rv != EXR_ERR_SUCCESS) {
    err = vf_exr_error(path, rv, "cannot start writing");
    goto fail;
  }
  int part = 0;
  rv = exr_add_part(out->ctx, NULL, tile ? EXR_STORAGE_TILED : EXR_STORAGE_SCANLINE, &part);
  /* The chunks are compressed by exr_chunk.c, which only needs the header to say so. */
  exr_compression_t kind = compression == VF_EXR_ZIP ? EXR_COMPRESSION_ZIP : EXR_COMPRESSION_NONE;
  if (rv == EXR_ERR_SUCCESS) rv = exr_initialize_required_attr_simple(out->ctx, part, width, height, kind);
  if (rv == EXR_ERR_SUCCESS && tile)
    rv = exr_set_tile_descriptor(out->ctx, part, (uint32_t)tile, (uint32_t)tile, EXR_TILE_ONE_LEVEL, EXR_TILE_ROUND_DOWN);
  for (int k = 0; rv == EXR_ERR_SUCCESS && k < n; k++)
    rv = exr_add_channel(out->ctx, part, names[k], (uint_mask >> k & 1) ? EXR_PIXEL_UINT : EXR_PIXEL_FLOAT,
                         (uint_mask >> k & 1) ? EXR_PERCEPTUALLY_LINEAR : EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
  /* A chunk holds the channels in the order of the file's (sorted) channel list. */
  const exr_attr_chlist_t *list = NULL;
  if (rv == EXR_ERR_SUCCESS) rv = exr_get_channels(out->ctx, part, &list);
  if (rv != EXR_ERR_SUCCESS || list == NULL || list->num_channels != n) {
    err = vf_exr_error(path, rv, "cannot define the image");
    goto fail;
  }
  for (int i = 0; i < n; i++) {
    int k = 0;
    while (k < n && strcmp(list->entries[i].name.str, names[k]) != 0) k++;
    if (k == n) {
      err = vf_error_set(VF_EINVAL, "%s: channel %s listed twice", path, list->entries[i].name.str);
      goto fail;
    }
    out->order[i] = k;
  }
  out->width = width;
  out->height = height;
  out->tile = tile;
  out->channels = n;
  out->compression = compression;
  return VF_OK;
fail:
  vf_exr_abort(out);
  return err;
}

/* Our own write errors carry the better message. */
static int write_error(vf_exr_out *out, exr_result_t rv, const char *what) {
  if (rv == EXR_ERR_WRITE_IO) return vf_error_set(VF_EIO, "%s", exr_message[0] ? exr_message : "write failed");
  return vf_exr_error(out->file.path, rv, what);
}

/* Chunks encoded ahead of their turn wait in memory, at most this many, so that a slow
 * chunk (noise, next to black) does not hold up the threads encoding the next ones. */
#define AHEAD_MAX 256

typedef struct {
  vf_exr_out *out;
  vf_exr_fill_fn fill;
  void *user;
  int cw, chh, across;
  float **scratch;      /* per thread: the chunk's planes */
  vf_exr_coder *coders; /* per thread */
  uint8_t **ahead;      /* per chunk: its bytes while it waits for its turn, owned */
  size_t *ahead_len;
  chunk_run run;
} write_job;

/* Writes chunk index (under the lock, in its turn). */
static int put_chunk(write_job *j, size_t index, const uint8_t *data, size_t len) {
  vf_exr_out *out = j->out;
  int tx = (int)(index % (size_t)j->across), ty = (int)(index / (size_t)j->across);
  clear_message();
  exr_result_t rv = out->tile ? exr_write_tile_chunk(out->ctx, 0, tx, ty, 0, 0, data, len)
                              : exr_write_scanline_chunk(out->ctx, 0, ty * j->chh, data, len);
  return rv == EXR_ERR_SUCCESS ? VF_OK : write_error(out, rv, "cannot write a chunk");
}

/* Fills and encodes chunk `index` on this thread; writes it if it is its turn, and the
 * chunks after it that were encoded ahead, else leaves a copy for the thread whose turn
 * it is. Chunks go to the file in order: its bytes do not depend on the threads. */
static int write_chunk(void *ctx, size_t index, int thread) {
  write_job *j = ctx;
  vf_exr_out *out = j->out;
  int x0 = (int)(index % (size_t)j->across) * j->cw, y0 = (int)(index / (size_t)j->across) * j->chh;
  int w = out->width - x0 < j->cw ? out->width - x0 : j->cw, h = out->height - y0 < j->chh ? out->height - y0 : j->chh;
  float *planes[VF_EXR_MAX_CHANNELS];
  const float *ordered[VF_EXR_MAX_CHANNELS];
  for (int k = 0; k < out->channels; k++) planes[k] = j->scratch[thread] + (size_t)k * (size_t)w * (size_t)h;
  j->fill(j->user, x0, y0, w, h, planes);
  for (int i = 0; i < out->channels; i++) ordered[i] = planes[out->order[i]];
  const uint8_t *data = NULL;
  size_t len = 0;
  int err = vf_exr_chunk_encode(&j->coders[thread], out->compression, out->channels, ordered, w, h, &data, &len);
  pthread_mutex_lock(&j->run.lock);
  while (index - j->run.next_write > AHEAD_MAX && !atomic_load(&j->run.failed))
    pthread_cond_wait(&j->run.turn, &j->run.lock);
  if (err == VF_OK && !atomic_load(&j->run.failed)) {
    if (index == j->run.next_write) {
      err = put_chunk(j, index, data, len);
      while (err == VF_OK && ++j->run.next_write < j->run.chunks && j->ahead[j->run.next_write]) {
        size_t next = j->run.next_write;
        err = put_chunk(j, next, j->ahead[next], j->ahead_len[next]);
        free(j->ahead[next]);
        j->ahead[next] = NULL;
      }
      pthread_cond_broadcast(&j->run.turn);
    } else if ((j->ahead[index] = malloc(len)) != NULL) {
      memcpy(j->ahead[index], data, len);
      j->ahead_len[index] = len;
    } else {
      err = vf_error_set(VF_ENOMEM, "out of memory for a chunk of %zu bytes", len);
    }
  }
  if (err != VF_OK) {
    run_fail(&j->run, err);
    pthread_cond_broadcast(&j->run.turn);
  }
  pthread_mutex_unlock(&j->run.lock);
  return VF_OK; /* a failure is recorded above, under the lock the writers wait on */
}

int vf_exr_write_pixels(vf_exr_out *out, int n, const char *const *names, vf_exr_fill_fn fill, void *user) {
  (void)names;
  if (n != out->channels) return vf_error_set(VF_EINVAL, "%d channels written, %d declared", n, out->channels);
  clear_message();
  exr_result_t rv = exr_write_header(out->ctx);
  if (rv != EXR_ERR_SUCCESS) return write_error(out, rv, "cannot write the header");
  int32_t lines = 1;
  if (!out->tile && (rv = exr_get_scanlines_per_chunk(out->ctx, 0, &lines)) != EXR_ERR_SUCCESS)
    return vf_exr_error(out->file.path, rv, "cannot query scanlines per chunk");
  write_job job = {.out = out, .fill = fill, .user = user};
  job.cw = out->tile ? out->tile : out->width;
  job.chh = out->tile ? out->tile : lines;
  job.across = (out->width + job.cw - 1) / job.cw;
  size_t chunks = (size_t)job.across * (size_t)((out->height + job.chh - 1) / job.chh);
  int threads = vf_exr_chunk_threads(chunks), err = VF_OK;
  job.scratch = calloc((size_t)threads, sizeof *job.scratch);
  job.coders = calloc((size_t)threads, sizeof *job.coders);
  job.ahead = calloc(chunks, sizeof *job.ahead);
  job.ahead_len = calloc(chunks, sizeof *job.ahead_len);
  if (!job.scratch || !job.coders || !job.ahead || !job.ahead_len)
    err = vf_error_set(VF_ENOMEM, "out of memory for %d writers", threads);
  job.run.chunks = chunks;
  for (int t = 0; err == VF_OK && t < threads; t++) {
    vf_exr_coder_init(&job.coders[t]);
    if ((job.scratch[t] = malloc((size_t)n * (size_t)job.cw * (size_t)job.chh * sizeof(float))) == NULL)
      err = vf_error_set(VF_ENOMEM, "out of memory for a %dx%d chunk", job.cw, job.chh);
  }
  if (err == VF_OK) err = run_chunks(&job.run, chunks, threads, write_chunk, &job);
  for (int t = 0; t < threads; t++) {
    if (job.coders) vf_exr_coder_destroy(&job.coders[t]);
    if (job.scratch) free(job.scratch[t]);
  }
  for (size_t i = 0; job.ahead && i < chunks; i++) free(job.ahead[i]); /* left by a failure */
  free(job.ahead);
  free(job.ahead_len);
  free(job.coders);
  free(job.scratch);
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
  int err = out->checksum ? vf_exr_write_checksum(out) : VF_OK;
  if (err != VF_OK) {
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
