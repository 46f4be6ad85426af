/* Requests to a vf_farm in process, as clients and workers send them, for the
 * coordinator's tests (test_farm_partial, test_deadline, test_farm_pilot): a job of a
 * built-in scene submitted, a worker registered, a lease asked for, the messages of a
 * result sent. Each answers
 * with what the test needs next and fails a check (check.h) where the farm's answer is
 * not the kind asked for. */
#ifndef VF_TEST_FARM_CALLS_H
#define VF_TEST_FARM_CALLS_H

#include "check.h"
#include "coordinator/farm.h"

#include <stdio.h>

/* Submits job `name`: built-in scene `builtin`, whose content hash is scene_hash (32
 * bytes), with the canonical settings text `settings`, `iterations` iterations, priority 1
 * and a time limit of time_limit seconds (0: none). Its id; 0 if refused. */
static inline uint64_t farm_submit_builtin(vf_farm *farm, double now, const char *name, const char *builtin,
                                           const uint8_t *scene_hash, const char *settings, uint64_t iterations,
                                           double time_limit) {
  Vcmfarm__Scene scene = VCMFARM__SCENE__INIT;
  scene.source_case = VCMFARM__SCENE__SOURCE_BUILTIN;
  scene.builtin = (char *)builtin;
  Vcmfarm__SubmitJob sm = VCMFARM__SUBMIT_JOB__INIT;
  sm.name = (char *)name;
  sm.scene = &scene;
  sm.scene_hash.data = (uint8_t *)scene_hash;
  sm.scene_hash.len = 32;
  sm.settings = (char *)settings;
  sm.iterations = iterations;
  sm.priority = 1;
  sm.time_limit = time_limit;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_SUBMIT;
  q.submit = &sm;
  vf_farm_reply r;
  vf_farm_handle(farm, &q, now, &r);
  CHECK_INT_EQ(r.env.body_case, VCMFARM__ENVELOPE__BODY_SUBMITTED);
  uint64_t id = r.env.body_case == VCMFARM__ENVELOPE__BODY_SUBMITTED ? r.submitted.job_id : 0;
  vf_farm_reply_release(&r);
  return id;
}

/* Registers worker `name`. Its id; 0 if refused. */
static inline uint64_t farm_register(vf_farm *farm, double now, const char *name) {
  Vcmfarm__Register reg = VCMFARM__REGISTER__INIT;
  reg.name = (char *)name;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_REGISTER;
  q.register_ = &reg;
  vf_farm_reply r;
  vf_farm_handle(farm, &q, now, &r);
  CHECK_INT_EQ(r.env.body_case, VCMFARM__ENVELOPE__BODY_REGISTERED);
  uint64_t id = r.env.body_case == VCMFARM__ENVELOPE__BODY_REGISTERED ? r.registered.worker_id : 0;
  vf_farm_reply_release(&r);
  return id;
}

/* Worker `worker` asks for work: 1 when the answer *r is a lease (r->lease; the caller
 * releases *r, whatever the answer). */
static inline int farm_request_lease(vf_farm *farm, double now, uint64_t worker, vf_farm_reply *r) {
  Vcmfarm__LeaseRequest lr = VCMFARM__LEASE_REQUEST__INIT;
  lr.worker_id = worker;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_LEASE_REQUEST;
  q.lease_request = &lr;
  vf_farm_handle(farm, &q, now, r);
  return r->env.body_case == VCMFARM__ENVELOPE__BODY_LEASE;
}

/* Sends one message of a result (what vf_film_send_tiles hands its callback); the answer's
 * message into message (size bytes), "not an ack" for another kind of answer. 1 when it
 * was accepted. */
static inline int farm_send_result(vf_farm *farm, double now, Vcmfarm__LeaseResult *m, char *message, size_t size) {
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_RESULT;
  q.result = m;
  vf_farm_reply r;
  vf_farm_handle(farm, &q, now, &r);
  int ack = r.env.body_case == VCMFARM__ENVELOPE__BODY_RESULT_ACK;
  int accepted = ack && r.result_ack.accepted;
  snprintf(message, size, "%s", ack ? r.result_ack.message : "not an ack");
  vf_farm_reply_release(&r);
  return accepted;
}

/* vf_film_send_tiles's callback over farm_send_result: the farm, its clock and the last
 * answer's message. */
typedef struct {
  vf_farm *farm;
  double now;
  char message[1024];
} farm_sender;

static inline int farm_send_one(void *ctx, Vcmfarm__LeaseResult *m) {
  farm_sender *s = ctx;
  return farm_send_result(s->farm, s->now, m, s->message, sizeof s->message);
}

#endif
