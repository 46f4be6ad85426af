#include "dashboard.h"

#include "../../common/clock.h"
#include "../../common/error.h"
#include "../farm_reply.h"
#include "http.h"
#include "../jobs.h"
#include "../log.h"
#include "../schedule.h"
#include "../state.h"

#include <errno.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <uv.h>

#define PUBLISH_MS 1000
#define FRESH_SECONDS 1.5    /* a reader takes a publication this young as it is */
#define WATCHED_SECONDS 10.0 /* the loop publishes while someone read this recently */
#define WATCHED_JOBS 8       /* jobs whose own status (with its log) is published */

typedef struct {
  uint64_t job_id;  /* 0: free slot */
  char *json;       /* owned; NULL once the job is gone */
  size_t len;
  double published; /* vf_seconds_now(); 0 never */
  double wanted;    /* the latest read */
} watched_job;

typedef struct pending {
  vf_dashboard_action action;
  int done, abandoned, status;
  char message[256];
  struct pending *next;
} pending;

struct vf_dashboard {
  vf_farm *farm;        /* borrowed: touched on the loop's thread only */
  uv_loop_t *loop;      /* borrowed */
  uv_async_t wake;      /* a reader or an action wants the loop */
  uv_timer_t publish_timer;
  vf_status_json_fn status_json;
  vf_http *http;        /* owned */
  /* ---- shared with the HTTP threads, under lock ---- */
  pthread_mutex_t lock;
  pthread_cond_t changed; /* a publication, an action done, stopping */
  char *status;           /* owned; NULL before the first publication */
  size_t status_len;
  double status_at;       /* vf_seconds_now() of it */
  watched_job watched[WATCHED_JOBS];
  double wanted_at;       /* the latest read of any status */
  int refresh;            /* a reader waits for a publication */
  pending *queue;         /* actions for the loop, oldest first */
  int closing;
};

static struct timespec deadline_in(double seconds) {
  struct timespec t;
  clock_gettime(CLOCK_REALTIME, &t);
  double whole = (double)(long)seconds;
  t.tv_sec += (time_t)whole;
  t.tv_nsec += (long)((seconds - whole) * 1e9);
  if (t.tv_nsec >= 1000000000L) t.tv_sec++, t.tv_nsec -= 1000000000L;
  return t;
}

/* The Status reply of the farm as JSON, or NULL (an unknown job, or out of memory). */
static char *status_text(vf_dashboard *d, uint64_t job_id, double now) {
  Vcmfarm__StatusRequest q = VCMFARM__STATUS_REQUEST__INIT;
  q.job_id = job_id;
  vf_farm_reply r;
  vf_farm_reply_init(&r);
  vf_jobs_status(d->farm, &q, now, &r);
  char *text = r.env.body_case == VCMFARM__ENVELOPE__BODY_STATUS ? d->status_json(&r.status) : NULL;
  vf_farm_reply_release(&r);
  return text;
}

/* On the loop: builds what is being read (everything when forced) and publishes it. */
static void publish(vf_dashboard *d, int force) {
  double now = vf_seconds_now();
  uint64_t wanted[WATCHED_JOBS];
  pthread_mutex_lock(&d->lock);
  int watched = force || d->refresh || now - d->wanted_at < WATCHED_SECONDS;
  for (int i = 0; i < WATCHED_JOBS; i++) {
    watched_job *w = &d->watched[i];
    wanted[i] = w->job_id && (force || now - w->wanted < WATCHED_SECONDS || w->published < w->wanted) ? w->job_id : 0;
  }
  pthread_mutex_unlock(&d->lock);
  if (!watched) return;

  char *status = status_text(d, 0, now);
  char *job_json[WATCHED_JOBS] = {0};
  for (int i = 0; i < WATCHED_JOBS; i++)
    if (wanted[i] && vf_farm_job(d->farm, wanted[i])) job_json[i] = status_text(d, wanted[i], now);

  pthread_mutex_lock(&d->lock);
  if (status) {
    free(d->status);
    d->status = status;
    d->status_len = strlen(status);
    d->status_at = now;
    status = NULL;
  }
  for (int i = 0; i < WATCHED_JOBS; i++) {
    watched_job *w = &d->watched[i];
    if (!wanted[i] || w->job_id != wanted[i]) { /* the slot was taken for another job meanwhile */
      free(job_json[i]);
      continue;
    }
    free(w->json);
    w->json = job_json[i];
    w->len = w->json ? strlen(w->json) : 0;
    w->published = now;
  }
  d->refresh = 0;
  pthread_cond_broadcast(&d->changed);
  pthread_mutex_unlock(&d->lock);
  free(status);
}

/* An HTTP status for a farm reply (coordinator/farm_reply.h), its sentence in message. */
static int reply_status(const vf_farm_reply *r, char *message, size_t n) {
  if (r->env.body_case == VCMFARM__ENVELOPE__BODY_ERROR) {
    snprintf(message, n, "%s", r->error.message ? r->error.message : "error");
    switch (r->error.code) {
    case VCMFARM__ERROR_CODE__ERROR_UNKNOWN_JOB: return 404;
    case VCMFARM__ERROR_CODE__ERROR_BAD_REQUEST: return 400;
    default: return 500;
    }
  }
  if (r->env.body_case == VCMFARM__ENVELOPE__BODY_RESULT_ACK) {
    snprintf(message, n, "%s", r->result_ack.message ? r->result_ack.message : "");
    return r->result_ack.accepted ? 200 : 409;
  }
  snprintf(message, n, "unexpected reply");
  return 500;
}

