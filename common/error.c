#include "error.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

static _Thread_local char detail[1024];
static _Thread_local int detail_err; /* the code detail belongs to; VF_OK when there is none */

const char *vf_strerror(int err) {
  switch (err) {
  case VF_OK: return "success";
#define XX(code, msg, _) case VF_##code: return msg;
    VF_ERRNO_MAP(XX)
#undef XX
  }
  return "unknown error";
}

int vf_error_is_input(int err) {
  enum { INPUT = 1, SYSTEM = 0 };
  switch (err) {
#define XX(code, _, fault) case VF_##code: return fault;
    VF_ERRNO_MAP(XX)
#undef XX
  }
  return 0;
}

int vf_error_set(int err, const char *fmt, ...) {
  /* Formatted aside first, so a caller may wrap the current detail:
   * vf_error_set(err, "files[3]: %s", vf_error_detail(err)). */
  char text[sizeof detail];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(text, sizeof text, fmt, ap);
  va_end(ap);
  memcpy(detail, text, sizeof detail);
  detail_err = detail[0] ? err : VF_OK;
  return err;
}

const char *vf_error_detail(int err) { return detail[0] != '\0' && detail_err == err ? detail : vf_strerror(err); }

int vf_error_code(void) { return detail[0] != '\0' ? detail_err : VF_OK; }

void vf_error_clear(void) {
  detail[0] = '\0';
  detail_err = VF_OK;
}
