/* `vcmfarm continue`: the film remembers everything a render needs (settings text, scene
 * hash and name, iteration set), so continuing is: rebuild the renderer from the film, pick
 * the smallest global indices the film lacks, and hand them to the one render loop. Since
 * an iteration depends only on (seed, global index), [0,k) continued with [k,N) is the film
 * of [0,N) rendered at once. */
#include "continue_cmd.h"

#include "options.h"
#include "../common/error.h"
#include "../common/film.h"
#include "../common/image.h"
#include "local_render.h"
#include "../worker/render.h"

#include <getopt.h>
#include <inttypes.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

static const char usage[] =
    "usage: vcmfarm continue FILM [--iterations N | --time S | --target-rmse X --reference REF |\n"
    "                              --target-error E] [--scene SCENE] [-o OUT] [--threads T]\n"
    "\n"
    "Renders the next global iterations FILM does not hold (its gaps first, then after its\n"
    "last), with the film's own settings and the merge radius of each global index, adds them\n"
    "and writes the result to OUT (default: FILM itself, atomically). The result equals the\n"
    "film of all its iterations rendered at once.\n"
    "\n"
    "  -n, --iterations N       iterations to add (default 16)\n"
    "  -t, --time S             render for S seconds instead\n"
    "      --reference REF      reference image (a film or an RGB EXR of the film's size)\n"
    "      --target-rmse X      stop once the RMSE against the reference is <= X\n"
    "      --target-error E     stop once the estimated RMSE (no reference) is <= E\n"
    "      --checkpoint-interval S  log an error entry and write OUT every S seconds\n"
    "                           (default 10; 0: only at the end)\n"
    "      --scene SCENE        the scene to load (default: the one the film names); its\n"
    "                           content hash must equal the film's\n"
    "  -o, --output OUT         where to write (default: FILM)\n"
    "  -j, --threads T          render threads (default: one per CPU)\n"
    "  -q, --quiet              no progress line or summary\n"
    "  -h, --help               this text\n"
    "\n"
    "Exit status: 0 done (or the target was already met: nothing written), 1 failure while\n"
    "rendering, 2 bad input: unreadable film or reference, other scene (nothing written).\n";

static volatile sig_atomic_t interrupted;
static void on_interrupt(int sig) {
  (void)sig;
  interrupted = 1;
}

static void hex32(const uint8_t *hash, char out[65]) {
  for (int i = 0; i < 32; i++) snprintf(out + 2 * i, 3, "%02x", hash[i]);
}

/* The end of the run of free indices that starts at `free_index`: the next index in the
 * set, or UINT64_MAX. */
static uint64_t gap_end(const vf_iterset *set, uint64_t free_index) {
  for (size_t i = 0; i < set->count; i++)
    if (set->ranges[i].begin > free_index) return set->ranges[i].begin;
  return UINT64_MAX;
}

/* Loads the scene the film names (or `scene_arg`) and checks it is the film's scene. */
static int load_scene(const vf_film *film, const char *film_path, const char *scene_arg, vf_scene **out) {
  const char *name = scene_arg ? scene_arg : film->scene_name;
  if (name[0] == '\0')
    return vf_error_set(VF_EUSAGE, "%s does not name its scene (no attribute vcmfarm:scene): give --scene", film_path);
  vf_scene *scene = NULL;
  int err = vf_scene_load(name, &scene);
  if (err != VF_OK) return err;
  if (memcmp(scene->hash, film->scene_hash, sizeof scene->hash) != 0) {
    char have[65], want[65];
    hex32(scene->hash, have);
    hex32(film->scene_hash, want);
    vf_scene_destroy(scene);
    return vf_error_set(VF_EMISMATCH, "scene %s has content hash %s but %s was rendered from scene hash %s", name,
                        have, film_path, want);
  }
  *out = scene;
  return VF_OK;
}

