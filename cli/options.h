/* Command-line helpers shared by the subcommands: strict number parsing with ranges and
 * the exit-status convention (0 success, 1 failure while working, 2 bad input: command
 * line, scene, EXR file or film, a key the coordinator refuses, a job it does not have or
 * a request it refuses for the job's state; nothing is written then). */
#ifndef VF_OPTIONS_H
#define VF_OPTIONS_H

#include "../common/settings.h"

#include <getopt.h>
#include <stddef.h>
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
/* Checks that a scene file's absolute path can be kept in a film (vcmfarm:scene): at most
 * 511 bytes, UTF-8. VF_EUSAGE saying which and what to do; VF_OK for a built-in name or a
 * path that does not resolve (loading it will say why). */
int vf_cli_scene_path(const char *source);

/* Checks a coordinator's address as an option (--coordinator, --connect, --listen) takes
 * it: tcp://HOST:PORT or ipc://PATH, which nanomsg alone would refuse with "Invalid
 * argument". VF_EUSAGE naming the option and what to write instead: an address without a
 * scheme ("127.0.0.1:7450": write tcp://127.0.0.1:7450), another scheme, inproc:// (which
 * reaches only a coordinator inside the same process), tcp:// without a port. */
int vf_cli_address(const char *option, const char *url);

/* Checks that path ends in ext (".exr", ".png"; any case), so that a file is never written
 * under a name that says another format. VF_EUSAGE naming the option, the path and `what`
 * the command writes there ("an OpenEXR film"). */
int vf_cli_extension(const char *option, const char *path, const char *ext, const char *what);

/* Refuses (VF_EUSAGE naming both options) an output that is the same file as one of the
 * command's inputs (by device and inode when it exists: links and other spellings of a
 * path count), where writing it would replace the input with something else. */
int vf_cli_not_input(const char *output_option, const char *output, const char *input_option, const char *input);

/* The render settings a command line may override (render, submit): -a/--algorithm,
 * -s/--seed, -l/--max-path-length, -r/--radius-factor, --alpha (option value 'A'),
 * -R/--resolution, --sampler (option value 'Q'), --mis-beta (option value 'B'). Unset fields leave the scene's settings as they are. The commands take
 * them through VF_CLI_SETTINGS_OPTIONS (getopt_long entries), VF_CLI_SETTINGS_SHORT (its
 * short letters) and VF_CLI_SETTINGS_HELP (their lines of --help), so the options and
 * their help exist once. */
/* getopt_long values of long options without a short letter that several commands share,
 * above every character so that they meet no letter. */
enum {
  VF_CLI_OPT_BACKGROUND = 0x100, /* --background COLOR|FILE.exr: render, continue */
  VF_CLI_OPT_RADIUS,             /* --radius global|per-pixel: the settings options */
  VF_CLI_OPT_VCM_STAGES,         /* --vcm-stages 1|2: the settings options */
  VF_CLI_OPT_LIGHT_PATH_PIXELS,  /* --light-path-pixels N: the settings options */
  VF_CLI_OPT_PILOT,              /* --pilot N: the settings options */
  VF_CLI_OPT_ALLOCATION_FROM,    /* --allocation-from FILM: render, submit */
};

#define VF_CLI_SETTINGS_OPTIONS                                                                              \
  {"algorithm", required_argument, 0, 'a'}, {"seed", required_argument, 0, 's'},                            \
      {"max-path-length", required_argument, 0, 'l'}, {"radius-factor", required_argument, 0, 'r'},         \
      {"alpha", required_argument, 0, 'A'}, {"resolution", required_argument, 0, 'R'},                      \
      {"sampler", required_argument, 0, 'Q'}, {"mis-beta", required_argument, 0, 'B'},                     \
      {"gather-from", required_argument, 0, 'G'}, {"radius", required_argument, 0, VF_CLI_OPT_RADIUS},                                                \
      {"vcm-stages", required_argument, 0, VF_CLI_OPT_VCM_STAGES},                                         \
      {"light-path-pixels", required_argument, 0, VF_CLI_OPT_LIGHT_PATH_PIXELS},                           \
      {"pilot", required_argument, 0, VF_CLI_OPT_PILOT}
