#include "lease.h"

#include "../common/error.h"
#include "partial.h"

#include <sodium.h>
#include <stdlib.h>
#include <string.h>

void vf_lease_table_init(vf_lease_table *t) { memset(t, 0, sizeof *t); }

void vf_lease_table_destroy(vf_lease_table *t) {
  for (size_t i = 0; i < t->count; i++) vf_partial_destroy(t->leases[i].partial);
  free(t->leases);
  memset(t, 0, sizeof *t);
}

int vf_lease_add(vf_lease_table *t, uint64_t job_id, uint64_t worker_id, uint64_t begin, uint64_t end, double now,
                 uint64_t *id) {
  if (t->count == t->capacity) {
    size_t cap = t->capacity ? 2 * t->capacity : 16;
    vf_lease *grown = realloc(t->leases, cap * sizeof *grown);
    if (grown == NULL) return vf_error_set(VF_ENOMEM, "out of memory for leases");
    t->leases = grown;
    t->capacity = cap;
  }
  uint64_t new_id;
  do {
    randombytes_buf(&new_id, sizeof new_id);
  } while (new_id == 0 || vf_lease_find(t, new_id) != NULL);
  t->leases[t->count++] = (vf_lease){.id = new_id, .job_id = job_id, .worker_id = worker_id, .begin = begin,
                                     .end = end, .first = begin, .state = VF_LEASE_ACTIVE, .granted = now};
  *id = new_id;
  return VF_OK;
}

vf_lease *vf_lease_find(vf_lease_table *t, uint64_t id) {
  for (size_t i = 0; i < t->count; i++)
    if (t->leases[i].id == id) return &t->leases[i];
  return NULL;
}

static void remove_at(vf_lease_table *t, size_t i) {
  vf_partial_destroy(t->leases[i].partial);
  memmove(&t->leases[i], &t->leases[i + 1], (t->count - i - 1) * sizeof *t->leases);
  t->count--;
}

void vf_lease_remove(vf_lease_table *t, uint64_t id) {
  for (size_t i = 0; i < t->count; i++)
    if (t->leases[i].id == id) {
      remove_at(t, i);
      return;
    }
}

void vf_lease_expire(vf_lease_table *t, uint64_t id) {
  vf_lease *l = vf_lease_find(t, id);
  if (l == NULL) return;
  l->state = VF_LEASE_EXPIRED;
  size_t expired = 0;
  for (size_t i = 0; i < t->count; i++) expired += t->leases[i].state == VF_LEASE_EXPIRED;
  /* The table is in grant order, so the first expired leases are the oldest. */
  for (size_t i = 0; i < t->count && expired > VF_LEASE_KEEP_EXPIRED;) {
    if (t->leases[i].state == VF_LEASE_EXPIRED) {
      remove_at(t, i);
      expired--;
    } else {
      i++;
    }
  }
}

uint64_t vf_lease_active_iterations(const vf_lease_table *t, uint64_t job_id) {
  uint64_t n = 0;
  for (size_t i = 0; i < t->count; i++)
    if (t->leases[i].job_id == job_id && t->leases[i].state == VF_LEASE_ACTIVE) n += t->leases[i].end - t->leases[i].begin;
  return n;
}

uint64_t vf_lease_rendering_iterations(const vf_lease_table *t, uint64_t job_id) {
  uint64_t n = 0;
  for (size_t i = 0; i < t->count; i++) {
    const vf_lease *l = &t->leases[i];
    if (l->job_id != job_id || l->state != VF_LEASE_ACTIVE) continue;
    uint64_t at = l->first + l->reported < l->end ? l->first + l->reported : l->end;
    if (at > l->begin) n += at - l->begin;
  }
  return n;
}

int vf_lease_free_range(const vf_lease_table *t, uint64_t job_id, const vf_iterset *done, uint64_t first,
                        uint64_t total, uint64_t max_size, uint64_t *begin, uint64_t *end, uint64_t *free_count) {
  vf_iterset taken;
  vf_iterset_init(&taken);
  int err = vf_iterset_copy(&taken, done);
  if (err != VF_OK) return err;
  for (size_t i = 0; i < t->count; i++) {
    const vf_lease *l = &t->leases[i];
    if (l->job_id != job_id || l->state != VF_LEASE_ACTIVE) continue;
    /* Active leases are cut from free iterations, so this cannot overlap; if it ever did,
     * the range is taken either way. */
    if ((err = vf_iterset_add(&taken, l->begin, l->end)) == VF_ENOMEM) goto done;
  }
  err = 0;
  uint64_t last = first + total, taken_inside = 0;
  for (size_t i = 0; i < taken.count; i++) {
    uint64_t b = taken.ranges[i].begin > first ? taken.ranges[i].begin : first;
    uint64_t e = taken.ranges[i].end < last ? taken.ranges[i].end : last;
    if (b < e) taken_inside += e - b;
  }
  *free_count = total - taken_inside;
  uint64_t b = vf_iterset_next_free(&taken, first);
  if (b >= last) goto done;
  uint64_t e = last - b > max_size ? b + max_size : last;
  for (size_t i = 0; i < taken.count; i++)
    if (taken.ranges[i].begin > b && taken.ranges[i].begin < e) e = taken.ranges[i].begin;
  *begin = b;
  *end = e;
  err = 1;
done:
  vf_iterset_destroy(&taken);
  return err;
}

uint64_t vf_lease_size(double rate, double target_seconds, uint64_t free_count, size_t workers) {
  double want = rate > 0.0 ? rate * target_seconds : 1.0;
  if (want > 1e9) want = 1e9;
  uint64_t size = want < 1.0 ? 1 : (uint64_t)want;
  if (workers < 1) workers = 1;
  uint64_t share = (free_count + workers - 1) / workers;
  if (size > share) size = share;
  return size < 1 ? 1 : size;
}
