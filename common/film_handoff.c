#include "film_handoff.h"

#include "error.h"

#include <pthread.h>
#include <stdlib.h>

/* A worker deposits one part at a time and waits for its answer, so the table stays tiny:
 * a linear search is all it needs. */
typedef struct {
  uint64_t token;
  vf_film *film;
} deposit;

struct vf_film_handoff {
  pthread_mutex_t lock;
  uint64_t next;
  deposit *items;
  size_t count, capacity;
};

int vf_film_handoff_create(vf_film_handoff **out) {
  vf_film_handoff *h = calloc(1, sizeof *h);
  if (h == NULL) return vf_error_set(VF_ENOMEM, "out of memory for a film handoff");
  pthread_mutex_init(&h->lock, NULL);
  h->next = 1;
  *out = h;
  return VF_OK;
}

void vf_film_handoff_destroy(vf_film_handoff *h) {
  if (h == NULL) return;
  for (size_t i = 0; i < h->count; i++) vf_film_destroy(h->items[i].film);
  free(h->items);
  pthread_mutex_destroy(&h->lock);
  free(h);
}

int vf_film_handoff_put(vf_film_handoff *h, vf_film *film, uint64_t *token) {
  int err = VF_OK;
  pthread_mutex_lock(&h->lock);
  if (h->count == h->capacity) {
    size_t capacity = h->capacity ? 2 * h->capacity : 4;
    deposit *items = realloc(h->items, capacity * sizeof *items);
    if (items == NULL) err = vf_error_set(VF_ENOMEM, "out of memory for a film handoff");
    else {
      h->items = items;
      h->capacity = capacity;
    }
  }
  if (err == VF_OK) {
    *token = h->next++;
    h->items[h->count++] = (deposit){*token, film};
  }
  pthread_mutex_unlock(&h->lock);
  return err;
}

vf_film *vf_film_handoff_take(vf_film_handoff *h, uint64_t token) {
  vf_film *film = NULL;
  pthread_mutex_lock(&h->lock);
  for (size_t i = 0; i < h->count; i++)
    if (h->items[i].token == token) {
      film = h->items[i].film;
      h->items[i] = h->items[--h->count];
      break;
    }
  pthread_mutex_unlock(&h->lock);
  return film;
}
