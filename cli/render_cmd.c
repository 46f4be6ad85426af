/* `vcmfarm render`: one machine, no set-up.
 *
 * The scene is loaded once, the renderer built from it, and the iterations handed to the
 * local render (cli/local_render.c), the driver `continue` also uses over the one render
 * loop (vf_render_range): the film written atomically at every due checkpoint with an
 * entry of its convergence log, a target tested after every iteration. A farm's workers
 * call the same loop, so a farm job of the same iterations gives this film, but for the
 * rounding of the order in which its coordinator adds the parts (tests/farm/test_render_farm.sh
 * holds the two to it). */
#include "render_cmd.h"

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
#include <stdio.h>

static const char usage[] =
    "usage: vcmfarm render SCENE [options] -o FILM.exr\n"
    "\n"
    "Renders global iterations [K, K+N) of SCENE (a built-in name, a JSON scene file, a\n"
    "glTF 2.0 (.gltf, .glb) or OBJ file or a Mitsuba 3 scene (.xml), see docs/SCENES.md) into FILM.exr, an OpenEXR film that any viewer opens and that\n"
    "`vcmfarm merge` and `continue` extend exactly. It renders on this machine's threads;\n"
    "a farm (`vcmfarm submit`, docs/PROTOCOL.md) renders the same iterations into the same\n"
    "film.\n"
    "\n" VF_CLI_STOP_HELP
    VF_CLI_CHECKPOINT_HELP
    "  -k, --start-iteration K  first global iteration index (default 0)\n"
    "  -j, --threads T          render threads (default: one per CPU)\n" VF_CLI_SETTINGS_HELP
    "      --camera NAME|INDEX  the glTF file's camera or Mitsuba scene's sensor to render\n"
    "                           (default: its first)\n"
    "      --background COLOR|FILE.exr  replaces the scene's background: a radiance R,G,B or\n"
    "                           a grey V, or a latitude-longitude EXR map (docs/SCENES.md);\n"
    "                           `continue` needs the same option\n"
    VF_CLI_ALLOCATION_FROM_HELP
    "  -o, --output FILM.exr    the film to write (required)\n"
    VF_CLI_PREVIEW_HELP
    "      --direct             accepted for compatibility: what render always does now\n"
    "                           (it used to skip an in-process coordinator and worker)\n"
    "  -q, --quiet              no progress line or summary\n"
    "  -v, --verbose            also the settings text and what the renderer enabled and\n"
    "                           skipped (techniques, kernels, geometry) before it starts\n"
    "  -h, --help               this text\n"
    "\n"
    "The random numbers of an iteration depend only on (seed, iteration index, pixel), so\n"
    "renders of disjoint iteration ranges merge into exactly the render of their union.\n"
    "With a target and neither --iterations nor --time, it renders until the target is met;\n"
    "a target is tested after every iteration and stops the render right after the\n"
    "iteration that meets it.\n"
    "Progress goes to stderr: on a terminal one line rewritten after every iteration,\n"
    "elsewhere (a log file, a batch system's output) a plain line every 10 s.\n"
    "Exit status: 0 done, 1 failure while rendering, 2 bad input (nothing is written).\n";

/* The render of the job, its film written to job->output (and the preview); progress and
 * summary on stderr unless quiet. Returns an exit status, having printed the error. */
