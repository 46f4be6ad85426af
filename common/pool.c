#include "pool.h"

#include "error.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <unistd.h>

struct vf_pool {
  int threads;
  pthread_t *handles;       /* threads - 1 helpers; thread 0 is the caller */
  pthread_mutex_t lock;
  pthread_cond_t wake, done;
  /* The current loop, published under lock with a new generation number. */
  unsigned long generation;
  vf_pool_task fn;
  void *ctx;
  size_t tasks;
  atomic_size_t next;
  int running;              /* helpers still inside the current loop */
  int quit;
};

typedef struct {
  vf_pool *pool;
  int index;
} helper_arg;

static void drain(vf_pool *p, int thread) {
  for (;;) {
    size_t t = atomic_fetch_add(&p->next, 1);
    if (t >= p->tasks) return;
    p->fn(p->ctx, t, thread);
  }
}

static void *helper_main(void *arg) {
  helper_arg a = *(helper_arg *)arg;
  free(arg);
  vf_pool *p = a.pool;
  unsigned long seen = 0;
  pthread_mutex_lock(&p->lock);
  for (;;) {
    while (!p->quit && p->generation == seen) pthread_cond_wait(&p->wake, &p->lock);
    if (p->quit) break;
    seen = p->generation;
    pthread_mutex_unlock(&p->lock);
    drain(p, a.index);
    pthread_mutex_lock(&p->lock);
    if (--p->running == 0) pthread_cond_signal(&p->done);
  }
  pthread_mutex_unlock(&p->lock);
  return NULL;
}

int vf_pool_create(int threads, vf_pool **out) {
  if (threads <= 0) {
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    threads = n > 0 ? (int)n : 1;
  }
  if (threads > 1024) return vf_error_set(VF_EINVAL, "%d threads is more than 1024", threads);
  vf_pool *p = calloc(1, sizeof *p);
  if (p == NULL) return VF_ENOMEM;
  p->threads = threads;
  pthread_mutex_init(&p->lock, NULL);
  pthread_cond_init(&p->wake, NULL);
  pthread_cond_init(&p->done, NULL);
  p->handles = calloc((size_t)threads, sizeof *p->handles);
  if (p->handles == NULL) goto fail;
  p->threads = 1; /* counts the threads started so far, for cleanup on failure */
  for (int i = 1; i < threads; i++) {
    helper_arg *a = malloc(sizeof *a);
    if (a == NULL) goto fail_threads;
    *a = (helper_arg){p, i};
    if (pthread_create(&p->handles[i], NULL, helper_main, a) != 0) {
      free(a);
      goto fail_threads;
    }
    p->threads = i + 1;
  }
  *out = p;
  return VF_OK;
fail_threads:
  vf_pool_destroy(p);
  return vf_error_set(VF_ENOMEM, "cannot start %d render threads", threads);
fail:
  free(p);
  return VF_ENOMEM;
}

void vf_pool_destroy(vf_pool *p) {
  if (p == NULL) return;
  pthread_mutex_lock(&p->lock);
  p->quit = 1;
  pthread_cond_broadcast(&p->wake);
  pthread_mutex_unlock(&p->lock);
  for (int i = 1; i < p->threads; i++) pthread_join(p->handles[i], NULL);
  pthread_cond_destroy(&p->wake);
  pthread_cond_destroy(&p->done);
  pthread_mutex_destroy(&p->lock);
  free(p->handles);
  free(p);
}

int vf_pool_threads(const vf_pool *p) { return p->threads; }

void vf_pool_run(vf_pool *p, size_t tasks, vf_pool_task fn, void *ctx) {
  if (p->threads == 1 || tasks <= 1) {
    for (size_t t = 0; t < tasks; t++) fn(ctx, t, 0);
    return;
  }
  pthread_mutex_lock(&p->lock);
  p->fn = fn;
  p->ctx = ctx;
  p->tasks = tasks;
  atomic_store(&p->next, 0);
  p->running = p->threads - 1;
  p->generation++;
  pthread_cond_broadcast(&p->wake);
  pthread_mutex_unlock(&p->lock);
  drain(p, 0);
  pthread_mutex_lock(&p->lock);
  while (p->running > 0) pthread_cond_wait(&p->done, &p->lock);
  pthread_mutex_unlock(&p->lock);
}
