#include "workers.h"

#include "leases.h"
#include "log.h"

#include <sodium.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void vf_workers_register(vf_farm *farm, const Vcmfarm__Register *m, double now, vf_farm_reply *r) {
  if (farm->num_workers == farm->workers_capacity) {
    size_t cap = farm->workers_capacity ? 2 * farm->workers_capacity : 8;
    vf_farm_worker *grown = realloc(farm->workers, cap * sizeof *grown);
    if (grown == NULL) return vf_farm_reply_error(r, VCMFARM__ERROR_CODE__ERROR_INTERNAL, "out of memory");
    farm->workers = grown;
    farm->workers_capacity = cap;
  }
  vf_farm_worker *w = &farm->workers[farm->num_workers++];
  memset(w, 0, sizeof *w);
  do {
    randombytes_buf(&w->id, sizeof w->id);
  } while (w->id == 0 || vf_farm_find_worker(farm, w->id) != w);
  snprintf(w->name, sizeof w->name, "%s", m->name);
  for (char *c = w->name; *c; c++)
    if ((unsigned char)*c < 0x20) *c = '?';
  w->cores = m->cores;
  w->threads = m->threads;
  w->last_seen = now;
  vf_log("worker %s registered (%u cores, %u threads, vcmfarm %.32s) as %016llx", w->name, w->cores, w->threads,
         m->software_version, (unsigned long long)w->id);
  vcmfarm__registered__init(&r->registered);
  r->registered.worker_id = w->id;
  double hb = farm->config.worker_timeout / 5.0;
  r->registered.heartbeat_ms = (uint32_t)(hb * 1000.0 < 50.0 ? 50.0 : hb * 1000.0);
  r->registered.timeout_ms = (uint32_t)(farm->config.worker_timeout * 1000.0);
  r->env.body_case = VCMFARM__ENVELOPE__BODY_REGISTERED;
  r->env.registered = &r->registered;
}

int vf_workers_expire(vf_farm *farm, double now) {
  int lost = 0;
  for (size_t i = 0; i < farm->num_workers;) {
    vf_farm_worker *w = &farm->workers[i];
    if (now - w->last_seen <= farm->config.worker_timeout) {
      i++;
      continue;
    }
    vf_lease *l = vf_lease_find(&farm->leases, w->lease_id);
    if (l) {
      vf_log("worker %s lost (silent for %.1f s); lease %016llx of job %llu [%llu,%llu) returns to the pool", w->name,
             now - w->last_seen, (unsigned long long)l->id, (unsigned long long)l->job_id,
             (unsigned long long)l->begin, (unsigned long long)l->end);
      vf_leases_end(farm, l, 1, now);
    } else {
      vf_log("worker %s lost (silent for %.1f s)", w->name, now - w->last_seen);
    }
    farm->workers[i] = farm->workers[--farm->num_workers];
    lost++;
  }
  return lost;
}
