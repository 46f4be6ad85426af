#include "farm_core.h"

#include "../common/clock.h"
#include "../common/error.h"

#include <stdlib.h>
#include <string.h>

void vf_farm_init(vf_farm *farm, const vf_farm_config *config) {
  memset(farm, 0, sizeof *farm);
  farm->config = *config;
  farm->next_job_id = 1;
  farm->state_lock_fd = -1;
  farm->started_at = vf_unix_now();
  vf_lease_table_init(&farm->leases);
  vf_events_init(&farm->events, farm->events_storage, VF_FARM_EVENTS);
}

void vf_farm_destroy(vf_farm *farm) {
  for (size_t i = 0; i < farm->num_jobs; i++) vf_job_destroy(farm->jobs[i]);
  free(farm->jobs);
  free(farm->workers);
  free(farm->checked);
  free(farm->blocks);
  vf_lease_table_destroy(&farm->leases);
  memset(farm, 0, sizeof *farm);
}

vf_job *vf_farm_job(const vf_farm *farm, uint64_t id) {
  for (size_t i = 0; i < farm->num_jobs; i++)
    if (farm->jobs[i]->id == id) return farm->jobs[i];
  return NULL;
}

vf_farm_worker *vf_farm_find_worker(vf_farm *farm, uint64_t id) {
  for (size_t i = 0; i < farm->num_workers; i++)
    if (farm->workers[i].id == id) return &farm->workers[i];
  return NULL;
}

int vf_farm_add_job(vf_farm *farm, vf_job *job) {
  if (farm->num_jobs == farm->jobs_capacity) {
    size_t cap = farm->jobs_capacity ? 2 * farm->jobs_capacity : 8;
    vf_job **grown = realloc(farm->jobs, cap * sizeof *grown);
    if (grown == NULL) return vf_error_set(VF_ENOMEM, "out of memory for jobs");
    farm->jobs = grown;
    farm->jobs_capacity = cap;
  }
  farm->jobs[farm->num_jobs++] = job;
  return VF_OK;
}
