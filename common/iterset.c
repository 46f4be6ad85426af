#include "iterset.h"

#include "error.h"
#include "parse.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void vf_iterset_init(vf_iterset *set) { memset(set, 0, sizeof *set); }

void vf_iterset_destroy(vf_iterset *set) {
  if (set == NULL) return;
  free(set->ranges);
  vf_iterset_init(set);
}

static int reserve(vf_iterset *set, size_t n) {
  if (n <= set->capacity) return VF_OK;
  size_t cap = set->capacity ? set->capacity * 2 : 4;
  while (cap < n) cap *= 2;
  vf_iter_range *r = realloc(set->ranges, cap * sizeof *r);
  if (r == NULL) return VF_ENOMEM;
  set->ranges = r;
  set->capacity = cap;
  return VF_OK;
}

int vf_iterset_copy(vf_iterset *dst, const vf_iterset *src) {
  vf_iterset tmp;
  vf_iterset_init(&tmp);
  if (reserve(&tmp, src->count) != VF_OK) return VF_ENOMEM;
  if (src->count) memcpy(tmp.ranges, src->ranges, src->count * sizeof *src->ranges);
  tmp.count = src->count;
  vf_iterset_destroy(dst);
  *dst = tmp;
  return VF_OK;
}

/* Index of the first range whose end is >= begin (the only candidates to touch it). */
static size_t lower(const vf_iterset *set, uint64_t begin) {
  size_t lo = 0, hi = set->count;
  while (lo < hi) {
    size_t mid = (lo + hi) / 2;
    if (set->ranges[mid].end < begin) lo = mid + 1;
    else hi = mid;
  }
  return lo;
}

int vf_iterset_add(vf_iterset *set, uint64_t begin, uint64_t end) {
  if (begin >= end) return vf_error_set(VF_EINVAL, "empty iteration range [%" PRIu64 ",%" PRIu64 ")", begin, end);
  size_t i = lower(set, begin);
  /* Overlap: a range with begin < end and range.end > begin. */
  for (size_t j = i; j < set->count && set->ranges[j].begin < end; j++)
    if (set->ranges[j].end > begin)
      return vf_error_set(VF_EOVERLAP, "iteration range [%" PRIu64 ",%" PRIu64 ") overlaps [%" PRIu64 ",%" PRIu64 ")",
                          begin, end, set->ranges[j].begin, set->ranges[j].end);
  int touch_left = i < set->count && set->ranges[i].end == begin;
  size_t right = touch_left ? i + 1 : i;
  int touch_right = right < set->count && set->ranges[right].begin == end;
  if (touch_left && touch_right) {
    set->ranges[i].end = set->ranges[right].end;
    memmove(&set->ranges[right], &set->ranges[right + 1], (set->count - right - 1) * sizeof *set->ranges);
    set->count--;
  } else if (touch_left) {
    set->ranges[i].end = end;
  } else if (touch_right) {
    set->ranges[right].begin = begin;
  } else {
    if (reserve(set, set->count + 1) != VF_OK) return VF_ENOMEM;
    memmove(&set->ranges[i + 1], &set->ranges[i], (set->count - i) * sizeof *set->ranges);
    set->ranges[i] = (vf_iter_range){begin, end};
    set->count++;
  }
  return VF_OK;
}

int vf_iterset_intersects(const vf_iterset *a, const vf_iterset *b) {
  size_t i = 0, j = 0;
  while (i < a->count && j < b->count) {
    if (a->ranges[i].end <= b->ranges[j].begin) i++;
    else if (b->ranges[j].end <= a->ranges[i].begin) j++;
    else return 1;
  }
  return 0;
}

int vf_iterset_union(vf_iterset *dst, const vf_iterset *src) {
  if (vf_iterset_intersects(dst, src))
    return vf_error_set(VF_EOVERLAP, "iteration sets overlap: samples would be counted twice");
  vf_iterset tmp;
  vf_iterset_init(&tmp);
  int err = vf_iterset_copy(&tmp, dst);
  for (size_t k = 0; err == VF_OK && k < src->count; k++)
    err = vf_iterset_add(&tmp, src->ranges[k].begin, src->ranges[k].end);
  if (err != VF_OK) {
    vf_iterset_destroy(&tmp);
    return err;
  }
  vf_iterset_destroy(dst);
  *dst = tmp;
  return VF_OK;
}

int vf_iterset_equal(const vf_iterset *a, const vf_iterset *b) {
  return a->count == b->count &&
         (a->count == 0 || memcmp(a->ranges, b->ranges, a->count * sizeof *a->ranges) == 0);
}

int vf_iterset_contains(const vf_iterset *set, uint64_t index) {
  size_t i = lower(set, index + 1);
  return i < set->count && set->ranges[i].begin <= index && index < set->ranges[i].end;
}

uint64_t vf_iterset_count(const vf_iterset *set) {
  uint64_t n = 0;
  for (size_t i = 0; i < set->count; i++) n += set->ranges[i].end - set->ranges[i].begin;
  return n;
}

uint64_t vf_iterset_next_free(const vf_iterset *set, uint64_t from) {
  for (size_t i = 0; i < set->count; i++)
    if (set->ranges[i].begin <= from && from < set->ranges[i].end) return set->ranges[i].end;
  return from;
}

int vf_iterset_format(const vf_iterset *set, char *buf, size_t n) {
  size_t used = 0;
  if (n == 0) return VF_EINVAL;
  buf[0] = '\0';
  for (size_t i = 0; i < set->count; i++) {
    int w = snprintf(buf + used, n - used, "%s[%" PRIu64 ",%" PRIu64 ")", i ? " " : "",
                     set->ranges[i].begin, set->ranges[i].end);
    if (w < 0 || (size_t)w >= n - used) return vf_error_set(VF_EINVAL, "iteration set text too long");
    used += (size_t)w;
  }
  return VF_OK;
}

/* One linear pass: the text comes from files and messages and may be long, and a parser
 * that rescans the rest of the string per range (sscanf does) would let a crafted input
 * take quadratic time. */
int vf_iterset_parse(vf_iterset *set, const char *text) {
  vf_iterset tmp;
  vf_iterset_init(&tmp);
  uint64_t prev_end = 0;
  for (const char *p = text; *p != '\0';) {
    const char *start = p;
    uint64_t b = 0, e = 0;
    int ok = (start == text || *p++ == ' ') && *p++ == '[' && (p = vf_parse_u64(p, &b)) != NULL && *p++ == ',' &&
             (p = vf_parse_u64(p, &e)) != NULL && *p++ == ')' && b < e && (start == text || b > prev_end);
    int err = ok ? vf_iterset_add(&tmp, b, e) : vf_error_set(VF_EINVAL, "malformed iteration set near \"%.40s\"", start);
    if (err != VF_OK) {
      vf_iterset_destroy(&tmp);
      return err;
    }
    prev_end = e;
  }
  vf_iterset_destroy(set);
  *set = tmp;
  return VF_OK;
}
