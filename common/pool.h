/* A fixed set of worker threads that run parallel loops.
 *
 * vf_pool_run(pool, n, fn, ctx) calls fn(ctx, task, thread) once for every task in [0, n)
 * and returns when all have run. Tasks are taken in increasing order by whichever thread is
 * free; results must therefore never depend on which thread ran a task (write per task, or
 * per-thread scratch that is combined in task order). The calling thread takes part as
 * thread 0. A pool of 1 thread runs everything on the caller. */
#ifndef VF_POOL_H
#define VF_POOL_H

#include <stddef.h>

typedef struct vf_pool vf_pool;
typedef void (*vf_pool_task)(void *ctx, size_t task, int thread);

/* threads <= 0 means one per online CPU. */
int vf_pool_create(int threads, vf_pool **out);
void vf_pool_destroy(vf_pool *pool);
int vf_pool_threads(const vf_pool *pool);
void vf_pool_run(vf_pool *pool, size_t tasks, vf_pool_task fn, void *ctx);

#endif
