/* Pictures of a job's film for the dashboard (docs/PROTOCOL.md, "Dashboard"): its mean,
 * value x 2^exposure, clamped and sRGB-encoded into a PNG (common/image.h), as of the
 * job's latest film checkpoint, DIR/job-ID.exr (coordinator/checkpoint.h: every
 * --checkpoint-interval while it gains iterations).
 *
 * Made on the HTTP threads, never on the loop: the checkpoint file is replaced by rename,
 * so it can be read at any moment without the farm; only its R, G, B channels are read
 * (they hold the mean, docs/FILM.md). A preview is box-filtered down to at most max_side
 * pixels on its longer side and cached per job: the file is looked at again at most every
 * VF_PREVIEW_REFRESH_SECONDS and read again only when it changed, the PNG encoded again
 * only for another exposure. One picture is made at a time (a mutex), which bounds the
 * memory and the cores the dashboard takes however many browsers ask. */
#ifndef VF_PREVIEW_H
#define VF_PREVIEW_H

#include <stddef.h>
#include <stdint.h>

#define VF_PREVIEW_REFRESH_SECONDS 2.0
#define VF_PREVIEW_MAX_SIDE 2048 /* the largest max_side asked for */

typedef struct vf_previews vf_previews;

/* A cache over the films of state_dir (borrowed). VF_ENOMEM. */
int vf_previews_create(const char *state_dir, vf_previews **out);
void vf_previews_destroy(vf_previews *previews); /* NULL is a no-op */

/* The job's preview (max_side 16 to VF_PREVIEW_MAX_SIDE) or, with max_side 0, the whole
 * film at full resolution (a baked image; not cached). Returns 200 with *png (malloc'ed:
 * the caller frees it) and *size, 404 when the job has no checkpoint yet, 500 when the
 * file cannot be read; message says what happened. */
int vf_previews_png(vf_previews *previews, uint64_t job_id, double exposure, int max_side, uint8_t **png,
                    size_t *size, char *message, size_t n);

#endif
