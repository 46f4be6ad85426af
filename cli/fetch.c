#include "fetch.h"

#include "../common/atomic_file.h"
#include "../common/clock.h"
#include "../common/error.h"
#include "../coordinator/checkpoint.h"

#include <errno.h>
#include <sodium.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <sys/statvfs.h>
#include <time.h>
#include <unistd.h>

#define MAX_RESTARTS 3          /* snapshots dropped under one fetch before it gives up */
#define MAX_WAIT_SECONDS 600.0  /* for the coordinator to have the film ready */
#define MAX_RETRY_MS 1000u      /* the longest pause a coordinator may ask for */

/* One fetch as it goes: what was asked for next and what the snapshot announced. */
typedef struct {
  vf_farm_client *client;
  uint64_t job_id;
  int timeout_ms;
  uint32_t chunk_bytes;             /* FetchRequest.max_chunk_bytes */
  uint64_t snapshot, offset, total; /* offset: bytes received, in order */
  uint8_t hash[32];                 /* announced with the first chunk */
  crypto_generichash_state received;
} transfer;

/* VF_EPROTO: a reply that does not fit the fetch. */
static int out_of_place(const transfer *t, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static int out_of_place(const transfer *t, const char *fmt, ...) {
  char what[512];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(what, sizeof what, fmt, ap);
  va_end(ap);
  return vf_error_set(VF_EPROTO, "%s: the coordinator's fetch reply %s", vf_farm_client_url(t->client), what);
}

static void restart(transfer *t) {
  t->snapshot = t->offset = t->total = 0;
  crypto_generichash_init(&t->received, NULL, 0, sizeof t->hash);
}

static int ask(transfer *t, Vcmfarm__Envelope **reply) {
  Vcmfarm__FetchRequest m = VCMFARM__FETCH_REQUEST__INIT;
  m.job_id = t->job_id;
  m.snapshot = t->snapshot;
  m.offset = t->offset;
  m.max_chunk_bytes = t->chunk_bytes;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_FETCH;
  q.fetch = &m;
  return vf_farm_request(t->client, &q, VCMFARM__ENVELOPE__BODY_FILM, t->timeout_ms, reply);
}

/* Checks a chunk against the fetch: the snapshot and offset asked for, a size within the
 * chunk limit and the announced total, the same total and hash as the chunks before. */
static int check_chunk(transfer *t, const Vcmfarm__Film *f) {
  if (f->snapshot == 0 || (t->snapshot != 0 && f->snapshot != t->snapshot))
    return out_of_place(t, "is a chunk of snapshot %016llx, not of %016llx", (unsigned long long)f->snapshot,
                        (unsigned long long)t->snapshot);
  if (f->offset != t->offset)
    return out_of_place(t, "is a chunk at offset %llu, not at %llu", (unsigned long long)f->offset,
                        (unsigned long long)t->offset);
  if (f->hash.len != sizeof t->hash) return out_of_place(t, "has a hash of %zu bytes, not 32", f->hash.len);
  if (f->data.len == 0 || f->data.len > VF_FETCH_CHUNK_BYTES)
    return out_of_place(t, "is a chunk of %zu bytes (1 to %zu expected)", f->data.len, VF_FETCH_CHUNK_BYTES);
  if (t->offset == 0) {
    t->snapshot = f->snapshot;
    t->total = f->total_size;
    memcpy(t->hash, f->hash.data, sizeof t->hash);
  } else if (f->total_size != t->total || memcmp(f->hash.data, t->hash, sizeof t->hash) != 0) {
    return out_of_place(t, "at %llu announces another film (%llu bytes) than its first chunk (%llu bytes)",
                        (unsigned long long)t->offset, (unsigned long long)f->total_size,
                        (unsigned long long)t->total);
  }
  if (f->data.len > t->total - t->offset)
    return out_of_place(t, "is a chunk of %zu bytes at %llu, past the film's end at %llu", f->data.len,
                        (unsigned long long)t->offset, (unsigned long long)t->total);
  return VF_OK;
}

/* Before the first chunk is written: room for the whole on the output's file system. */
static int check_room(const vf_atomic_file *file, uint64_t total) {
  struct statvfs fs;
  if (fstatvfs(file->fd, &fs) != 0) return VF_OK; /* unknown: the writes will tell */
  uint64_t room = (uint64_t)fs.f_bavail * (uint64_t)fs.f_frsize;
  if (room < total)
    return vf_error_set(VF_EIO, "%s: the film is %.1f MB, its file system has %.1f MB free", file->path,
                        (double)total / 1e6, (double)room / 1e6);
  return VF_OK;
}

static void pause_ms(unsigned ms) {
  struct timespec ts = {ms / 1000u, (long)(ms % 1000u) * 1000000L};
  nanosleep(&ts, NULL); /* a signal ends it early: fine */
}

/* Receives the film into file, every chunk in order, until the last; then checks the
 * whole against the announced hash. */
static int receive(transfer *t, vf_atomic_file *file) {
  unsigned restarts = 0;
  double wait_until = vf_seconds_now() + MAX_WAIT_SECONDS;
  for (;;) {
    Vcmfarm__Envelope *reply;
    int err = ask(t, &reply);
    if (err != VF_OK) return err;
    const Vcmfarm__Film *f = reply->film;
    switch (f->state) {
    case VCMFARM__FILM__STATE__CHUNK:
      if ((err = check_chunk(t, f)) == VF_OK && t->offset == 0) err = check_room(file, t->total);
      if (err == VF_OK) err = vf_atomic_pwrite(file, f->data.data, f->data.len, t->offset);
      if (err == VF_OK) {
        crypto_generichash_update(&t->received, f->data.data, f->data.len);
        t->offset += f->data.len;
      }
      break;
    case VCMFARM__FILM__STATE__WAIT:
      if (t->offset != 0) err = out_of_place(t, "says to wait after %llu bytes", (unsigned long long)t->offset);
      else if (t->snapshot != 0 && f->snapshot != t->snapshot)
        err = out_of_place(t, "says to wait for snapshot %016llx, not for %016llx", (unsigned long long)f->snapshot,
                           (unsigned long long)t->snapshot);
      else if (vf_seconds_now() > wait_until)
        err = vf_error_set(VF_ETIMEDOUT, "%s: the coordinator did not have the film ready within %.0f s",
                           vf_farm_client_url(t->client), MAX_WAIT_SECONDS);
      else {
        t->snapshot = f->snapshot; /* 0: another fetch is in the way; start again */
        pause_ms(f->retry_ms == 0 ? 1u : f->retry_ms < MAX_RETRY_MS ? f->retry_ms : MAX_RETRY_MS);
      }
      break;
    case VCMFARM__FILM__STATE__GONE:
      if (++restarts > MAX_RESTARTS) {
        err = vf_error_set(VF_EREFUSED, "%s: the coordinator dropped the film under the fetch %u times: %.300s",
                           vf_farm_client_url(t->client), restarts, f->message);
      } else if (ftruncate(file->fd, 0) != 0) {
        err = vf_error_set(VF_EIO, "%s: %s", file->tmp_path, strerror(errno));
      } else {
        restart(t);
        wait_until = vf_seconds_now() + MAX_WAIT_SECONDS;
      }
      break;
    default: err = out_of_place(t, "is in an unknown state %d", (int)f->state);
    }
    vf_message_free(reply);
    if (err != VF_OK) return err;
    if (t->total != 0 && t->offset == t->total) break;
  }
  uint8_t hash[32];
  crypto_generichash_final(&t->received, hash, sizeof hash);
  if (sodium_memcmp(hash, t->hash, sizeof hash) != 0) {
    char got[65], announced[65];
    sodium_bin2hex(got, sizeof got, hash, sizeof hash);
    sodium_bin2hex(announced, sizeof announced, t->hash, sizeof t->hash);
    return vf_error_set(VF_EMISMATCH, "%s: the film's %llu bytes as received hash to %.16s..., not to the %.16s... "
                        "the coordinator announced", vf_farm_client_url(t->client), (unsigned long long)t->total,
                        got, announced);
  }
  return VF_OK;
}

int vf_fetch_film(vf_farm_client *client, uint64_t job_id, const char *output, int timeout_ms, size_t chunk_bytes,
                  vf_film **film) {
  if (sodium_init() < 0) return vf_error_set(VF_EINVAL, "libsodium failed to initialise");
  vf_atomic_file file;
  int err = vf_atomic_open(&file, output);
  if (err != VF_OK) return err;
  transfer t = {.client = client, .job_id = job_id, .timeout_ms = timeout_ms,
                .chunk_bytes = chunk_bytes > UINT32_MAX ? UINT32_MAX : (uint32_t)chunk_bytes};
  restart(&t);
  vf_film *read_back = NULL;
  if ((err = receive(&t, &file)) == VF_OK && film != NULL && (err = vf_film_read(file.tmp_path, &read_back)) != VF_OK)
    err = vf_error_set(err, "the fetched film: %s", vf_error_detail(err));
  if (err != VF_OK) {
    vf_atomic_abort(&file);
    return vf_error_set(err, "%s (job %llu: %llu of %llu bytes received; %s left as it was)", vf_error_detail(err),
                        (unsigned long long)job_id, (unsigned long long)t.offset, (unsigned long long)t.total, output);
  }
  if ((err = vf_atomic_commit(&file)) != VF_OK) {
    vf_film_destroy(read_back);
    return err;
  }
  if (film != NULL) *film = read_back;
  return VF_OK;
}
