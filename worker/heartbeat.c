#include "heartbeat.h"

#include "../common/error.h"
#include "../common/farm_client.h"

#include <errno.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

struct vf_heartbeat {
  pthread_t thread;
  pthread_mutex_t lock;
  pthread_cond_t wake;
  vf_farm_client *client;
  volatile sig_atomic_t *terminating; /* the worker's stop flag, or NULL */
  /* under lock */
  int said_stopping;            /* the Goodbye that says we are stopping went out */
  int stopping;
  uint64_t worker_id, lease_id; /* lease_id 0: no lease, no beats */
  int interval_ms;
  uint64_t generation;          /* bumped by every set/clear, so a stale answer is ignored */
  /* any thread */
  atomic_uint_fast64_t iterations_done;
  _Atomic double seconds;
  atomic_int revoked;
  atomic_int deliver_now;
  atomic_uint ship_interval_ms;
};

static void deadline_after(struct timespec *ts, int ms) {
  clock_gettime(CLOCK_REALTIME, ts);
  ts->tv_sec += ms / 1000;
  ts->tv_nsec += (long)(ms % 1000) * 1000000L;
  if (ts->tv_nsec >= 1000000000L) {
    ts->tv_sec++;
    ts->tv_nsec -= 1000000000L;
  }
}

static void *beat(void *arg) {
  vf_heartbeat *hb = arg;
  pthread_mutex_lock(&hb->lock);
  while (!hb->stopping) {
    if (hb->lease_id == 0) {
      pthread_cond_wait(&hb->wake, &hb->lock);
      continue;
    }
    uint64_t generation = hb->generation;
    /* The interval in slices, so that a SIGTERM is told at once, not after the iteration
     * being rendered (which may take longer than the interval). */
    int goodbye = 0;
    for (int waited = 0; waited < hb->interval_ms && !hb->stopping && hb->generation == generation;) {
      if (hb->terminating && *hb->terminating && !hb->said_stopping) {
        goodbye = 1;
        break;
      }
      int slice = hb->interval_ms - waited < 100 ? hb->interval_ms - waited : 100;
      struct timespec ts;
      deadline_after(&ts, slice);
      if (pthread_cond_timedwait(&hb->wake, &hb->lock, &ts) == ETIMEDOUT) waited += slice;
    }
    if (hb->stopping || hb->generation != generation) continue;
    if (goodbye) {
      hb->said_stopping = 1;
      Vcmfarm__Goodbye g = VCMFARM__GOODBYE__INIT;
      g.worker_id = hb->worker_id;
      pthread_mutex_unlock(&hb->lock);
      Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply = NULL;
      q.body_case = VCMFARM__ENVELOPE__BODY_GOODBYE;
      q.goodbye = &g;
      if (vf_farm_call(hb->client, &q, 2000, &reply) == VF_OK) vf_message_free(reply);
      pthread_mutex_lock(&hb->lock);
      continue; /* and beat on: the lease stays ours until it is shipped or handed back */
    }
    Vcmfarm__Heartbeat m = VCMFARM__HEARTBEAT__INIT;
    m.worker_id = hb->worker_id;
    m.lease_id = hb->lease_id;
    m.iterations_done = atomic_load(&hb->iterations_done);
    m.seconds = atomic_load(&hb->seconds);
    int timeout = hb->interval_ms < 1000 ? 1000 : hb->interval_ms;
    pthread_mutex_unlock(&hb->lock);
    Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply = NULL;
    q.body_case = VCMFARM__ENVELOPE__BODY_HEARTBEAT;
    q.heartbeat = &m;
    int err = vf_farm_call(hb->client, &q, timeout, &reply);
    pthread_mutex_lock(&hb->lock);
    if (err != VF_OK) continue; /* coordinator away: keep trying; it decides who is lost */
    int invalid = (reply->body_case == VCMFARM__ENVELOPE__BODY_HEARTBEAT_ACK && !reply->heartbeat_ack->lease_valid) ||
                  (reply->body_case == VCMFARM__ENVELOPE__BODY_ERROR &&
                   reply->error->code == VCMFARM__ERROR_CODE__ERROR_UNKNOWN_WORKER);
    if (invalid && hb->generation == generation) atomic_store(&hb->revoked, 1);
    if (reply->body_case == VCMFARM__ENVELOPE__BODY_HEARTBEAT_ACK && reply->heartbeat_ack->lease_valid &&
        reply->heartbeat_ack->deliver_now && hb->generation == generation)
      atomic_store(&hb->deliver_now, 1);
    if (reply->body_case == VCMFARM__ENVELOPE__BODY_HEARTBEAT_ACK && reply->heartbeat_ack->ship_interval_ms > 0)
      atomic_store(&hb->ship_interval_ms, reply->heartbeat_ack->ship_interval_ms);
    vf_message_free(reply);
  }
  pthread_mutex_unlock(&hb->lock);
  return NULL;
}

