#include "options.h"

#include "../common/error.h"
#include "../common/film.h"
#include "../common/parse.h"

#include <errno.h>
#include <getopt.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
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
  *o = (vf_cli_settings){NULL, NULL, NULL, NULL, 0, 0, 0, 0, 0, -1, -1.0, -1.0, -1.0, 0, 0, -1};
}

int vf_cli_settings_option(vf_cli_settings *o, int c, const char *arg, int *err) {
  switch (c) {
  case 'a': o->algorithm = arg; *err = VF_OK; return 1;
  case 'Q': o->sampler = arg; *err = VF_OK; return 1;
  case 'G': o->gather = arg; *err = VF_OK; return 1;
  case VF_CLI_OPT_RADIUS: o->radius = arg; *err = VF_OK; return 1;
  case VF_CLI_OPT_VCM_STAGES: *err = vf_cli_int("--vcm-stages", arg, 1, 2, &o->vcm_stages); return 1;
  case VF_CLI_OPT_LIGHT_PATH_PIXELS:
    *err = vf_cli_int("--light-path-pixels", arg, 1, VF_MAX_LIGHT_PATH_PIXELS, &o->light_path_pixels);
    if (*err == VF_OK && (o->light_path_pixels & (o->light_path_pixels - 1)) != 0)
      *err = vf_error_set(VF_EUSAGE, "--light-path-pixels: '%s' is not a power of two (1, 2, 4, ... %d)", arg,
                          VF_MAX_LIGHT_PATH_PIXELS);
    return 1;
  case VF_CLI_OPT_PILOT:
    *err = vf_cli_int("--pilot", arg, 0, VF_MAX_PILOT, &o->pilot);
    if (*err == VF_OK && o->pilot == 1)
      *err = vf_error_set(VF_EUSAGE, "--pilot: a pilot needs at least 2 iterations (0: no pilot)");
    return 1;
  case 's': o->have_seed = 1; *err = vf_cli_u64("--seed", arg, &o->seed); return 1;
  case 'l': *err = vf_cli_int("--max-path-length", arg, 1, VF_MAX_PATH_LENGTH, &o->max_path_length); return 1;
  case 'r': *err = vf_cli_double("--radius-factor", arg, 1e-12, 1.0, &o->radius_factor); return 1;
  case 'A': *err = vf_cli_double("--alpha", arg, 1e-6, 1.0, &o->alpha); return 1;
  case 'B': *err = vf_cli_double("--mis-beta", arg, 1.0, VF_MAX_MIS_BETA, &o->mis_beta); return 1;
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
  if (o->gather && (err = vf_gather_parse(o->gather, &settings->gather)) != VF_OK) return err;
  if (o->radius && (err = vf_radius_mode_parse(o->radius, &settings->radius)) != VF_OK) return err;
  if (o->have_seed) settings->seed = o->seed;
  if (o->max_path_length > 0) settings->max_path_length = (int)o->max_path_length;
  if (o->radius_factor > 0.0) settings->radius_factor = o->radius_factor;
  if (o->alpha > 0.0) settings->alpha = o->alpha;
  if (o->mis_beta > 0.0) settings->mis_beta = o->mis_beta;
  if (o->vcm_stages > 0) settings->vcm_stages = (int)o->vcm_stages;
  if (o->light_path_pixels > 0) settings->light_path_pixels = (int)o->light_path_pixels;
  if (o->pilot >= 0) settings->pilot = (int)o->pilot;
  if (o->have_resolution) {
    settings->width = o->width;
    settings->height = o->height;
  }
  return VF_OK;
}

/* Whether text is a port number: 1 to 5 digits and nothing else. */
static int is_port(const char *text) {
  size_t n = strspn(text, "0123456789");
  return n >= 1 && n <= 5 && text[n] == '\0' && atol(text) <= 65535;
}

int vf_cli_address(const char *option, const char *url) {
  static const char forms[] = "tcp://HOST:PORT or ipc://PATH";
  const char *sep = strstr(url, "://");
  if (sep == NULL) {
    const char *colon = strrchr(url, ':');
    if (colon != NULL && colon > url && is_port(colon + 1))
      return vf_error_set(VF_EUSAGE, "%s %s: an address starts with its scheme: write tcp://%s", option, url, url);
    if (strchr(url, '/') != NULL || strstr(url, ".sock") != NULL)
      return vf_error_set(VF_EUSAGE, "%s %s: an address starts with its scheme: write ipc://%s for this socket file",
                          option, url, url);
    return vf_error_set(VF_EUSAGE, "%s %s: not an address; write %s (tcp://%s:PORT for a host)", option, url, forms,
                        url[0] ? url : "HOST");
  }
  size_t scheme = (size_t)(sep - url);
  const char *rest = sep + 3;
  if (scheme == 3 && strncmp(url, "tcp", 3) == 0) {
    const char *colon = strrchr(rest, ':');
    if (colon == NULL || colon == rest || !is_port(colon + 1))
      return vf_error_set(VF_EUSAGE, "%s %s: a tcp:// address is tcp://HOST:PORT, with a port number", option, url);
    return VF_OK;
  }
  if (scheme == 3 && strncmp(url, "ipc", 3) == 0) {
    if (rest[0] == '\0')
      return vf_error_set(VF_EUSAGE, "%s %s: an ipc:// address names a socket file: ipc://PATH", option, url);
    return VF_OK;
  }
  if (scheme == 6 && strncmp(url, "inproc", 6) == 0)
    return vf_error_set(VF_EUSAGE, "%s %s: inproc:// reaches only a coordinator inside the same process; write %s",
                        option, url, forms);
  return vf_error_set(VF_EUSAGE, "%s %s: unknown scheme '%.*s://'; write %s (tcp://%s for a host and port)", option,
                      url, (int)scheme, url, forms, rest[0] ? rest : "HOST:PORT");
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
  case VF_EAUTH: /* the coordinator refused the key: the key file given is not the farm's */
  case VF_ENOJOB: /* the command line named a job the coordinator does not have */
    return VF_EXIT_BAD_INPUT;
  default: return VF_EXIT_FAILURE;
  }
}

