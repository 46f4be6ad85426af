/* Command-line helpers shared by the subcommands: strict number parsing with ranges and
 * the exit-status convention (0 success, 1 failure while working, 2 bad input: command
 * line, scene, EXR file or film). */
#ifndef VF_OPTIONS_H
#define VF_OPTIONS_H

#include "../common/settings.h"

#include <stdint.h>

enum { VF_EXIT_OK = 0, VF_EXIT_FAILURE = 1, VF_EXIT_BAD_INPUT = 2 };

/* Each parses the whole of text or fails with VF_EUSAGE and a detail naming the option. */
int vf_cli_int(const char *option, const char *text, long long min, long long max, long long *out);
int vf_cli_u64(const char *option, const char *text, uint64_t *out);
int vf_cli_double(const char *option, const char *text, double min, double max, double *out);
int vf_cli_resolution(const char *option, const char *text, int *width, int *height);
/* A size in bytes: a whole number with an optional suffix K, M, G or T (powers of 1024),
 * at least 1. VF_EUSAGE naming the option. */
int vf_cli_bytes(const char *option, const char *text, uint64_t *out);
/* Checks, before hours of work, that a file can be written at path: its directory exists
 * and is writable, and path is not a directory. VF_EUSAGE naming the option and the path. */
int vf_cli_writable(const char *option, const char *path);

/* The render settings a command line may override (render, submit): -a/--algorithm,
 * -s/--seed, -l/--max-path-length, -r/--radius-factor, --alpha (option value 'A'),
 * -R/--resolution. Unset fields leave the scene's settings as they are. */
typedef struct {
  const char *algorithm; /* borrowed from argv, or NULL */
  uint64_t seed;
  int have_seed, have_resolution, width, height;
  long long max_path_length; /* <= 0: unset */
  double radius_factor, alpha; /* <= 0: unset */
} vf_cli_settings;

void vf_cli_settings_init(vf_cli_settings *o);
/* If option c is one of the settings options, parses arg into o, stores the result code
 * in *err and returns 1; otherwise returns 0. */
int vf_cli_settings_option(vf_cli_settings *o, int c, const char *arg, int *err);

/* Applies the overrides to *settings (an algorithm name is checked here). */
int vf_cli_settings_apply(const vf_cli_settings *o, vf_settings *settings);

/* Exit status for an error code: 2 for bad input, 1 otherwise. */
int vf_cli_exit_status(int err);

/* Prints "vcmfarm CMD: detail" to stderr and returns vf_cli_exit_status(err). */
int vf_cli_fail(const char *command, int err);

/* getopt_long's answer '?' or ':' for `vcmfarm CMD`: names the option it could not take
 * (argv[optind - 1]), prints the command's usage and returns VF_EXIT_BAD_INPUT. */
int vf_cli_bad_option(const char *command, char **argv, const char *usage);

#endif
