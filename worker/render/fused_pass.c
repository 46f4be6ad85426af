/* bpt's fused pass: fused_pass.h. */
#include "fused_pass.h"

#include "../../common/clock.h"
#include "camera_pass.h"
#include "light_pass.h"
#include "single_stage.h"

static void fused_task(void *ctx, size_t task, int thread) {
  vf_vcm *v = ctx;
  camera_tile tile = vf_camera_pass_tile(v, (uint32_t)task);
  double t0 = vf_seconds_now();
  vf_light_pass_tile(v, thread, &tile);
  if (v->single_stage) vf_single_stage_keep_tile(v, thread, &tile);
  v->stats[thread].light_seconds += vf_seconds_now() - t0;
  vf_camera_pass_run_tile(v, thread, &tile);
}

void vf_fused_pass_run(vf_vcm *v) { vf_pool_run(v->pool, vf_camera_pass_tiles(v), fused_task, v); }
