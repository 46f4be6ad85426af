/* The compact accumulator: film_accum.h. */
#include "film_accum.h"

#include "error.h"
#include "exr_util.h" /* VF_EXR_MAX_SIDE, VF_EXR_MAX_PIXELS: the sizes a film may have */
#include "sampler.h"  /* VF_SOBOL_REPLICATES */

#include <inttypes.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

/* The side table: values that left int64, by key 2 * index + (0 sum, 1 square_sum) + 1
 * (0 marks a free slot), open addressing, at most half full. Written under the lock by the
 * pool's threads (rarely: a value leaves int64 after 2^31 in radiance), read alone. */
typedef struct {
  uint64_t *keys;
  vf_fixed *values;
  size_t capacity, count;
} side_table;

struct vf_film_accum {
  int width, height;
  size_t bytes;            /* of each array */
  int64_t *sum;            /* 3 a pixel, units of 2^-VF_FILM_SUM_BITS, mapped */
  int64_t *square_sum;     /* 3 a pixel, square_sum's units (film.h), mapped */
  int64_t limit;           /* a slot's largest magnitude */
  unsigned char *row_side; /* per row: some value of the row is in the side table */
  side_table side;
  pthread_mutex_t lock;    /* guards side and row_side while iterations are added */
};

/* Mapped, so that the pages come zeroed, stay untouched until written, and go back to the
 * kernel when emptied (vf_film_accum_clear). */
static int64_t *slots_alloc(size_t bytes) {
  void *p = mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (p == MAP_FAILED) return NULL;
  madvise(p, bytes, MADV_HUGEPAGE); /* a hint: refused, the pages are small */
  return p;
}

int vf_film_accum_create(int width, int height, vf_film_accum **out) {
  if (out == NULL || width < 1 || height < 1 || width > VF_EXR_MAX_SIDE || height > VF_EXR_MAX_SIDE ||
      (int64_t)width * height > VF_EXR_MAX_PIXELS)
    return vf_error_set(VF_EINVAL, "accumulator size %dx%d is outside a film's", width, height);
  vf_film_accum *a = calloc(1, sizeof *a);
  if (a == NULL) goto fail;
  a->width = width;
  a->height = height;
  a->bytes = 3 * (size_t)width * (size_t)height * sizeof(int64_t);
  a->limit = INT64_MAX;
  a->row_side = calloc((size_t)height, 1);
  if (a->row_side == NULL || (a->sum = slots_alloc(a->bytes)) == NULL) goto fail_sum;
  if ((a->square_sum = slots_alloc(a->bytes)) == NULL) goto fail_square;
  pthread_mutex_init(&a->lock, NULL);
  *out = a;
  return VF_OK;
fail_square:
  munmap(a->sum, a->bytes);
fail_sum:
  free(a->row_side);
  free(a);
fail:
  return vf_error_set(VF_ENOMEM, "out of memory for a %dx%d accumulator", width, height);
}

void vf_film_accum_destroy(vf_film_accum *a) {
  if (a == NULL) return;
  pthread_mutex_destroy(&a->lock);
  munmap(a->sum, a->bytes);
  munmap(a->square_sum, a->bytes);
  free(a->side.keys);
  free(a->side.values);
  free(a->row_side);
  free(a);
}

static size_t side_slot(const side_table *t, uint64_t key) {
  uint64_t h = key * 0x9E3779B97F4A7C15ull;
  size_t i = (size_t)(h >> 20) & (t->capacity - 1);
  while (t->keys[i] != 0 && t->keys[i] != key) i = (i + 1) & (t->capacity - 1);
  return i;
}

/* The side table's value of key, 0 when it has none. */
static vf_fixed side_get(const side_table *t, uint64_t key) {
  if (t->count == 0) return 0;
  size_t i = side_slot(t, key);
  return t->keys[i] == key ? t->values[i] : 0;
}

