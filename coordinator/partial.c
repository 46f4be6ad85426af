#include "partial.h"

#include "../common/blob.h"
#include "../common/error.h"
#include "../common/film_wire.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct vf_partial {
  uint64_t begin, end;
  uint32_t total, received;
  uint8_t *seen;   /* one per tile, owned */
  vf_film *film;   /* the staged part, owned until taken */
  /* the header every message of the part repeats */
  double render_seconds, cpu_seconds;
  uint64_t nonfinite, biased_merges;
  int pilot;       /* a pilot part (LeaseResult.pilot) */
  uint8_t allocation[32]; /* LeaseResult.allocation, allocation_len bytes of it (0 or 32) */
  size_t allocation_len;
  double updated;  /* vf_seconds_now() of its last message */
  /* The loop's, never the merge thread's (coordinator/results.c): */
  unsigned refs;      /* the lease's and each message on the merge thread */
  uint32_t queued;    /* tiles handed to the merge thread so far */
  int width, height;  /* the header, for vf_partial_same without touching the film */
  uint8_t scene_hash[32];
  char *settings;     /* owned */
  char failure[512];  /* set when a message of it was refused; "" */
};

static int check_header(const vf_job *job, const Vcmfarm__LeaseResult *m) {
  const vf_film *f = job->film;
  if (m->width != (uint32_t)f->width || m->height != (uint32_t)f->height)
    return vf_error_set(VF_EMISMATCH, "tiles of a %ux%u film, job %llu is %dx%d", m->width, m->height,
                        (unsigned long long)job->id, f->width, f->height);
  if (m->scene_hash.len != 32 || memcmp(m->scene_hash.data, job->scene_hash, 32) != 0)
    return vf_error_set(VF_EMISMATCH, "scene hash differs from job %llu's", (unsigned long long)job->id);
  if (strcmp(m->settings, job->settings_text) != 0)
    return vf_error_set(VF_EMISMATCH, "settings '%.200s' differ from job %llu's '%s'", m->settings,
                        (unsigned long long)job->id, job->settings_text);
  /* A pilot part and a part of the image never pass for each other, and a part of the image
   * is of the job's allocation of camera sub-paths (docs/PROTOCOL.md, "Pilots"). */
  if (m->pilot && job->settings.pilot == 0)
    return vf_error_set(VF_EMISMATCH, "a pilot part, but job %llu has no pilot", (unsigned long long)job->id);
  if (m->pilot && m->allocation.len != 0)
    return vf_error_set(VF_EMISMATCH, "a pilot part names an allocation of camera sub-paths: a pilot has none");
  if (!m->pilot && job->settings.pilot == 0 && m->allocation.len != 0)
    return vf_error_set(VF_EMISMATCH, "the part names an allocation of camera sub-paths, but job %llu has no pilot",
                        (unsigned long long)job->id);
  if (!m->pilot && job->settings.pilot > 0) {
    if (f->samples == NULL)
      return vf_error_set(VF_EMISMATCH, "a part of job %llu's image before its pilot decided the allocation",
                          (unsigned long long)job->id);
    if (m->allocation.len != 32 || memcmp(m->allocation.data, job->allocation_hash, 32) != 0) {
      char theirs[65] = "none", ours[65];
      if (m->allocation.len == 32) vf_blob_hex(m->allocation.data, theirs);
      vf_blob_hex(job->allocation_hash, ours);
      return vf_error_set(VF_EMISMATCH, "the part was rendered with allocation %.16s, job %llu's is %.16s: its "
                          "camera sub-paths per pixel differ", theirs, (unsigned long long)job->id, ours);
    }
  }
  uint32_t total = vf_film_tile_count(f->width, f->height);
  if (m->tiles_total != total)
    return vf_error_set(VF_EINVAL, "tiles_total %u, a %dx%d film has %u tiles", m->tiles_total, f->width, f->height,
                        total);
  if (!(m->render_seconds >= 0.0 && m->render_seconds <= 1e9) || !(m->cpu_seconds >= 0.0 && m->cpu_seconds <= 1e9))
    return vf_error_set(VF_EINVAL, "render or CPU seconds out of range");
  if (m->nonfinite_samples > (m->end - m->begin) * 2 * (uint64_t)f->width * (uint64_t)f->height)
    return vf_error_set(VF_EINVAL, "%llu non-finite samples in %llu iterations of %dx%d pixels",
                        (unsigned long long)m->nonfinite_samples, (unsigned long long)(m->end - m->begin), f->width,
                        f->height);
  return VF_OK;
}

/* A part's range and header, whether its pixels come as tiles or as a film. */
static int check_part(const vf_job *job, const Vcmfarm__LeaseResult *m) {
  if (m->begin >= m->end) return vf_error_set(VF_EINVAL, "empty range [%llu,%llu)", (unsigned long long)m->begin,
                                              (unsigned long long)m->end);
  return check_header(job, m);
}

/* A whole part's film checked as every film is (vf_film_validate), named by its range. */
static int validate_part(const vf_film *film, uint64_t begin, uint64_t end) {
  char name[96];
  snprintf(name, sizeof name, "result [%llu,%llu)", (unsigned long long)begin, (unsigned long long)end);
  return vf_film_validate(film, name);
}

