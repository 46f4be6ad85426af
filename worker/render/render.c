#include "render.h"

#include "../../common/allocation.h"
#include "../../common/clock.h"
#include "../../common/error.h"
#include "../../common/parse.h"
#include "../../common/pool.h"
#include "accel.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

struct vf_renderer {
  const vf_scene *scene; /* borrowed */
  vf_settings settings;
  vf_accel *accel;
  vf_pool *pool;
  vf_vcm *vcm;
  float *camera_rgb, *light_rgb; /* one iteration's output */
  uint8_t *samples; /* with a pilot: the allocation the renderer has (samples_set), owned */
  int samples_set;
};

int vf_renderer_create(const vf_scene *scene, const vf_settings *settings, int threads, vf_renderer **out) {
  int err = vf_settings_validate(settings);
  if (err != VF_OK) return err;
  vf_renderer *r = calloc(1, sizeof *r);
  if (r == NULL) return VF_ENOMEM;
  r->scene = scene;
  r->settings = *settings;
  size_t n = 3 * (size_t)settings->width * (size_t)settings->height;
  err = VF_ENOMEM;
  r->camera_rgb = malloc(n * sizeof(float));
  r->light_rgb = malloc(n * sizeof(float));
  if (r->camera_rgb == NULL || r->light_rgb == NULL) goto fail;
  if (settings->pilot > 0 && (r->samples = malloc(n / 3)) == NULL) goto fail;
  if ((err = vf_accel_create(scene, &r->accel)) != VF_OK) goto fail;
  if ((err = vf_pool_create(threads, &r->pool)) != VF_OK) goto fail;
  if ((err = vf_vcm_create(scene, r->accel, settings, r->pool, &r->vcm)) != VF_OK) goto fail;
  *out = r;
  return VF_OK;
fail:
  vf_renderer_destroy(r);
  return err;
}

void vf_renderer_destroy(vf_renderer *r) {
  if (r == NULL) return;
  vf_vcm_destroy(r->vcm);
  vf_pool_destroy(r->pool);
  vf_accel_destroy(r->accel);
  free(r->camera_rgb);
  free(r->light_rgb);
  free(r->samples);
  free(r);
}

const vf_vcm *vf_renderer_vcm(const vf_renderer *r) { return r->vcm; }

const vf_settings *vf_renderer_settings(const vf_renderer *r) { return &r->settings; }

/* Process CPU time of all threads: with the wall time it shows how well threads were used. */
static double cpu_seconds_now(void) {
  struct timespec ts;
  if (clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts) != 0) return 0.0;
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* "builtin:cornell" is stored as "cornell", the name vf_scene_load takes; a file as its
 * absolute path, so that `continue` finds it from another working directory. A path that
 * does not fit (511 bytes) or is not UTF-8 is refused: cut, or with bytes that are no text,
 * it would make a film no tool reads (film attributes must be UTF-8). */
static int scene_name(const char *source, char *out, size_t n) {
  static const char prefix[] = "builtin:";
  char resolved[PATH_MAX];
  const char *name = source;
  if (strncmp(source, prefix, sizeof prefix - 1) == 0) name = source + sizeof prefix - 1;
  else if (realpath(source, resolved) != NULL) name = resolved;
  size_t len = strlen(name);
  if (len >= n)
    return vf_error_set(VF_EINVAL, "scene path of %zu bytes: a film holds at most %zu (move the scene to a shorter "
                        "path)", len, n - 1);
  if (!vf_utf8_valid(name, len))
    return vf_error_set(VF_EINVAL, "scene path '%s' is not valid UTF-8: a film's text must be (rename the file)",
                        name);
  memcpy(out, name, len + 1);
  return VF_OK;
}

int vf_renderer_stamp(const vf_renderer *r, vf_film *film) {
  char name[sizeof film->scene_name];
  int err = scene_name(r->scene->source, name, sizeof name);
  if (err != VF_OK) return err;
  memcpy(film->scene_hash, r->scene->hash, sizeof film->scene_hash);
  memcpy(film->scene_name, name, sizeof film->scene_name);
  return vf_settings_format(&r->settings, film->settings_text, sizeof film->settings_text);
}

