/* Results in parts (coordinator/partial.c, coordinator/results.c), in process: a job of a
 * 128x64 film (two 64x64 tiles) and one registered worker holding a lease, whose result
 * arrives one tile per message. Checks that nothing touches the job film before every
 * tile of a part is there, that a bad tile drops the part, that a part merged shrinks the
 * lease and is merged once even when sent twice, and that a part left incomplete is
 * dropped once its sender is silent for the worker timeout. */
#include "check.h"
#include "common/error.h"
#include "common/film_wire.h"
#include "common/settings.h"
#include "coordinator/farm.h"
#include "farm_calls.h"

#include <stdlib.h>
#include <unistd.h>

#define TIMEOUT 15.0

static char dir[64];
static const uint8_t scene_hash[32] = {7, 7, 7};
static char settings[512];

typedef struct {
  vf_farm farm;
  uint64_t worker, lease, job, begin, end;
  double now;
} fixture;

static void request(fixture *f, Vcmfarm__Envelope *q, vf_farm_reply *r) { vf_farm_handle(&f->farm, q, f->now, r); }

static void setup(fixture *f, uint64_t iterations) {
  vf_farm_config config = {dir, TIMEOUT, 1000.0, 0.0};
  vf_farm_init(&f->farm, &config);
  f->now = 1000.0;
  vf_farm_reply r;
  f->job = farm_submit_builtin(&f->farm, f->now, "parts", "cornell", scene_hash, settings, iterations, 0.0);
  f->worker = farm_register(&f->farm, f->now, "w");
  /* A fast worker, so that its lease covers the whole job. */
  f->farm.workers[0].rate = 1e6;
  CHECK(farm_request_lease(&f->farm, f->now, f->worker, &r));
  f->lease = r.lease.lease_id;
  f->begin = r.lease.begin;
  f->end = r.lease.end;
  vf_farm_reply_release(&r);
}

/* The film of iterations [begin, end) with made-up but valid sums, and 3 biased merges
 * (upg's) per iteration. */
static vf_film *part_film(uint64_t begin, uint64_t end) {
  vf_film *film;
  if (vf_film_create(128, 64, &film) != VF_OK) return NULL;
  memcpy(film->scene_hash, scene_hash, 32);
  snprintf(film->settings_text, sizeof film->settings_text, "%s", settings);
  float *rgb = malloc(3 * 128 * 64 * sizeof *rgb);
  for (uint64_t k = begin; k < end; k++) {
    for (int i = 0; i < 3 * 128 * 64; i++) rgb[i] = (float)((i * 7 + k * 13) % 17) / 17.0f;
    vf_film_add_iteration(film, k, rgb, rgb, NULL);
  }
  free(rgb);
  film->render_seconds = 0.5;
  film->biased_merges = 3 * (end - begin);
  return film;
}

typedef struct {
  fixture *f;
  int spoil_second; /* the second message's tile holds a NaN */
  int only_first;   /* send the first message only */
  int sent;
  char message[1024];
} sender;

static int send_one(void *ctx, Vcmfarm__LeaseResult *m) {
  sender *s = ctx;
  if (s->only_first && s->sent == 1) return 1;
  s->sent++;
  Vcmfarm__Tile spoilt, *kept = m->n_tiles ? m->tiles[0] : NULL;
  uint8_t *block = NULL;
  if (s->spoil_second && s->sent == 2 && (block = calloc(72 * 64 * 64, 1)) != NULL) {
    /* the same tile, uncompressed (18 channels of 64 x 64), with a NaN in its first (FLOAT) */
    float nan = NAN;
    memcpy(block + 4 * 5, &nan, sizeof nan);
    vcmfarm__tile__init(&spoilt);
    spoilt.x = kept->x;
    spoilt.y = kept->y;
    spoilt.chunk = (ProtobufCBinaryData){72 * 64 * 64, block};
    m->tiles[0] = &spoilt;
  }
  int accepted = farm_send_result(&s->f->farm, s->f->now, m, s->message, sizeof s->message);
  if (kept) m->tiles[0] = kept;
  free(block);
  return accepted;
}

static int send_part(fixture *f, uint64_t begin, uint64_t end, sender *s) {
  vf_film *film = part_film(begin, end);
  Vcmfarm__LeaseResult m = VCMFARM__LEASE_RESULT__INIT;
  m.worker_id = f->worker;
  m.lease_id = f->lease;
  m.job_id = f->job;
  m.begin = begin;
  s->f = f;
  int rc = vf_film_send_tiles(film, &m, 1, send_one, s);
  vf_film_destroy(film);
  return rc;
}

static uint64_t done(fixture *f) { return vf_iterset_count(&vf_farm_job(&f->farm, f->job)->film->iterations); }

