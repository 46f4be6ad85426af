#include "farm_reply.h"

#include "../common/error.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void vf_farm_reply_init(vf_farm_reply *r) {
  memset(r, 0, sizeof *r);
  vcmfarm__envelope__init(&r->env);
}

void vf_farm_reply_error(vf_farm_reply *r, Vcmfarm__ErrorCode code, const char *message) {
  char text[sizeof r->text]; /* message may be r->text */
  snprintf(text, sizeof text, "%s", message);
  vf_farm_reply_init(r);
  vcmfarm__error__init(&r->error);
  memcpy(r->text, text, sizeof text);
  r->error.code = code;
  r->error.message = r->text;
  r->env.body_case = VCMFARM__ENVELOPE__BODY_ERROR;
  r->env.error = &r->error;
}

void vf_farm_reply_errorf(vf_farm_reply *r, Vcmfarm__ErrorCode code, const char *fmt, ...) {
  char text[1024];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(text, sizeof text, fmt, ap);
  va_end(ap);
  vf_farm_reply_error(r, code, text);
}

Vcmfarm__ErrorCode vf_farm_wire_code(int err) {
  if (err == VF_EVERSION) return VCMFARM__ERROR_CODE__ERROR_VERSION;
  if (err == VF_ENOJOB) return VCMFARM__ERROR_CODE__ERROR_UNKNOWN_JOB;
  return vf_error_is_input(err) ? VCMFARM__ERROR_CODE__ERROR_BAD_REQUEST : VCMFARM__ERROR_CODE__ERROR_INTERNAL;
}

void vf_farm_reply_fail(vf_farm_reply *r, int err) { vf_farm_reply_error(r, vf_farm_wire_code(err), vf_error_detail(err)); }

void vf_farm_reply_ack(vf_farm_reply *r, int accepted, const char *message) {
  vcmfarm__result_ack__init(&r->result_ack);
  if (message != r->text) snprintf(r->text, sizeof r->text, "%s", message);
  r->result_ack.accepted = accepted;
  r->result_ack.message = r->text;
  r->env.body_case = VCMFARM__ENVELOPE__BODY_RESULT_ACK;
  r->env.result_ack = &r->result_ack;
}

void vf_farm_reply_release(vf_farm_reply *r) {
  free(r->job_status);
  free(r->job_status_ptrs);
  free(r->worker_status);
  free(r->worker_status_ptrs);
  free(r->film_bytes);
  free(r->log);
  free(r->log_ptrs);
  free(r->events);
  free(r->event_ptrs);
  free(r->tag_ptrs);
  free(r->missing);
  free(r->blob_bytes);
  free(r->file_refs);
  free(r->file_ref_ptrs);
  vf_farm_reply_init(r);
}
