#include "render_cmd.h"

#include "../common/cli.h"
#include "../common/error.h"
#include "../common/film.h"
#include "../common/image.h"
#include "checkpoint.h"
#include "render.h"

#include <getopt.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static const char usage[] =
    "usage: vcmfarm render SCENE [options] -o FILM.exr\n"
    "\n"
    "Renders global iterations [K, K+N) of SCENE (a built-in name or a JSON scene file,\n"
    "see docs/SCENES.md) into FILM.exr, an OpenEXR film that any viewer opens and that\n"
    "`vcmfarm merge` and `continue` extend exactly.\n"
    "\n"
    "  -a, --algorithm A        vcm (default), bpt, pt, lt, ppm, bpm or auto\n"
    "  -n, --iterations N       number of iterations (default: the scene's, else 16)\n"
    "  -t, --time S             render for S seconds instead (no new iteration after S)\n"
    "      --reference REF      reference image (a film or an RGB EXR of the same size):\n"
    "                           the convergence log records the RMSE against it\n"
    "      --target-rmse X      stop once the RMSE against the reference is <= X\n"
    "      --target-error E     stop once the estimated RMSE (no reference) is <= E\n"
    "      --checkpoint-interval S  every S seconds (default 10) append an entry to the\n"
    "                           film's convergence log and write the film, so a killed\n"
    "                           render keeps its work; 0: only at the end\n"
    "  -k, --start-iteration K  first global iteration index (default 0)\n"
    "  -s, --seed S             job seed (default: the scene's, else 1)\n"
    "  -j, --threads T          render threads (default: one per CPU)\n"
    "  -l, --max-path-length L  maximum path segments (default 10)\n"
    "  -r, --radius-factor F    initial merge radius / scene radius (default 0.003)\n"
    "      --alpha A            radius reduction exponent in (0, 1] (default 0.75)\n"
    "  -R, --resolution WxH     image size (default: the scene camera's)\n"
    "  -o, --output FILM.exr    the film to write (required)\n"
    "  -p, --preview IMAGE.png  also write a tone-mapped sRGB preview\n"
    "  -e, --exposure E         preview exposure in stops (default 0)\n"
    "  -q, --quiet              no progress line or summary\n"
    "  -h, --help               this text\n"
    "\n"
    "The random numbers of an iteration depend only on (seed, iteration index, pixel), so\n"
    "renders of disjoint iteration ranges merge into exactly the render of their union.\n"
    "With a target and neither --iterations nor --time, it renders until the target is met.\n"
    "Exit status: 0 done, 1 failure while rendering, 2 bad input (nothing is written).\n";

static volatile sig_atomic_t interrupted;
static void on_interrupt(int sig) {
  (void)sig;
  interrupted = 1;
}