/* The film's allocation of camera sub-paths to the renderer, unless it has it. */
static int set_allocation(vf_renderer *r, const vf_film *film) {
  size_t n = (size_t)film->width * (size_t)film->height;
  if (r->samples_set && memcmp(r->samples, film->samples, n) == 0) return VF_OK;
  int err = vf_vcm_set_allocation(r->vcm, film->samples);
  if (err != VF_OK) return err;
  memcpy(r->samples, film->samples, n);
  r->samples_set = 1;
  return VF_OK;
}

int vf_render_pilot_range(vf_renderer *r, vf_film *pilot, uint64_t begin, uint64_t end, const vf_render_control *control,
                          vf_render_status *status) {
  if (r->settings.pilot == 0) return vf_error_set(VF_EINVAL, "the render has no pilot");
  if (end > (uint64_t)r->settings.pilot)
    return vf_error_set(VF_EINVAL, "iterations up to %llu are not all the pilot's [0, %d)", (unsigned long long)end,
                        r->settings.pilot);
  if (pilot->samples != NULL) return vf_error_set(VF_EINVAL, "a pilot renders into a film without an allocation");
  pilot->pilot = 1; /* never an image of the job (common/film.h) */
  vf_vcm_set_pilot_phase(r->vcm, 1);
  int err = vf_render_range(r, pilot, begin, end, control, status);
  vf_vcm_set_pilot_phase(r->vcm, 0);
  return err;
}

int vf_render_pilot(vf_renderer *r, vf_film *film, const vf_render_control *control, vf_render_status *status) {
  if (status) memset(status, 0, sizeof *status);
  if (r->settings.pilot == 0 || film->samples != NULL) return r->settings.pilot == 0 ? VF_OK : set_allocation(r, film);
  vf_film *pilot = NULL;
  int err = vf_film_create(film->width, film->height, &pilot);
  if (err != VF_OK) return err;
  if ((err = vf_renderer_stamp(r, pilot)) != VF_OK) goto done;
  /* Only the interrupt reaches the pilot: nothing of it is delivered or shown. */
  vf_render_control pc = {0};
  if (control) pc.interrupt = control->interrupt;
  vf_render_status st;
  err = vf_render_pilot_range(r, pilot, 0, (uint64_t)r->settings.pilot, &pc, &st);
  if (status) *status = st;
  if (err != VF_OK) goto done;
  if (st.iterations_done < (uint64_t)r->settings.pilot) {
    err = vf_error_set(VF_EINVAL, "the pilot was interrupted after %llu of its %d iterations; nothing written",
                       (unsigned long long)st.iterations_done, r->settings.pilot);
    goto done;
  }
  uint8_t *samples = malloc((size_t)film->width * (size_t)film->height);
  if (samples == NULL) {
    err = VF_ENOMEM;
    goto done;
  }
  err = vf_allocation_compute(pilot, samples, NULL);
  if (err == VF_OK) err = vf_film_set_samples(film, samples);
  free(samples);
  if (err != VF_OK) goto done;
  /* The job's film carries what its pilot cost (its non-finite samples, in no image of
   * the job, are the caller's to report). */
  film->render_seconds += pilot->render_seconds;
  film->cpu_seconds += pilot->cpu_seconds;
  err = set_allocation(r, film);
done:
  vf_film_destroy(pilot);
  return err;
}

/* One candidate of auto: its pilot rendered by r (set up for it) into a film of its own,
 * its allocation into counts and its figures into *c. */