int vf_heartbeat_start(const char *url, const vf_wire_key *key, volatile sig_atomic_t *terminating,
                       vf_heartbeat **out) {
  vf_heartbeat *hb = calloc(1, sizeof *hb);
  if (hb == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  hb->terminating = terminating;
  int err = vf_farm_client_open(url, key, &hb->client);
  if (err != VF_OK) goto free_hb;
  pthread_mutex_init(&hb->lock, NULL);
  pthread_cond_init(&hb->wake, NULL);
  if (pthread_create(&hb->thread, NULL, beat, hb) != 0) {
    err = vf_error_set(VF_ENOMEM, "cannot start the heartbeat thread");
    goto destroy_sync;
  }
  *out = hb;
  return VF_OK;
destroy_sync:
  pthread_cond_destroy(&hb->wake);
  pthread_mutex_destroy(&hb->lock);
  vf_farm_client_close(hb->client);
free_hb:
  free(hb);
  return err;
}

void vf_heartbeat_stop(vf_heartbeat *hb) {
  if (hb == NULL) return;
  pthread_mutex_lock(&hb->lock);
  hb->stopping = 1;
  pthread_cond_signal(&hb->wake);
  pthread_mutex_unlock(&hb->lock);
  pthread_join(hb->thread, NULL);
  pthread_cond_destroy(&hb->wake);
  pthread_mutex_destroy(&hb->lock);
  vf_farm_client_close(hb->client);
  free(hb);
}

void vf_heartbeat_set_lease(vf_heartbeat *hb, uint64_t worker_id, uint64_t lease_id, int interval_ms) {
  pthread_mutex_lock(&hb->lock);
  hb->worker_id = worker_id;
  hb->lease_id = lease_id;
  hb->interval_ms = interval_ms < 10 ? 10 : interval_ms;
  hb->generation++;
  atomic_store(&hb->iterations_done, 0);
  atomic_store(&hb->seconds, 0.0);
  atomic_store(&hb->revoked, 0);
  atomic_store(&hb->deliver_now, 0);
  pthread_cond_signal(&hb->wake);
  pthread_mutex_unlock(&hb->lock);
}

void vf_heartbeat_clear_lease(vf_heartbeat *hb) {
  pthread_mutex_lock(&hb->lock);
  hb->lease_id = 0;
  hb->generation++;
  pthread_cond_signal(&hb->wake);
  pthread_mutex_unlock(&hb->lock);
}

void vf_heartbeat_progress(vf_heartbeat *hb, uint64_t iterations_done, double seconds) {
  atomic_store(&hb->iterations_done, iterations_done);
  atomic_store(&hb->seconds, seconds);
}

int vf_heartbeat_revoked(vf_heartbeat *hb) { return atomic_load(&hb->revoked); }

int vf_heartbeat_deliver_now(vf_heartbeat *hb) { return atomic_load(&hb->deliver_now); }

uint32_t vf_heartbeat_ship_interval_ms(vf_heartbeat *hb) { return atomic_load(&hb->ship_interval_ms); }