int vf_cmd_render(int argc, char **argv) {
  static const struct option options[] = {
      {"algorithm", required_argument, 0, 'a'},   {"iterations", required_argument, 0, 'n'},
      {"time", required_argument, 0, 't'},        {"start-iteration", required_argument, 0, 'k'},
      {"seed", required_argument, 0, 's'},        {"threads", required_argument, 0, 'j'},
      {"max-path-length", required_argument, 0, 'l'}, {"radius-factor", required_argument, 0, 'r'},
      {"alpha", required_argument, 0, 'A'},       {"resolution", required_argument, 0, 'R'},
      {"output", required_argument, 0, 'o'},      {"preview", required_argument, 0, 'p'},
      {"exposure", required_argument, 0, 'e'},    {"quiet", no_argument, 0, 'q'},
      {"help", no_argument, 0, 'h'},              {"reference", required_argument, 0, 'F'},
      {"target-rmse", required_argument, 0, 'X'}, {"target-error", required_argument, 0, 'E'},
      {"checkpoint-interval", required_argument, 0, 'C'}, {0, 0, 0, 0}};
  const char *cmd = "render";
  const char *output = NULL, *preview = NULL;
  const char *reference_path = NULL;
  vf_cli_settings overrides;
  double target_rmse = 0.0, target_error = 0.0, checkpoint_interval = 10.0;
  long long iterations = -1, threads = 0;
  uint64_t start = 0;
  int quiet = 0;
  double time_limit = 0.0, exposure = 0.0;
  int err = VF_OK, c;
  vf_cli_settings_init(&overrides);
  optind = 1;
  opterr = 0;
  while ((c = getopt_long(argc, argv, "a:n:t:k:s:j:l:r:R:o:p:e:qh", options, NULL)) != -1) {
    if (vf_cli_settings_option(&overrides, c, optarg, &err)) {
      if (err != VF_OK) return vf_cli_fail(cmd, err);
      continue;
    }
    switch (c) {
    case 'n': err = vf_cli_int("--iterations", optarg, 1, 1000000000LL, &iterations); break;
    case 't': err = vf_cli_double("--time", optarg, 1e-3, 1e9, &time_limit); break;
    case 'k': err = vf_cli_u64("--start-iteration", optarg, &start); break;
    case 'j': err = vf_cli_int("--threads", optarg, 1, 1024, &threads); break;
    case 'o': output = optarg; break;
    case 'p': preview = optarg; break;
    case 'e': err = vf_cli_double("--exposure", optarg, -64.0, 64.0, &exposure); break;
    case 'q': quiet = 1; break;
    case 'F': reference_path = optarg; break;
    case 'X': err = vf_cli_double("--target-rmse", optarg, 1e-300, 1e300, &target_rmse); break;
    case 'E': err = vf_cli_double("--target-error", optarg, 1e-300, 1e300, &target_error); break;
    case 'C': err = vf_cli_double("--checkpoint-interval", optarg, 0.0, 1e9, &checkpoint_interval); break;
    case 'h': fputs(usage, stdout); return VF_EXIT_OK;
    default:
      fprintf(stderr, "vcmfarm render: unknown or incomplete option '%s'\n%s", argv[optind - 1], usage);
      return VF_EXIT_BAD_INPUT;
    }
    if (err != VF_OK) return vf_cli_fail(cmd, err);
  }
  if (optind != argc - 1) {
    fprintf(stderr, "vcmfarm render: expected exactly one SCENE\n%s", usage);
    return VF_EXIT_BAD_INPUT;
  }
  if (output == NULL) {
    fprintf(stderr, "vcmfarm render: missing -o FILM.exr\n");
    return VF_EXIT_BAD_INPUT;
  }
  if (iterations > 0 && time_limit > 0.0) {
    fprintf(stderr, "vcmfarm render: give --iterations or --time, not both\n");
    return VF_EXIT_BAD_INPUT;
  }
  if (target_rmse > 0.0 && reference_path == NULL) {
    fprintf(stderr, "vcmfarm render: --target-rmse needs --reference\n");
    return VF_EXIT_BAD_INPUT;
  }

  vf_scene *scene = NULL;
  vf_renderer *renderer = NULL;
  vf_film *film = NULL;
  vf_image reference = {0};
  vf_checkpointer cp = {0};
  if ((err = vf_scene_load(argv[optind], &scene)) != VF_OK) return vf_cli_fail(cmd, err);

  /* Settings: defaults, then the scene's "render" object, then the command line. */
  vf_settings settings = scene->settings;
  if ((err = vf_cli_settings_apply(&overrides, &settings)) != VF_OK) goto done;
  if ((err = vf_settings_validate(&settings)) != VF_OK) goto done;
  if (reference_path && (err = vf_reference_load(reference_path, settings.width, settings.height, &reference)) != VF_OK)
    goto done;
  int open_ended = time_limit > 0.0 || target_rmse > 0.0 || target_error > 0.0;
  uint64_t count = iterations > 0 ? (uint64_t)iterations : (open_ended ? UINT64_MAX - start : 16);
  if (count > UINT64_MAX - start) {
    err = vf_error_set(VF_EUSAGE, "--start-iteration %llu + --iterations overflows", (unsigned long long)start);
    goto done;
  }

  if ((err = vf_renderer_create(scene, &settings, (int)threads, &renderer)) != VF_OK) goto done;
  if ((err = vf_film_create(settings.width, settings.height, &film)) != VF_OK) goto done;
  if ((err = vf_renderer_stamp(renderer, film)) != VF_OK) goto done;
  if (!quiet) {
    char text[512];
    vf_settings_format(&settings, text, sizeof text);
    fprintf(stderr, "vcmfarm render: %s, %s\n", scene->source, text);
    vf_vcm_describe(vf_renderer_vcm(renderer), stderr);
  }

  int tty = !quiet && isatty(STDERR_FILENO);
  if ((err = vf_checkpointer_init(&cp, film, output, reference_path ? &reference : NULL, target_rmse, target_error,
                                  tty)) != VF_OK)
    goto done;
  vf_render_control control = {time_limit, NULL, NULL, &interrupted, 0.0, NULL};
  vf_checkpointer_attach(&cp, &control, checkpoint_interval);
  struct sigaction sa, old_int, old_term;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_interrupt;
  sigaction(SIGINT, &sa, &old_int);
  sigaction(SIGTERM, &sa, &old_term);
  vf_render_status st;
  err = vf_render_range(renderer, film, start, start + count, &control, &st);
  sigaction(SIGINT, &old_int, NULL);
  sigaction(SIGTERM, &old_term, NULL);
  if (tty) fputc('\n', stderr);
  if (err != VF_OK) goto done;
  if (st.iterations_done == 0) {
    err = vf_error_set(VF_EINVAL, "no iteration finished; nothing written");
    goto done;
  }
  /* The final checkpoint wrote the film. */
  if (preview) {
    vf_image img;
    if ((err = vf_image_alloc(&img, film->width, film->height)) != VF_OK) goto done;
    vf_film_mean(film, img.rgb);
    err = vf_image_write_png(preview, &img, (float)exposure);
    vf_image_destroy(&img);
    if (err != VF_OK) goto done;
  }
  if (!quiet) {
    char set[256];
    if (vf_iterset_format(&film->iterations, set, sizeof set) != VF_OK) snprintf(set, sizeof set, "(long)");
    double rate = (double)st.iterations_done / st.seconds;
    double per = 1000.0 / (double)st.iterations_done;
    fprintf(stderr,
            "rendered %llu iteration(s) %s in %.2f s: %.3f it/s, %.2f Mrays/s, %llu light vertices/it\n"
            "per iteration: light sub-paths %.1f ms, grid %.1f ms, camera sub-paths %.1f ms; "
            "%llu non-finite sample(s)%s\n",
            (unsigned long long)st.iterations_done, set, st.seconds, rate, (double)st.stats.rays / st.seconds * 1e-6,
            (unsigned long long)(st.stats.light_vertices / st.iterations_done), st.stats.light_seconds * per,
            st.stats.grid_seconds * per, st.stats.camera_seconds * per,
            (unsigned long long)st.stats.nonfinite, interrupted ? " (interrupted)" : "");
    fprintf(stderr, "estimated RMSE %.4g", cp.last.estimated_rmse);
    if (reference_path) fprintf(stderr, ", RMSE %.4g against %s", cp.last.rmse, reference_path);
    fprintf(stderr, "%s\nwrote %s%s%s\n", cp.target_reached ? " (target reached)" : "", output,
            preview ? " and " : "", preview ? preview : "");
  }
done:
  vf_checkpointer_destroy(&cp);
  vf_image_destroy(&reference);
  vf_film_destroy(film);
  vf_renderer_destroy(renderer);
  vf_scene_destroy(scene);
  return err == VF_OK ? VF_EXIT_OK : vf_cli_fail(cmd, err);
}