static int measure_candidate(vf_renderer *r, volatile sig_atomic_t *interrupt, uint8_t *counts, double *variances,
                             vf_auto_choice *choice, int i) {
  vf_film *pilot = NULL;
  int err = vf_film_create(r->settings.width, r->settings.height, &pilot);
  if (err != VF_OK) return err;
  vf_render_control pc = {.interrupt = interrupt};
  vf_render_status st;
  uint64_t n = (uint64_t)r->settings.pilot;
  if ((err = vf_renderer_stamp(r, pilot)) != VF_OK || (err = vf_render_pilot_range(r, pilot, 0, n, &pc, &st)) != VF_OK)
    goto done;
  if (st.iterations_done < n) {
    err = vf_error_set(VF_EINVAL, "auto's pilot of %s was interrupted after %llu of its %d iterations",
                       vf_algorithm_name(r->settings.algorithm), (unsigned long long)st.iterations_done, r->settings.pilot);
    goto done;
  }
  vf_allocation_report report;
  if ((err = vf_allocation_compute(pilot, counts, &report)) != VF_OK) goto done;
  if (variances && (err = vf_allocation_variances(pilot, variances)) != VF_OK) goto done;
  double light = (st.stats.light_seconds + st.stats.grid_seconds) / (double)n, camera = st.stats.camera_seconds / (double)n;
  double cost = light + camera * report.mean;
  choice->candidates[i].algorithm = r->settings.algorithm;
  choice->candidates[i].merging = r->settings.algorithm == VF_ALGO_VCM;
  choice->candidates[i].light_seconds = light;
  choice->candidates[i].camera_seconds = camera;
  choice->candidates[i].camera_subpaths = report.mean;
  choice->candidates[i].variance = report.variance;
  /* A pilot that saw no variance at all (an image of constant pixels) is as efficient as
   * it gets: the cheapest such candidate wins. */
  choice->candidates[i].efficiency = report.variance > 0.0 ? 1.0 / (cost * report.variance) : 1e300 / (1.0 + cost);
  choice->render_seconds += pilot->render_seconds;
  choice->cpu_seconds += pilot->cpu_seconds;
done:
  vf_film_destroy(pilot);
  return err;
}

/* What a candidate's predicted efficiency counts for in the choice: pt's over the margin,
 * bpt's and vcm's (merging everywhere or per tile) as they are. pt's estimate misses what
 * pt samples rarely (caustics through glass, the fog's volumetric caustic): on cornell-fog
 * its pilot predicted 1.01x bpt's efficiency, and bpt with a pilot reached 0.1 four times
 * sooner. vcm's error is variance and merging's bias, and the pilot's estimate sees only the
 * variance; but at the default radius, since a pixel's radius shrinks with its camera
 * sub-paths (pixel_radius.h), vcm with a pilot reaches 0.01 relative RMSE as soon as bpt
 * with one or sooner on the boxes, where its pilot predicted 0.77-1.05x bpt's efficiency
 * (docs/BENCHMARKS.md, "auto with a pilot", "auto to 0.01 relative RMSE"). */
static double choice_score(const vf_auto_choice *choice, int i) {
  return choice->candidates[i].efficiency / (choice->candidates[i].algorithm == VF_ALGO_PT ? VF_AUTO_MARGIN : 1.0);
}

/* The candidate of vcm merging per pixel (render.h), from bpt's and vcm's measured ones
 * (b and m) and their pilots' variances: its allocation into counts and its figures into
 * choice's next candidate, unless every pixel or none merges (then it is vcm or bpt). */
