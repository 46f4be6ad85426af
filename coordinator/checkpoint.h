/* Film checkpoints off the event loop: the coordinator's film writer (vf_farm_film_writer).
 *
 * Writing a 1920x1080 job film (ZIP compression of 23 float channels, fsync, rename) takes
 * seconds; on the loop it would leave every worker and client unanswered that long. The
 * farm copies the film on the loop (a memcpy, tens of milliseconds at that size) and hands
 * the copy here; libuv's thread pool (uv_queue_work) writes it atomically as before
 * (temporary file, fsync, rename, fsync of the directory: vf_film_write), and the
 * after-callback, back on the loop, reports to the farm with vf_farm_film_written. The farm
 * never starts two writes of one job, so a file is only ever written by one thread. */
#ifndef VF_WRITER_H
#define VF_WRITER_H

#include "../common/film.h"
#include "farm.h"

#include <stdint.h>
#include <uv.h>

typedef struct vf_writer vf_writer;

/* A writer on `loop` reporting to `farm` (both borrowed, outliving it). *out on success. */
int vf_writer_create(uv_loop_t *loop, vf_farm *farm, vf_writer **out);
/* Frees the writer; call only when no write is pending (vf_farm_writes_pending is 0).
 * NULL is a no-op. */
void vf_writer_destroy(vf_writer *w);

/* vf_farm_film_writer: ctx is the vf_writer. Takes ownership of snapshot on VF_OK;
 * path is copied. VF_ENOMEM, or VF_EIO when libuv refuses the work. */
int vf_writer_start(void *ctx, uint64_t job_id, vf_film *snapshot, const char *path);

#endif