/* Adds v to key's value, the table grown first when it would be more than half full. */
static int side_add(side_table *t, uint64_t key, vf_fixed v) {
  if (2 * (t->count + 1) > t->capacity) {
    side_table bigger = {calloc(t->capacity ? 2 * t->capacity : 64, sizeof(uint64_t)), NULL,
                         t->capacity ? 2 * t->capacity : 64, t->count};
    bigger.values = calloc(bigger.capacity, sizeof(vf_fixed));
    if (bigger.keys == NULL || bigger.values == NULL) {
      free(bigger.keys);
      free(bigger.values);
      return 0;
    }
    for (size_t i = 0; i < t->capacity; i++)
      if (t->keys[i] != 0) {
        size_t j = side_slot(&bigger, t->keys[i]);
        bigger.keys[j] = t->keys[i];
        bigger.values[j] = t->values[i];
      }
    free(t->keys);
    free(t->values);
    *t = bigger;
  }
  size_t i = side_slot(t, key);
  if (t->keys[i] == 0) {
    t->keys[i] = key;
    t->values[i] = 0;
    t->count++;
  }
  t->values[i] += v;
  return 1;
}

/* *slot += v, exactly: in the slot while it stays within the limit, else slot and v move
 * to the side table (key's entry) and the slot starts again from 0. 0 when the table
 * could not grow (nothing changed). */
static int add_value(vf_film_accum *a, int64_t *slot, uint64_t key, size_t row, vf_fixed v) {
  int64_t small = (int64_t)v, r;
  if ((vf_fixed)small == v && !__builtin_add_overflow(*slot, small, &r) && r <= a->limit && r >= -a->limit) {
    *slot = r;
    return 1;
  }
  pthread_mutex_lock(&a->lock);
  int ok = side_add(&a->side, key, (vf_fixed)*slot + v);
  if (ok) {
    *slot = 0;
    a->row_side[row] = 1;
  }
  pthread_mutex_unlock(&a->lock);
  return ok;
}

/* Pixels of one task: a fixed block, as vf_film_add_iteration's. */
#define ADD_BLOCK 16384u

typedef struct {
  vf_film_accum *a;
  const float *camera_rgb, *light_rgb;
  uint64_t *nonfinite; /* per task */
  int *failed;         /* per task: the side table could not grow */
  int second_moment, replicate_one;
} add_ctx;

static void add_task(void *ctx, size_t task, int thread) {
  (void)thread;
  add_ctx *c = ctx;
  vf_film_accum *a = c->a;
  size_t n = (size_t)a->width * (size_t)a->height;
  size_t begin = task * ADD_BLOCK, end = begin + ADD_BLOCK < n ? begin + ADD_BLOCK : n;
  uint64_t nonfinite = 0;
  int ok = 1;
  for (size_t p = begin; p < end; p++) {
    vf_fixed sum[3], square[3];
    nonfinite += (uint64_t)vf_film_pixel_terms(c->camera_rgb + 3 * p, c->light_rgb + 3 * p, c->second_moment, sum,
                                               square);
    size_t row = p / (size_t)a->width;
    for (size_t k = 0; k < 3; k++) {
      size_t i = 3 * p + k;
      ok &= add_value(a, &a->sum[i], 2 * (uint64_t)i + 1, row, sum[k]);
      if (!c->replicate_one) ok &= add_value(a, &a->square_sum[i], 2 * (uint64_t)i + 2, row, square[k]);
    }
  }
  c->nonfinite[task] = nonfinite;
  c->failed[task] = !ok;
}

