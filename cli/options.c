#include "options.h"

#include "../common/error.h"

#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

int vf_cli_int(const char *option, const char *text, long long min, long long max, long long *out) {
  char *end;
  errno = 0;
  long long v = strtoll(text, &end, 10);
  if (errno || end == text || *end != '\0' || v < min || v > max)
    return vf_error_set(VF_EUSAGE, "%s: '%s' is not a whole number in [%lld, %lld]", option, text, min, max);
  *out = v;
  return VF_OK;
}

int vf_cli_u64(const char *option, const char *text, uint64_t *out) {
  char *end;
  errno = 0;
  if (text[0] == '-') return vf_error_set(VF_EUSAGE, "%s: '%s' must not be negative", option, text);
  unsigned long long v = strtoull(text, &end, 10);
  if (errno || end == text || *end != '\0')
    return vf_error_set(VF_EUSAGE, "%s: '%s' is not a whole number", option, text);
  *out = v;
  return VF_OK;
}

int vf_cli_double(const char *option, const char *text, double min, double max, double *out) {
  char *end;
  errno = 0;
  double v = strtod(text, &end);
  if (errno || end == text || *end != '\0' || !isfinite(v) || v < min || v > max)
    return vf_error_set(VF_EUSAGE, "%s: '%s' is not a number in [%g, %g]", option, text, min, max);
  *out = v;
  return VF_OK;
}

int vf_cli_resolution(const char *option, const char *text, int *width, int *height) {
  int w, h, n = 0;
  if (sscanf(text, "%dx%d%n", &w, &h, &n) != 2 || text[n] != '\0' || w < 1 || h < 1 || w > 65536 || h > 65536)
    return vf_error_set(VF_EUSAGE, "%s: '%s' is not WIDTHxHEIGHT with both in [1, 65536]", option, text);
  *width = w;
  *height = h;
  return VF_OK;
}

void vf_cli_settings_init(vf_cli_settings *o) {
  *o = (vf_cli_settings){NULL, NULL, 0, 0, 0, 0, 0, -1, -1.0, -1.0};
}

int vf_cli_settings_option(vf_cli_settings *o, int c, const char *arg, int *err) {
  switch (c) {
  case 'a': o->algorithm = arg; *err = VF_OK; return 1;
  case 'Q': o->sampler = arg; *err = VF_OK; return 1;
  case 's': o->have_seed = 1; *err = vf_cli_u64("--seed", arg, &o->seed); return 1;
  case 'l': *err = vf_cli_int("--max-path-length", arg, 1, VF_MAX_PATH_LENGTH, &o->max_path_length); return 1;
  case 'r': *err = vf_cli_double("--radius-factor", arg, 1e-12, 1.0, &o->radius_factor); return 1;
  case 'A': *err = vf_cli_double("--alpha", arg, 1e-6, 1.0, &o->alpha); return 1;
  case 'R':
    o->have_resolution = 1;
    *err = vf_cli_resolution("--resolution", arg, &o->width, &o->height);
    return 1;
  default: return 0;
  }
}

int vf_cli_settings_apply(const vf_cli_settings *o, vf_settings *settings) {
  int err;
  if (o->algorithm && (err = vf_algorithm_parse(o->algorithm, &settings->algorithm)) != VF_OK) return err;
  if (o->sampler && (err = vf_sampler_parse(o->sampler, &settings->sampler)) != VF_OK) return err;
  if (o->have_seed) settings->seed = o->seed;
  if (o->max_path_length > 0) settings->max_path_length = (int)o->max_path_length;
  if (o->radius_factor > 0.0) settings->radius_factor = o->radius_factor;
  if (o->alpha > 0.0) settings->alpha = o->alpha;
  if (o->have_resolution) {
    settings->width = o->width;
    settings->height = o->height;
  }
  return VF_OK;
}

int vf_cli_extension(const char *option, const char *path, const char *ext, const char *what) {
  size_t n = strlen(path), e = strlen(ext);
  if (n > e && strcasecmp(path + n - e, ext) == 0) return VF_OK;
  return vf_error_set(VF_EUSAGE, "%s: '%s' must be a %s file (%s is written there), but it does not end in %s",
                      option, path, ext, what, ext);
}

int vf_cli_not_input(const char *output_option, const char *output, const char *input_option, const char *input) {
  struct stat a, b;
  int same = strcmp(output, input) == 0 ||
             (stat(output, &a) == 0 && stat(input, &b) == 0 && a.st_dev == b.st_dev && a.st_ino == b.st_ino);
  if (!same) return VF_OK;
  return vf_error_set(VF_EUSAGE, "%s %s is the %s file: writing it would replace that input", output_option, output,
                      input_option);
}

int vf_cli_stop_option(vf_cli_stop *s, int c, const char *arg, int *err) {
  switch (c) {
  case 'n': *err = vf_cli_int("--iterations", arg, 1, (long long)VF_CLI_ITERATIONS_OPEN_ENDED, &s->iterations); return 1;
  case 't': *err = vf_cli_double("--time", arg, 1e-3, 366.0 * 86400.0, &s->time_limit); return 1;
  case 'F': s->reference = arg; *err = VF_OK; return 1;
  case 'X': *err = vf_cli_double("--target-rmse", arg, 1e-30, 1e30, &s->target_rmse); return 1;
  case 'E': *err = vf_cli_double("--target-error", arg, 1e-30, 1e30, &s->target_error); return 1;
  default: return 0;
  }
}

