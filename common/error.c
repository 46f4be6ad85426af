#include "error.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

static _Thread_local char detail[1024];

const char *vf_strerror(int err) {
  switch (err) {
  case VF_OK: return "success";
#define XX(code, msg) case VF_##code: return msg;
    VF_ERRNO_MAP(XX)
#undef XX
  }
  return "unknown error";
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
  return err;
}

const char *vf_error_detail(int err) {
  return detail[0] ? detail : vf_strerror(err);
}

void vf_error_clear(void) { detail[0] = '\0'; }
