#include "worker.h"

#include "../common/allocation.h"
#include "../common/error.h"
#include "../common/farm_client.h"
#include "../common/film_wire.h"
#include "render/accel.h"
#include "blob_cache.h"
#include "heartbeat.h"
#include "machine.h"
#include "scene/job_scene.h"
#include "render/render.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#define REQUEST_TIMEOUT_MS 10000
#define RESULT_TIMEOUT_MS 60000
#define BACKOFF_MAX_MS 5000
#define RESULT_ATTEMPTS 8
/* Parts are shipped from the render thread, which waits meanwhile: a part is encoded and
 * framed, then the coordinator takes it in (docs/BENCHMARKS.md, "A coordinator for 1000
 * workers", has what each costs). Shipping no more often than SHIP_COST_FACTOR times the
 * last part's cost keeps that wait to one part in SHIP_COST_FACTOR of the rendering. */
#define SHIP_COST_FACTOR 50.0

typedef struct {
  const char *url;
  volatile sig_atomic_t *terminating; /* the caller's stop flag */
  volatile sig_atomic_t render_stop;  /* stop rendering the lease after this iteration */
  int quiet;
  vf_farm_client *client;
  vf_heartbeat *heartbeat;
  uint64_t worker_id;
  int heartbeat_ms;
  int threads;
  char name[128];
  const char *cache_dir; /* scene files by content hash (worker/blob_cache.h) */
  uint64_t cache_max_bytes;
  int backoff_ms;
  /* the renderer of the last job, kept for its next lease */
  uint64_t job_id;
  uint8_t job_hash[32];
  char job_settings[512];
  vf_scene *scene;
  vf_renderer *renderer;
  /* the allocation of camera sub-paths of the last lease that had one (Lease.allocation),
   * kept for the job's next lease: owned, width x height counts; NULL none */
  uint8_t *allocation;
  uint8_t allocation_hash[32];
  size_t allocation_pixels;
  double ship_interval;
  /* the lease being rendered */
  const Vcmfarm__Lease *lease;
  uint64_t shipped;    /* iterations [lease begin, shipped) are merged */
  double shipped_at;   /* vf_render_status.seconds of the last part's end, this lease */
  double ship_cost;    /* seconds the last part took to ship (kept across leases) */
  vf_film_accum *accum; /* the lease's pixels (common/film_accum.h): its film's sums stay
                         * zero and untouched, half the memory; owned, per lease */
  int part_merged;     /* the last acknowledgement said the part was merged */
  double deadline;     /* vf_seconds_now() at which the lease's job reaches its time limit; 0 none */
  int at_deadline;     /* rendering stopped for the job's time limit */
  int dropped;         /* a part was refused or could not be sent: stop, send nothing more */
  /* test hooks */
  int iteration_delay_ms;
  const char *stall_file;
  int stalled;
  const char *abort_scene;
  const vf_tags *tags; /* the operator's, borrowed from the config; NULL: none */
  int no_auto_tags;
} worker;

static void log_v(const char *fmt, va_list ap) {
  char line[1200];
  vsnprintf(line, sizeof line, fmt, ap);
  fprintf(stderr, "vcmfarm worker %d: %s\n", (int)getpid(), line);
}

