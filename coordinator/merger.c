#include "merger.h"

#include "../common/clock.h"
#include "../common/error.h"

#include <pthread.h>
#include <stdlib.h>
#include <uv.h>

struct vf_merger {
  pthread_t thread;
  pthread_mutex_t lock;
  pthread_cond_t wake;
  uv_async_t async;          /* wakes the loop when items are done */
  /* under lock */
  vf_merge_item *todo, **todo_tail;
  vf_merge_item *finished, **finished_tail;
  int stopping;
  double busy;
  size_t pending;            /* the loop's count: queued and not yet `done` */
};

static void *run(void *arg) {
  vf_merger *m = arg;
  pthread_mutex_lock(&m->lock);
  for (;;) {
    while (m->todo == NULL && !m->stopping) pthread_cond_wait(&m->wake, &m->lock);
    if (m->todo == NULL) break;
    vf_merge_item *item = m->todo;
    m->todo = item->next;
    if (m->todo == NULL) m->todo_tail = &m->todo;
    pthread_mutex_unlock(&m->lock);
    double t0 = vf_seconds_now();
    item->work(item);
    item->seconds = vf_seconds_now() - t0;
    pthread_mutex_lock(&m->lock);
    m->busy += item->seconds;
    item->next = NULL;
    *m->finished_tail = item;
    m->finished_tail = &item->next;
    uv_async_send(&m->async);
  }
  pthread_mutex_unlock(&m->lock);
  return NULL;
}

/* On the loop: every finished item's `done`, in order. */
static void drain(vf_merger *m) {
  pthread_mutex_lock(&m->lock);
  vf_merge_item *items = m->finished;
  m->finished = NULL;
  m->finished_tail = &m->finished;
  pthread_mutex_unlock(&m->lock);
  while (items != NULL) {
    vf_merge_item *next = items->next;
    m->pending--;
    items->done(items);
    items = next;
  }
}

static void on_async(uv_async_t *handle) { drain(handle->data); }

int vf_merger_start(struct uv_loop_s *loop, vf_merger **out) {
  vf_merger *m = calloc(1, sizeof *m);
  if (m == NULL) return vf_error_set(VF_ENOMEM, "out of memory for the merge thread");
  m->todo_tail = &m->todo;
  m->finished_tail = &m->finished;
  int err = VF_OK;
  if (uv_async_init(loop, &m->async, on_async) != 0) {
    err = vf_error_set(VF_ENOMEM, "libuv: cannot create the merge thread's wake-up");
    goto free_merger;
  }
  m->async.data = m;
  pthread_mutex_init(&m->lock, NULL);
  pthread_cond_init(&m->wake, NULL);
  if (pthread_create(&m->thread, NULL, run, m) != 0) {
    err = vf_error_set(VF_ENOMEM, "cannot start the merge thread");
    goto destroy_sync;
  }
  *out = m;
  return VF_OK;
destroy_sync:
  pthread_cond_destroy(&m->wake);
  pthread_mutex_destroy(&m->lock);
  uv_close((uv_handle_t *)&m->async, NULL);
  uv_run(loop, UV_RUN_NOWAIT); /* lets the close land before the memory goes */
free_merger:
  free(m);
  return err;
}

static void free_after_close(uv_handle_t *h) { free(h->data); }

void vf_merger_stop(vf_merger *m) {
  if (m == NULL) return;
  pthread_mutex_lock(&m->lock);
  m->stopping = 1;
  pthread_cond_signal(&m->wake);
  pthread_mutex_unlock(&m->lock);
  pthread_join(m->thread, NULL); /* the thread works off what is queued before it ends */
  drain(m);
  pthread_cond_destroy(&m->wake);
  pthread_mutex_destroy(&m->lock);
  uv_close((uv_handle_t *)&m->async, free_after_close);
}

void vf_merger_queue(vf_merger *m, vf_merge_item *item) {
  item->next = NULL;
  m->pending++;
  pthread_mutex_lock(&m->lock);
  *m->todo_tail = item;
  m->todo_tail = &item->next;
  pthread_cond_signal(&m->wake);
  pthread_mutex_unlock(&m->lock);
}

size_t vf_merger_pending(const vf_merger *m) { return m->pending; }
int vf_merger_full(const vf_merger *m) { return m->pending >= VF_MERGER_QUEUE; }

double vf_merger_busy_seconds(vf_merger *m) {
  pthread_mutex_lock(&m->lock);
  double b = m->busy;
  pthread_mutex_unlock(&m->lock);
  return b;
}
