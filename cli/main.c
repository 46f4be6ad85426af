/* vcmfarm: one executable, one subcommand per task. */
#include "continue_cmd.h"
#include "client_cmd.h"
#include "coordinator_cmd.h"
#include "render_cmd.h"
#include "worker_cmd.h"
#include "compare_cmd.h"
#include "film_cmd.h"
#include "info_cmd.h"
#include "options.h"
#include "plot.h"

#ifdef __GLIBC__
#include <malloc.h>
#endif
#include <stdio.h>
#include <string.h>

/* Blocks of this size and above are mapped on their own and unmapped when freed. glibc's
 * default threshold rises, up to 32 MiB, each time such a block is freed, after which the
 * farm's messages (up to 4 MiB each, a part's worth in flight at once) come from malloc's
 * heaps and their pages stay with the process when freed: at 1920x1080 `render` kept 65
 * to 88 MiB more that way (docs/BENCHMARKS.md, "Memory"). A fixed threshold keeps the rule
 * of the first allocation: every large block goes back to the kernel. */
#define LARGE_BLOCK_BYTES (1 << 20)

typedef struct {
  const char *name;
  int (*run)(int argc, char **argv);
  const char *summary;
} command;

static const command commands[] = {
    {"render", vf_cmd_render, "render global iterations of a scene into a film"},
    {"continue", vf_cmd_continue, "render a film's next unused iterations into it"},
    {"info", vf_cmd_info, "a film's attributes, estimated error and convergence log"},
    {"plot", vf_cmd_plot, "log-log plot of films' error against time and iterations"},
    {"merge", vf_cmd_merge, "add films of disjoint iterations into one film"},
    {"bake", vf_cmd_bake, "write a film's mean as a clean EXR or an sRGB PNG"},
    {"errors", vf_cmd_errors, "RMSE, relative MSE and MAE of an image against a reference"},
    {"diff", vf_cmd_diff, "false-colour relative difference of two images, with a legend"},
    {"coordinator", vf_cmd_coordinator, "serve a render farm: jobs, leases, merging, checkpoints"},
    {"worker", vf_cmd_worker, "render leases for a coordinator"},
    {"submit", vf_cmd_submit, "submit a job to a coordinator; prints the job id"},
    {"status", vf_cmd_status, "jobs and workers of a coordinator"},
    {"fetch", vf_cmd_fetch, "write a job's current film"},
    {"cancel", vf_cmd_cancel, "cancel a job"},
    {"pause", vf_cmd_pause, "stop leasing a job (its leases out finish and ship)"},
    {"resume", vf_cmd_resume, "lease a paused job again"},
    {"remove", vf_cmd_remove, "forget an ended job: its film, scene and unshared files"},
    {"keygen", vf_cmd_keygen, "write a new farm key file"},
};

static void print_usage(FILE *out) {
  fprintf(out, "usage: vcmfarm COMMAND [options]   (vcmfarm COMMAND --help for its options)\n\ncommands:\n");
  for (size_t i = 0; i < sizeof commands / sizeof *commands; i++)
    fprintf(out, "  %-12s %s\n", commands[i].name, commands[i].summary);
  fprintf(out, "\n  --version    print the version\n  --help       this text\n");
}

int main(int argc, char **argv) {
#ifdef __GLIBC__
  mallopt(M_MMAP_THRESHOLD, LARGE_BLOCK_BYTES);
#endif
  if (argc < 2) {
    print_usage(stderr);
    return 2;
  }
  if (strcmp(argv[1], "--version") == 0) {
    printf("vcmfarm %s\n", VF_VERSION);
    return 0;
  }
  if (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0) {
    print_usage(stdout);
    return 0;
  }
  enum { COUNT = sizeof commands / sizeof *commands };
  const char *names[COUNT];
  for (size_t i = 0; i < COUNT; i++) {
    if (strcmp(argv[1], commands[i].name) == 0) return commands[i].run(argc - 1, argv + 1);
    names[i] = commands[i].name;
  }
  const char *nearest = vf_cli_nearest(argv[1], strlen(argv[1]), names, COUNT);
  fprintf(stderr, "vcmfarm: unknown command '%s'%s%s%s; try 'vcmfarm --help'\n", argv[1],
          nearest ? " (did you mean " : "", nearest ? nearest : "", nearest ? "?)" : "");
  return 2;
}
