/* The coordinator's state directory, enough to resume every job after any crash:
 *
 *   DIR/state.json     format version, next job id, and per job: id, name, priority,
 *                      scene kind and hash, settings, stop conditions, running time,
 *                      whether it has a reference, cancelled/failed/stopped + why
 *   DIR/job-ID.scene   the job's scene (built-in name or JSON text), written at submit
 *   DIR/job-ID.files   the table of the files a JSON scene names (name, hash, size; JSON),
 *                      written before the scene; absent when it names none
 *   DIR/blobs/HEX      those files' bytes by content hash, shared by all jobs, written
 *                      when received (coordinator/blobs.h, common/blob.h)
 *   DIR/job-ID.exr     the job's film, checkpointed (docs/FILM.md), with its convergence log
 *   DIR/job-ID.reference.exr  the job's reference image, if it has one, written at submit
 *   DIR/job-ID.pilot.exr  a job with a pilot, during its pilot: the pilot film (a film
 *                      marked a pilot's, docs/FILM.md), checkpointed as the job's film is;
 *                      once the job's film holds the allocation (which is also kept as a
 *                      blob, coordinator/blobs.h) it is removed at the next start
 *   DIR/lock           held (flock) by the running coordinator
 *
 * Every file is replaced atomically (temporary, fsync, rename), so a SIGKILL at any moment
 * leaves each file either old or new. A job's film is the truth about its progress: after
 * a restart, iterations in the film are done and everything else goes back to the pool
 * (leases are not persisted). Files are untrusted input when read back.
 *
 * Films are written off the event loop (coordinator/checkpoint.h), so state.json may be
 * written while a job's final film is still on its way: until it lands, a stopped job is
 * recorded as active, so that a crash in between cannot leave it stopped short of the
 * iterations it had merged (it resumes from its last film and stops again). */
#ifndef VF_STATE_H
#define VF_STATE_H

#include "farm_core.h"

/* Creates DIR if needed and takes its lock; VF_EIO with a detail if another process
 * holds it. *fd (the lock's descriptor, closed at exit) is written on success only. */
int vf_state_lock(const char *dir, int *fd);

/* Loads DIR/state.json (if present) and each job's scene and film into an empty farm.
 * A missing film means no iteration done. A film that cannot be read or does not match
 * its job (truncated, damaged, extended past the job's range) fails that job alone, with
 * the reason as its message and an event (job->film_unreadable: its file is never
 * written over); any other malformed file is an error naming the file (VF_EINVAL...). */
int vf_state_load(vf_farm *farm);

int vf_state_save_index(vf_farm *farm);          /* state.json; clears farm->state_dirty */

/* A state directory deleted while the coordinator runs is made again (with its parents),
 * and one emptied (its lock file, farm->state_lock_fd, has lost its name) is filled again:
 * locked again, and every job's scene text, file table and reference written again; every
 * film and the job list are marked to be written by the checkpoint that follows, so that no
 * finished job waits for a final film that cannot land and a restart finds its jobs. 0 when
 * the directory is there, 1 when it was made again, a negative error (logged) when it
 * cannot be: the films stay in memory and the next checkpoint tries again. The blobs of
 * scenes' files are not in memory and are lost with the directory (logged per job). */
int vf_state_recreate(vf_farm *farm);
int vf_state_save_scene(const char *dir, const vf_job *job); /* job-ID.files, then job-ID.scene */
/* Writes the job's film on the calling thread; clears job->film_dirty, final_pending and
 * checkpoint_error. Nothing for a film that could not be read back (job->film_unreadable). */
int vf_state_save_film(const char *dir, vf_job *job);
/* Writes the pilot film of a job in its pilot phase (job->pilot_film, coordinator/job.h) to
 * DIR/job-ID.pilot.exr on the calling thread and clears job->pilot_dirty; nothing for a job
 * without one. Read back at start (a job whose film has its allocation needs it no more:
 * the file is removed then). */
int vf_state_save_pilot(const char *dir, vf_job *job);
/* DIR/job-ID.exr into buf (n bytes); VF_EINVAL when it does not fit. */
int vf_state_film_path(const char *dir, uint64_t id, char *buf, size_t n);
/* DIR/job-ID.pilot.exr, the same way. */
int vf_state_pilot_path(const char *dir, uint64_t id, char *buf, size_t n);
/* Makes DIR/job-ID.reference.exr the blob of hash (a hard link: no copy, and it outlives
 * the blob) and loads it into the job (vf_job_load_reference); on failure removes it
 * again: VF_EIO, or the reading error of a bad image. */
int vf_state_save_reference(const char *dir, vf_job *job, const uint8_t hash[32]);
/* Removes the files of a job that was refused after they were written. */
void vf_state_remove_job_files(const char *dir, uint64_t id);

#endif
