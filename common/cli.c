#include "cli.h"

#include "error.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

int vf_cli_int(const char *option, const char *text, long long min, long long max, long long *out) {
  char *end;
  errno = 0;
  long long v = strtoll(text, &end, 10);
  if (errno || end == text || *end != '\0' || v < min || v > max)
    return vf_error_set(VF_EUSAGE, "%s: '%s' is not a whole number in [%lld, %lld]", option, text, min, max);
  *out = v;
  return VF_OK;
}

int vf_cli_u64(const char *option, const char *text, uint64_t *out) {
  char *end;
  errno = 0;
  if (text[0] == '-') return vf_error_set(VF_EUSAGE, "%s: '%s' must not be negative", option, text);
  unsigned long long v = strtoull(text, &end, 10);
  if (errno || end == text || *end != '\0')
    return vf_error_set(VF_EUSAGE, "%s: '%s' is not a whole number", option, text);
  *out = v;
  return VF_OK;
}

int vf_cli_double(const char *option, const char *text, double min, double max, double *out) {
  char *end;
  errno = 0;
  double v = strtod(text, &end);
  if (errno || end == text || *end != '\0' || !isfinite(v) || v < min || v > max)
    return vf_error_set(VF_EUSAGE, "%s: '%s' is not a number in [%g, %g]", option, text, min, max);
  *out = v;
  return VF_OK;
}

int vf_cli_resolution(const char *option, const char *text, int *width, int *height) {
  int w, h, n = 0;
  if (sscanf(text, "%dx%d%n", &w, &h, &n) != 2 || text[n] != '\0' || w < 1 || h < 1 || w > 65536 || h > 65536)
    return vf_error_set(VF_EUSAGE, "%s: '%s' is not WIDTHxHEIGHT with both in [1, 65536]", option, text);
  *width = w;
  *height = h;
  return VF_OK;
}

const char *vf_parse_u64(const char *s, uint64_t *out) {
  uint64_t v = 0;
  const char *p = s;
  for (; *p >= '0' && *p <= '9'; p++) {
    unsigned d = (unsigned)(*p - '0');
    if (v > (UINT64_MAX - d) / 10) return NULL;
    v = v * 10 + d;
  }
  if (p == s) return NULL;
  *out = v;
  return p;
}

int vf_cli_exit_status(int err) {
  switch (err) {
  case VF_OK: return VF_EXIT_OK;
  case VF_EINVAL:
  case VF_ENOENT:
  case VF_EUSAGE:
  case VF_ESCENE:
  case VF_EMESH:
  case VF_EEXR:
  case VF_EFILM:
  case VF_EMISMATCH:
  case VF_EOVERLAP: return VF_EXIT_BAD_INPUT;
  default: return VF_EXIT_FAILURE;
  }
}

int vf_cli_fail(const char *command, int err) {
  fprintf(stderr, "vcmfarm %s: %s\n", command, vf_error_detail(err));
  return vf_cli_exit_status(err);
}