static int mix_candidate(vf_auto_choice *choice, int b, int m, const double *bpt_variances,
                         const double *vcm_variances, int width, int height, uint8_t *counts) {
  size_t n = (size_t)width * (size_t)height;
  const double pixels = (double)n;
  double bpt_cost = choice->candidates[b].camera_seconds / pixels, vcm_cost = choice->candidates[m].camera_seconds / pixels;
  if (!(bpt_cost > 0.0 && vcm_cost > 0.0)) return VF_OK; /* a clock too coarse to tell: no prediction */
  vf_allocation_report report;
  int err = vf_allocation_choose(bpt_variances, vcm_variances, bpt_cost, vcm_cost, VF_AUTO_MARGIN, width, height, counts,
                                 &report);
  if (err != VF_OK || report.no_merging == 0 || report.no_merging == n) return err;
  double camera = 0.0;
  for (size_t p = 0; p < n; p++)
    camera += vf_allocation_count(counts[p]) * (vf_allocation_merges(counts[p]) ? vcm_cost : bpt_cost);
  double cost = choice->candidates[m].light_seconds + camera;
  int i = choice->count++;
  choice->candidates[i] = choice->candidates[m];
  choice->candidates[i].merging = 1.0 - (double)report.no_merging / pixels;
  choice->candidates[i].camera_seconds = camera / report.mean; /* per camera sub-path a pixel, as the others' */
  choice->candidates[i].camera_subpaths = report.mean;
  choice->candidates[i].variance = report.variance;
  choice->candidates[i].efficiency = report.variance > 0.0 ? 1.0 / (cost * report.variance) : 1e300 / (1.0 + cost);
  return VF_OK;
}

int vf_render_choose_algorithm(const vf_scene *scene, vf_settings *settings, int threads,
                               volatile sig_atomic_t *interrupt, uint8_t *samples, vf_auto_choice *choice) {
  static const vf_algorithm candidates[3] = {VF_ALGO_PT, VF_ALGO_BPT, VF_ALGO_VCM};
  if (!vf_settings_choose_by_pilots(settings))
    return vf_error_set(VF_EINVAL, "an algorithm is chosen by pilots only for --algorithm auto with --pilot");
  memset(choice, 0, sizeof *choice);
  size_t n = (size_t)settings->width * (size_t)settings->height;
  uint8_t *counts = malloc(n), *best_counts = malloc(n);
  double *variances[2] = {malloc(n * sizeof(double)), malloc(n * sizeof(double))}; /* bpt's, vcm's */
  vf_renderer *r = NULL;
  int err = counts && best_counts && variances[0] && variances[1] ? VF_OK : VF_ENOMEM, best = -1, measured[2] = {-1, -1};
  for (int i = 0; err == VF_OK && i < 3; i++) {
    vf_settings s = *settings;
    s.algorithm = candidates[i];
    if (vf_settings_validate(&s) != VF_OK) { /* e.g. pt with light sub-paths per block */
      vf_error_clear();
      continue;
    }
    /* One scene structure and pool for all: only the algorithm's renderer changes. */
    if (r == NULL) {
      err = vf_renderer_create(scene, &s, threads, &r);
    } else {
      vf_vcm_destroy(r->vcm);
      r->vcm = NULL;
      r->settings = s;
      err = vf_vcm_create(scene, r->accel, &s, r->pool, &r->vcm);
    }
    int side = candidates[i] == VF_ALGO_BPT ? 0 : candidates[i] == VF_ALGO_VCM ? 1 : -1;
    if (err != VF_OK ||
        (err = measure_candidate(r, interrupt, counts, side >= 0 ? variances[side] : NULL, choice, choice->count)) != VF_OK)
      break;
    if (side >= 0) measured[side] = choice->count;
    if (best < 0 || choice_score(choice, choice->count) > choice_score(choice, best)) {
      best = choice->count;
      memcpy(best_counts, counts, n);
    }
    choice->count++;
  }
  if (err == VF_OK && measured[0] >= 0 && measured[1] >= 0) {
    int before = choice->count;
    err = mix_candidate(choice, measured[0], measured[1], variances[0], variances[1], settings->width, settings->height,
                        counts);
    if (err == VF_OK && choice->count > before && choice_score(choice, before) > choice_score(choice, best)) {
      best = before;
      memcpy(best_counts, counts, n);
    }
  }
  if (err == VF_OK && best < 0) err = vf_error_set(VF_EINVAL, "none of pt, bpt and vcm takes these settings");
  if (err == VF_OK) {
    choice->algorithm = choice->candidates[best].algorithm;
    choice->chosen = best;
    settings->algorithm = choice->algorithm;
    if (samples) memcpy(samples, best_counts, n);
  }
  vf_renderer_destroy(r);
  free(counts);
  free(best_counts);
  free(variances[0]);
  free(variances[1]);
  return err;
}

