/* merge and bake, and the film-or-image reader shared with errors and diff.
 *
 * merge reads the inputs one at a time into one accumulating film, so merging many large
 * films costs the memory of two. Before each input is added it is checked against the
 * first input (size, scene, settings) and against the iteration set of every earlier
 * input, so a refusal names the two files involved instead of only "films differ". */
#include "film_cmd.h"

#include "options.h"
#include "../common/error.h"
#include "../common/exr_util.h"
#include "../common/file_lock.h"
#include "../common/film.h"

#include <getopt.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* The attribute that marks a film (common/film.c, docs/FILM.md). */
#define FILM_MARKER_ATTRIBUTE "vcmfarm:format_version"

int vf_reference_read(const char *path, vf_image *out, int *is_film) {
  if (path == NULL || out == NULL) return vf_error_set(VF_EINVAL, "vf_reference_read: NULL argument");
  vf_exr_in in;
  int err = vf_exr_open(path, &in);
  if (err != VF_OK) return err;
  const exr_attribute_t *marker = NULL;
  int film_file = exr_get_attribute_by_name(in.ctx, 0, FILM_MARKER_ATTRIBUTE, &marker) == EXR_ERR_SUCCESS;
  vf_exr_close(&in);

  vf_image img = {0};
  if (!film_file) {
    if ((err = vf_image_read_exr(path, &img)) != VF_OK) return err;
  } else {
    vf_film *film = NULL;
    if ((err = vf_film_read(path, &film)) != VF_OK) return err;
    err = vf_image_alloc(&img, film->width, film->height);
    if (err == VF_OK) vf_film_mean(film, img.rgb);
    vf_film_destroy(film);
    if (err != VF_OK) return err;
  }
  *out = img;
  if (is_film) *is_film = film_file;
  return VF_OK;
}

/* ---- merge ---- */

static const char merge_usage[] =
    "usage: vcmfarm merge -o OUT.exr IN.exr IN.exr...\n"
    "\n"
    "Adds the accumulations of two or more films exactly: OUT holds the union of their\n"
    "iteration sets and equals the film of one render of all those iterations.\n"
    "The films must have the same size, scene and settings (algorithm, seed, resolution...)\n"
    "and disjoint iteration sets; otherwise the two files concerned are named and nothing\n"
    "is written. OUT may be one of the inputs: it is replaced atomically.\n"
    "\n"
    "  -o, --output OUT.exr  the merged film (required)\n"
    "  -q, --quiet           no line saying what was written\n"
    "  -h, --help            this text\n"
    "\n"
    "Exit status: 0 done, 1 failure while writing, 2 bad input (nothing is written).\n";

/* The first pair of ranges, one from each set, that intersect; 0 if the sets are disjoint. */
static int first_overlap(const vf_iterset *a, const vf_iterset *b, vf_iter_range *ra, vf_iter_range *rb) {
  size_t i = 0, j = 0;
  while (i < a->count && j < b->count) {
    if (a->ranges[i].end <= b->ranges[j].begin) i++;
    else if (b->ranges[j].end <= a->ranges[i].begin) j++;
    else {
      *ra = a->ranges[i];
      *rb = b->ranges[j];
      return 1;
    }
  }
  return 0;
}

/* Length of the space-separated token at s. */
static size_t token_length(const char *s) { return strcspn(s, " "); }

/* "NAME: settings differ from FIRST's (seed=2 vs seed=1)", naming the first differing
 * key=value pair of the canonical settings text, or both texts if they do not line up. */
static int settings_mismatch(const char *name, const char *settings, const char *first, const char *first_settings) {
  const char *a = settings, *b = first_settings;
  while (*a != '\0' && *b != '\0') {
    size_t la = token_length(a), lb = token_length(b);
    if (la != lb || memcmp(a, b, la) != 0)
      return vf_error_set(VF_EMISMATCH, "%s: settings differ from %s's (%.*s vs %.*s)", name, first, (int)la, a,
                          (int)lb, b);
    a += la;
    b += lb;
    a += strspn(a, " ");
    b += strspn(b, " ");
  }
  return vf_error_set(VF_EMISMATCH, "%s: settings differ from %s's (\"%.200s\" vs \"%.200s\")", name, first,
                      settings, first_settings);
}

static void hash_prefix(const uint8_t *hash, char *hex) {
  for (int i = 0; i < 8; i++) snprintf(hex + 2 * i, 3, "%02x", hash[i]);
}

