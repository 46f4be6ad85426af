#include "convergence.h"

#include "error.h"
#include "parse.h"

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define ATTR "vcmfarm:convergence"

void vf_convergence_init(vf_convergence_log *log) {
  log->entries = NULL;
  log->count = log->capacity = 0;
}

void vf_convergence_destroy(vf_convergence_log *log) {
  if (log == NULL) return;
  free(log->entries);
  vf_convergence_init(log);
}

int vf_convergence_reserve(vf_convergence_log *log, size_t more) {
  if (more > SIZE_MAX / sizeof *log->entries / 2 - log->count) return vf_error_set(VF_ENOMEM, "convergence log too long");
  size_t need = log->count + more;
  if (need <= log->capacity) return VF_OK;
  size_t cap = log->capacity ? log->capacity : 8;
  while (cap < need) cap *= 2;
  vf_convergence_entry *e = realloc(log->entries, cap * sizeof *e);
  if (e == NULL) return vf_error_set(VF_ENOMEM, "out of memory for a convergence log of %zu entries", need);
  log->entries = e;
  log->capacity = cap;
  return VF_OK;
}

int vf_convergence_copy(vf_convergence_log *dst, const vf_convergence_log *src) {
  int err = vf_convergence_reserve(dst, src->count);
  if (err != VF_OK) return err;
  if (src->count) memcpy(dst->entries, src->entries, src->count * sizeof *src->entries);
  dst->count = src->count;
  return VF_OK;
}

int vf_convergence_append(vf_convergence_log *log, const vf_convergence_entry *entry) {
  int err = vf_convergence_reserve(log, 1);
  if (err != VF_OK) return err;
  log->entries[log->count++] = *entry;
  return VF_OK;
}

void vf_convergence_append_runs(vf_convergence_log *dst, const vf_convergence_log *src) {
  uint32_t offset = dst->count ? dst->entries[dst->count - 1].run + 1 : 0;
  uint32_t base = src->count ? src->entries[0].run : 0;
  for (size_t i = 0; i < src->count && dst->count < dst->capacity; i++) {
    vf_convergence_entry e = src->entries[i];
    e.run = e.run - base + offset;
    dst->entries[dst->count++] = e;
  }
}

uint32_t vf_convergence_next_run(const vf_convergence_log *log, uint64_t iterations, double wall_seconds) {
  if (log->count == 0) return 0;
  const vf_convergence_entry *last = &log->entries[log->count - 1];
  /* The iteration count alone decides: the logged times are rounded to 9 digits. */
  (void)wall_seconds;
  if (last->iterations == iterations) return last->run;
  return last->run + 1;
}

static int nan_or_nonnegative(double v) { return isnan(v) || (isfinite(v) && v >= 0); }

int vf_convergence_validate(const vf_convergence_log *log, const char *name) {
  if (name == NULL) name = "film";
  for (size_t i = 0; i < log->count; i++) {
    const vf_convergence_entry *e = &log->entries[i];
    const char *problem = NULL;
    if (!isfinite(e->wall_seconds) || e->wall_seconds < 0) problem = "wall time is not a finite number >= 0";
    else if (!isfinite(e->cpu_seconds) || e->cpu_seconds < 0) problem = "CPU time is not a finite number >= 0";
    else if (!nan_or_nonnegative(e->rmse) || !nan_or_nonnegative(e->rel_mse) || !nan_or_nonnegative(e->estimated_rmse))
      problem = "an error value is neither nan nor a finite number >= 0";
    else if (i > 0 && e->run < log->entries[i - 1].run) problem = "runs decrease";
    if (problem) return vf_error_set(VF_EFILM, "%s: attribute " ATTR ": entry %zu: %s", name, i, problem);
  }
  return VF_OK;
}

/* "%.9g" keeps a double to 9 significant digits, plenty for times and errors; NaN is
 * written "nan" whatever the C library would print. */
static int put_double(char *buf, size_t n, double v) { return isnan(v) ? snprintf(buf, n, "nan") : snprintf(buf, n, "%.9g", v); }

int vf_convergence_format(const vf_convergence_log *log, char **out) {
  enum { LINE = 160 }; /* two 20-digit integers and five doubles of at most 16 bytes, with blanks */
  char *text = malloc(log->count * LINE + 1), *p = text;
  if (text == NULL) return vf_error_set(VF_ENOMEM, "out of memory for the convergence log text");
  *p = '\0';
  for (size_t i = 0; i < log->count; i++) {
    const vf_convergence_entry *e = &log->entries[i];
    char wall[32], cpu[32], rmse[32], rel[32], est[32];
    put_double(wall, sizeof wall, e->wall_seconds);
    put_double(cpu, sizeof cpu, e->cpu_seconds);
    put_double(rmse, sizeof rmse, e->rmse);
    put_double(rel, sizeof rel, e->rel_mse);
    put_double(est, sizeof est, e->estimated_rmse);
    p += snprintf(p, LINE, "%" PRIu32 " %s %s %" PRIu64 " %s %s %s\n", e->run, wall, cpu, e->iterations, rmse, rel, est);
  }
  *out = text;
  return VF_OK;
}

/* A double as strtod reads it, but without leading blanks (fields are separated by exactly
 * one space). Returns the end or NULL. */
static const char *parse_double(const char *s, double *out) {
  if (*s == '\0' || *s == ' ' || *s == '\t' || *s == '\n' || *s == '\r' || *s == '\v' || *s == '\f') return NULL;
  char *end;
  double v = strtod(s, &end);
  if (end == s) return NULL;
  *out = v;
  return end;
}

static const char *parse_line(const char *p, vf_convergence_entry *e) {
  uint64_t run;
  double *doubles_a[] = {&e->wall_seconds, &e->cpu_seconds};
  double *doubles_b[] = {&e->rmse, &e->rel_mse, &e->estimated_rmse};
  if ((p = vf_parse_u64(p, &run)) == NULL || run > UINT32_MAX) return NULL;
  e->run = (uint32_t)run;
  for (int k = 0; k < 2; k++)
    if (*p++ != ' ' || (p = parse_double(p, doubles_a[k])) == NULL) return NULL;
  if (*p++ != ' ' || (p = vf_parse_u64(p, &e->iterations)) == NULL) return NULL;
  for (int k = 0; k < 3; k++)
    if (*p++ != ' ' || (p = parse_double(p, doubles_b[k])) == NULL) return NULL;
  return *p == '\n' ? p + 1 : NULL;
}

int vf_convergence_parse(vf_convergence_log *log, const char *text, const char *name) {
  if (name == NULL) name = "film";
  int err = VF_OK;
  for (const char *p = text; *p != '\0';) {
    vf_convergence_entry e;
    const char *next = parse_line(p, &e);
    if (next == NULL) {
      err = vf_error_set(VF_EFILM, "%s: attribute " ATTR ": entry %zu is malformed near \"%.40s\"", name, log->count, p);
      goto fail;
    }
    if ((err = vf_convergence_append(log, &e)) != VF_OK) goto fail;
    p = next;
  }
  if ((err = vf_convergence_validate(log, name)) != VF_OK) goto fail;
  return VF_OK;
fail:
  vf_convergence_destroy(log);
  return err;
}