int vf_render_range(vf_renderer *r, vf_film *film, uint64_t begin, uint64_t end, const vf_render_control *control,
                    vf_render_status *status) {
  if (film->width != r->settings.width || film->height != r->settings.height)
    return vf_error_set(VF_EMISMATCH, "film is %dx%d but the settings say %dx%d", film->width, film->height,
                        r->settings.width, r->settings.height);
  vf_render_status st;
  memset(&st, 0, sizeof st);
  st.iterations_total = end - begin;
  if (film->pilot && !vf_vcm_pilot_phase(r->vcm))
    return vf_error_set(VF_EINVAL, "a pilot's film takes only the pilot's iterations (vf_render_pilot_range)");
  if (r->settings.pilot > 0 && !vf_vcm_pilot_phase(r->vcm)) {
    if (film->samples == NULL)
      return vf_error_set(VF_EINVAL, "the film has no allocation of camera sub-paths: its pilot has not run "
                          "(vf_render_pilot)");
    int e = set_allocation(r, film);
    if (e != VF_OK) return e;
  }
  double start = vf_seconds_now(), last_delivery = start;
  int err = VF_OK, stop = 0, since_delivery = 0;
  for (uint64_t k = begin; k < end && !stop; k++) {
    if (control && control->interrupt && *control->interrupt) break;
    if (control && control->time_limit > 0.0 && vf_seconds_now() - start >= control->time_limit) break;
    if (vf_iterset_contains(&film->iterations, k)) {
      err = vf_error_set(VF_EOVERLAP, "iteration %llu is already in the film", (unsigned long long)k);
      break;
    }
    double t0 = vf_seconds_now(), cpu0 = cpu_seconds_now();
    uint64_t nonfinite0 = st.stats.nonfinite, biased0 = st.stats.upg_fallbacks;
    if ((err = vf_vcm_iteration(r->vcm, k, r->camera_rgb, r->light_rgb, &st.stats)) != VF_OK) break;
    err = control && control->accum
              ? vf_film_accum_add_iteration(control->accum, film, k, r->camera_rgb, r->light_rgb, r->pool)
              : vf_film_add_iteration(film, k, r->camera_rgb, r->light_rgb, r->pool);
    if (err != VF_OK) break;
    /* Counted per iteration so that a delivery sees a consistent film. */
    film->nonfinite_samples += st.stats.nonfinite - nonfinite0;
    film->biased_merges += st.stats.upg_fallbacks - biased0;
    film->render_seconds += vf_seconds_now() - t0;
    film->cpu_seconds += cpu_seconds_now() - cpu0;
    st.iterations_done++;
    since_delivery = 1;
    double now = vf_seconds_now();
    st.seconds = now - start;
    if (st.iterations_done == 1) {
      st.first_seconds = st.seconds;
      st.first_rays = st.stats.rays;
    }
    if (control && control->deliver) {
      /* After the range's last iteration the final delivery follows: it is the one due. */
      st.delivery_due = k + 1 < end && control->delivery_interval > 0.0 &&
                        now - last_delivery >= control->delivery_interval;
      int rc = control->deliver(control->ctx, film, &st);
      if (rc < 0) {
        err = rc;
        break;
      }
      if (st.delivery_due) {
        last_delivery = vf_seconds_now();
        since_delivery = 0;
      }
      stop = rc == VF_RENDER_STOP;
      st.delivery_due = 0;
    }
    if (control && control->progress) control->progress(control->ctx, &st);
  }
  st.seconds = vf_seconds_now() - start;
  /* The iterations' buffers are not needed while the film is delivered (shipped, written)
   * and the next range starts: gone, they leave room for the film's copies then. */
  vf_vcm_trim(r->vcm);
  if (err == VF_OK && since_delivery && control && control->deliver) {
    st.delivery_due = st.final = 1;
    int rc = control->deliver(control->ctx, film, &st);
    if (rc < 0) err = rc;
  }
  if (status) *status = st;
  return err;
}