static int render(const vf_render_job *o) {
  int err;
  vf_scene *scene = NULL;
  vf_renderer *renderer = NULL;
  vf_film *film = NULL;
  vf_image reference = {0};
  uint8_t *samples = NULL; /* the allocation auto chose, or --allocation-from's; owned */
  if ((err = vf_cli_scene_path(o->scene)) != VF_OK || (err = vf_scene_load_camera(o->scene, o->camera, &scene)) != VF_OK)
    return vf_cli_fail("render", err);
  vf_cli_print_notes(scene->source, scene->notes);
  if (o->background && (err = vf_scene_set_background(scene, o->background)) != VF_OK) goto done;

  /* Settings: defaults, then the scene's "render" object, then the command line. */
  vf_settings settings = scene->settings;
  if ((err = vf_cli_settings_apply(&o->overrides, &settings)) != VF_OK) goto done;
  /* --allocation-from: FILM's allocation, and no pilot rendered (vf_render_pilot skips a
   * film that has one). */
  if (o->allocation_from &&
      (err = vf_render_job_allocation_from(o->allocation_from, scene->hash, o->overrides.pilot, &settings, &samples)) != VF_OK)
    goto done;
  if ((err = vf_settings_validate(&settings)) != VF_OK) goto done;
  if (o->stop.reference &&
      (err = vf_reference_load(o->stop.reference, settings.width, settings.height, &reference)) != VF_OK)
    goto done;
  if (vf_cli_stop_iterations(&o->stop) > UINT64_MAX - o->start) {
    err = vf_error_set(VF_EUSAGE, "--start-iteration %llu + --iterations overflows", (unsigned long long)o->start);
    goto done;
  }

  /* auto with a pilot: each candidate's pilot decides, and the chosen one's is the job's. */
  vf_auto_choice choice;
  int chose = samples == NULL && vf_settings_choose_by_pilots(&settings);
  if (chose) {
    if ((samples = malloc((size_t)settings.width * (size_t)settings.height)) == NULL) {
      err = VF_ENOMEM;
      goto done;
    }
    if ((err = vf_render_choose_algorithm(scene, &settings, o->threads, NULL, samples, &choice)) != VF_OK) goto done;
    if (!o->quiet) vf_render_job_print_choice(&choice, settings.pilot);
  }
  if ((err = vf_renderer_create(scene, &settings, o->threads, &renderer)) != VF_OK) goto done;
  if ((err = vf_film_create(settings.width, settings.height, &film)) != VF_OK) goto done;
  if ((err = vf_renderer_stamp(renderer, film)) != VF_OK) goto done;
  /* The chosen pilot's allocation (the film's times include every pilot), or FILM's. */
  if (samples != NULL && (err = vf_film_set_samples(film, samples)) != VF_OK) goto done;
  if (chose) {
    film->render_seconds += choice.render_seconds;
    film->cpu_seconds += choice.cpu_seconds;
  }
  if (!o->quiet) {
    char what[512], until[512];
    vf_render_job_format_what(scene->source, &settings, vf_vcm_algorithm(vf_renderer_vcm(renderer)), what,
                              sizeof what);
    vf_render_job_format_stop(&o->stop, o->start, until, sizeof until);
    fprintf(stderr, "vcmfarm render: %s, %s -> %s\n", what, until, o->output);
    if (o->verbose) vf_render_job_print_details(&settings, renderer);
  }
  vf_local_render_options lo = {o->output, o->stop.reference ? &reference : NULL, &o->stop, o->checkpoint,
                                vf_progress_mode_for_stderr(o->quiet)};
  vf_local_render_result r;
  if ((err = vf_local_render(renderer, film, o->start, &lo, &r)) != VF_OK) goto done;
  if ((err = vf_render_job_write_preview(o, film)) != VF_OK) goto done;
  if (!o->quiet) {
    vf_render_job_print_summary(film, r.seconds, &r.stats, r.iterations, r.interrupted);
    if (r.iterations >= 2 && r.render_seconds > r.first_seconds) {
      /* The rate a long render settles at: the first iteration also pays for the first
       * touches of the renderer's buffers (tens of thousands of page faults), and the film
       * written at the end is paid once per run, not per iteration (checkpoints due
       * between iterations are counted). */
      double s = r.render_seconds - r.first_seconds;
      fprintf(stderr, "after the first iteration: %.3f it/s, %.2f Mrays/s\n", (double)(r.iterations - 1) / s,
              (double)(r.stats.rays - r.first_rays) / s * 1e-6);
    }
    vf_render_job_print_result(o, r.last.estimated_rmse, r.last.rmse, r.target_reached ? "target reached" : NULL);
  }
done:
  free(samples);
  vf_image_destroy(&reference);
  vf_film_destroy(film);
  vf_renderer_destroy(renderer);
  vf_scene_destroy(scene);
  return err == VF_OK ? VF_EXIT_OK : vf_cli_fail("render", err);
}

