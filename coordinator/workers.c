#include "workers.h"

#include "../common/clock.h"
#include "../common/error.h"
#include "../common/parse.h"
#include "leases.h"
#include "log.h"
#include "poison.h"

#include <sodium.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Untrusted text from a worker, for status and logs: no control characters. */
/* A peer's text as status and its JSON can show it: control characters and bytes that are
 * not UTF-8 (a character cut at the end included) become '?'. */
static void copy_text(char *dst, size_t n, const char *src) {
  snprintf(dst, n, "%s", src);
  for (char *c = dst; *c; c++)
    if ((unsigned char)*c < 0x20 || *c == 0x7f) *c = '?';
  vf_utf8_sanitize(dst);
}

static void depart(vf_farm *farm, size_t i, vf_worker_state state);

/* The worker's lease ends with the worker gone: a failure of the lease when no part of it
 * was merged and the loss is the worker's own (`blame`, coordinator/poison.h), else it
 * only returns to the pool. */
static void lose_lease(vf_farm *farm, vf_farm_worker *w, vf_lease *l, const char *why, int blame, double now) {
  uint64_t job_id = l->job_id;
  int progress = l->begin != l->first;
  vf_leases_end(farm, l, 1, now);
  if (!progress && blame) vf_poison_lease_failed(farm, job_id, w->name, why, now);
  else if (!progress)
    vf_log("job %llu: the lease of worker %s is not counted as failed: no worker was heard in its silence, so it was "
           "the coordinator's (its network, or a stall) rather than the worker's", (unsigned long long)job_id, w->name);
}

/* A worker registering under the name of one still registered is that worker restarted:
 * the old one crashed (or was killed) and is lost now, its lease failed when it had merged
 * nothing. Names identify workers across restarts (docs/PROTOCOL.md, "Poison jobs"). */
static void replace_restarted(vf_farm *farm, const char *name, double now) {
  for (size_t i = 0; i < farm->num_workers;) {
    vf_farm_worker *old = &farm->workers[i];
    if (strcmp(old->name, name) != 0) {
      i++;
      continue;
    }
    double at = vf_unix_now();
    vf_lease *l = vf_lease_find(&farm->leases, old->lease_id);
    if (l) {
      vf_job *job = vf_farm_job(farm, l->job_id);
      vf_log("worker %s registered again while holding lease %016llx of job %llu [%llu,%llu): it restarted; the lease "
             "returns to the pool", old->name, (unsigned long long)l->id, (unsigned long long)l->job_id,
             (unsigned long long)l->begin, (unsigned long long)l->end);
      if (job)
        vf_events_add(&job->events, at, "worker_lost", job->id, old->name,
                      "worker %s restarted while holding lease [%llu,%llu), which returns to the pool", old->name,
                      (unsigned long long)l->begin, (unsigned long long)l->end);
      lose_lease(farm, old, l, "it restarted (crashed?) while holding the lease", 1, now);
    } else {
      vf_log("worker %s registered again: the earlier one is lost", old->name);
    }
    vf_events_add(&farm->events, at, "worker_lost", 0, old->name, "worker %s restarted", old->name);
    depart(farm, i, VF_WORKER_LOST);
  }
}