int vf_partial_create(const vf_job *job, const Vcmfarm__LeaseResult *m, vf_partial **out) {
  int err = check_part(job, m);
  if (err != VF_OK) return err;
  vf_partial *p = calloc(1, sizeof *p);
  if (p == NULL) return vf_error_set(VF_ENOMEM, "out of memory for a partial result");
  p->total = m->tiles_total;
  if ((p->seen = calloc(p->total, 1)) == NULL) {
    err = vf_error_set(VF_ENOMEM, "out of memory for a partial result");
    goto free_partial;
  }
  if ((err = vf_film_create(job->film->width, job->film->height, &p->film)) != VF_OK) goto free_seen;
  if ((err = vf_iterset_add(&p->film->iterations, m->begin, m->end)) != VF_OK) goto free_film;
  p->film->pilot = p->pilot = m->pilot != 0;
  p->allocation_len = m->allocation.len; /* 0 or 32: check_header */
  if (p->allocation_len) memcpy(p->allocation, m->allocation.data, 32);
  if (!p->pilot && job->film->samples != NULL && (err = vf_film_set_samples(p->film, job->film->samples)) != VF_OK)
    goto free_film;
  memcpy(p->film->scene_hash, job->scene_hash, 32);
  snprintf(p->film->settings_text, sizeof p->film->settings_text, "%s", job->settings_text);
  /* What `continue` loads: the built-in name, or the JSON scene's path on the submitting
   * machine (empty when it gave none). */
  memcpy(p->film->scene_name, job->film->scene_name, sizeof p->film->scene_name);
  p->film->render_seconds = p->render_seconds = m->render_seconds;
  p->film->cpu_seconds = p->cpu_seconds = m->cpu_seconds;
  p->film->nonfinite_samples = p->nonfinite = m->nonfinite_samples;
  p->film->biased_merges = p->biased_merges = m->biased_merges;
  p->begin = m->begin;
  p->end = m->end;
  p->refs = 1;
  p->width = job->film->width;
  p->height = job->film->height;
  memcpy(p->scene_hash, job->scene_hash, 32);
  if ((p->settings = strdup(job->settings_text)) == NULL) {
    err = vf_error_set(VF_ENOMEM, "out of memory for a partial result");
    goto free_film;
  }
  *out = p;
  return VF_OK;
free_film:
  vf_film_destroy(p->film);
free_seen:
  free(p->seen);
free_partial:
  free(p);
  return err;
}

void vf_partial_destroy(vf_partial *p) {
  if (p == NULL || --p->refs > 0) return;
  vf_film_destroy(p->film);
  free(p->settings);
  free(p->seen);
  free(p);
}

void vf_partial_retain(vf_partial *p) { p->refs++; }

uint32_t vf_partial_queue(vf_partial *p, uint32_t tiles) {
  p->queued = tiles > UINT32_MAX - p->queued ? UINT32_MAX : p->queued + tiles;
  return p->queued;
}

void vf_partial_fail(vf_partial *p, const char *why) {
  if (p->failure[0] == '\0') snprintf(p->failure, sizeof p->failure, "%s", why);
}

const char *vf_partial_failure(const vf_partial *p) { return p->failure[0] ? p->failure : NULL; }

int vf_partial_same(const vf_partial *p, const Vcmfarm__LeaseResult *m) {
  return m->begin == p->begin && m->end == p->end && m->tiles_total == p->total && (m->pilot != 0) == p->pilot &&
         m->allocation.len == p->allocation_len &&
         (p->allocation_len == 0 || memcmp(m->allocation.data, p->allocation, 32) == 0) &&
         m->render_seconds == p->render_seconds && m->cpu_seconds == p->cpu_seconds &&
         m->nonfinite_samples == p->nonfinite && m->biased_merges == p->biased_merges &&
         m->width == (uint32_t)p->width && m->height == (uint32_t)p->height &&
         m->scene_hash.len == 32 && memcmp(m->scene_hash.data, p->scene_hash, 32) == 0 &&
         strcmp(m->settings, p->settings) == 0;
}

int vf_partial_add(vf_partial *p, const Vcmfarm__LeaseResult *m) {
  if (p->film == NULL) return vf_error_set(VF_EINVAL, "this partial result was merged already");
  uint32_t across = vf_film_tiles_across(p->film->width);
  vf_film_tile *tiles = NULL;
  int err = vf_film_tiles_decode(m, p->film->width, p->film->height, &tiles);
  if (err != VF_OK) return err;
  for (size_t i = 0; i < m->n_tiles && err == VF_OK; i++) {
    const vf_film_tile *t = &tiles[i];
    for (size_t j = 0; j < i && err == VF_OK; j++)
      if (tiles[j].x == t->x && tiles[j].y == t->y)
        err = vf_error_set(VF_EINVAL, "tile (%u,%u) twice in one message", t->x, t->y);
    if (err == VF_OK && p->seen[t->y * across + t->x] && !vf_film_tile_matches(p->film, t))
      err = vf_error_set(VF_EINVAL, "tile (%u,%u) arrived before with other values", t->x, t->y);
  }
  for (size_t i = 0; i < m->n_tiles && err == VF_OK; i++) {
    const vf_film_tile *t = &tiles[i];
    uint8_t *seen = &p->seen[t->y * across + t->x];
    if (*seen) continue;
    vf_film_tile_store(p->film, t);
    *seen = 1;
    p->received++;
  }
  vf_film_tiles_free(tiles, m->n_tiles);
  return err;
}

void vf_partial_touch(vf_partial *p, double now) { p->updated = now; }
double vf_partial_updated(const vf_partial *p) { return p->updated; }

uint32_t vf_partial_received(const vf_partial *p) { return p->received; }
uint32_t vf_partial_total(const vf_partial *p) { return p->total; }

int vf_partial_take(vf_partial *p, vf_film **out) {
  if (p->film == NULL || p->received != p->total)
    return vf_error_set(VF_EINVAL, "%u of %u tiles received", p->received, p->total);
  int err = validate_part(p->film, p->begin, p->end);
  if (err != VF_OK) return err;
  *out = p->film;
  p->film = NULL;
  return VF_OK;
}
