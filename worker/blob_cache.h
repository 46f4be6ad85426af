/* A worker's cache of scene files: a blob store (common/blob.h) in a directory of its
 * own, filled from the coordinator by content hash. A file used by several jobs, or by
 * every lease of one job on a restarted worker, is transferred once.
 *
 * Every blob is checked against its hash when it arrives and again when a job takes it
 * from the cache (a damaged copy is fetched again), so what the worker loads is what was
 * submitted; the scene hash check after loading (worker_cmd.c) closes the loop. */
#ifndef VF_BLOB_CACHE_H
#define VF_BLOB_CACHE_H

#include "../common/blob.h"
#include "../common/farm_client.h"
#include "scene/scene.h"

#include <stddef.h>
#include <stdint.h>

/* $XDG_CACHE_HOME/vcmfarm, else $HOME/.cache/vcmfarm, into out. VF_EINVAL when neither
 * variable is set (then --cache is needed). */
int vf_blob_cache_default_dir(char *out, size_t n);

/* Creates the cache directory (and its parents) if needed and checks that it is writable,
 * so a worker that could not keep files says so when it starts, not when a job needs
 * them. VF_EIO with a detail naming the directory. */
int vf_blob_cache_open(const char *cache_dir);

/* Makes every file of `files` available in cache_dir: checks the cached ones and fetches
 * the others (BlobRequest as worker_id), one per request, checking size and hash before
 * storing, and touches every one (its last use, for vf_blob_cache_trim). Logs each blob
 * fetched unless quiet. *fetched (may be NULL) counts the blobs
 * transferred.
 * Errors name the file: VF_EREFUSED (the coordinator does not have it), VF_EMISMATCH
 * (bytes or size not those of the table), VF_ETIMEDOUT / VF_ENET (try again later),
 * VF_EIO. */
int vf_blob_cache_fill(vf_farm_client *client, uint64_t worker_id, const char *cache_dir, const vf_blob_table *files,
                       int quiet, unsigned *fetched);

/* Keeps the cache at most max_bytes (0: no limit) by removing the blobs used least
 * recently (a blob's modification time is its last use: vf_blob_cache_fill touches the
 * blobs a job takes), never one of `keep` (the files of the job about to render, NULL:
 * none). Returns the number of blobs removed; a cache that the kept blobs alone make too
 * big stays so. */
unsigned vf_blob_cache_trim(const char *cache_dir, uint64_t max_bytes, const vf_blob_table *keep);

/* A lease's scene: its file table checked, its files in the cache (then the cache
 * trimmed to max_bytes, keeping them), then loaded as vf_job_scene_load does. *out on success only; errors of the steps, with details naming
 * `label`. */
int vf_blob_cache_load_scene(vf_farm_client *client, uint64_t worker_id, const char *cache_dir,
                             uint64_t max_bytes, const Vcmfarm__Scene *scene, const char *label, int quiet,
                             vf_scene **out);

#endif