void vf_workers_register(vf_farm *farm, const Vcmfarm__Register *m, double now, vf_farm_reply *r) {
  /* Tags are checked before anything changes: a worker refused for them is not registered
   * and does not replace one of its name. */
  vf_tags tags;
  vf_tags_init(&tags);
  if (m->n_tags > VF_TAGS_MAX)
    return vf_farm_reply_errorf(r, VCMFARM__ERROR_CODE__ERROR_BAD_REQUEST, "Register.tags: %zu tags, at most %d",
                                m->n_tags, VF_TAGS_MAX);
  for (size_t i = 0; i < m->n_tags; i++)
    if (vf_tags_add("Register.tags", &tags, m->tags[i], strlen(m->tags[i]), 0) != VF_OK)
      return vf_farm_reply_errorf(r, VCMFARM__ERROR_CODE__ERROR_BAD_REQUEST, "%s", vf_error_detail(VF_EINVAL));
  char name[128];
  copy_text(name, sizeof name, m->name);
  if (name[0] != '\0') replace_restarted(farm, name, now);
  if (farm->num_workers == farm->workers_capacity) {
    size_t cap = farm->workers_capacity ? 2 * farm->workers_capacity : 8;
    vf_farm_worker *grown = realloc(farm->workers, cap * sizeof *grown);
    if (grown == NULL) return vf_farm_reply_fail(r, vf_error_set(VF_ENOMEM, "out of memory"));
    farm->workers = grown;
    farm->workers_capacity = cap;
  }
  vf_farm_worker *w = &farm->workers[farm->num_workers++];
  memset(w, 0, sizeof *w);
  do {
    randombytes_buf(&w->id, sizeof w->id);
  } while (w->id == 0 || vf_farm_find_worker(farm, w->id) != w);
  memcpy(w->name, name, sizeof w->name);
  copy_text(w->host, sizeof w->host, m->host);
  copy_text(w->version, sizeof w->version, m->software_version);
  w->cores = m->cores;
  w->threads = m->threads;
  w->tags = tags;
  w->memory_bytes = m->memory_bytes;
  w->last_seen = now;
  w->registered_at = vf_unix_now();
  char tag_list[VF_TAGS_MAX * (VF_TAG_MAX_BYTES + 1) + 1];
  vf_tags_format(&w->tags, tag_list, sizeof tag_list);
  vf_log("worker %s registered (%u core%s, %u thread%s, %.1f GiB, tags %s, vcmfarm %s, host %s) as %016llx", w->name,
         w->cores, w->cores == 1 ? "" : "s", w->threads, w->threads == 1 ? "" : "s",
         (double)w->memory_bytes / (double)(1u << 30), tag_list[0] ? tag_list : "none", w->version,
         w->host[0] ? w->host : "unnamed", (unsigned long long)w->id);
  vf_events_add(&farm->events, w->registered_at, "worker_registered", 0, w->name, "worker %s registered: %u core%s, %u thread%s",
                w->name, w->cores, w->cores == 1 ? "" : "s", w->threads, w->threads == 1 ? "" : "s");
  vcmfarm__registered__init(&r->registered);
  r->registered.worker_id = w->id;
  double hb = farm->config.worker_timeout / 5.0;
  r->registered.heartbeat_ms = (uint32_t)(hb * 1000.0 < 50.0 ? 50.0 : hb * 1000.0);
  r->registered.timeout_ms = (uint32_t)(farm->config.worker_timeout * 1000.0);
  r->env.body_case = VCMFARM__ENVELOPE__BODY_REGISTERED;
  r->env.registered = &r->registered;
}

/* Moves worker i to the departed (left or lost), its lease already ended. */
static void depart(vf_farm *farm, size_t i, vf_worker_state state) {
  vf_farm_worker *w = &farm->workers[i];
  w->state = state;
  w->departed_at = vf_unix_now();
  w->lease_id = 0;
  farm->departed[farm->departed_next] = *w;
  farm->departed_next = (farm->departed_next + 1) % VF_FARM_DEPARTED;
  if (farm->num_departed < VF_FARM_DEPARTED) farm->num_departed++;
  farm->workers[i] = farm->workers[--farm->num_workers];
}

vf_farm_worker *vf_workers_find_any(vf_farm *farm, uint64_t id) {
  vf_farm_worker *w = vf_farm_find_worker(farm, id);
  for (unsigned i = 0; w == NULL && i < farm->num_departed; i++)
    if (farm->departed[i].id == id) w = &farm->departed[i];
  return w;
}

const vf_farm_worker *vf_workers_departed(const vf_farm *farm, unsigned i) {
  if (i >= farm->num_departed) return NULL;
  return &farm->departed[(farm->departed_next + VF_FARM_DEPARTED - farm->num_departed + i) % VF_FARM_DEPARTED];
}

void vf_workers_excuse(vf_farm *farm, double gap, double now) {
  for (size_t i = 0; i < farm->num_workers; i++) {
    vf_farm_worker *w = &farm->workers[i];
    w->last_seen = w->last_seen + gap < now ? w->last_seen + gap : now;
  }
}