/* Checks that film (read from name) can join the films read so far: same size, scene and
 * settings as the first, iterations disjoint from every earlier input's. */
static int check_mergeable(const vf_film *film, const char *name, const vf_film *first, char **names,
                           const vf_iterset *sets, int earlier) {
  if (film->width != first->width || film->height != first->height)
    return vf_error_set(VF_EMISMATCH, "%s: size %dx%d differs from %s's %dx%d", name, film->width, film->height,
                        names[0], first->width, first->height);
  if (memcmp(film->scene_hash, first->scene_hash, sizeof film->scene_hash) != 0) {
    char a[17], b[17];
    hash_prefix(film->scene_hash, a);
    hash_prefix(first->scene_hash, b);
    return vf_error_set(VF_EMISMATCH, "%s: rendered from a different scene than %s (scene hash %s... vs %s...)", name,
                        names[0], a, b);
  }
  if (strcmp(film->settings_text, first->settings_text) != 0)
    return settings_mismatch(name, film->settings_text, names[0], first->settings_text);
  for (int j = 0; j < earlier; j++) {
    vf_iter_range mine, theirs;
    if (first_overlap(&film->iterations, &sets[j], &mine, &theirs))
      return vf_error_set(VF_EOVERLAP,
                          "%s: iterations [%" PRIu64 ",%" PRIu64 ") overlap %s's [%" PRIu64 ",%" PRIu64
                          ") (merging would count samples twice)",
                          name, mine.begin, mine.end, names[j], theirs.begin, theirs.end);
  }
  return VF_OK;
}