int vf_cli_fail(const char *command, int err) {
  fprintf(stderr, "vcmfarm %s: %s\n", command, vf_error_detail(err));
  return vf_cli_exit_status(err);
}

/* What vf_cli_getopt refused, for vf_cli_bad_option: "unknown option '--x'". */
static char refused_option[512];

const char *vf_cli_plural(unsigned long long n, const char *one, const char *many) { return n == 1 ? one : many; }

/* Levenshtein distance of a[0, n) and b, or a large number when either is too long to
 * be a typo of the other. */
static size_t edit_distance(const char *a, size_t n, const char *b) {
  enum { LONGEST = 64 };
  size_t m = strlen(b), row[LONGEST + 1];
  if (n > LONGEST || m > LONGEST) return (size_t)-1;
  for (size_t j = 0; j <= m; j++) row[j] = j;
  for (size_t i = 1; i <= n; i++) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= m; j++) {
      size_t above = row[j], best = diagonal + (a[i - 1] != b[j - 1]);
      if (above + 1 < best) best = above + 1;
      if (row[j - 1] + 1 < best) best = row[j - 1] + 1;
      row[j] = best;
      diagonal = above;
    }
  }
  return row[m];
}

const char *vf_cli_nearest(const char *word, size_t n, const char *const *names, size_t count) {
  const char *nearest = NULL;
  size_t best = 3; /* at most 2 edits */
  int tie = 0;
  for (size_t i = 0; i < count; i++) {
    size_t d = edit_distance(word, n, names[i]);
    if (d < best) {
      best = d;
      nearest = names[i];
      tie = 0;
    } else if (d == best) {
      tie = 1;
    }
  }
  return tie ? NULL : nearest;
}

/* The long option named exactly name[0, n), or NULL. */
static const struct option *long_option(const struct option *longopts, const char *name, size_t n) {
  for (const struct option *o = longopts; o->name != NULL; o++)
    if (strlen(o->name) == n && strncmp(o->name, name, n) == 0) return o;
  return NULL;
}

/* " (did you mean --iterations?)" for an unknown long option name[0, n): the options it
 * begins (what getopt_long would have taken it for), else the one it is a typo of; or "". */
static void suggest(const struct option *longopts, const char *name, size_t n, char *out, size_t size) {
  const char *names[128], *prefixed[3];
  size_t count = 0, matches = 0;
  for (const struct option *o = longopts; o->name != NULL && count < 128; o++) {
    names[count++] = o->name;
    if (n > 0 && strncmp(o->name, name, n) == 0 && matches < 3) prefixed[matches++] = o->name;
  }
  out[0] = '\0';
  if (matches == 1) snprintf(out, size, " (did you mean --%s?)", prefixed[0]);
  else if (matches == 2) snprintf(out, size, " (did you mean --%s or --%s?)", prefixed[0], prefixed[1]);
  else if (matches == 0) {
    const char *nearest = vf_cli_nearest(name, n, names, count);
    if (nearest) snprintf(out, size, " (did you mean --%s?)", nearest);
  }
}

