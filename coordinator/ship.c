#include "ship.h"

#include "leases.h"
#include "merger.h"

#include <math.h>

/* A new measurement of merge work per part is taken over at least this long, or this many
 * parts, whichever comes later. */
#define SAMPLE_SECONDS 5.0
#define SAMPLE_PARTS 2

double vf_ship_part_seconds(const vf_farm *farm, double pixels) {
  double per_pixel = farm->part_pixels > 0.0 ? farm->part_seconds / farm->part_pixels : VF_SHIP_PRIOR_SECONDS_PER_PIXEL;
  return per_pixel * pixels;
}

void vf_ship_part_work(vf_farm *farm, double seconds, int ends_part) {
  farm->part_work += seconds;
  if (ends_part) farm->part_work_parts++;
}

/* The largest film of the running jobs, in pixels: parts of it are what loads the thread. */
static double film_pixels(const vf_farm *farm, size_t *busy) {
  double pixels = 0.0;
  *busy = 0;
  /* Workers that may ship: every registered one that is not stopping. Counting only the busy
   * ones would tell the first workers of a new job a short interval that the rest then
   * follow all at once. */
  for (size_t i = 0; i < farm->num_workers; i++) *busy += farm->workers[i].state == VF_WORKER_ACTIVE;
  for (size_t i = 0; i < farm->num_jobs; i++) {
    const vf_job *j = farm->jobs[i];
    if (!vf_job_runnable(j)) continue;
    double p = (double)j->film->width * (double)j->film->height;
    if (p > pixels) pixels = p;
  }
  return pixels;
}

void vf_ship_tick(vf_farm *farm, double now) {
  size_t busy;
  double pixels = film_pixels(farm, &busy);
  /* The merge thread's work per part, per pixel of the parts merged meanwhile. */
  if (farm->part_work_since == 0.0) farm->part_work_since = now;
  if (farm->part_work_parts >= SAMPLE_PARTS && now - farm->part_work_since >= SAMPLE_SECONDS && pixels > 0.0) {
    double sample = farm->part_work / farm->part_work_parts;
    if (farm->part_pixels > 0.0) {
      double old = farm->part_seconds / farm->part_pixels * pixels;
      farm->part_seconds = 0.7 * old + 0.3 * sample;
    } else {
      farm->part_seconds = sample;
    }
    farm->part_pixels = pixels;
    farm->part_work = 0.0;
    farm->part_work_parts = 0;
    farm->part_work_since = now;
  }
  /* Loads over the last tick, smoothed over about five seconds. */
  double dt = farm->load_at > 0.0 ? now - farm->load_at : 0.0;
  if (dt > 0.0) {
    double busy_now = farm->merger ? vf_merger_busy_seconds(farm->merger) : 0.0;
    double merge = (busy_now - farm->load_busy) / dt, loop = farm->loop_busy / dt;
    double a = dt / 5.0 > 1.0 ? 1.0 : dt / 5.0;
    farm->merge_load += a * ((merge > 1.0 ? 1.0 : merge) - farm->merge_load);
    farm->loop_load += a * ((loop > 1.0 ? 1.0 : loop) - farm->loop_load);
    farm->load_busy = busy_now;
    farm->loop_busy = 0.0;
  } else if (farm->merger) {
    farm->load_busy = vf_merger_busy_seconds(farm->merger);
  }
  double previous = farm->ship_seconds > 0.0 ? farm->ship_seconds : VF_SHIP_MIN_SECONDS;
  double want = (double)busy * vf_ship_part_seconds(farm, pixels) / VF_SHIP_TARGET_LOAD;
  double over = farm->merge_load > farm->loop_load ? farm->merge_load : farm->loop_load;
  if (over > 0.9 && want < previous) want = previous; /* saturated: no shorter */
  if (want < previous && dt > 0.0) { /* shrink slowly */
    double floor = previous * (1.0 - 0.1 * dt);
    if (want < floor) want = floor;
  }
  if (want < VF_SHIP_MIN_SECONDS) want = VF_SHIP_MIN_SECONDS;
  if (want > VF_SHIP_MAX_SECONDS) want = VF_SHIP_MAX_SECONDS;
  farm->ship_seconds = want;
  farm->load_at = now;
}

void vf_ship_workers_changed(vf_farm *farm) {
  size_t workers;
  double pixels = film_pixels(farm, &workers);
  double want = (double)workers * vf_ship_part_seconds(farm, pixels) / VF_SHIP_TARGET_LOAD;
  if (want > VF_SHIP_MAX_SECONDS) want = VF_SHIP_MAX_SECONDS;
  if (want < VF_SHIP_MIN_SECONDS) want = VF_SHIP_MIN_SECONDS;
  if (want > farm->ship_seconds) farm->ship_seconds = want;
}

uint32_t vf_ship_interval_ms(const vf_farm *farm) {
  double s = farm->ship_seconds > 0.0 ? farm->ship_seconds : VF_SHIP_MIN_SECONDS;
  return (uint32_t)(s * 1000.0 + 0.5);
}

double vf_ship_lease_seconds(const vf_farm *farm) {
  double s = farm->ship_seconds > 0.0 ? farm->ship_seconds : VF_SHIP_MIN_SECONDS;
  return s > VF_SHIP_MIN_SECONDS && s > farm->config.lease_seconds ? s : farm->config.lease_seconds;
}

uint32_t vf_ship_retry_ms(const vf_farm *farm) {
  size_t busy;
  double ms = 1000.0 * vf_ship_part_seconds(farm, film_pixels(farm, &busy));
  if (ms < 100.0) ms = 100.0;
  if (ms > 5000.0) ms = 5000.0;
  return (uint32_t)ms;
}
