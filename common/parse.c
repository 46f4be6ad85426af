#include "parse.h"

#include <stddef.h>

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
