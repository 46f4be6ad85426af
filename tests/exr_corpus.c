/* Walking the OpenEXR corpus for test_film.c and test_image.c (exr_corpus.h). */
#include "exr_corpus.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

int exr_corpus_present(void) {
  struct stat st;
  if (stat(EXR_CORPUS "/Damaged", &st) == 0 && S_ISDIR(st.st_mode)) return 1;
  printf("  note: %s not found, corpus cases skipped\n", EXR_CORPUS);
  return 0;
}

int exr_corpus_list(const char *folder, int include_readme, char ***paths) {
  *paths = NULL;
  DIR *d = opendir(folder);
  if (d == NULL) return 0;
  char **names = NULL;
  int n = 0;
  struct dirent *e;
  while ((e = readdir(d)) != NULL) {
    if (e->d_name[0] == '.') continue;
    if (!include_readme && strstr(e->d_name, "README")) continue;
    names = realloc(names, (size_t)(n + 1) * sizeof *names);
    names[n] = malloc(strlen(folder) + strlen(e->d_name) + 2);
    sprintf(names[n], "%s/%s", folder, e->d_name);
    n++;
  }
  closedir(d);
  /* sorted, so that the output and the first failure do not depend on the file system */
  for (int i = 1; i < n; i++)
    for (int j = i; j > 0 && strcmp(names[j - 1], names[j]) > 0; j--) {
      char *t = names[j];
      names[j] = names[j - 1];
      names[j - 1] = t;
    }
  *paths = names;
  return n;
}

void exr_corpus_list_free(char **paths, int count) {
  for (int i = 0; i < count; i++) free(paths[i]);
  free(paths);
}

const char *exr_corpus_name(const char *path) {
  size_t n = strlen(EXR_CORPUS);
  return strncmp(path, EXR_CORPUS, n) == 0 && path[n] == '/' ? path + n + 1 : path;
}

double exr_corpus_seconds(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

int exr_corpus_read_in_child(int (*reader)(const char *path), const char *path, double *seconds,
                             int *signal_number) {
  fflush(stdout);
  fflush(stderr);
  double t0 = exr_corpus_seconds();
  pid_t pid = fork();
  if (pid == 0) {
    alarm(30); /* a hang becomes a signal the parent reports */
    exit(reader(path));
  }
  *seconds = 0.0;
  *signal_number = 0;
  if (pid < 0) return -1; /* waitpid(-1) would reap some other child */
  int status = 0;
  waitpid(pid, &status, 0);
  *seconds = exr_corpus_seconds() - t0;
  *signal_number = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}
