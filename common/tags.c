#include "tags.h"

#include "error.h"
#include "parse.h"

#include <stdio.h>
#include <string.h>

void vf_tags_init(vf_tags *tags) { memset(tags, 0, sizeof *tags); }

/* tag[0, len) for an error message: printable ASCII as it is, every other byte as \xNN,
 * at most 48 bytes of it (then "..."), so that a refusal never carries what it refuses. */
static void quote(char *out, size_t n, const char *tag, size_t len) {
  size_t k = 0;
  for (size_t i = 0; i < len && k + 8 < n; i++) {
    unsigned char c = (unsigned char)tag[i];
    if (i == 48) {
      k += (size_t)snprintf(out + k, n - k, "...");
      break;
    }
    if (c >= 0x20 && c < 0x7f && c != '\\') out[k++] = (char)c;
    else k += (size_t)snprintf(out + k, n - k, "\\x%02x", c);
  }
  out[k] = '\0';
}

/* N and its unit after "mem>=": the bytes, or 0 when malformed or above 2^60. */
static uint64_t memory_bytes(const char *s, size_t len) {
  uint64_t n;
  const char *unit = len > 0 ? vf_parse_u64(s, &n) : NULL;
  if (unit == NULL || unit != s + len - 1 || n == 0) return 0;
  unsigned shift = *unit == 'K' ? 10 : *unit == 'M' ? 20 : *unit == 'G' ? 30 : *unit == 'T' ? 40 : 0;
  if (shift == 0 || n > (UINT64_C(1) << (60 - shift))) return 0;
  return n << shift;
}

uint64_t vf_tag_memory(const char *tag) {
  size_t p = strlen(VF_TAG_MEMORY_PREFIX);
  if (strncmp(tag, VF_TAG_MEMORY_PREFIX, p) != 0) return 0;
  return memory_bytes(tag + p, strlen(tag + p));
}

int vf_tag_check(const char *what, const char *tag, size_t len, int requirement) {
  char shown[256];
  quote(shown, sizeof shown, tag, len);
  if (len == 0) return vf_error_set(VF_EINVAL, "%s: an empty tag", what);
  if (len > VF_TAG_MAX_BYTES)
    return vf_error_set(VF_EINVAL, "%s: tag '%s' is %zu bytes long, at most %d", what, shown, len, VF_TAG_MAX_BYTES);
  if (!vf_utf8_valid(tag, len)) return vf_error_set(VF_EINVAL, "%s: tag '%s' is not UTF-8", what, shown);
  for (size_t i = 0; i < len; i++) {
    unsigned char c = (unsigned char)tag[i];
    if (c <= 0x20 || c == 0x7f || c == ',')
      return vf_error_set(VF_EINVAL, "%s: tag '%s' holds a %s (not allowed in a tag)", what, shown,
                          c == ',' ? "comma" : c == ' ' ? "space" : "control character");
  }
  size_t p = strlen(VF_TAG_MEMORY_PREFIX);
  if (len >= p && memcmp(tag, VF_TAG_MEMORY_PREFIX, p) == 0) {
    if (!requirement)
      return vf_error_set(VF_EINVAL, "%s: tag '%s': mem>= is a requirement a job makes; a worker's memory is measured, "
                          "not given as a tag", what, shown);
    if (memory_bytes(tag + p, len - p) == 0)
      return vf_error_set(VF_EINVAL, "%s: requirement '%s': memory is mem>=N with N a whole number from 1 and a unit "
                          "K, M, G or T (mem>=64G), at most 2^60 bytes", what, shown);
  }
  return VF_OK;
}

int vf_tags_add(const char *what, vf_tags *tags, const char *tag, size_t len, int requirement) {
  int err = vf_tag_check(what, tag, len, requirement);
  if (err != VF_OK) return err;
  for (unsigned i = 0; i < tags->count; i++)
    if (strlen(tags->tag[i]) == len && memcmp(tags->tag[i], tag, len) == 0) return VF_OK;
  if (tags->count == VF_TAGS_MAX) {
    char shown[256];
    quote(shown, sizeof shown, tag, len);
    return vf_error_set(VF_EINVAL, "%s: more than %d tags (at '%s')", what, VF_TAGS_MAX, shown);
  }
  memcpy(tags->tag[tags->count], tag, len);
  tags->tag[tags->count][len] = '\0';
  tags->count++;
  return VF_OK;
}

int vf_tags_parse(const char *what, const char *list, vf_tags *tags, int requirement) {
  vf_tags grown = *tags;
  const char *s = list;
  for (;;) {
    const char *comma = strchr(s, ',');
    size_t len = comma ? (size_t)(comma - s) : strlen(s);
    if (len == 0)
      return vf_error_set(VF_EINVAL, "%s: '%.60s' has an empty tag (tags are separated by single commas)", what, list);
    int err = vf_tags_add(what, &grown, s, len, requirement);
    if (err != VF_OK) return err;
    if (comma == NULL) break;
    s = comma + 1;
  }
  *tags = grown;
  return VF_OK;
}

int vf_tags_satisfied(const vf_tags *requires, const vf_tags *tags, uint64_t memory_bytes, const char **missing) {
  for (unsigned i = 0; i < requires->count; i++) {
    const char *r = requires->tag[i];
    uint64_t need = vf_tag_memory(r);
    int ok = 0;
    if (need > 0) {
      ok = memory_bytes >= need;
    } else {
      for (unsigned k = 0; k < tags->count && !ok; k++) ok = strcmp(tags->tag[k], r) == 0;
    }
    if (!ok) {
      if (missing) *missing = r;
      return 0;
    }
  }
  return 1;
}

void vf_tags_format(const vf_tags *tags, char *buf, size_t n) {
  size_t k = 0;
  if (n == 0) return;
  buf[0] = '\0';
  for (unsigned i = 0; i < tags->count; i++) {
    int w = snprintf(buf + k, n - k, "%s%s", i ? "," : "", tags->tag[i]);
    if (w < 0 || (size_t)w >= n - k) break;
    k += (size_t)w;
  }
}