int vf_cmd_render(int argc, char **argv) {
  static const struct option options[] = {
      VF_CLI_STOP_OPTIONS,
      VF_CLI_SETTINGS_OPTIONS,
      {"start-iteration", required_argument, 0, 'k'}, {"threads", required_argument, 0, 'j'},
      {"output", required_argument, 0, 'o'},          {"preview", required_argument, 0, 'p'},
      {"exposure", required_argument, 0, 'e'},        {"quiet", no_argument, 0, 'q'},
      {"help", no_argument, 0, 'h'},                  {"checkpoint-interval", required_argument, 0, 'C'},
      {"direct", no_argument, 0, 'D'},                {"camera", required_argument, 0, 'M'},
      {"verbose", no_argument, 0, 'v'},               {"background", required_argument, 0, VF_CLI_OPT_BACKGROUND},
      {"allocation-from", required_argument, 0, VF_CLI_OPT_ALLOCATION_FROM}, {0, 0, 0, 0}};
  const char *cmd = "render";
  vf_render_job o = {.checkpoint = VF_CLI_CHECKPOINT_DEFAULT};
  long long threads = 0;
  int err = VF_OK, c;
  vf_cli_settings_init(&o.overrides);
  optind = 0; /* 0: getopt starts again from scratch (glibc), forgetting the last argv */
  while ((c = vf_cli_getopt(argc, argv, VF_CLI_STOP_SHORT VF_CLI_SETTINGS_SHORT "k:j:o:p:e:qvh", options)) != -1) {
    if (vf_cli_settings_option(&o.overrides, c, optarg, &err) || vf_cli_stop_option(&o.stop, c, optarg, &err)) {
      if (err != VF_OK) return vf_cli_fail(cmd, err);
      continue;
    }
    switch (c) {
    case 'k': err = vf_cli_u64("--start-iteration", optarg, &o.start); break;
    case 'j': err = vf_cli_int("--threads", optarg, 1, 1024, &threads); break;
    case 'o': o.output = optarg; break;
    case 'p': o.preview = optarg; break;
    case 'e': err = vf_cli_double("--exposure", optarg, -64.0, 64.0, &o.exposure); break;
    case 'q': o.quiet = 1; break;
    case 'v': o.verbose = 1; break;
    case 'D': break; /* --direct: the default, kept for the scripts that say it */
    case 'M': o.camera = optarg; break;
    case VF_CLI_OPT_BACKGROUND: o.background = optarg; break;
    case VF_CLI_OPT_ALLOCATION_FROM: o.allocation_from = optarg; break;
    case 'C': err = vf_cli_checkpoint_option(&o.checkpoint, optarg); break;
    case 'h': fputs(usage, stdout); return VF_EXIT_OK;
    default:
      return vf_cli_bad_option("render");
    }
    if (err != VF_OK) return vf_cli_fail(cmd, err);
  }
  if (optind != argc - 1) return vf_cli_usage_error("render", "expected exactly one SCENE");
  if (o.output == NULL) {
    fprintf(stderr, "vcmfarm render: missing -o FILM.exr\n");
    return VF_EXIT_BAD_INPUT;
  }
  if ((err = vf_cli_stop_check(&o.stop, 1)) != VF_OK || (err = vf_cli_writable("-o", o.output)) != VF_OK ||
      (err = vf_cli_extension("-o", o.output, ".exr", "an OpenEXR film")) != VF_OK ||
      (o.preview && (err = vf_cli_preview_check(o.preview)) != VF_OK))
    return vf_cli_fail(cmd, err);
  if (o.stop.reference && (err = vf_cli_not_input("-o", o.output, "--reference", o.stop.reference)) != VF_OK)
    return vf_cli_fail(cmd, err);
  o.scene = argv[optind];
  o.threads = (int)threads;
  /* Two renders into one film would each replace the other's checkpoints. */
  vf_file_lock lock;
  if ((err = vf_file_lock_acquire(o.output, "render", &lock)) != VF_OK) return vf_cli_fail(cmd, err);
  int status = render(&o);
  vf_file_lock_release(&lock);
  return status;
}
