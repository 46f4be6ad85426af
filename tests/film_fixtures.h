/* What the film tests share (test_film, test_image, test_continue, test_plot,
 * test_convergence, test_film_tools): a scratch directory and paths in it, whole-file
 * helpers, command functions run in-process, and small films whose iterations are a pure
 * function of their index.
 *
 * Nothing here asserts: check.h keeps its counters per translation unit, so a helper
 * reports failure by its result and the test checks that. */
#ifndef VF_TEST_FILM_FIXTURES_H
#define VF_TEST_FILM_FIXTURES_H

#include "common/film.h"

#include <stddef.h>
#include <stdint.h>

/* ---- the scratch directory ---- */

/* Creates the test's private directory VF_BINARY_DIR/TEST.XXXXXX. 0, or -1 with a message. */
int fixture_scratch_open(const char *test);
const char *fixture_scratch_dir(void);
/* DIR/name in one of 16 rotating buffers: valid until 16 more calls. */
const char *fixture_path(const char *name);
/* Removes the directory and everything in it: 0, or -1 (with a note) when it remains. */
int fixture_scratch_close(void);

/* ---- files ---- */

/* All of path in a new buffer (the caller frees), *size its length; NULL when unreadable. */
unsigned char *fixture_slurp(const char *path, size_t *size);
/* Replaces path with size bytes (or this text): 1, or 0 on failure. */
int fixture_spill(const char *path, const void *bytes, size_t size);
int fixture_spill_text(const char *path, const char *text);
/* 1 when path holds exactly these bytes (or this text), else 0. */
int fixture_file_holds(const char *path, const void *bytes, size_t size);
int fixture_file_holds_text(const char *path, const char *text);
int fixture_exists(const char *path);
/* 1 when no temporary file of an atomic write (a name with ".tmp.") is left in the
 * scratch directory. */
int fixture_no_temp_files(void);

/* Runs child(user) in a child process whose files may not grow past `limit` bytes, with
 * SIGXFSZ ignored so that a write past it fails (EFBIG) as on a full disk; the child exits
 * with child's result. Returns the child's wait status (waitpid), -1 if it did not start. */
int fixture_run_with_file_limit(long limit, int (*child)(void *), void *user);

/* ---- command functions ---- */

/* Runs cmd (vf_cmd_render, vf_cmd_merge, ...) on the NULL-terminated arguments, name
 * first, standard output flushed around it: its exit status. The strings are passed as
 * they are, not copied: a command that restarts getopt with optind = 1 rather than 0 keeps
 * a pointer into the previous call's arguments, which must therefore stay valid (string
 * literals, fixture_path). */
int fixture_run(int (*cmd)(int, char **), const char *name, ...);

/* ---- films ---- */

uint64_t fixture_xorshift(uint64_t *state);
/* Uniform in [0, 1), from the next xorshift state. */
double fixture_uniform(uint64_t *state);

/* The camera and light inputs (3 floats per pixel each) of one iteration of a w x h
 * "render", a pure function of the iteration's index, spanning four decades: films that
 * receive the same iterations in different groupings must agree. */
void fixture_iteration_inputs(int w, int h, uint64_t iteration, float *cam, float *light);

/* A film of iterations [begin, end) of those inputs: scene hash 0xab..., canonical
 * settings text with this seed at w x h, 1.25 s of render time per iteration. NULL when
 * it cannot be created. */
vf_film *fixture_film(int w, int h, uint64_t begin, uint64_t end, int seed);

/* Writes to path a forged film of version 2 (no checksum) with film's size, scene hash,
 * settings and scene name but the iteration set `iterations` (vf_iterset_format text) and
 * film's sums as they are: a film vf_film_write would refuse (N = 0 with sums...). VF_OK or
 * an error. */
int fixture_forge_film(const char *path, const vf_film *film, const char *iterations);

#endif