#define VF_CLI_SETTINGS_SHORT "a:s:l:r:R:"
#define VF_CLI_SETTINGS_HELP                                                                 \
  "  -a, --algorithm A        vcm (default), upg (vcm without merging's bias: unbiased\n"   \
  "                           photon gathering), bpt, pt, lt, ppm, bpm or auto (the\n"      \
  "                           cheapest set of techniques for the scene's light transport;\n" \
  "                           with --pilot, the most efficient of pt, bpt and vcm on\n"      \
  "                           their pilots, and the film names it)\n"                        \
  "      --gather-from SIDE   upg: light (default), camera or auto (per path, the side\n"  \
  "                           that scatters less sharply): the side it gathers from where\n" \
  "                           both can (films of different sides never merge)\n"          \
  "  -s, --seed S             job seed (default: the scene's, else 1)\n"                     \
  "  -l, --max-path-length L  maximum path segments (default 10)\n"                          \
  "  -r, --radius-factor F    initial merge radius / scene radius (default 0.003)\n"         \
  "      --radius global|per-pixel  one merge radius for the image (default), or one per\n" \
  "                           pixel from its footprint (films of the two never merge)\n"  \
  "      --alpha A            radius reduction exponent in (0, 1] (default 0.75)\n"          \
  "  -R, --resolution WxH     image size (default: the scene camera's)\n"                   \
  "      --sampler S          sobol (default: Owen-scrambled Sobol' over the iterations)\n" \
  "                           or independent (films of the two never merge)\n"            \
  "      --mis-beta B         the MIS heuristic's exponent in [1, 4]: 1 balance (default),\n" \
  "                           2 and more power (films of different ones never merge)\n"   \
  "      --vcm-stages 1|2     vcm: 2, trace and store all light sub-paths before the\n"    \
  "                           camera sub-paths (default), or 1, one pass whose camera\n"  \
  "                           sub-paths merge with the iteration before's light vertices\n" \
  "                           (films of the two never merge)\n"                          \
  "      --light-path-pixels N  pixels that share one light sub-path an iteration: 1\n"   \
  "                           (default) or a power of two up to 1024, the image in\n"    \
  "                           blocks of N (8: 4x2) each tracing one; less memory for\n"  \
  "                           large images (films of different N never merge)\n"         \
  "      --pilot N            pt, bpt, vcm: a pilot render of N iterations first gives\n" \
  "                           each pixel 1 to 16 camera sub-paths an iteration, by its\n" \
  "                           error there (films of different pilots never merge)\n"

typedef struct {
  const char *algorithm; /* borrowed from argv, or NULL */
  const char *sampler;   /* borrowed from argv, or NULL */
  const char *gather;    /* borrowed from argv, or NULL */
  const char *radius;    /* borrowed from argv, or NULL */
  uint64_t seed;
  int have_seed, have_resolution, width, height;
  long long max_path_length; /* <= 0: unset */
  double radius_factor, alpha, mis_beta; /* <= 0: unset */
  long long vcm_stages; /* 0: unset */
  long long light_path_pixels; /* 0: unset */
  long long pilot; /* -1: unset */
} vf_cli_settings;

void vf_cli_settings_init(vf_cli_settings *o);
/* If option c is one of the settings options, parses arg into o, stores the result code
 * in *err and returns 1; otherwise returns 0. */
int vf_cli_settings_option(vf_cli_settings *o, int c, const char *arg, int *err);

/* Applies the overrides to *settings (an algorithm name is checked here). */
int vf_cli_settings_apply(const vf_cli_settings *o, vf_settings *settings);

/* The stop conditions of a render (render, continue, submit): -n/--iterations,
 * -t/--time, --reference (option value 'F'), --target-rmse ('X'), --target-error ('E'),
 * through VF_CLI_STOP_OPTIONS, VF_CLI_STOP_SHORT and VF_CLI_STOP_HELP like the settings. */
typedef struct {
  long long iterations; /* 0: not given */
  double time_limit, target_rmse, target_error; /* 0: none */
  const char *reference; /* borrowed from argv, or NULL */
} vf_cli_stop;
#define VF_CLI_STOP_OPTIONS                                                                              \
  {"iterations", required_argument, 0, 'n'}, {"time", required_argument, 0, 't'},                       \
      {"reference", required_argument, 0, 'F'}, {"target-rmse", required_argument, 0, 'X'},             \
      {"target-error", required_argument, 0, 'E'}
#define VF_CLI_STOP_SHORT "n:t:"
#define VF_CLI_STOP_HELP                                                                       \
  "  -n, --iterations N       at most N iterations (default 16; none when a time or a\n"    \
  "                           target ends the render)\n"                                      \
  "  -t, --time S             stop after S seconds of wall-clock time: no iteration starts\n" \
  "                           later (a farm job counts them from its first lease; its\n"      \
  "                           workers then ship what they rendered, which is merged before\n" \
  "                           the job stops: nothing rendered is lost)\n"                    \
  "      --reference REF      reference image (a film or an RGB EXR of the same size):\n"     \
  "                           the convergence log records the RMSE against it\n"              \
  "      --target-rmse X      stop once the RMSE against the reference is at most X\n"        \
  "      --target-error E     stop once the estimated RMSE (no reference) is at most E\n"

/* If option c is a stop condition, parses arg into s, stores the result code in *err and
 * returns 1; otherwise returns 0. */
int vf_cli_stop_option(vf_cli_stop *s, int c, const char *arg, int *err);
/* The conditions' own consistency: --target-rmse needs --reference; with exclusive set,
 * --iterations and --time are not given together (with it unset, the first to hold stops).
 * VF_EUSAGE naming the options. */