int vf_workers_expire(vf_farm *farm, double now) {
  int lost = 0;
  /* The latest sign of life of any worker, before anyone is removed: a worker is to blame
   * for its silence only when others were heard well into it. */
  double latest = 0.0;
  for (size_t i = 0; i < farm->num_workers; i++)
    if (farm->workers[i].last_seen > latest) latest = farm->workers[i].last_seen;
  for (size_t i = 0; i < farm->num_workers;) {
    vf_farm_worker *w = &farm->workers[i];
    if (now - w->last_seen <= farm->config.worker_timeout) {
      i++;
      continue;
    }
    double at = vf_unix_now(), silent = now - w->last_seen;
    int blame = latest - w->last_seen >= VF_WORKERS_HEARD_FRACTION * farm->config.worker_timeout;
    vf_lease *l = vf_lease_find(&farm->leases, w->lease_id);
    if (l) {
      vf_log("worker %s lost (silent for %.1f s); lease %016llx of job %llu [%llu,%llu) returns to the pool", w->name,
             silent, (unsigned long long)l->id, (unsigned long long)l->job_id, (unsigned long long)l->begin,
             (unsigned long long)l->end);
      vf_job *job = vf_farm_job(farm, l->job_id);
      if (job)
        vf_events_add(&job->events, at, "worker_lost", job->id, w->name,
                      "worker %s lost after %.1f s of silence; its lease [%llu,%llu) expired and returns to the pool",
                      w->name, silent, (unsigned long long)l->begin, (unsigned long long)l->end);
      char why[96];
      snprintf(why, sizeof why, "lost after %.1f s of silence while holding the lease", silent);
      lose_lease(farm, w, l, why, blame, now);
    } else {
      vf_log("worker %s lost (silent for %.1f s)", w->name, silent);
    }
    vf_events_add(&farm->events, at, "worker_lost", 0, w->name, "worker %s lost after %.1f s of silence", w->name,
                  silent);
    depart(farm, i, VF_WORKER_LOST);
    lost++;
  }
  return lost;
}

void vf_workers_goodbye(vf_farm *farm, vf_farm_worker *w, const Vcmfarm__Goodbye *m, double now, vf_farm_reply *r) {
  double at = vf_unix_now();
  vf_lease *l = vf_lease_find(&farm->leases, w->lease_id);
  if (!m->done) {
    if (w->state != VF_WORKER_STOPPING) {
      w->state = VF_WORKER_STOPPING;
      vf_log("worker %s is stopping%s", w->name, l ? ": it finishes its lease" : "");
      vf_events_add(&farm->events, at, "worker_stopping", l ? l->job_id : 0, w->name, "worker %s is stopping%s",
                    w->name, l ? ": it ships what it rendered and hands back the rest" : "");
    }
    return vf_farm_reply_ack(r, 1, "stopping");
  }
  if (l) {
    vf_job *job = vf_farm_job(farm, l->job_id);
    vf_log("worker %s left holding lease %016llx; [%llu,%llu) returns to the pool", w->name, (unsigned long long)l->id,
           (unsigned long long)l->begin, (unsigned long long)l->end);
    if (job)
      vf_events_add(&job->events, at, "lease_expired", job->id, w->name,
                    "worker %s left holding lease [%llu,%llu), which returns to the pool", w->name,
                    (unsigned long long)l->begin, (unsigned long long)l->end);
    vf_leases_end(farm, l, 1, now);
  } else {
    vf_log("worker %s left", w->name);
  }
  vf_events_add(&farm->events, at, "worker_left", 0, w->name, "worker %s left", w->name);
  depart(farm, (size_t)(w - farm->workers), VF_WORKER_LEFT);
  vf_farm_reply_ack(r, 1, "goodbye");
}

const char *vf_worker_state_name(vf_farm *farm, const vf_farm_worker *w) {
  switch (w->state) {
  case VF_WORKER_STOPPING: return "stopping";
  case VF_WORKER_LEFT: return "left";
  case VF_WORKER_LOST: return "lost";
  default: return vf_lease_find(&farm->leases, w->lease_id) != NULL ? "busy" : "idle";
  }
}
