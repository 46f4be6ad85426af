/* Errors on the wire (coordinator/farm_reply.h): one table, common/error.h's, says for every
 * error code whether the request was wrong (ERROR_BAD_REQUEST: fix it) or the coordinator
 * failed (ERROR_INTERNAL: the same request may succeed later), and every handler answers a
 * failed call through it, so a client can decide from the code whether to retry. */
#include "check.h"

#include "common/error.h"
#include "common/settings.h"
#include "coordinator/farm.h"
#include "coordinator/log.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char dir[64];

/* Failures of this machine or its link: the only codes a client may retry (a module not
 * installed is this machine's: common/module.h). */
static int is_system(int err) {
  return err == VF_ENOMEM || err == VF_EIO || err == VF_EEMBREE || err == VF_ETIMEDOUT || err == VF_ENET ||
         err == VF_EBUSY || err == VF_EMODULE;
}

static void test_every_code_has_one_wire_code(void) {
  int codes = 0;
#define XX(code, _, __)                                                                                     \
  {                                                                                                         \
    int err = VF_##code;                                                                                    \
    Vcmfarm__ErrorCode want = err == VF_EVERSION ? VCMFARM__ERROR_CODE__ERROR_VERSION                       \
                              : err == VF_ENOJOB ? VCMFARM__ERROR_CODE__ERROR_UNKNOWN_JOB                   \
                              : is_system(err)   ? VCMFARM__ERROR_CODE__ERROR_INTERNAL                      \
                                                 : VCMFARM__ERROR_CODE__ERROR_BAD_REQUEST;                  \
    if (vf_farm_wire_code(err) != want) CHECK_FAIL_("VF_%s answers %d, expected %d", #code, vf_farm_wire_code(err), want); \
    CHECK_INT_EQ(vf_error_is_input(err), !is_system(err));                                                  \
    codes++;                                                                                                \
  }
  VF_ERRNO_MAP(XX)
#undef XX
  CHECK(codes >= 22);
  /* A code outside the table is the coordinator's failure, never the request's. */
  CHECK_INT_EQ(vf_farm_wire_code(-1), VCMFARM__ERROR_CODE__ERROR_INTERNAL);
}

static void test_a_failure_answers_its_code_and_detail(void) {
  vf_farm_reply r;
  vf_farm_reply_fail(&r, vf_error_set(VF_ENOMEM, "out of memory for leases"));
  CHECK_INT_EQ(r.env.body_case, VCMFARM__ENVELOPE__BODY_ERROR);
  CHECK_INT_EQ(r.error.code, VCMFARM__ERROR_CODE__ERROR_INTERNAL);
  CHECK_STR_CONTAINS(r.error.message, "out of memory for leases");
  vf_farm_reply_release(&r);
  vf_farm_reply_fail(&r, vf_error_set(VF_EINVAL, "settings: alpha 2 is not in (0, 1]"));
  CHECK_INT_EQ(r.error.code, VCMFARM__ERROR_CODE__ERROR_BAD_REQUEST);
  CHECK_STR_CONTAINS(r.error.message, "alpha 2");
  vf_farm_reply_release(&r);
}

/* Through a handler: a submission naming a scene blob the coordinator does not hold, and
 * one with broken settings, are the request's fault. */
static void submit(vf_farm *farm, const char *settings, const Vcmfarm__Scene *scene, vf_farm_reply *r) {
  static const uint8_t hash[32] = {7};
  Vcmfarm__SubmitJob sm = VCMFARM__SUBMIT_JOB__INIT;
  sm.name = "errors";
  sm.scene = (Vcmfarm__Scene *)scene;
  sm.scene_hash.data = (uint8_t *)hash;
  sm.scene_hash.len = 32;
  sm.settings = (char *)settings;
  sm.iterations = 10;
  sm.priority = 1;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_SUBMIT;
  q.submit = &sm;
  vf_farm_handle(farm, &q, 1000.0, r);
}

static void test_handlers_answer_through_the_table(void) {
  vf_farm farm;
  vf_farm_config config = {dir, 1e9, 20.0, 0.0};
  vf_farm_init(&farm, &config);
  vf_settings s;
  vf_settings_default(&s);
  s.width = 16;
  s.height = 16;
  char settings[512];
  vf_settings_format(&s, settings, sizeof settings);

  uint8_t missing[32] = {1, 2, 3};
  Vcmfarm__BlobRef ref = VCMFARM__BLOB_REF__INIT;
  ref.hash.data = missing;
  ref.hash.len = 32;
  ref.size = 100;
  Vcmfarm__Scene blob_scene = VCMFARM__SCENE__INIT;
  blob_scene.source_case = VCMFARM__SCENE__SOURCE_JSON_BLOB;
  blob_scene.json_blob = &ref;
  vf_farm_reply r;
  submit(&farm, settings, &blob_scene, &r);
  CHECK_INT_EQ(r.env.body_case, VCMFARM__ENVELOPE__BODY_ERROR);
  CHECK_INT_EQ(r.error.code, VCMFARM__ERROR_CODE__ERROR_BAD_REQUEST);
  CHECK_STR_CONTAINS(r.error.message, "send it first");
  vf_farm_reply_release(&r);

  Vcmfarm__Scene builtin = VCMFARM__SCENE__INIT;
  builtin.source_case = VCMFARM__SCENE__SOURCE_BUILTIN;
  builtin.builtin = "cornell";
  submit(&farm, "algorithm=vcm alpha=7", &builtin, &r);
  CHECK_INT_EQ(r.env.body_case, VCMFARM__ENVELOPE__BODY_ERROR);
  CHECK_INT_EQ(r.error.code, VCMFARM__ERROR_CODE__ERROR_BAD_REQUEST);
  CHECK_STR_CONTAINS(r.error.message, "settings");
  vf_farm_reply_release(&r);

  submit(&farm, settings, &builtin, &r);
  CHECK_INT_EQ(r.env.body_case, VCMFARM__ENVELOPE__BODY_SUBMITTED);
  vf_farm_reply_release(&r);
  vf_farm_destroy(&farm);
}

int main(void) {
  snprintf(dir, sizeof dir, "/tmp/vf-test-farm-reply-XXXXXX");
  if (mkdtemp(dir) == NULL) return 1;
  vf_log_set_quiet(1);
  RUN(test_every_code_has_one_wire_code);
  RUN(test_a_failure_answers_its_code_and_detail);
  RUN(test_handlers_answer_through_the_table);
  char cmd[128];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
  if (system(cmd) != 0) return 1;
  return check_finish();
}