static void test_a_part_merges_only_complete_and_once(void) {
  fixture f;
  setup(&f, 8);
  CHECK_INT_EQ(f.begin, 0);
  CHECK_INT_EQ(f.end, 8);
  sender s = {.only_first = 1};
  CHECK_INT_EQ(send_part(&f, 0, 3, &s), 1);
  CHECK_STR_CONTAINS(s.message, "tiles 1/2");
  CHECK_INT_EQ(done(&f), 0); /* half a part touches nothing */
  s = (sender){0};
  CHECK_INT_EQ(send_part(&f, 0, 3, &s), 1); /* the whole part: tile 1 again, identical, and tile 2 */
  CHECK_STR_CONTAINS(s.message, "merged");
  CHECK_INT_EQ(done(&f), 3);
  CHECK_INT_EQ(vf_farm_job(&f.farm, f.job)->film->biased_merges, 9); /* the header's count, carried */
  vf_lease *l = vf_lease_find(&f.farm.leases, f.lease);
  CHECK(l != NULL && l->begin == 3 && l->end == 8); /* the lease shrank */
  s = (sender){0};
  CHECK_INT_EQ(send_part(&f, 0, 3, &s), 1); /* sent again: acknowledged, not counted */
  CHECK_STR_CONTAINS(s.message, "already merged");
  CHECK_INT_EQ(done(&f), 3);
  s = (sender){0};
  CHECK_INT_EQ(send_part(&f, 3, 8, &s), 1);
  CHECK_INT_EQ(done(&f), 8);
  CHECK_INT_EQ(vf_farm_job(&f.farm, f.job)->film->biased_merges, 24); /* counted once, summed */
  CHECK(vf_lease_find(&f.farm.leases, f.lease) == NULL); /* nothing left of it */
  CHECK_INT_EQ(vf_farm_job(&f.farm, f.job)->results_refused, 0);
  vf_farm_destroy(&f.farm);
}

static void test_a_bad_tile_drops_the_part_and_spares_the_film(void) {
  fixture f;
  setup(&f, 8);
  sender s = {.spoil_second = 1};
  CHECK_INT_EQ(send_part(&f, 0, 4, &s), 0);
  CHECK_STR_CONTAINS(s.message, "not finite");
  CHECK_INT_EQ(done(&f), 0);
  vf_lease *l = vf_lease_find(&f.farm.leases, f.lease);
  CHECK(l != NULL && l->partial == NULL && l->begin == 0);
  CHECK_INT_EQ(vf_farm_job(&f.farm, f.job)->results_refused, 1);
  /* A tile arriving again with other values is refused too. */
  s = (sender){.only_first = 1};
  CHECK_INT_EQ(send_part(&f, 0, 4, &s), 1);
  vf_film *other = part_film(0, 4);
  other->sum[0] += 1;
  Vcmfarm__LeaseResult m = VCMFARM__LEASE_RESULT__INIT;
  m.worker_id = f.worker;
  m.lease_id = f.lease;
  m.job_id = f.job;
  s = (sender){0};
  s.f = &f;
  CHECK_INT_EQ(vf_film_send_tiles(other, &m, 1, send_one, &s), 0);
  CHECK_STR_CONTAINS(s.message, "other values");
  vf_film_destroy(other);
  CHECK_INT_EQ(done(&f), 0);
  vf_farm_destroy(&f.farm);
}

/* Issue 41: a result is merged only from the worker that holds the lease: another
 * registered worker's result for it is refused, nothing merged, and the holder's still
 * merges. */
static void test_a_result_from_another_worker_is_refused(void) {
  fixture f;
  setup(&f, 8);
  vf_farm_reply r;
  Vcmfarm__Register reg = VCMFARM__REGISTER__INIT;
  reg.name = "intruder";
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_REGISTER;
  q.register_ = &reg;
  request(&f, &q, &r);
  uint64_t intruder = r.registered.worker_id, holder = f.worker;
  vf_farm_reply_release(&r);
  CHECK(intruder != holder);
  sender s = {0};
  f.worker = intruder;
  CHECK_INT_EQ(send_part(&f, 0, 4, &s), 0);
  CHECK_STR_CONTAINS(s.message, "not by the sender");
  CHECK_INT_EQ(done(&f), 0);
  f.worker = holder;
  s = (sender){0};
  CHECK_INT_EQ(send_part(&f, 0, 4, &s), 1);
  CHECK_STR_CONTAINS(s.message, "merged");
  CHECK_INT_EQ(done(&f), 4);
  vf_farm_destroy(&f.farm);
}

static void test_an_incomplete_part_is_dropped_when_silent(void) {
  fixture f;
  setup(&f, 8);
  sender s = {.only_first = 1};
  CHECK_INT_EQ(send_part(&f, 0, 2, &s), 1);
  vf_lease *l = vf_lease_find(&f.farm.leases, f.lease);
  CHECK(l != NULL && l->partial != NULL);
  vf_farm_expire(&f.farm, f.now + TIMEOUT / 2);
  l = vf_lease_find(&f.farm.leases, f.lease);
  CHECK(l != NULL && l->partial != NULL); /* not silent long enough */
  vf_farm_expire(&f.farm, f.now + TIMEOUT + 1.0);
  l = vf_lease_find(&f.farm.leases, f.lease);
  CHECK(l != NULL && l->partial == NULL); /* kept as expired, without the staged film */
  CHECK_INT_EQ(done(&f), 0);
  vf_farm_destroy(&f.farm);
}

int main(void) {
  snprintf(dir, sizeof dir, "/tmp/vf_test_farm_partial_XXXXXX");
  if (mkdtemp(dir) == NULL) return 1;
  vf_settings s;
  vf_settings_default(&s);
  s.width = 128;
  s.height = 64;
  vf_settings_format(&s, settings, sizeof settings);
  RUN(test_a_part_merges_only_complete_and_once);
  RUN(test_a_bad_tile_drops_the_part_and_spares_the_film);
  RUN(test_an_incomplete_part_is_dropped_when_silent);
  RUN(test_a_result_from_another_worker_is_refused);
  char cmd[128];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
  if (system(cmd) != 0) return 1;
  return check_finish();
}
