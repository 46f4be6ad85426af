/* `vcmfarm continue`: the film remembers everything a render needs (settings text, scene
 * hash and name, iteration set), so continuing is: rebuild the renderer from the film, pick
 * the smallest global indices the film lacks, and hand them to the one render loop. Since
 * an iteration depends only on (seed, global index), [0,k) continued with [k,N) is the film
 * of [0,N) rendered at once. */
#include "continue_cmd.h"

#include "../common/error.h"
#include "../common/file_lock.h"
#include "../common/film.h"
#include "../common/image.h"
#include "../worker/render/render.h"
#include "../worker/scene/background.h"
#include "../worker/scene/load.h"
#include "local_render.h"
#include "options.h"
#include "render_job.h"

#include <getopt.h>
#include <inttypes.h>
#include <stdio.h>
#include <string.h>

static const char usage[] =
    "usage: vcmfarm continue FILM [--iterations N | --time S | --target-rmse X --reference REF |\n"
    "                              --target-error E] [--scene SCENE] [-o OUT] [--preview PNG]\n"
    "                              [--threads T] [-v]\n"
    "\n"
    "Renders the next global iterations FILM does not hold (its gaps first, then after its\n"
    "last), with the film's own settings and the merge radius of each global index, adds them\n"
    "and writes the result to OUT (default: FILM itself, atomically). The result equals the\n"
    "film of all its iterations rendered at once. Progress shows as render's does: one line\n"
    "rewritten on a terminal, elsewhere a plain line every 10 s.\n"
    "\n" VF_CLI_STOP_HELP
    VF_CLI_CHECKPOINT_HELP
    "      --scene SCENE        the scene to load (default: the one the film names); its\n"
    "                           content hash must equal the film's\n"
    "      --camera NAME|INDEX  the glTF file's camera the film was rendered with (as render's)\n"
    "      --background COLOR|FILE.exr  the background the film was rendered with (as render's)\n"
    "  -o, --output OUT         where to write (default: FILM)\n" VF_CLI_PREVIEW_HELP
    "  -j, --threads T          render threads (default: one per CPU)\n"
    "  -q, --quiet              no progress line or summary\n"
    "  -v, --verbose            also the settings text and what the renderer enabled and\n"
    "                           skipped, as render -v\n"
    "  -h, --help               this text\n"
    "\n"
    "Exit status: 0 done (or the target was already met: nothing written), 1 failure while\n"
    "rendering, 2 bad input: unreadable film or reference, other scene (nothing written).\n";

static void hex32(const uint8_t *hash, char out[65]) {
  for (int i = 0; i < 32; i++) snprintf(out + 2 * i, 3, "%02x", hash[i]);
}