/* Reads and sums inputs[0..n) into *out (written only on success). */
static int merge_inputs(char **inputs, int n, vf_film **out) {
  vf_iterset *sets = calloc((size_t)n, sizeof *sets);
  if (sets == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  vf_film *sum = NULL, *film = NULL;
  int err = vf_film_read(inputs[0], &sum);
  if (err != VF_OK) goto done;
  if ((err = vf_iterset_copy(&sets[0], &sum->iterations)) != VF_OK) goto done;
  for (int i = 1; i < n; i++) {
    if ((err = vf_film_read(inputs[i], &film)) != VF_OK) goto done;
    if ((err = check_mergeable(film, inputs[i], sum, inputs, sets, i)) != VF_OK) goto done;
    if ((err = vf_iterset_copy(&sets[i], &film->iterations)) != VF_OK) goto done;
    if ((err = vf_film_merge(sum, film)) != VF_OK) {
      /* anything the checks above did not foresee, still attributed to the file */
      char detail[512];
      snprintf(detail, sizeof detail, "%s", vf_error_detail(err));
      err = vf_error_set(err, "%s: cannot be merged: %s", inputs[i], detail);
      goto done;
    }
    vf_film_destroy(film);
    film = NULL;
  }
  *out = sum;
  sum = NULL;
done:
  vf_film_destroy(film);
  vf_film_destroy(sum);
  for (int i = 0; i < n; i++) vf_iterset_destroy(&sets[i]);
  free(sets);
  return err;
}

int vf_cmd_merge(int argc, char **argv) {
  static const struct option options[] = {{"output", required_argument, 0, 'o'},
                                          {"quiet", no_argument, 0, 'q'},
                                          {"help", no_argument, 0, 'h'},
                                          {0, 0, 0, 0}};
  const char *output = NULL;
  int quiet = 0, c;
  vf_error_clear();
  optind = 0;
  while ((c = vf_cli_getopt(argc, argv, "o:qh", options)) != -1) {
    switch (c) {
    case 'o': output = optarg; break;
    case 'q': quiet = 1; break;
    case 'h': fputs(merge_usage, stdout); return VF_EXIT_OK;
    default:
      return vf_cli_bad_option("merge");
    }
  }
  if (output == NULL) return vf_cli_usage_error("merge", "missing -o OUT.exr");
  int n = argc - optind;
  if (n < 2) return vf_cli_usage_error("merge", "expected at least two input films, got %d", n);
  /* OUT may be one of the inputs (it then grows by the others), but no other vcmfarm
   * process may write it meanwhile. */
  vf_film *sum = NULL;
  vf_file_lock lock = {-1, NULL, -1};
  int err = vf_file_lock_acquire(output, "merge", &lock);
  if (err == VF_OK) err = merge_inputs(argv + optind, n, &sum);
  if (err == VF_OK) err = vf_film_write(sum, output);
  vf_file_lock_release(&lock);
  if (err == VF_OK && !quiet) {
    char set[256];
    if (vf_iterset_format(&sum->iterations, set, sizeof set) != VF_OK) snprintf(set, sizeof set, "(long)");
    uint64_t count = vf_iterset_count(&sum->iterations);
    fprintf(stderr, "wrote %s: %d films merged, %" PRIu64 " %s %s, %.2f s of rendering\n", output, n, count,
            vf_cli_plural(count, "iteration", "iterations"), set, sum->render_seconds);
  }
  vf_film_destroy(sum);
  return err == VF_OK ? VF_EXIT_OK : vf_cli_fail("merge", err);
}

/* ---- bake ---- */

static const char bake_usage[] =
    "usage: vcmfarm bake FILM.exr -o IMAGE.exr|IMAGE.png [--exposure E] [-q]\n"
    "\n"
    "Writes the film's mean radiance as a clean image: a FLOAT RGB EXR (R, G, B only, no\n"
    "film channels or attributes) or an 8-bit sRGB PNG. The output type follows the\n"
    "extension of IMAGE (.exr or .png, any case).\n"
    "\n"
    "  -o, --output IMAGE    the image to write (required)\n"
    "  -e, --exposure E      PNG only: scale radiance by 2^E before tone mapping (default 0)\n"
    "  -q, --quiet           no line saying what was written\n"
    "  -h, --help            this text\n"
    "\n"
    "Exit status: 0 done, 1 failure while writing, 2 bad input (nothing is written).\n";

static int has_extension(const char *path, const char *ext) {
  size_t n = strlen(path), e = strlen(ext);
  return n > e && strcasecmp(path + n - e, ext) == 0;
}

int vf_cmd_bake(int argc, char **argv) {
  static const struct option options[] = {{"output", required_argument, 0, 'o'},
                                          {"exposure", required_argument, 0, 'e'},
                                          {"quiet", no_argument, 0, 'q'},
                                          {"help", no_argument, 0, 'h'},
                                          {0, 0, 0, 0}};
  const char *output = NULL;
  double exposure = 0.0;
  int have_exposure = 0, quiet = 0, err = VF_OK, c;
  vf_error_clear();
  optind = 0;
  while ((c = vf_cli_getopt(argc, argv, "o:e:qh", options)) != -1) {
    switch (c) {
    case 'o': output = optarg; break;
    case 'e':
      err = vf_cli_double("--exposure", optarg, -64.0, 64.0, &exposure);
      have_exposure = 1;
      break;
    case 'q': quiet = 1; break;
    case 'h': fputs(bake_usage, stdout); return VF_EXIT_OK;
    default:
      return vf_cli_bad_option("bake");
    }
    if (err != VF_OK) return vf_cli_fail("bake", err);
  }
  if (optind != argc - 1) return vf_cli_usage_error("bake", "expected exactly one FILM");
  if (output == NULL) return vf_cli_usage_error("bake", "missing -o IMAGE.exr or IMAGE.png");
  int png = has_extension(output, ".png");
  if (!png && !has_extension(output, ".exr"))
    return vf_cli_fail("bake", vf_error_set(VF_EUSAGE, "%s: unknown output type (the name must end in .exr or .png)",
                                            output));
  if (!png && have_exposure)
    return vf_cli_fail("bake", vf_error_set(VF_EUSAGE, "--exposure applies to PNG output only; the EXR holds the "
                                                       "radiance itself"));

  if ((err = vf_cli_not_input("-o", output, "FILM", argv[optind])) != VF_OK) return vf_cli_fail("bake", err);
  vf_film *film = NULL;
  vf_image img = {0};
  if ((err = vf_film_read(argv[optind], &film)) != VF_OK) goto done;
  if ((err = vf_image_alloc(&img, film->width, film->height)) != VF_OK) goto done;
  vf_film_mean(film, img.rgb);
  err = png ? vf_image_write_png(output, &img, (float)exposure) : vf_image_write_exr(output, &img);
  if (err == VF_OK && !quiet) {
    uint64_t count = vf_iterset_count(&film->iterations);
    fprintf(stderr, "wrote %s: the mean of %s (%dx%d, %" PRIu64 " %s) as %s\n", output, argv[optind], img.width,
            img.height, count, vf_cli_plural(count, "iteration", "iterations"),
            png ? "an 8-bit sRGB PNG" : "a float RGB EXR");
  }
done:
  vf_image_destroy(&img);
  vf_film_destroy(film);
  return err == VF_OK ? VF_EXIT_OK : vf_cli_fail("bake", err);
}