int vf_cli_stop_check(const vf_cli_stop *s, int exclusive);
/* Whether a time or a target may end the render before its iterations do. */
int vf_cli_stop_open_ended(const vf_cli_stop *s);
/* The iterations to render, by the one rule every command follows: --iterations when
 * given; else VF_CLI_ITERATIONS_OPEN_ENDED when a time or target ends the render; else
 * VF_CLI_ITERATIONS_DEFAULT. */
#define VF_CLI_ITERATIONS_DEFAULT 16
#define VF_CLI_ITERATIONS_OPEN_ENDED 1000000000ull /* also the most one farm job holds */
uint64_t vf_cli_stop_iterations(const vf_cli_stop *s);

/* --checkpoint-interval of the commands that render into a film (render, continue): how
 * often the film is logged and written (a film checkpoint). Given, every `seconds` (0:
 * only at the end). Not given, every VF_CLI_CHECKPOINT_SECONDS, or VF_CLI_CHECKPOINT_COST
 * times as long as the last checkpoint took when that is longer, up to
 * VF_CLI_CHECKPOINT_MAX_SECONDS: checkpoints then take about 1% of the render, where a
 * 1920x1080 film written every 10 s cost 6% of a local render and 10% of one through the
 * in-process farm (docs/BENCHMARKS.md, "Checkpoints at production size"), and a crash
 * loses at most 5 minutes. */
typedef struct {
  double seconds; /* the interval given */
  int given;
} vf_cli_checkpoint;
#define VF_CLI_CHECKPOINT_SECONDS 10.0
#define VF_CLI_CHECKPOINT_COST 100.0
#define VF_CLI_CHECKPOINT_MAX_SECONDS 300.0
#define VF_CLI_CHECKPOINT_DEFAULT ((vf_cli_checkpoint){0.0, 0})
#define VF_CLI_CHECKPOINT_HELP                                                                \
  "      --checkpoint-interval S  append an entry to the film's convergence log and write\n"  \
  "                           the film every S seconds, so a killed render keeps its\n"      \
  "                           work; 0: only at the end (default: every 10 s, or 100\n"       \
  "                           times as long as the last checkpoint took if longer, at\n"     \
  "                           most 300 s)\n"
/* Parses the option's value into c. */
int vf_cli_checkpoint_option(vf_cli_checkpoint *c, const char *arg);
/* Seconds from a checkpoint that took `cost` seconds (0 before the first) to the next; 0:
 * none before the end. */
double vf_cli_checkpoint_next(const vf_cli_checkpoint *c, double cost);

/* Prints what the loaded scene's files ask for that vcmfarm does not do (vf_scene.notes),
 * each line as "SCENE: note: ...", to stderr: once, where the command loads the scene. */
void vf_cli_print_notes(const char *source, const char *notes);

/* Exit status for an error code: 2 for bad input, 1 otherwise. */
int vf_cli_exit_status(int err);

/* Prints "vcmfarm CMD: detail" to stderr and returns vf_cli_exit_status(err). */
int vf_cli_fail(const char *command, int err);

/* getopt_long for every subcommand, with two differences. A long option is taken only
 * spelled in full: getopt_long takes any unambiguous prefix, so `--iteration 4` would be
 * --iterations and a prefix would change meaning as options are added. And an option
 * refused (unknown, inexact, missing its value or given one it does not take) is described
 * for vf_cli_bad_option, with the option the user probably meant.
 * The caller sets optind = 0 before the first call, which checks the whole of argv before
 * getopt_long sees any of it (so nothing is parsed from a command line that will be
 * refused). Returns what getopt_long returns, and '?' for every refusal. Not thread-safe
 * (getopt's state is global). */
int vf_cli_getopt(int argc, char **argv, const char *shortopts, const struct option *longopts);

/* After vf_cli_getopt returned '?' for `vcmfarm CMD`: prints one line, "vcmfarm CMD:
 * unknown option '--iteration' (did you mean --iterations?); try 'vcmfarm CMD --help'", to
 * stderr and returns VF_EXIT_BAD_INPUT. */
int vf_cli_bad_option(const char *command);

/* A command line whose operands are wrong (a missing or extra one): prints "vcmfarm CMD:
 * <detail>; try 'vcmfarm CMD --help'" on one line and returns VF_EXIT_BAD_INPUT. */
int vf_cli_usage_error(const char *command, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* one when n is 1, else many: "1 file", "2 files". */
const char *vf_cli_plural(unsigned long long n, const char *one, const char *many);

/* The name among names[0, count) nearest to word[0, n) by edit distance, when one is
 * nearest and at most 2 edits away (a typo); else NULL. */
const char *vf_cli_nearest(const char *word, size_t n, const char *const *names, size_t count);

#endif
