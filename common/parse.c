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

int vf_utf8_valid(const char *text, size_t n) {
  const unsigned char *s = (const unsigned char *)text;
  for (size_t i = 0; i < n;) {
    unsigned c = s[i];
    size_t extra = c < 0x80 ? 0 : (c & 0xE0) == 0xC0 ? 1 : (c & 0xF0) == 0xE0 ? 2 : (c & 0xF8) == 0xF0 ? 3 : 4;
    if (extra == 4 || extra > n - i - 1) return 0; /* a bad lead byte, or cut short */
    unsigned cp = extra == 0 ? c : c & (0x3Fu >> extra);
    for (size_t k = 1; k <= extra; k++) {
      if ((s[i + k] & 0xC0) != 0x80) return 0;
      cp = cp << 6 | (s[i + k] & 0x3Fu);
    }
    static const unsigned least[4] = {0, 0x80, 0x800, 0x10000};
    if (cp < least[extra] || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return 0;
    i += extra + 1;
  }
  return 1;
}

void vf_utf8_sanitize(char *s) {
  for (size_t i = 0; s[i];) {
    size_t k = 1;
    while (k <= 4 && s[i + k - 1] != '\0' && !vf_utf8_valid(s + i, k)) k++;
    if (k <= 4 && s[i + k - 1] != '\0') i += k;
    else s[i++] = '?';
  }
}