/* Failures and retries: always logged. */
static void log_line(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static void log_line(const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  log_v(fmt, ap);
  va_end(ap);
}

/* The ordinary course of leases: not logged when quiet. */
static void note(const worker *w, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void note(const worker *w, const char *fmt, ...) {
  if (w->quiet) return;
  va_list ap;
  va_start(ap, fmt);
  log_v(fmt, ap);
  va_end(ap);
}

static void sleep_ms(worker *w, int ms) {
  while (ms > 0 && !*w->terminating) {
    int step = ms < 50 ? ms : 50;
    struct timespec ts = {0, (long)step * 1000000L};
    nanosleep(&ts, NULL);
    ms -= step;
  }
}

static void back_off(worker *w) {
  w->backoff_ms = w->backoff_ms ? w->backoff_ms * 2 : 100;
  if (w->backoff_ms > BACKOFF_MAX_MS) w->backoff_ms = BACKOFF_MAX_MS;
  sleep_ms(w, w->backoff_ms / 2 + rand() % (w->backoff_ms / 2 + 1));
}

/* Errors after which retrying cannot help. */
static int fatal(int err) { return err == VF_EVERSION || err == VF_EAUTH; }

static int register_worker(worker *w) {
  long cores = sysconf(_SC_NPROCESSORS_ONLN);
  Vcmfarm__Register m = VCMFARM__REGISTER__INIT;
  m.name = w->name;
  m.cores = cores > 0 ? (uint32_t)cores : 1;
  m.threads = w->threads > 0 ? (uint32_t)w->threads : m.cores;
  m.software_version = VF_VERSION;
  /* The operator's tags and the CPU's (checked by the command line; the coordinator
   * checks them again), and the memory mem>= requirements are compared with. */
  vf_tags tags;
  vf_tags_init(&tags);
  if (w->tags) tags = *w->tags;
  if (!w->no_auto_tags && vf_machine_tags(&tags) != VF_OK)
    log_line("not every automatic tag fits: %s", vf_error_detail(VF_EINVAL));
  char *tag_ptrs[VF_TAGS_MAX];
  for (unsigned i = 0; i < tags.count; i++) tag_ptrs[i] = tags.tag[i];
  m.n_tags = tags.count;
  m.tags = tag_ptrs;
  m.memory_bytes = vf_machine_memory_bytes();
  char host[64] = "";
  if (gethostname(host, sizeof host - 1) != 0) host[0] = '\0';
  m.host = host;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_REGISTER;
  q.register_ = &m;
  for (int attempt = 0; !*w->terminating; attempt++) {
    int err = vf_farm_request(w->client, &q, VCMFARM__ENVELOPE__BODY_REGISTERED, REQUEST_TIMEOUT_MS / 2, &reply);
    if (err == VF_OK) {
      w->worker_id = reply->registered->worker_id;
      w->heartbeat_ms = (int)reply->registered->heartbeat_ms;
      vf_message_free(reply);
      w->backoff_ms = 0;
      note(w, "registered with %s as %016llx; Embree's %s kernels", w->url, (unsigned long long)w->worker_id,
           vf_accel_kernels());
      return VF_OK;
    }
    if (fatal(err) || err == VF_EREFUSED) return err;
    if (attempt == 0 || attempt % 10 == 0) log_line("%s; retrying", vf_error_detail(err));
    back_off(w);
  }
  return VF_OK;
}

static void release_lease(worker *w, uint64_t lease_id, const char *failure) {
  Vcmfarm__LeaseRelease m = VCMFARM__LEASE_RELEASE__INIT;
  m.worker_id = w->worker_id;
  m.lease_id = lease_id;
  m.failure = (char *)failure;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_RELEASE;
  q.release = &m;
  if (vf_farm_call(w->client, &q, REQUEST_TIMEOUT_MS / 2, &reply) == VF_OK) vf_message_free(reply);
  if (failure[0]) log_line("failed lease %016llx: %s", (unsigned long long)lease_id, failure);
  else note(w, "handed back lease %016llx", (unsigned long long)lease_id);
}

/* The renderer for the lease's job, reusing the last one when job, scene and settings agree. */
static int prepare(worker *w, const Vcmfarm__Lease *l, const vf_settings *settings) {
  if (w->renderer && w->job_id == l->job_id && memcmp(w->job_hash, l->scene_hash.data, 32) == 0 &&
      strcmp(w->job_settings, l->settings) == 0)
    return VF_OK;
  vf_renderer_destroy(w->renderer);
  vf_scene_destroy(w->scene);
  w->renderer = NULL;
  w->scene = NULL;
  char label[64];
  snprintf(label, sizeof label, "job %llu scene", (unsigned long long)l->job_id);
  if (w->abort_scene != NULL &&
      (l->scene->source_case == VCMFARM__SCENE__SOURCE_BUILTIN ? strcmp(l->scene->builtin, w->abort_scene) == 0
                                                                : strstr(l->scene->json, w->abort_scene) != NULL)) {
    log_line("%s: crashing (test: --test-abort-scene %s)", label, w->abort_scene);
    abort();
  }
  /* Its files (if any) come from the cache, fetched first when missing. */
  int err = vf_blob_cache_load_scene(w->client, w->worker_id, w->cache_dir, w->cache_max_bytes, l->scene, label,
                                     w->quiet, &w->scene);
  if (err != VF_OK) return err;
  if (memcmp(w->scene->hash, l->scene_hash.data, 32) != 0) {
    char hex[65];
    vf_scene_hash_hex(w->scene, hex);
    return vf_error_set(VF_EMISMATCH, "%s loads with hash %s, not the job's (different vcmfarm versions?)", label, hex);
  }
  if ((err = vf_renderer_create(w->scene, settings, w->threads, &w->renderer)) != VF_OK) return err;
  w->job_id = l->job_id;
  memcpy(w->job_hash, l->scene_hash.data, 32);
  snprintf(w->job_settings, sizeof w->job_settings, "%s", l->settings);
  return VF_OK;
}

static void on_progress(void *ctx, const vf_render_status *st) {
  worker *w = ctx;
  vf_heartbeat_progress(w->heartbeat, st->iterations_done, st->seconds);
  if (w->iteration_delay_ms > 0) {
    /* A real iteration runs to its end whatever signal arrives: so does the delay. */
    struct timespec ts = {w->iteration_delay_ms / 1000, (long)(w->iteration_delay_ms % 1000) * 1000000L};
    while (nanosleep(&ts, &ts) != 0 && errno == EINTR) {
    }
  }
  if (vf_heartbeat_revoked(w->heartbeat) || *w->terminating) w->render_stop = 1;
  /* The job's time limit (protocol 9): what is rendered goes out as the final part. */
  if ((w->deadline > 0.0 && vf_seconds_now() >= w->deadline) || vf_heartbeat_deliver_now(w->heartbeat)) {
    w->render_stop = 1;
    w->at_deadline = 1;
  }
  /* A lease bounded by time (its rate was unknown): ship what is rendered, hand back the rest. */
  if (w->lease && w->lease->seconds_ms > 0 && st->seconds >= w->lease->seconds_ms / 1000.0) w->render_stop = 1;
}

static void stall(worker *w) {
  char marker[4200];
  snprintf(marker, sizeof marker, "%s.stalled", w->stall_file);
  FILE *f = fopen(marker, "w");
  if (f) fclose(f);
  log_line("stalling (test) until %s exists", w->stall_file);
  while (!*w->terminating && access(w->stall_file, F_OK) != 0) sleep_ms(w, 20);
  w->stalled = 1;
}

/* Sends the tiles of one LeaseResult message; 1 accepted, 0 refused (logged), < 0 not
 * sent. A message whose reply was lost is sent again; the coordinator takes it once. */
static int send_tiles(worker *w, Vcmfarm__LeaseResult *m) {
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_RESULT;
  q.result = m;
  int err = VF_OK, busy_waits = 0;
  for (int attempt = 0; attempt < RESULT_ATTEMPTS; attempt++) {
    err = vf_farm_request(w->client, &q, VCMFARM__ENVELOPE__BODY_RESULT_ACK, RESULT_TIMEOUT_MS, &reply);
    if (err == VF_OK && !reply->result_ack->accepted && reply->result_ack->retry_ms > 0) {
      /* Not refused: the coordinator's merge queue is full. The same message again later,
       * spread over half to one and a half times the wait it asks for. */
      int ms = (int)(reply->result_ack->retry_ms > 60000 ? 60000 : reply->result_ack->retry_ms);
      vf_message_free(reply);
      if (*w->terminating && busy_waits > 600) break;
      busy_waits++;
      attempt--;
      sleep_ms(w, ms / 2 + rand() % (ms + 1));
      continue;
    }
    if (err == VF_OK) {
      int accepted = reply->result_ack->accepted;
      w->part_merged = accepted && (strcmp(reply->result_ack->message, "merged") == 0 ||
                                    strcmp(reply->result_ack->message, "already merged") == 0);
      if (!accepted && !(w->quiet && *w->terminating)) /* stopping quietly: the job may have ended */
        log_line("job %llu [%llu,%llu): refused: %s", (unsigned long long)m->job_id, (unsigned long long)m->begin,
                 (unsigned long long)m->end, reply->result_ack->message);
      vf_message_free(reply);
      return accepted;
    }
    log_line("sending job %llu [%llu,%llu): %s", (unsigned long long)m->job_id, (unsigned long long)m->begin,
             (unsigned long long)m->end, vf_error_detail(err));
    if (fatal(err) || err == VF_EREFUSED || *w->terminating) break;
    back_off(w);
  }
  return err < 0 ? err : VF_ETIMEDOUT;
}

static int send_tiles_cb(void *ctx, Vcmfarm__LeaseResult *m) { return send_tiles(ctx, m); }

/* Ships the film of [w->shipped, ...) as tiles (docs/PROTOCOL.md). Returns 1 when the
 * coordinator merged it; otherwise the lease is dropped (w->dropped). */
static int ship(worker *w, const vf_film *film) {
  Vcmfarm__LeaseResult m = VCMFARM__LEASE_RESULT__INIT;
  m.worker_id = w->worker_id;
  m.lease_id = w->lease->lease_id;
  m.job_id = w->lease->job_id;
  m.begin = w->shipped;
  /* A pilot part is marked so, and a part of the image names its allocation: neither can
   * be merged as the other (docs/PROTOCOL.md, "Pilots"). */
  m.pilot = w->lease->pilot;
  if (!w->lease->pilot && w->lease->allocation != NULL) {
    m.allocation.data = w->allocation_hash;
    m.allocation.len = 32;
  }
  w->part_merged = 0;
  int rc = vf_film_send_tiles_pending(film, w->accum, &m, VF_FILM_TILES_PER_MESSAGE, send_tiles_cb, w);
  /* Every tile taken, yet not merged: the coordinator lost tiles of it (it dropped the
   * part, or restarted); the lease cannot go on from here. */
  if (rc == 1 && !w->part_merged) {
    log_line("job %llu [%llu,%llu): sent but not merged; dropping the lease", (unsigned long long)m.job_id,
             (unsigned long long)m.begin, (unsigned long long)m.end);
    rc = 0;
  }
  if (rc == 1) {
    w->shipped = m.end;
    return 1;
  }
  if (rc < 0 && rc != VF_ETIMEDOUT) log_line("sending tiles: %s", vf_error_detail(rc));
  w->dropped = 1;
  w->render_stop = 1;
  return 0;
}

/* The film after its iterations were shipped: empty again, ready for the next part. */
static void film_reset(worker *w, vf_film *film) {
  /* The accumulator's pages are given back: when parts are one iteration long (large
   * images), the pixels are not resident while the next iteration renders, the peak of a
   * worker's memory. The film's own sums were never written. */
  vf_film_accum_clear(w->accum);
  vf_iterset_destroy(&film->iterations);
  vf_iterset_init(&film->iterations);
  film->render_seconds = film->cpu_seconds = 0.0;
  film->nonfinite_samples = film->biased_merges = 0;
}

/* The interval between parts: --ship-interval when given, else the coordinator's latest
 * word (its heartbeat acknowledgement, else the lease), else the default. */
static double ship_interval(worker *w) {
  if (w->ship_interval > 0.0) return w->ship_interval;
  uint32_t ms = vf_heartbeat_ship_interval_ms(w->heartbeat);
  if (ms == 0 && w->lease) ms = w->lease->ship_interval_ms;
  return ms > 0 ? ms / 1000.0 : VF_WORKER_SHIP_SECONDS;
}

/* The render loop's delivery, after every iteration: once the ship interval (or 50
 * times the last part's cost, if more) has passed since the last part, the iterations so
 * far go to the coordinator and the film starts again empty. The end of the lease is
 * shipped by run_lease, after the loop. */
static int ship_part(void *ctx, vf_film *film, const vf_render_status *st) {
  worker *w = ctx;
  if (st->final || w->dropped || vf_heartbeat_revoked(w->heartbeat)) return VF_OK;
  double interval = ship_interval(w);
  if (interval < SHIP_COST_FACTOR * w->ship_cost) interval = SHIP_COST_FACTOR * w->ship_cost;
  if (st->seconds - w->shipped_at < interval) return VF_OK;
  if (w->shipped + vf_iterset_count(&film->iterations) >= w->lease->end) return VF_OK; /* the last: after the loop */
  double t0 = vf_seconds_now();
  if (ship(w, film)) film_reset(w, film);
  w->ship_cost = vf_seconds_now() - t0;
  w->shipped_at = st->seconds + w->ship_cost;
  return VF_OK;
}

/* The lease's allocation of camera sub-paths (a job with a pilot, Lease.allocation) into
 * w->allocation: kept from the last lease when its hash is the same, else fetched into the
 * cache like a scene's file (checked against its hash there) and checked as counts of the
 * film's pixels. Errors of vf_blob_cache_fill, or VF_EMISMATCH naming what is wrong. */
static int load_allocation(worker *w, const Vcmfarm__Lease *l, size_t pixels) {
  const Vcmfarm__BlobRef *ref = l->allocation;
  if (ref == NULL || ref->hash.len != 32 || ref->size != pixels)
    return vf_error_set(VF_EMISMATCH, "job %llu: the lease's allocation of camera sub-paths is missing or not one "
                        "count per pixel", (unsigned long long)l->job_id);
  if (w->allocation != NULL && w->allocation_pixels == pixels && memcmp(w->allocation_hash, ref->hash.data, 32) == 0)
    return VF_OK;
  vf_blob_table table = {0};
  int err = vf_blob_table_add(&table, "allocation", ref->hash.data, ref->size);
  if (err == VF_OK) err = vf_blob_cache_fill(w->client, w->worker_id, w->cache_dir, &table, w->quiet, NULL);
  vf_blob_table_clear(&table);
  uint8_t *counts = NULL;
  size_t n = 0;
  if (err == VF_OK) err = vf_blob_store_get(w->cache_dir, ref->hash.data, &counts, &n);
  if (err == VF_OK && n != pixels)
    err = vf_error_set(VF_EMISMATCH, "job %llu: an allocation of %zu counts for %zu pixels",
                       (unsigned long long)l->job_id, n, pixels);
  if (err == VF_OK) err = vf_allocation_validate(counts, pixels, "the lease's allocation");
  if (err != VF_OK) {
    free(counts);
    return err;
  }
  free(w->allocation);
  w->allocation = counts;
  w->allocation_pixels = pixels;
  memcpy(w->allocation_hash, ref->hash.data, 32);
  return VF_OK;
}

static void run_lease(worker *w, const Vcmfarm__Lease *l) {
  /* On our clock from now: the lease left the coordinator moments ago. */
  w->deadline = l->deadline_ms > 0 ? vf_seconds_now() + l->deadline_ms / 1000.0 : 0.0;
  w->at_deadline = 0;
  vf_settings settings;
  const char *bad = NULL;
  if (l->scene == NULL || l->scene->source_case == VCMFARM__SCENE__SOURCE__NOT_SET) bad = "no scene";
  else if (l->scene->source_case == VCMFARM__SCENE__SOURCE_JSON_BLOB) bad = "scene text as a blob (only a submission has one)";
  else if (l->scene_hash.len != 32) bad = "scene hash is not 32 bytes";
  else if (l->begin >= l->end || l->end - l->begin > 1000000000ull) bad = "empty or huge iteration range";
  else if (vf_settings_parse(&settings, l->settings) != VF_OK || vf_settings_validate(&settings) != VF_OK)
    bad = "invalid settings";
  else if (l->pilot && (settings.pilot == 0 || l->end > (uint64_t)settings.pilot))
    bad = "a pilot lease beyond the job's pilot";
  if (bad) return release_lease(w, l->lease_id, bad);
  int err = prepare(w, l, &settings);
  /* A scene file that could not be fetched in time, or kept in the cache, is no fault of
   * the job: hand the lease back, and wait before asking again. */
  if (err == VF_ETIMEDOUT || err == VF_ENET || err == VF_EIO) {
    log_line("%s", vf_error_detail(err));
    release_lease(w, l->lease_id, "");
    back_off(w);
    return;
  }
  if (err != VF_OK) return release_lease(w, l->lease_id, vf_error_detail(err));
  size_t pixels = (size_t)settings.width * (size_t)settings.height;
  if (settings.pilot > 0 && !l->pilot && (err = load_allocation(w, l, pixels)) != VF_OK) {
    log_line("%s", vf_error_detail(err));
    if (err == VF_ETIMEDOUT || err == VF_ENET || err == VF_EIO) {
      release_lease(w, l->lease_id, "");
      back_off(w);
      return;
    }
    return release_lease(w, l->lease_id, vf_error_detail(err));
  }
  vf_film *film = NULL;
  if ((err = vf_film_create(settings.width, settings.height, &film)) != VF_OK ||
      (err = vf_renderer_stamp(w->renderer, film)) != VF_OK ||
      (settings.pilot > 0 && !l->pilot && (err = vf_film_set_samples(film, w->allocation)) != VF_OK) ||
      (err = vf_film_accum_create(settings.width, settings.height, &w->accum)) != VF_OK) {
    vf_film_destroy(film);
    return release_lease(w, l->lease_id, vf_error_detail(err));
  }
  w->lease = l;
  w->shipped = l->begin;
  w->shipped_at = 0.0;
  w->dropped = 0;
  vf_heartbeat_set_lease(w->heartbeat, w->worker_id, l->lease_id, w->heartbeat_ms);
  w->render_stop = *w->terminating;
  vf_render_control control = {.progress = on_progress, .ctx = w, .interrupt = &w->render_stop,
                               .deliver = ship_part, .accum = w->accum};
  vf_render_status st;
  memset(&st, 0, sizeof st);
  err = l->pilot ? vf_render_pilot_range(w->renderer, film, l->begin, l->end, &control, &st)
                 : vf_render_range(w->renderer, film, l->begin, l->end, &control, &st);
  int revoked = vf_heartbeat_revoked(w->heartbeat);
  uint64_t rendered = l->begin + st.iterations_done;
  note(w, "lease %016llx: rendered %llu %siteration%s of job %llu [%llu,%llu)%s", (unsigned long long)l->lease_id,
       (unsigned long long)st.iterations_done, l->pilot ? "pilot " : "", st.iterations_done == 1 ? "" : "s",
       (unsigned long long)l->job_id,
       (unsigned long long)l->begin, (unsigned long long)rendered, w->at_deadline ? " (the job's time limit)" : "");
  /* The heartbeat goes on until the last part is shipped and the rest handed back: a part
   * waiting at a congested gate or a busy coordinator must not make us look lost. */
  if (err != VF_OK) {
    release_lease(w, l->lease_id, vf_error_detail(err));
  } else if (revoked) {
    note(w, "lease %016llx revoked by the coordinator; dropped", (unsigned long long)l->lease_id);
  } else if (!w->dropped) {
    /* What is rendered is shipped, also when stopping early (SIGTERM): then the rest of
     * the lease is handed back. */
    if (vf_iterset_count(&film->iterations) > 0) {
      if (w->stall_file && !w->stalled) { /* a hung worker (test): silent, heartbeat too */
        vf_heartbeat_clear_lease(w->heartbeat);
        stall(w);
      }
      ship(w, film);
    }
    if (!w->dropped && rendered < l->end) release_lease(w, l->lease_id, "");
    else if (!w->dropped)
      note(w, "job %llu [%llu,%llu): merged", (unsigned long long)l->job_id, (unsigned long long)l->begin,
               (unsigned long long)l->end);
  }
  vf_heartbeat_clear_lease(w->heartbeat);
  w->lease = NULL;
  vf_film_destroy(film);
  vf_film_accum_destroy(w->accum);
  w->accum = NULL;
}

/* Told to stop, with its lease shipped and handed back: the coordinator may forget us
 * (Goodbye, done). Once and briefly: a coordinator away will time us out instead. */
static void say_goodbye(worker *w) {
  Vcmfarm__Goodbye m = VCMFARM__GOODBYE__INIT;
  m.worker_id = w->worker_id;
  m.done = 1;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_GOODBYE;
  q.goodbye = &m;
  if (vf_farm_request(w->client, &q, VCMFARM__ENVELOPE__BODY_RESULT_ACK, 2000, &reply) == VF_OK) {
    note(w, "said goodbye to %s", w->url);
    vf_message_free(reply);
  }
}

static int serve(worker *w) {
  int err = register_worker(w);
  while (err == VF_OK && !*w->terminating) {
    Vcmfarm__LeaseRequest m = VCMFARM__LEASE_REQUEST__INIT;
    m.worker_id = w->worker_id;
    Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
    q.body_case = VCMFARM__ENVELOPE__BODY_LEASE_REQUEST;
    q.lease_request = &m;
    if ((err = vf_farm_call(w->client, &q, REQUEST_TIMEOUT_MS, &reply)) != VF_OK) {
      if (fatal(err)) break;
      log_line("%s; retrying", vf_error_detail(err));
      back_off(w);
      err = VF_OK;
      continue;
    }
    w->backoff_ms = 0;
    switch (reply->body_case) {
    case VCMFARM__ENVELOPE__BODY_LEASE: run_lease(w, reply->lease); break;
    case VCMFARM__ENVELOPE__BODY_IDLE: sleep_ms(w, (int)(reply->idle->retry_ms > 60000 ? 60000 : reply->idle->retry_ms)); break;
    case VCMFARM__ENVELOPE__BODY_ERROR:
      if (reply->error->code == VCMFARM__ERROR_CODE__ERROR_UNKNOWN_WORKER) {
        note(w, "the coordinator does not know us (restarted, or we were declared lost): registering again");
        err = register_worker(w);
      } else {
        log_line("coordinator: %s", reply->error->message);
        back_off(w);
      }
      break;
    default: log_line("unexpected %s reply to a lease request", vf_message_name(reply)); back_off(w);
    }
    vf_message_free(reply);
  }
  return err;
}


int vf_worker_run(const vf_worker_config *config, volatile sig_atomic_t *stop) {
  worker *w = calloc(1, sizeof *w);
  if (w == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  w->url = config->url;
  w->terminating = stop;
  w->quiet = config->quiet;
  w->threads = config->threads;
  w->cache_dir = config->cache_dir;
  w->cache_max_bytes = config->cache_max_bytes;
  w->ship_interval = config->ship_interval; /* 0: the coordinator's */
  w->iteration_delay_ms = config->iteration_delay_ms;
  w->stall_file = config->stall_file;
  w->abort_scene = config->abort_scene;
  w->tags = config->tags;
  w->no_auto_tags = config->no_auto_tags;
  if (config->name) {
    snprintf(w->name, sizeof w->name, "%s", config->name);
  } else {
    char host[64] = "host";
    gethostname(host, sizeof host - 1);
    snprintf(w->name, sizeof w->name, "%s/%d", host, (int)getpid());
  }
  int err = vf_farm_client_open(w->url, &config->key, &w->client);
  if (err == VF_OK && (err = vf_heartbeat_start(w->url, &config->key, stop, &w->heartbeat)) == VF_OK) {
    err = serve(w);
    if (err == VF_OK) note(w, "stopping");
    if (w->worker_id != 0 && *w->terminating) say_goodbye(w);
    vf_heartbeat_stop(w->heartbeat);
  }
  vf_farm_client_close(w->client);
  vf_renderer_destroy(w->renderer);
  free(w->allocation);
  vf_scene_destroy(w->scene);
  free(w);
  return err;
}