/* Loads the scene the film names (or `scene_arg`) and checks it is the film's scene. */
static int load_scene(const vf_film *film, const char *film_path, const char *scene_arg, const char *camera,
                      const char *background, vf_scene **out) {
  const char *name = scene_arg ? scene_arg : film->scene_name;
  if (name[0] == '\0')
    return vf_error_set(VF_EUSAGE, "%s does not name its scene (no attribute vcmfarm:scene): give --scene", film_path);
  vf_scene *scene = NULL;
  int err = vf_cli_scene_path(name);
  if (err == VF_OK) err = vf_scene_load_camera(name, camera, &scene);
  if (err != VF_OK) return err;
  if (background && (err = vf_scene_set_background(scene, background)) != VF_OK) {
    vf_scene_destroy(scene);
    return err;
  }
  if (memcmp(scene->hash, film->scene_hash, sizeof scene->hash) != 0) {
    char have[65], want[65];
    hex32(scene->hash, have);
    hex32(film->scene_hash, want);
    vf_scene_destroy(scene);
    return vf_error_set(VF_EMISMATCH, "scene %s has content hash %s but %s was rendered from scene hash %s%s", name,
                        have, film_path, want,
                        vf_scene_is_model_file(name) ? " (was it rendered with another --camera or --background?)"
                                                      : " (was it rendered with another --background?)");
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
      VF_CLI_STOP_OPTIONS,
      {"checkpoint-interval", required_argument, 0, 'C'}, {"scene", required_argument, 0, 'S'},
      {"output", required_argument, 0, 'o'},              {"threads", required_argument, 0, 'j'},
      {"quiet", no_argument, 0, 'q'},                     {"help", no_argument, 0, 'h'},
      {"camera", required_argument, 0, 'M'},              {"preview", required_argument, 0, 'p'},
      {"background", required_argument, 0, VF_CLI_OPT_BACKGROUND},
      {"exposure", required_argument, 0, 'e'},            {"verbose", no_argument, 0, 'v'},
      {0, 0, 0, 0}};
  const char *cmd = "continue", *output = NULL, *scene_arg = NULL, *camera = NULL, *preview = NULL, *background = NULL;
  double exposure = 0.0;
  vf_cli_stop stop = {0};
  long long threads = 0;
  vf_cli_checkpoint checkpoint = VF_CLI_CHECKPOINT_DEFAULT;
  int quiet = 0, verbose = 0, err = VF_OK, c;
  optind = 0; /* 0: getopt starts again from scratch (glibc), forgetting the last argv */
  while ((c = vf_cli_getopt(argc, argv, VF_CLI_STOP_SHORT "o:j:p:e:qvh", options)) != -1) {
    if (vf_cli_stop_option(&stop, c, optarg, &err)) {
      if (err != VF_OK) return vf_cli_fail(cmd, err);
      continue;
    }
    switch (c) {
    case 'C': err = vf_cli_checkpoint_option(&checkpoint, optarg); break;
    case 'S': scene_arg = optarg; break;
    case 'M': camera = optarg; break;
    case VF_CLI_OPT_BACKGROUND: background = optarg; break;
    case 'o': output = optarg; break;
    case 'j': err = vf_cli_int("--threads", optarg, 1, 1024, &threads); break;
    case 'q': quiet = 1; break;
    case 'v': verbose = 1; break;
    case 'p': preview = optarg; break;
    case 'e': err = vf_cli_double("--exposure", optarg, -64.0, 64.0, &exposure); break;
    case 'h': fputs(usage, stdout); return VF_EXIT_OK;
    default:
      return vf_cli_bad_option("continue");
    }
    if (err != VF_OK) return vf_cli_fail(cmd, err);
  }
  if (optind != argc - 1) return vf_cli_usage_error("continue", "expected exactly one FILM");
  const char *film_path = argv[optind];
  if (output == NULL) output = film_path;
  if ((err = vf_cli_stop_check(&stop, 1)) != VF_OK || (err = vf_cli_writable("-o", output)) != VF_OK ||
      (err = vf_cli_extension("-o", output, ".exr", "an OpenEXR film")) != VF_OK ||
      (preview && (err = vf_cli_preview_check(preview)) != VF_OK))
    return vf_cli_fail(cmd, err);

  if (stop.reference && (err = vf_cli_not_input("-o", output, "--reference", stop.reference)) != VF_OK)
    return vf_cli_fail(cmd, err);
  vf_film *film = NULL;
  vf_scene *scene = NULL;
  vf_renderer *renderer = NULL;
  vf_image reference = {0};
  vf_settings settings;
  /* The film is read after the lock is taken: a writer that held it has finished. */
  vf_file_lock lock = {-1, NULL, -1};
  if ((err = vf_file_lock_acquire(output, "continue", &lock)) != VF_OK) goto done;
  if ((err = vf_film_read(film_path, &film)) != VF_OK) goto done;
  if ((err = film_settings(film, film_path, &settings)) != VF_OK) goto done;
  if ((err = load_scene(film, film_path, scene_arg, camera, background, &scene)) != VF_OK) goto done;
  if (stop.reference && (err = vf_reference_load(stop.reference, film->width, film->height, &reference)) != VF_OK)
    goto done;
  if ((err = vf_renderer_create(scene, &settings, (int)threads, &renderer)) != VF_OK) goto done;
  /* A film from an older build may lack the scene name: stamp it now, the hash matched. */
  if (film->scene_name[0] == '\0') {
    vf_film *stamped = NULL;
    if ((err = vf_film_create(film->width, film->height, &stamped)) != VF_OK) goto done;
    err = vf_renderer_stamp(renderer, stamped);
    if (err == VF_OK) memcpy(film->scene_name, stamped->scene_name, sizeof film->scene_name);
    vf_film_destroy(stamped);
    if (err != VF_OK) goto done;
  }
  if (!quiet) {
    char what[512], until[512];
    vf_render_job_format_what(scene->source, &settings, vf_vcm_algorithm(vf_renderer_vcm(renderer)), what,
                              sizeof what);
    vf_render_job_format_stop(&stop, 0, until, sizeof until);
    uint64_t held = vf_iterset_count(&film->iterations);
    fprintf(stderr, "vcmfarm continue: %s holds %" PRIu64 " %s of %s; rendering %s -> %s\n", film_path, held,
            vf_cli_plural(held, "iteration", "iterations"), what, until, output);
    if (verbose) vf_render_job_print_details(&settings, renderer);
  }
  vf_local_render_options lo = {output, stop.reference ? &reference : NULL, &stop, checkpoint,
                                vf_progress_mode_for_stderr(quiet)};
  vf_local_render_result r;
  err = vf_local_render(renderer, film, 0, &lo, &r);
  if (err == VF_OK && r.iterations == 0 && r.target_reached) {
    if (!quiet)
      fprintf(stderr, "vcmfarm continue: %s already meets the target (estimated RMSE %.4g, RMSE %.4g); nothing done\n",
              film_path, r.last.estimated_rmse, r.last.rmse);
    goto done;
  }
  if (err != VF_OK) goto done;
  if (preview && (err = vf_preview_write(film, preview, exposure)) != VF_OK) goto done;
  if (!quiet) {
    char set[256];
    if (vf_iterset_format(&film->iterations, set, sizeof set) != VF_OK) snprintf(set, sizeof set, "(long)");
    fprintf(stderr, "added %" PRIu64 " %s in %.2f s%s; the film holds %s\n", r.iterations,
            vf_cli_plural(r.iterations, "iteration", "iterations"), r.seconds, r.interrupted ? " (interrupted)" : "",
            set);
    vf_render_job_print_estimate(r.last.estimated_rmse);
    if (stop.reference) fprintf(stderr, ", RMSE %.4g against %s", r.last.rmse, stop.reference);
    fprintf(stderr, "%s\nwrote %s%s%s\n", r.target_reached ? " (target reached)" : "", output, preview ? " and " : "",
            preview ? preview : "");
  }
done:
  vf_file_lock_release(&lock);
  vf_renderer_destroy(renderer);
  vf_image_destroy(&reference);
  vf_scene_destroy(scene);
  vf_film_destroy(film);
  return err == VF_OK ? VF_EXIT_OK : vf_cli_fail(cmd, err);
}