int vf_film_accum_add_iteration(vf_film_accum *a, vf_film *film, uint64_t iteration, const float *camera_rgb,
                                const float *light_rgb, vf_pool *pool) {
  if (a == NULL || film == NULL || camera_rgb == NULL || light_rgb == NULL)
    return vf_error_set(VF_EINVAL, "vf_film_accum_add_iteration: NULL argument");
  if (film->width != a->width || film->height != a->height)
    return vf_error_set(VF_EMISMATCH, "accumulator is %dx%d but the film %dx%d", a->width, a->height, film->width,
                        film->height);
  if (iteration == UINT64_MAX) return vf_error_set(VF_EINVAL, "iteration index %" PRIu64 " is too large", iteration);
  if (vf_iterset_contains(&film->iterations, iteration))
    return vf_error_set(VF_EOVERLAP, "iteration %" PRIu64 " is already in the film", iteration);
  size_t n = (size_t)a->width * (size_t)a->height, tasks = (n + ADD_BLOCK - 1) / ADD_BLOCK;
  uint64_t *nonfinite = calloc(tasks, sizeof *nonfinite);
  int *failed = calloc(tasks, sizeof *failed);
  int err = VF_OK;
  if (nonfinite == NULL || failed == NULL) {
    err = VF_ENOMEM;
    goto done;
  }
  int sobol = vf_film_sobol(film);
  add_ctx c = {a, camera_rgb, light_rgb, nonfinite, failed, !sobol, sobol && iteration % VF_SOBOL_REPLICATES != 0};
  if (pool) vf_pool_run(pool, tasks, add_task, &c);
  else
    for (size_t t = 0; t < tasks; t++) add_task(&c, t, 0);
  /* A value the table could not take leaves the iteration partly added: no film can say
   * so, and the caller (a worker) drops the part. */
  for (size_t t = 0; t < tasks; t++)
    if (failed[t]) {
      err = vf_error_set(VF_ENOMEM, "out of memory for the accumulator's side table");
      goto done;
    }
  if ((err = vf_iterset_add(&film->iterations, iteration, iteration + 1)) != VF_OK) goto done;
  for (size_t t = 0; t < tasks; t++) film->nonfinite_samples += nonfinite[t];
done:
  free(nonfinite);
  free(failed);
  return err;
}

void vf_film_accum_rect(const vf_film_accum *a, int x0, int y0, int w, int h, vf_fixed *sum, vf_fixed *square_sum) {
  for (int y = 0; y < h; y++) {
    size_t row = (size_t)(y0 + y), at = 3 * (row * (size_t)a->width + (size_t)x0), out = 3 * (size_t)y * (size_t)w;
    for (size_t i = 0; i < 3 * (size_t)w; i++) {
      sum[out + i] = a->sum[at + i];
      square_sum[out + i] = a->square_sum[at + i];
    }
    if (!a->row_side[row]) continue;
    for (size_t i = 0; i < 3 * (size_t)w; i++) {
      sum[out + i] += side_get(&a->side, 2 * (uint64_t)(at + i) + 1);
      square_sum[out + i] += side_get(&a->side, 2 * (uint64_t)(at + i) + 2);
    }
  }
}

void vf_film_accum_carry(vf_film_accum *a, vf_film *film) {
  size_t n = 3 * (size_t)a->width * (size_t)a->height;
  for (size_t i = 0; i < n; i++) {
    film->sum[i] += a->sum[i];
    film->square_sum[i] += a->square_sum[i];
  }
  for (size_t i = 0; i < a->side.capacity; i++) {
    uint64_t key = a->side.keys[i];
    if (key == 0) continue;
    size_t index = (size_t)((key - 1) / 2);
    if ((key - 1) % 2 == 0) film->sum[index] += a->side.values[i];
    else film->square_sum[index] += a->side.values[i];
  }
  vf_film_accum_clear(a);
}

void vf_film_accum_clear(vf_film_accum *a) {
  if (madvise(a->sum, a->bytes, MADV_DONTNEED) != 0) memset(a->sum, 0, a->bytes);
  if (madvise(a->square_sum, a->bytes, MADV_DONTNEED) != 0) memset(a->square_sum, 0, a->bytes);
  free(a->side.keys);
  free(a->side.values);
  a->side = (side_table){0};
  memset(a->row_side, 0, (size_t)a->height);
}

size_t vf_film_accum_spilled(const vf_film_accum *a) { return a->side.count; }

void vf_film_accum_set_limit(vf_film_accum *a, int64_t limit) { a->limit = limit > 0 ? limit : INT64_MAX; }
