#include "writer.h"

#include "../common/clock.h"
#include "../common/error.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct vf_writer {
  uv_loop_t *loop; /* borrowed */
  vf_farm *farm;   /* borrowed */
};

/* One write: lives from vf_writer_start to its after-callback. */
typedef struct {
  uv_work_t work;
  vf_writer *writer;
  uint64_t job_id;
  vf_film *snapshot; /* owned */
  char *path;        /* owned */
  int err;
  char detail[1024]; /* the error detail is per thread: carried back to the loop's */
  double seconds;
} film_write;

int vf_writer_create(uv_loop_t *loop, vf_farm *farm, vf_writer **out) {
  vf_writer *w = calloc(1, sizeof *w);
  if (w == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  w->loop = loop;
  w->farm = farm;
  *out = w;
  return VF_OK;
}

void vf_writer_destroy(vf_writer *w) { free(w); }

/* On a thread of libuv's pool: touches only the write's own snapshot and path. */
static void write_film(uv_work_t *work) {
  film_write *fw = work->data;
  double t0 = vf_seconds_now();
  vf_error_clear();
  fw->err = vf_film_write(fw->snapshot, fw->path);
  if (fw->err != VF_OK) snprintf(fw->detail, sizeof fw->detail, "%s", vf_error_detail(fw->err));
  fw->seconds = vf_seconds_now() - t0;
}

/* Back on the loop. */
static void written(uv_work_t *work, int status) {
  film_write *fw = work->data;
  int err = fw->err;
  if (status != 0) err = vf_error_set(VF_EIO, "%s: the write was cancelled: %s", fw->path, uv_strerror(status));
  else if (err != VF_OK) err = vf_error_set(err, "%s", fw->detail);
  vf_film_destroy(fw->snapshot);
  vf_farm_film_written(fw->writer->farm, fw->job_id, err, fw->seconds);
  free(fw->path);
  free(fw);
}

int vf_writer_start(void *ctx, uint64_t job_id, vf_film *snapshot, const char *path) {
  vf_writer *w = ctx;
  film_write *fw = calloc(1, sizeof *fw);
  char *copy = strdup(path);
  if (fw == NULL || copy == NULL) {
    free(fw);
    free(copy);
    return vf_error_set(VF_ENOMEM, "out of memory starting a checkpoint of %s", path);
  }
  fw->work.data = fw;
  fw->writer = w;
  fw->job_id = job_id;
  fw->snapshot = snapshot;
  fw->path = copy;
  int rv = uv_queue_work(w->loop, &fw->work, write_film, written);
  if (rv != 0) {
    free(copy);
    free(fw);
    return vf_error_set(VF_EIO, "%s: cannot start the checkpoint: %s", path, uv_strerror(rv));
  }
  return VF_OK;
}
