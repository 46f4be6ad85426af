#include "preview.h"

#include "../../common/clock.h"
#include "../../common/error.h"
#include "../../common/image.h"

#include <errno.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define ENTRIES 8

typedef struct {
  uint64_t job_id; /* 0: free */
  int max_side;
  dev_t dev;       /* the file the image was read from */
  ino_t ino;
  off_t size;
  struct timespec mtime;
  double looked_at, used_at; /* vf_seconds_now() */
  vf_image image;  /* downscaled mean */
  uint8_t *png;    /* owned: the image at png_exposure */
  size_t png_size;
  double png_exposure;
} entry;

struct vf_previews {
  pthread_mutex_t lock;
  const char *state_dir;
  entry entries[ENTRIES];
};

int vf_previews_create(const char *state_dir, vf_previews **out) {
  vf_previews *p = calloc(1, sizeof *p);
  if (p == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  pthread_mutex_init(&p->lock, NULL);
  p->state_dir = state_dir;
  *out = p;
  return VF_OK;
}

static void entry_clear(entry *e) {
  vf_image_destroy(&e->image);
  free(e->png);
  memset(e, 0, sizeof *e);
}

void vf_previews_destroy(vf_previews *p) {
  if (p == NULL) return;
  for (int i = 0; i < ENTRIES; i++) entry_clear(&p->entries[i]);
  pthread_mutex_destroy(&p->lock);
  free(p);
}

/* The mean of each factor x factor block (fewer at the right and bottom edges). */
static int downscale(const vf_image *in, int max_side, vf_image *out) {
  int side = in->width > in->height ? in->width : in->height;
  int factor = side > max_side ? (side + max_side - 1) / max_side : 1;
  int w = (in->width + factor - 1) / factor, h = (in->height + factor - 1) / factor;
  if (vf_image_alloc(out, w, h) != VF_OK) return VF_ENOMEM;
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++) {
      double sum[3] = {0, 0, 0};
      int count = 0;
      for (int sy = y * factor; sy < (y + 1) * factor && sy < in->height; sy++)
        for (int sx = x * factor; sx < (x + 1) * factor && sx < in->width; sx++, count++)
          for (int c = 0; c < 3; c++) sum[c] += in->rgb[((size_t)sy * in->width + sx) * 3 + c];
      for (int c = 0; c < 3; c++) out->rgb[((size_t)y * w + x) * 3 + c] = (float)(sum[c] / count);
    }
  return VF_OK;
}

static int same_file(const entry *e, const struct stat *st) {
  return e->dev == st->st_dev && e->ino == st->st_ino && e->size == st->st_size &&
         e->mtime.tv_sec == st->st_mtim.tv_sec && e->mtime.tv_nsec == st->st_mtim.tv_nsec;
}

/* The film's mean from its checkpoint into *image; 404 or 500 with the message. */
static int read_film(const char *path, vf_image *image, char *message, size_t n) {
  int err = vf_image_read_exr(path, image);
  if (err == VF_OK) return 200;
  if (err == VF_ENOENT) return snprintf(message, n, "no film checkpoint yet"), 404;
  snprintf(message, n, "%s", vf_error_detail(err));
  return 500;
}

static entry *find_entry(vf_previews *p, uint64_t job_id, int max_side) {
  entry *oldest = &p->entries[0];
  for (int i = 0; i < ENTRIES; i++) {
    entry *e = &p->entries[i];
    if (e->job_id == job_id && e->max_side == max_side) return e;
    if (e->used_at < oldest->used_at) oldest = e;
  }
  entry_clear(oldest);
  oldest->job_id = job_id;
  oldest->max_side = max_side;
  return oldest;
}

static int bake(const char *path, double exposure, uint8_t **png, size_t *size, char *message, size_t n) {
  vf_image image = {0};
  int status = read_film(path, &image, message, n);
  if (status != 200) return status;
  int err = vf_image_encode_png(&image, (float)exposure, png, size);
  vf_image_destroy(&image);
  if (err != VF_OK) return snprintf(message, n, "%s", vf_error_detail(err)), 500;
  return 200;
}

int vf_previews_png(vf_previews *p, uint64_t job_id, double exposure, int max_side, uint8_t **png, size_t *size,
                    char *message, size_t n) {
  char path[4200];
  snprintf(path, sizeof path, "%s/job-%llu.exr", p->state_dir, (unsigned long long)job_id);
  snprintf(message, n, "ok");
  pthread_mutex_lock(&p->lock);
  if (max_side == 0) {
    int status = bake(path, exposure, png, size, message, n);
    pthread_mutex_unlock(&p->lock);
    return status;
  }
  entry *e = find_entry(p, job_id, max_side);
  double now = vf_seconds_now();
  e->used_at = now;
  int status = 200;
  if (e->image.rgb == NULL || now - e->looked_at >= VF_PREVIEW_REFRESH_SECONDS) {
    struct stat st;
    if (stat(path, &st) != 0) {
      status = errno == ENOENT ? (snprintf(message, n, "no film checkpoint yet"), 404)
                               : (snprintf(message, n, "%s: %s", path, strerror(errno)), 500);
    } else if (e->image.rgb == NULL || !same_file(e, &st)) {
      vf_image full = {0}, small = {0};
      status = read_film(path, &full, message, n);
      if (status == 200 && downscale(&full, max_side, &small) != VF_OK)
        status = (snprintf(message, n, "out of memory"), 500);
      vf_image_destroy(&full);
      if (status == 200) {
        vf_image_destroy(&e->image);
        free(e->png);
        e->png = NULL;
        e->image = small;
        e->dev = st.st_dev;
        e->ino = st.st_ino;
        e->size = st.st_size;
        e->mtime = st.st_mtim;
      }
    }
    e->looked_at = now;
  }
  if (status != 200) {
    entry_clear(e);
  } else if (e->png == NULL || e->png_exposure != exposure) {
    free(e->png);
    e->png = NULL;
    int err = vf_image_encode_png(&e->image, (float)exposure, &e->png, &e->png_size);
    if (err != VF_OK) status = (snprintf(message, n, "%s", vf_error_detail(err)), 500);
    e->png_exposure = exposure;
  }
  if (status == 200 && (*png = malloc(e->png_size)) == NULL) status = (snprintf(message, n, "out of memory"), 500);
  if (status == 200) {
    memcpy(*png, e->png, e->png_size);
    *size = e->png_size;
  }
  pthread_mutex_unlock(&p->lock);
  return status;
}