/* A new weight that keeps the job's virtual time (coordinator/schedule.h): from now on it
 * gets its new share, without credit or debt for the time it had the old one. */
static int set_priority(vf_dashboard *d, uint64_t job_id, int priority, char *message, size_t n) {
  vf_job *job = vf_farm_job(d->farm, job_id);
  if (job == NULL) return snprintf(message, n, "no job %llu", (unsigned long long)job_id), 404;
  if (priority < VF_PRIORITY_MIN || priority > VF_PRIORITY_MAX)
    return snprintf(message, n, "priority %d: a weight from %d to %d", priority, VF_PRIORITY_MIN, VF_PRIORITY_MAX), 400;
  if (!vf_job_runnable(job))
    return snprintf(message, n, "job %llu is %s already", (unsigned long long)job_id, vf_job_state(job, 0)), 409;
  int old = job->priority;
  double vtime = vf_schedule_vtime(job);
  job->priority = priority;
  job->service = vtime * (double)priority;
  vf_events_add(&job->events, vf_unix_now(), "priority_changed", job->id, "", "priority %d -> %d (dashboard)", old,
                priority);
  d->farm->state_dirty = 1;
  int err = vf_state_save_index(d->farm);
  vf_log("job %llu: priority %d -> %d (dashboard)", (unsigned long long)job_id, old, priority);
  if (err != VF_OK) return snprintf(message, n, "%s", vf_error_detail(err)), 500;
  snprintf(message, n, "priority %d", priority);
  return 200;
}

static int run_action(vf_dashboard *d, const vf_dashboard_action *a, char *message, size_t n) {
  if (a->verb == VF_DASHBOARD_PRIORITY) return set_priority(d, a->job_id, a->priority, message, n);
  vf_farm_reply r;
  vf_farm_reply_init(&r);
  if (a->verb == VF_DASHBOARD_CANCEL) {
    Vcmfarm__CancelRequest q = VCMFARM__CANCEL_REQUEST__INIT;
    q.job_id = a->job_id;
    vf_jobs_cancel(d->farm, &q, vf_seconds_now(), &r);
  } else if (a->verb == VF_DASHBOARD_PAUSE || a->verb == VF_DASHBOARD_RESUME) {
    vf_jobs_pause(d->farm, a->job_id, a->verb == VF_DASHBOARD_PAUSE, &r);
  } else {
    Vcmfarm__RemoveRequest q = VCMFARM__REMOVE_REQUEST__INIT;
    q.job_id = a->job_id;
    vf_jobs_remove(d->farm, &q, &r);
  }
  int status = reply_status(&r, message, n);
  if (status == 200)
    vf_log("job %llu %s from the dashboard", (unsigned long long)a->job_id,
           a->verb == VF_DASHBOARD_CANCEL  ? "cancelled"
           : a->verb == VF_DASHBOARD_PAUSE ? "paused"
           : a->verb == VF_DASHBOARD_RESUME ? "resumed"
                                            : "removed");
  vf_farm_reply_release(&r);
  return status;
}

static void on_wake(uv_async_t *handle) {
  vf_dashboard *d = handle->data;
  pthread_mutex_lock(&d->lock);
  pending *queue = d->queue;
  d->queue = NULL;
  pthread_mutex_unlock(&d->lock);
  for (pending *p = queue; p; p = p->next) /* the loop's thread owns p's result until done is set */
    p->status = run_action(d, &p->action, p->message, sizeof p->message);
  /* Published before any action is answered: a page that reads after its answer sees its effect. */
  publish(d, queue != NULL);
  pthread_mutex_lock(&d->lock);
  while (queue) {
    pending *p = queue;
    queue = p->next;
    if (p->abandoned) free(p);
    else p->done = 1;
  }
  pthread_cond_broadcast(&d->changed);
  pthread_mutex_unlock(&d->lock);
}

static void on_publish(uv_timer_t *timer) { publish(timer->data, 0); }