/* The film's settings, checked to be canonical so the renderer stamps the same text. */
static int film_settings(const vf_film *film, const char *film_path, vf_settings *out) {
  vf_settings s;
  char text[sizeof film->settings_text];
  int err = vf_settings_parse(&s, film->settings_text);
  if (err == VF_OK) err = vf_settings_validate(&s);
  if (err != VF_OK) {
    char detail[256]; /* the detail buffer is about to be overwritten */
    snprintf(detail, sizeof detail, "%s", vf_error_detail(err));
    return vf_error_set(VF_EFILM, "%s: attribute vcmfarm:settings: %s", film_path, detail);
  }
  if (vf_settings_format(&s, text, sizeof text) != VF_OK || strcmp(text, film->settings_text) != 0)
    return vf_error_set(VF_EFILM, "%s: attribute vcmfarm:settings is not in canonical form: \"%.200s\"", film_path,
                        film->settings_text);
  if (s.width != film->width || s.height != film->height)
    return vf_error_set(VF_EFILM, "%s: settings say %dx%d but the film is %dx%d", film_path, s.width, s.height,
                        film->width, film->height);
  *out = s;
  return VF_OK;
}

int vf_cmd_continue(int argc, char **argv) {
  static const struct option options[] = {
      {"iterations", required_argument, 0, 'n'},  {"time", required_argument, 0, 't'},
      {"reference", required_argument, 0, 'F'},   {"target-rmse", required_argument, 0, 'X'},
      {"target-error", required_argument, 0, 'E'}, {"checkpoint-interval", required_argument, 0, 'C'},
      {"scene", required_argument, 0, 'S'},       {"output", required_argument, 0, 'o'},
      {"threads", required_argument, 0, 'j'},     {"quiet", no_argument, 0, 'q'},
      {"help", no_argument, 0, 'h'},              {0, 0, 0, 0}};
  const char *cmd = "continue", *output = NULL, *scene_arg = NULL, *reference_path = NULL;
  long long iterations = -1, threads = 0;
  double time_limit = 0.0, target_rmse = 0.0, target_error = 0.0, checkpoint_interval = 10.0;
  int quiet = 0, err = VF_OK, c;
  optind = 1;
  opterr = 0;
  while ((c = getopt_long(argc, argv, "n:t:o:j:qh", options, NULL)) != -1) {
    switch (c) {
    case 'n': err = vf_cli_int("--iterations", optarg, 1, 1000000000LL, &iterations); break;
    case 't': err = vf_cli_double("--time", optarg, 1e-3, 1e9, &time_limit); break;
    case 'F': reference_path = optarg; break;
    case 'X': err = vf_cli_double("--target-rmse", optarg, 1e-300, 1e300, &target_rmse); break;
    case 'E': err = vf_cli_double("--target-error", optarg, 1e-300, 1e300, &target_error); break;
    case 'C': err = vf_cli_double("--checkpoint-interval", optarg, 0.0, 1e9, &checkpoint_interval); break;
    case 'S': scene_arg = optarg; break;
    case 'o': output = optarg; break;
    case 'j': err = vf_cli_int("--threads", optarg, 1, 1024, &threads); break;
    case 'q': quiet = 1; break;
    case 'h': fputs(usage, stdout); return VF_EXIT_OK;
    default:
      return vf_cli_bad_option("continue", argv, usage);
    }
    if (err != VF_OK) return vf_cli_fail(cmd, err);
  }
  if (optind != argc - 1) {
    fprintf(stderr, "vcmfarm continue: expected exactly one FILM\n%s", usage);
    return VF_EXIT_BAD_INPUT;
  }
  if (iterations > 0 && time_limit > 0.0) {
    fprintf(stderr, "vcmfarm continue: give --iterations or --time, not both\n");
    return VF_EXIT_BAD_INPUT;
  }
  if (target_rmse > 0.0 && reference_path == NULL) {
    fprintf(stderr, "vcmfarm continue: --target-rmse needs --reference\n");
    return VF_EXIT_BAD_INPUT;
  }
  const char *film_path = argv[optind];
  if (output == NULL) output = film_path;
  if ((err = vf_cli_writable("-o", output)) != VF_OK) return vf_cli_fail(cmd, err);

  vf_film *film = NULL;
  vf_scene *scene = NULL;
  vf_renderer *renderer = NULL;
  vf_image reference = {0};
  vf_checkpointer cp = {0};
  vf_settings settings;
  if ((err = vf_film_read(film_path, &film)) != VF_OK) goto done;
  if ((err = film_settings(film, film_path, &settings)) != VF_OK) goto done;
  if ((err = load_scene(film, film_path, scene_arg, &scene)) != VF_OK) goto done;
  if (reference_path && (err = vf_reference_load(reference_path, film->width, film->height, &reference)) != VF_OK)
    goto done;
  if ((err = vf_renderer_create(scene, &settings, (int)threads, &renderer)) != VF_OK) goto done;
  /* A film from an older build may lack the scene name: stamp it now, the hash matched. */
  if (film->scene_name[0] == '\0') {
    vf_film *stamped = NULL;
    if ((err = vf_film_create(film->width, film->height, &stamped)) != VF_OK) goto done;
    vf_renderer_stamp(renderer, stamped);
    memcpy(film->scene_name, stamped->scene_name, sizeof film->scene_name);
    vf_film_destroy(stamped);
  }
  int tty = !quiet && isatty(STDERR_FILENO);
  if ((err = vf_checkpointer_init(&cp, film, output, reference_path ? &reference : NULL, target_rmse, target_error,
                                  tty)) != VF_OK)
    goto done;
  vf_checkpointer_measure(&cp, film);
  if (cp.target_reached) {
    if (!quiet)
      fprintf(stderr, "vcmfarm continue: %s already meets the target (estimated RMSE %.4g, RMSE %.4g); nothing done\n",
              film_path, cp.last.estimated_rmse, cp.last.rmse);
    goto done;
  }
  if (!quiet) {
    fprintf(stderr, "vcmfarm continue: %s (%" PRIu64 " iterations), scene %s, %s\n", film_path,
            vf_iterset_count(&film->iterations), scene->source, film->settings_text);
    vf_vcm_describe(vf_renderer_vcm(renderer), stderr);
  }

  int open_ended = time_limit > 0.0 || target_rmse > 0.0 || target_error > 0.0;
  uint64_t remaining = iterations > 0 ? (uint64_t)iterations : (open_ended ? UINT64_MAX : 16), done = 0;
  vf_render_control control = {0.0, NULL, NULL, &interrupted, 0.0, NULL};
  vf_checkpointer_attach(&cp, &control, checkpoint_interval);
  struct sigaction sa, old_int, old_term;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_interrupt;
  sigaction(SIGINT, &sa, &old_int);
  sigaction(SIGTERM, &sa, &old_term);
  double start = vf_seconds_now(), seconds = 0.0;
  /* One call per gap of the iteration set: the loop over iterations stays in vf_render_range. */
  while (remaining > 0 && !interrupted && !cp.target_reached) {
    uint64_t begin = vf_iterset_next_free(&film->iterations, 0), end = gap_end(&film->iterations, begin);
    if (end - begin > remaining) end = begin + remaining;
    if (time_limit > 0.0) {
      control.time_limit = time_limit - (vf_seconds_now() - start);
      if (control.time_limit <= 0.0) break;
    }
    vf_render_status st;
    err = vf_render_range(renderer, film, begin, end, &control, &st);
    done += st.iterations_done;
    remaining -= st.iterations_done;
    if (err != VF_OK || st.iterations_done < end - begin) break;
  }
  seconds = vf_seconds_now() - start;
  sigaction(SIGINT, &old_int, NULL);
  sigaction(SIGTERM, &old_term, NULL);
  if (tty) fputc('\n', stderr);
  if (err != VF_OK) goto done;
  if (done == 0) {
    err = vf_error_set(VF_EINVAL, "no iteration finished; nothing written");
    goto done;
  }
  /* Every call's final checkpoint wrote the film. */
  if (!quiet) {
    char set[256];
    if (vf_iterset_format(&film->iterations, set, sizeof set) != VF_OK) snprintf(set, sizeof set, "(long)");
    fprintf(stderr, "added %" PRIu64 " iteration(s) in %.2f s%s; the film holds %s\nestimated RMSE %.4g", done, seconds,
            interrupted ? " (interrupted)" : "", set, cp.last.estimated_rmse);
    if (reference_path) fprintf(stderr, ", RMSE %.4g against %s", cp.last.rmse, reference_path);
    fprintf(stderr, "%s\nwrote %s\n", cp.target_reached ? " (target reached)" : "", output);
  }
done:
  vf_checkpointer_destroy(&cp);
  vf_renderer_destroy(renderer);
  vf_image_destroy(&reference);
  vf_scene_destroy(scene);
  vf_film_destroy(film);
  return err == VF_OK ? VF_EXIT_OK : vf_cli_fail(cmd, err);
}