/* Checks argv as getopt_long will read it (operands anywhere, "--" ends the options),
 * with long options matched exactly; 0, or -1 with refused_option set. */
static int check_argv(int argc, char **argv, const char *shortopts, const struct option *longopts) {
  char hint[256];
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i];
    if (strcmp(a, "--") == 0) return 0;
    if (a[0] != '-' || a[1] == '\0') continue; /* an operand */
    if (a[1] == '-') {
      const char *name = a + 2, *eq = strchr(name, '=');
      size_t n = eq ? (size_t)(eq - name) : strlen(name);
      const struct option *o = long_option(longopts, name, n);
      if (o == NULL) {
        suggest(longopts, name, n, hint, sizeof hint);
        snprintf(refused_option, sizeof refused_option, "unknown option '--%.*s'%s", (int)n, name, hint);
        return -1;
      }
      if (o->has_arg == no_argument && eq) {
        snprintf(refused_option, sizeof refused_option, "option '--%s' takes no value", o->name);
        return -1;
      }
      if (o->has_arg == required_argument && eq == NULL && ++i >= argc) {
        snprintf(refused_option, sizeof refused_option, "option '--%s' needs a value", o->name);
        return -1;
      }
      continue;
    }
    for (const char *p = a + 1; *p != '\0'; p++) {
      const char *spec = *p == ':' ? NULL : strchr(shortopts, *p);
      if (spec == NULL) {
        /* "-iterations": a long option written with one dash */
        hint[0] = '\0';
        if (p == a + 1 && long_option(longopts, a + 1, strlen(a + 1)) != NULL)
          snprintf(hint, sizeof hint, " (did you mean --%s?)", a + 1);
        snprintf(refused_option, sizeof refused_option, "unknown option '-%c'%s", *p, hint);
        return -1;
      }
      if (spec[1] == ':') { /* its value is the rest of this word, or the next word */
        if (p[1] == '\0' && ++i >= argc) {
          snprintf(refused_option, sizeof refused_option, "option '-%c' needs a value", *p);
          return -1;
        }
        break;
      }
    }
  }
  return 0;
}

int vf_cli_getopt(int argc, char **argv, const char *shortopts, const struct option *longopts) {
  if (optind == 0) {
    opterr = 0;
    refused_option[0] = '\0';
    if (check_argv(argc, argv, shortopts, longopts) != 0) return '?';
  }
  int c = getopt_long(argc, argv, shortopts, longopts, NULL);
  if ((c == '?' || c == ':') && refused_option[0] == '\0') /* not foreseen by check_argv */
    snprintf(refused_option, sizeof refused_option, "unknown or incomplete option '%s'",
             optind > 0 && optind <= argc ? argv[optind - 1] : "?");
  return c == ':' ? '?' : c;
}

int vf_cli_bad_option(const char *command) {
  fprintf(stderr, "vcmfarm %s: %s; try 'vcmfarm %s --help'\n", command,
          refused_option[0] ? refused_option : "bad option", command);
  return VF_EXIT_BAD_INPUT;
}

int vf_cli_usage_error(const char *command, const char *fmt, ...) {
  char detail[512];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(detail, sizeof detail, fmt, ap);
  va_end(ap);
  fprintf(stderr, "vcmfarm %s: %s; try 'vcmfarm %s --help'\n", command, detail, command);
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

int vf_cli_scene_path(const char *source) {
  char path[PATH_MAX];
  if (strncmp(source, "builtin:", 8) == 0 || realpath(source, path) == NULL) return VF_OK;
  size_t n = strlen(path), cap = sizeof ((vf_film *)0)->scene_name;
  if (n >= cap)
    return vf_error_set(VF_EUSAGE, "scene path of %zu bytes: a film holds at most %zu (move the scene to a shorter "
                        "path)", n, cap - 1);
  if (!vf_utf8_valid(path, n))
    return vf_error_set(VF_EUSAGE, "scene path '%s' is not valid UTF-8: a film's text must be (rename the file)",
                        path);
  return VF_OK;
}