int vf_dashboard_start(vf_farm *farm, uv_loop_t *loop, const vf_wire_key *key, const char *address,
                       vf_status_json_fn status_json, vf_dashboard **out) {
  if (status_json == NULL) return vf_error_set(VF_EINVAL, "the dashboard needs the status document's form");
  vf_dashboard *d = calloc(1, sizeof *d);
  if (d == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  d->farm = farm;
  d->loop = loop;
  d->status_json = status_json;
  pthread_mutex_init(&d->lock, NULL);
  pthread_cond_init(&d->changed, NULL);
  uv_async_init(loop, &d->wake, on_wake);
  uv_timer_init(loop, &d->publish_timer);
  d->wake.data = d->publish_timer.data = d;
  int err = vf_http_start(d, key, address, &d->http);
  if (err != VF_OK) {
    uv_close((uv_handle_t *)&d->wake, NULL);
    uv_close((uv_handle_t *)&d->publish_timer, NULL);
    uv_run(loop, UV_RUN_NOWAIT); /* let the closes land before d goes */
    vf_dashboard_destroy(d);
    return err;
  }
  uv_timer_start(&d->publish_timer, on_publish, PUBLISH_MS, PUBLISH_MS);
  *out = d;
  return VF_OK;
}

void vf_dashboard_stop(vf_dashboard *d) {
  if (d == NULL) return;
  pthread_mutex_lock(&d->lock);
  d->closing = 1;
  pthread_cond_broadcast(&d->changed);
  pthread_mutex_unlock(&d->lock);
  vf_http_stop(d->http); /* joins the threads: nobody waits on us after this */
  d->http = NULL;
  for (pending *p = d->queue, *next; p; p = next) { /* queued, never run: their readers are gone */
    next = p->next;
    free(p);
  }
  d->queue = NULL;
  uv_close((uv_handle_t *)&d->wake, NULL);
  uv_close((uv_handle_t *)&d->publish_timer, NULL);
}

void vf_dashboard_destroy(vf_dashboard *d) {
  if (d == NULL) return;
  vf_http_stop(d->http);
  free(d->status);
  for (int i = 0; i < WATCHED_JOBS; i++) free(d->watched[i].json);
  pthread_cond_destroy(&d->changed);
  pthread_mutex_destroy(&d->lock);
  free(d);
}

/* The slot of a job read now (the least recently read one is taken for a new job). Under lock. */
static watched_job *watch(vf_dashboard *d, uint64_t job_id, double now) {
  watched_job *slot = NULL;
  for (int i = 0; i < WATCHED_JOBS && slot == NULL; i++)
    if (d->watched[i].job_id == job_id) slot = &d->watched[i];
  if (slot == NULL) {
    slot = &d->watched[0];
    for (int i = 1; i < WATCHED_JOBS; i++)
      if (d->watched[i].wanted < slot->wanted) slot = &d->watched[i];
    free(slot->json);
    *slot = (watched_job){.job_id = job_id};
  }
  slot->wanted = now;
  return slot;
}

int vf_dashboard_status(vf_dashboard *d, uint64_t job_id, char **json, size_t *len) {
  double now = vf_seconds_now();
  pthread_mutex_lock(&d->lock);
  d->wanted_at = now;
  watched_job *slot = job_id ? watch(d, job_id, now) : NULL;
  int woken = 0;
  struct timespec deadline = deadline_in(VF_DASHBOARD_WAIT_SECONDS);
  for (;;) {
    double at = slot ? slot->published : d->status_at;
    if (d->closing) break;
    if (at > 0.0 && now - at < FRESH_SECONDS) break;
    if (!woken) {
      d->refresh = 1;
      uv_async_send(&d->wake);
      woken = 1;
    }
    if (pthread_cond_timedwait(&d->changed, &d->lock, &deadline) == ETIMEDOUT) break;
    if (slot && slot->job_id != job_id) slot = watch(d, job_id, now); /* taken by another reader meanwhile */
  }
  int status = 503;
  const char *text = slot ? slot->json : d->status;
  size_t n = slot ? slot->len : d->status_len;
  if (!d->closing && slot && slot->published > 0.0 && text == NULL) status = 404;
  else if (!d->closing && text && (*json = malloc(n + 1))) {
    memcpy(*json, text, n + 1);
    *len = n;
    status = 200;
  }
  pthread_mutex_unlock(&d->lock);
  return status;
}

int vf_dashboard_act(vf_dashboard *d, const vf_dashboard_action *action, char *message, size_t n) {
  pending *p = calloc(1, sizeof *p);
  if (p == NULL) return snprintf(message, n, "out of memory"), 503;
  p->action = *action;
  pthread_mutex_lock(&d->lock);
  if (d->closing) {
    pthread_mutex_unlock(&d->lock);
    free(p);
    return snprintf(message, n, "the coordinator is stopping"), 503;
  }
  pending **tail = &d->queue;
  while (*tail) tail = &(*tail)->next;
  *tail = p;
  uv_async_send(&d->wake);
  struct timespec deadline = deadline_in(VF_DASHBOARD_WAIT_SECONDS);
  while (!p->done && !d->closing)
    if (pthread_cond_timedwait(&d->changed, &d->lock, &deadline) == ETIMEDOUT) break;
  int status;
  if (p->done) {
    status = p->status;
    snprintf(message, n, "%s", p->message);
    free(p);
  } else {
    /* Still queued or running: the loop frees it when it is done (vf_dashboard_stop if never). */
    p->abandoned = 1;
    status = 503;
    snprintf(message, n, d->closing ? "the coordinator is stopping"
                                    : "the coordinator did not answer within %.0f s: the action may still happen",
             VF_DASHBOARD_WAIT_SECONDS);
  }
  pthread_mutex_unlock(&d->lock);
  return status;
}

const char *vf_dashboard_state_dir(const vf_dashboard *d) { return d->farm->config.state_dir; }
