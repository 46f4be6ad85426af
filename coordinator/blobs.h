/* The coordinator's side of scene files by content hash (docs/PROTOCOL.md, "Files of
 * scenes"): it keeps every blob once, by hash, in the state directory's blob store
 * (DIR/blobs/HEX, common/blob.h), whoever sent it and however many jobs use it; it checks
 * a job's file table against the store before accepting the job; and it serves blobs to
 * workers. A blob goes when the last job naming it is removed (coordinator/jobs.h), or,
 * named by none, a day after it arrived (vf_blobs_collect).
 *
 * A blob is read back and checked against its name before it is used (a query, a worker's
 * first chunk, a reference), but once per version of the file: a blob found intact is
 * read again only when its size or modification time changed, so a file of gigabytes does
 * not stall the loop at every request for it.
 *
 * The handlers answer into a vf_farm_reply (coordinator/farm_reply.h); coordinator/farm.c
 * dispatches to them. */
#ifndef VF_COORDINATOR_BLOBS_H
#define VF_COORDINATOR_BLOBS_H

#include "farm_core.h"
#include "farm_reply.h"

/* Checks a submitted scene's file table (common/blob.h checks, no files for a built-in
 * scene, every blob held with the table's size) and gives it to the job. VF_EINVAL with a
 * detail naming the file, VF_ENOMEM. */
int vf_blobs_attach(const vf_farm *farm, vf_job *job, const Vcmfarm__Scene *scene);

/* Checks a submitted reference's entry: a 32-byte hash of a blob the store holds, intact,
 * with the entry's size. VF_EINVAL naming the problem ("send it first"), VF_EIO. */
int vf_blobs_reference(vf_farm *farm, const Vcmfarm__BlobRef *ref);

/* The text of a JSON scene sent as a blob (Scene.json_blob): the blob must be held, intact,
 * of the entry's size and at most VF_JOB_MAX_SCENE bytes. *text (malloc'ed and
 * NUL-terminated, the caller frees) and *len on success; VF_EINVAL naming the problem
 * ("send it first"), VF_EIO, VF_ENOMEM. */
int vf_blobs_scene_text(vf_farm *farm, const Vcmfarm__BlobRef *ref, char **text, size_t *len);

/* Puts the job's file table into the lease being built (r->scene.files). VF_ENOMEM. */
int vf_blobs_lease(const vf_job *job, vf_farm_reply *r);

/* The allocation a job was submitted with (SubmitJob.allocation, version 12): a blob the
 * store holds, intact, of `pixels` bytes, whose counts vf_allocation_validate accepts.
 * *samples (malloc'ed, the caller frees) on success; VF_EINVAL naming the problem ("send
 * it first", a size that is not the film's), VF_EFILM for counts that are not an
 * allocation, VF_EIO, VF_ENOMEM. */
int vf_blobs_allocation(vf_farm *farm, const Vcmfarm__BlobRef *ref, size_t pixels, uint8_t **samples);

/* A job with a pilot whose allocation is computed (job->film->samples): its counts, one byte
 * a pixel, kept in the blob store under job->allocation_hash (written unless there and
 * intact), which leases name (Lease.allocation) and workers fetch like a scene's file.
 * VF_OK at once for a job without one; errors of the store (VF_EIO) naming the job. */
int vf_blobs_put_allocation(vf_farm *farm, const vf_job *job);

/* 1 when a job of the farm other than `except` (may be NULL) names the blob among its
 * scene's files. */
int vf_blobs_named(const vf_farm *farm, const uint8_t hash[32], const vf_job *except);

/* Removes the blobs of the store that no job names and that have not changed for min_age
 * seconds: those of submissions that failed after their files were sent, and references
 * (each job keeps a link of its own; coordinator/state.h). A younger one may belong to a
 * submission in progress. The coordinator calls it at start and every hour. Returns the
 * number removed. */
unsigned vf_blobs_collect(const vf_farm *farm, double min_age);

/* BlobQuery -> BlobHave: which of the hashes the store lacks. */
void vf_blobs_query(vf_farm *farm, const Vcmfarm__BlobQuery *m, vf_farm_reply *r);
/* BlobPut -> ResultAck: one chunk of a blob's transfer; the blob is stored once its last
 * chunk is in and the whole hashes to its name (common/blob.h, vf_blob_store_append). */
void vf_blobs_put(vf_farm *farm, const Vcmfarm__BlobPut *m, vf_farm_reply *r);
/* BlobRequest (from a registered worker) -> Blob: the chunk at the requested offset; the
 * first chunk's request reads the whole blob back and checks it first. */
void vf_blobs_request(vf_farm *farm, const vf_farm_worker *w, const Vcmfarm__BlobRequest *m, vf_farm_reply *r);

#endif