int vf_cli_stop_check(const vf_cli_stop *s, int exclusive) {
  if (exclusive && s->iterations > 0 && s->time_limit > 0.0)
    return vf_error_set(VF_EUSAGE, "give --iterations or --time, not both");
  if (s->target_rmse > 0.0 && s->reference == NULL) return vf_error_set(VF_EUSAGE, "--target-rmse needs --reference");
  return VF_OK;
}

int vf_cli_stop_open_ended(const vf_cli_stop *s) {
  return s->time_limit > 0.0 || s->target_rmse > 0.0 || s->target_error > 0.0;
}

uint64_t vf_cli_stop_iterations(const vf_cli_stop *s) {
  if (s->iterations > 0) return (uint64_t)s->iterations;
  return vf_cli_stop_open_ended(s) ? VF_CLI_ITERATIONS_OPEN_ENDED : VF_CLI_ITERATIONS_DEFAULT;
}

int vf_cli_checkpoint_option(vf_cli_checkpoint *c, const char *arg) {
  c->given = 1;
  return vf_cli_double("--checkpoint-interval", arg, 0.0, 1e9, &c->seconds);
}

double vf_cli_checkpoint_next(const vf_cli_checkpoint *c, double cost) {
  if (c->given) return c->seconds;
  return fmin(fmax(VF_CLI_CHECKPOINT_COST * cost, VF_CLI_CHECKPOINT_SECONDS), VF_CLI_CHECKPOINT_MAX_SECONDS);
}

int vf_cli_bytes(const char *option, const char *text, uint64_t *out) {
  char *end;
  errno = 0;
  if (text[0] < '0' || text[0] > '9') return vf_error_set(VF_EUSAGE, "%s: '%s' is not a size", option, text);
  unsigned long long v = strtoull(text, &end, 10);
  int shift = 0;
  switch (*end) {
  case 'K': shift = 10; break;
  case 'M': shift = 20; break;
  case 'G': shift = 30; break;
  case 'T': shift = 40; break;
  case '\0': break;
  default: return vf_error_set(VF_EUSAGE, "%s: '%s' is not a size (a number, then K, M, G or T)", option, text);
  }
  if (*end != '\0' && end[1] != '\0')
    return vf_error_set(VF_EUSAGE, "%s: '%s' is not a size (a number, then K, M, G or T)", option, text);
  if (errno != 0 || v == 0 || v > (UINT64_MAX >> shift))
    return vf_error_set(VF_EUSAGE, "%s: '%s' is out of range", option, text);
  *out = (uint64_t)v << shift;
  return VF_OK;
}

int vf_cli_writable(const char *option, const char *path) {
  char dir[4096];
  const char *slash = strrchr(path, '/');
  if (slash == NULL) snprintf(dir, sizeof dir, ".");
  else if (slash == path) snprintf(dir, sizeof dir, "/");
  else if ((size_t)(slash - path) < sizeof dir) snprintf(dir, sizeof dir, "%.*s", (int)(slash - path), path);
  else return vf_error_set(VF_EUSAGE, "%s %s: path too long", option, path);
  struct stat st;
  if (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode))
    return vf_error_set(VF_EUSAGE, "%s %s: no directory %s", option, path, dir);
  if (access(dir, W_OK | X_OK) != 0)
    return vf_error_set(VF_EUSAGE, "%s %s: cannot write in %s: %s", option, path, dir, strerror(errno));
  if (stat(path, &st) == 0 && S_ISDIR(st.st_mode))
    return vf_error_set(VF_EUSAGE, "%s %s: is a directory", option, path);
  return VF_OK;
}

int vf_cli_exit_status(int err) {
  switch (err) {
  case VF_OK: return VF_EXIT_OK;
  case VF_EINVAL:
  case VF_ENOENT:
  case VF_EUSAGE:
  case VF_ESCENE:
  case VF_EMESH:
  case VF_ETEXTURE:
  case VF_EEXR:
  case VF_EFILM:
  case VF_EMISMATCH:
  case VF_EOVERLAP:
  case VF_EBUSY: /* refused before anything was written, like bad input */
    return VF_EXIT_BAD_INPUT;
  default: return VF_EXIT_FAILURE;
  }
}

int vf_cli_fail(const char *command, int err) {
  fprintf(stderr, "vcmfarm %s: %s\n", command, vf_error_detail(err));
  return vf_cli_exit_status(err);
}

int vf_cli_bad_option(const char *command, char **argv, const char *usage) {
  fprintf(stderr, "vcmfarm %s: unknown or incomplete option '%s'\n%s", command, argv[optind - 1], usage);
  return VF_EXIT_BAD_INPUT;
}

void vf_cli_print_notes(const char *source, const char *notes) {
  const char *slash = strrchr(source, '/'), *base = slash ? slash + 1 : source;
  size_t k = strlen(base);
  for (const char *line = notes; line != NULL && *line != '\0';) {
    /* A model file's notes name it; its scene's label names it already. */
    if (strncmp(line, base, k) == 0 && strncmp(line + k, ": ", 2) == 0) line += k + 2;
    const char *end = strchr(line, '\n');
    int n = end ? (int)(end - line) : (int)strlen(line);
    fprintf(stderr, "%s: note: %.*s\n", source, n, line);
    line = end ? end + 1 : NULL;
  }
}
