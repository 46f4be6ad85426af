/* The OpenEXR robustness corpus (shared/exr-corpus beside the checkout, found through the
 * VF_SOURCE_DIR that tests/CMakeLists.txt passes in) as test_film.c and test_image.c walk it:
 * its folders as sorted file lists, and a way to read an untrusted file in a child process
 * so that a crash or a hang of the reader under test is reported, not suffered.
 * Compiled into those two tests, never into a library. Nothing here checks: check.h keeps a
 * case's state in the test's own translation unit, so the tests judge what these return. */
#ifndef VF_TEST_EXR_CORPUS_H
#define VF_TEST_EXR_CORPUS_H

#define EXR_CORPUS VF_SOURCE_DIR "/../shared/exr-corpus"

/* Every file of the corpus, valid or damaged, must be read or refused within this time. */
#define EXR_CORPUS_MAX_SECONDS_PER_FILE 5.0

/* 1 when the corpus is there (its Damaged folder); otherwise prints a note that the corpus
 * cases are skipped and returns 0. */
int exr_corpus_present(void);

/* The regular files of one folder (a full path), sorted by name, dot files left out and
 * README files too unless include_readme. Returns their count and the paths in *paths, which
 * the caller frees with exr_corpus_list_free(); 0 and NULL when the folder cannot be opened. */
int exr_corpus_list(const char *folder, int include_readme, char ***paths);
void exr_corpus_list_free(char **paths, int count);

/* A path inside the corpus without the corpus prefix ("Damaged/x.exr"), for messages. */
const char *exr_corpus_name(const char *path);

/* Monotonic wall-clock seconds, for the per-file time limit. */
double exr_corpus_seconds(void);

/* Calls reader(path) in a forked child that exits with its return value (0 .. 255); a hang
 * past 30 s becomes SIGALRM. Returns the child's exit status, or -1 when a signal ended it
 * (or fork failed), with the signal's number in *signal_number (0 otherwise) and the child's
 * wall time in *seconds. stdout and stderr are flushed first, so nothing is printed twice. */
int exr_corpus_read_in_child(int (*reader)(const char *path), const char *path, double *seconds,
                             int *signal_number);

#endif
