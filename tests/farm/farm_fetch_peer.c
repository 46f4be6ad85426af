/* Helper of test_farm.sh's bad_fetches case (not a test by itself): fetches in chunks
 * (docs/PROTOCOL.md, "Fetching a film") from both ends.
 *
 *   farm_fetch_peer URL KEYFILE JOB
 *
 * A confused client of the coordinator at URL, whose job JOB has had nothing merged (no
 * worker): asks for an unknown job, a start at an offset, an unknown snapshot, an offset
 * past the end; checks that two fetches started together share one snapshot, that its
 * chunks hash to what they announce, that it is gone once both read it whole, and that
 * one nobody asks for is dropped after VF_SNAPSHOT_IDLE_SECONDS. Exit status 0 when every
 * expectation held.
 *
 *   farm_fetch_peer --chunks URL KEYFILE JOB
 *
 * The size of chunks (FetchRequest.max_chunk_bytes), on a job whose film is several times
 * VF_FETCH_CHUNK_BYTES: the first chunk of one snapshot asked for with no limit, 1 MiB, 1
 * byte and 1 GiB is 16 MiB, 1 MiB, 64 KiB (the least) and 16 MiB long, and a chunk at
 * 1 MiB follows on. Nothing more is read; the snapshot is left to expire.
 *
 *   farm_fetch_peer --serve URL KEYFILE MODE FILM
 *
 * A coordinator that answers every FetchRequest with the bytes of FILM in chunks of
 * 16 KiB, spoiled as MODE says: good (not at all), wait (twice "wait" first), gone_once
 * (one "gone" first), stop (no reply after the first chunk), hash (a wrong hash), flip
 * (one byte of the second chunk altered), size (the second chunk announces another size),
 * offset (the second chunk at another offset), past (a last chunk past the announced
 * end), snapshot (the second chunk from another snapshot), gone (always "gone"), notfilm
 * (the first 1000 bytes as the whole, hashed right). Serves until no request came for
 * 10 s. */
#include "common/error.h"
#include "common/farm_client.h"
#include "common/file.h"
#include "common/message.h"
#include "coordinator/checkpoint.h"

#include <nanomsg/nn.h>
#include <nanomsg/reqrep.h>
#include <sodium.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static int failures;

static void expect(int cond, const char *what) {
  printf("%s %s\n", cond ? "ok  " : "FAIL", what);
  if (!cond) failures++;
}

/* The reply to FetchRequest {job, snapshot, offset, max_chunk_bytes}, or NULL when none came. */
static Vcmfarm__Envelope *fetch_at_most(vf_farm_client *c, uint64_t job, uint64_t snapshot, uint64_t offset,
                                        uint32_t most) {
  Vcmfarm__FetchRequest m = VCMFARM__FETCH_REQUEST__INIT;
  m.job_id = job;
  m.snapshot = snapshot;
  m.offset = offset;
  m.max_chunk_bytes = most;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_FETCH;
  q.fetch = &m;
  return vf_farm_call(c, &q, 10000, &reply) == VF_OK ? reply : NULL;
}

static Vcmfarm__Envelope *fetch(vf_farm_client *c, uint64_t job, uint64_t snapshot, uint64_t offset) {
  return fetch_at_most(c, job, snapshot, offset, 0);
}

static int is_error(const Vcmfarm__Envelope *r, Vcmfarm__ErrorCode code, const char *needle) {
  if (r && r->body_case == VCMFARM__ENVELOPE__BODY_ERROR) printf("     %s\n", r->error->message);
  return r && r->body_case == VCMFARM__ENVELOPE__BODY_ERROR && r->error->code == code &&
         strstr(r->error->message, needle) != NULL;
}

static int is_film(const Vcmfarm__Envelope *r, Vcmfarm__Film__State state) {
  if (r && r->body_case == VCMFARM__ENVELOPE__BODY_FILM && r->film->message[0]) printf("     %s\n", r->film->message);
  return r && r->body_case == VCMFARM__ENVELOPE__BODY_FILM && r->film->state == state;
}

/* Asks for snapshot id at offset (chunks of at most `most` bytes) until it is no longer
 * "wait"; the last reply. */
static Vcmfarm__Envelope *await_at_most(vf_farm_client *c, uint64_t job, uint64_t id, uint64_t offset, uint32_t most) {
  for (int i = 0; i < 2000; i++) {
    Vcmfarm__Envelope *r = fetch_at_most(c, job, id, offset, most);
    if (!is_film(r, VCMFARM__FILM__STATE__WAIT)) return r;
    vf_message_free(r);
    usleep(10000);
  }
  return NULL;
}

static Vcmfarm__Envelope *await(vf_farm_client *c, uint64_t job, uint64_t id, uint64_t offset) {
  return await_at_most(c, job, id, offset, 0);
}

/* The length of the chunk at offset of snapshot id, asked for with max_chunk_bytes most;
 * 0 when the reply is not a chunk there. */
static size_t chunk_length(vf_farm_client *c, uint64_t job, uint64_t id, uint64_t offset, uint32_t most) {
  Vcmfarm__Envelope *r = await_at_most(c, job, id, offset, most);
  size_t len = is_film(r, VCMFARM__FILM__STATE__CHUNK) && r->film->snapshot == id && r->film->offset == offset
                   ? r->film->data.len
                   : 0;
  vf_message_free(r);
  return len;
}

static int chunks(const char *url, const vf_wire_key *key, uint64_t job) {
  vf_farm_client *c;
  if (vf_farm_client_open(url, key, &c) != VF_OK) return 2;
  Vcmfarm__Envelope *r = fetch(c, job, 0, 0);
  uint64_t id = r && r->body_case == VCMFARM__ENVELOPE__BODY_FILM ? r->film->snapshot : 0;
  uint64_t total = r && r->body_case == VCMFARM__ENVELOPE__BODY_FILM ? r->film->total_size : 0;
  vf_message_free(r);
  if (id != 0 && total == 0) { /* waited: the size comes with the first chunk */
    r = await(c, job, id, 0);
    total = is_film(r, VCMFARM__FILM__STATE__CHUNK) ? r->film->total_size : 0;
    vf_message_free(r);
  }
  printf("     snapshot %016llx of %llu bytes\n", (unsigned long long)id, (unsigned long long)total);
  expect(id != 0 && total > 3 * VF_FETCH_CHUNK_BYTES, "the job's film is several chunks long");
  expect(chunk_length(c, job, id, 0, 0) == VF_FETCH_CHUNK_BYTES, "no limit asked for: chunks of 16 MiB");
  expect(chunk_length(c, job, id, 0, 1u << 20) == 1u << 20, "1 MiB asked for: chunks of 1 MiB");
  expect(chunk_length(c, job, id, 1u << 20, 1u << 20) == 1u << 20, "the next chunk of 1 MiB follows on");
  expect(chunk_length(c, job, id, 0, 1) == VF_FETCH_CHUNK_MIN, "1 byte asked for: chunks of 64 KiB, the least");
  expect(chunk_length(c, job, id, 0, 1u << 30) == VF_FETCH_CHUNK_BYTES, "1 GiB asked for: chunks of 16 MiB");
  vf_farm_client_close(c);
  return failures ? 1 : 0;
}

static int client(const char *url, const vf_wire_key *key, uint64_t job) {
  vf_farm_client *c;
  if (vf_farm_client_open(url, key, &c) != VF_OK) return 2;
  Vcmfarm__Envelope *r = fetch(c, job + 1000, 0, 0);
  expect(is_error(r, VCMFARM__ERROR_CODE__ERROR_UNKNOWN_JOB, "no job"), "a fetch of an unknown job is refused");
  vf_message_free(r);
  r = fetch(c, job, 0, 5);
  expect(is_error(r, VCMFARM__ERROR_CODE__ERROR_BAD_REQUEST, "starts at offset 0"),
         "a fetch starting at another offset than 0 is refused");
  vf_message_free(r);
  r = fetch(c, job, 0x1234, 0);
  expect(is_film(r, VCMFARM__FILM__STATE__GONE) && strstr(r->film->message, "start again"),
         "a chunk of an unknown snapshot is \"gone\": start again");
  vf_message_free(r);

  /* The film was never written: a fetch waits for the checkpoint of its snapshot (always,
   * since the write lands on the loop after this reply). */
  Vcmfarm__Envelope *a = fetch(c, job, 0, 0);
  uint64_t id = a && a->body_case == VCMFARM__ENVELOPE__BODY_FILM ? a->film->snapshot : 0;
  expect(is_film(a, VCMFARM__FILM__STATE__WAIT) && id != 0 && a->film->retry_ms > 0,
         "a new fetch waits for its snapshot's checkpoint, knowing the snapshot's id");
  vf_message_free(a);
  r = await(c, job, id, (uint64_t)1 << 40);
  expect(is_error(r, VCMFARM__ERROR_CODE__ERROR_BAD_REQUEST, "past the end"), "a chunk past the film's end is refused");
  vf_message_free(r);

  /* A second fetch of the unchanged film joins the snapshot, which is then read whole, in
   * order: the chunks agree and hash to what they announce. */
  crypto_generichash_state state;
  crypto_generichash_init(&state, NULL, 0, 32);
  uint64_t offset = 0, total = 0, chunks = 0, last = 0;
  uint8_t announced[32] = {0}, hash[32];
  int consistent = 1;
  do {
    r = chunks == 0 ? fetch(c, job, 0, 0) : await(c, job, id, offset);
    if (chunks == 0) expect(is_film(r, VCMFARM__FILM__STATE__CHUNK) && r->film->snapshot == id,
                            "a second fetch of an unchanged film joins the first one's snapshot");
    if (!is_film(r, VCMFARM__FILM__STATE__CHUNK) || r->film->hash.len != 32 || r->film->offset != offset ||
        r->film->data.len == 0 || r->film->data.len > VF_FETCH_CHUNK_BYTES ||
        (chunks > 0 && (r->film->total_size != total || memcmp(announced, r->film->hash.data, 32) != 0))) {
      consistent = 0;
      vf_message_free(r);
      break;
    }
    total = r->film->total_size;
    memcpy(announced, r->film->hash.data, 32);
    crypto_generichash_update(&state, r->film->data.data, r->film->data.len);
    last = offset;
    offset += r->film->data.len;
    chunks++;
    vf_message_free(r);
  } while (offset < total);
  crypto_generichash_final(&state, hash, sizeof hash);
  printf("     the empty film: %llu bytes in %llu chunk(s)\n", (unsigned long long)total, (unsigned long long)chunks);
  expect(consistent && offset == total && total > 0, "the snapshot's chunks follow each other to its end");
  expect(consistent && memcmp(hash, announced, 32) == 0, "its bytes hash to the hash every chunk announces");
  r = fetch(c, job, id, last);
  expect(is_film(r, VCMFARM__FILM__STATE__CHUNK), "the snapshot stays for the first fetch, which began with it");
  vf_message_free(r);
  r = fetch(c, job, id, 0);
  expect(is_film(r, VCMFARM__FILM__STATE__GONE), "a snapshot read whole by both fetches is dropped");
  vf_message_free(r);

  /* Begun, never read: dropped once nobody asked for it for long enough. The film has not
   * changed, so the snapshot is the checkpoint on disk, hashed. */
  r = fetch(c, job, 0, 0);
  uint64_t unread = r && r->body_case == VCMFARM__ENVELOPE__BODY_FILM ? r->film->snapshot : 0;
  expect(is_film(r, VCMFARM__FILM__STATE__WAIT) && unread != 0 && unread != id,
         "the next fetch has a new snapshot, hashed from the checkpoint on disk");
  vf_message_free(r);
  sleep((unsigned)VF_SNAPSHOT_IDLE_SECONDS + 2);
  r = fetch(c, job, unread, 0);
  expect(is_film(r, VCMFARM__FILM__STATE__GONE), "a snapshot nobody asks for is dropped");
  vf_message_free(r);
  vf_farm_client_close(c);
  return failures ? 1 : 0;
}

/* ---- --serve: a coordinator whose chunks lie ---- */

#define SERVE_CHUNK 16384

typedef enum { GOOD, WAIT, GONE_ONCE, STOP, HASH, FLIP, SIZE, OFFSET, PAST, SNAPSHOT, GONE, NOTFILM } mode;

static const char *const mode_names[] = {"good", "wait", "gone_once", "stop", "hash", "flip",
                                         "size", "offset", "past", "snapshot", "gone", "notfilm"};

/* The reply to request number `k` (from 0) for offset of a film of len bytes. */
static void spoil(mode how, unsigned k, uint64_t offset, uint8_t *film, size_t len, Vcmfarm__Film *f, uint8_t *hash) {
  size_t total = how == NOTFILM ? 1000 : how == PAST ? len - 10 : len;
  crypto_generichash(hash, 32, film, total, NULL, 0);
  f->snapshot = 77;
  if ((how == WAIT && k < 2) || (how == GONE_ONCE && k == 0) || how == GONE) {
    f->state = how == WAIT ? VCMFARM__FILM__STATE__WAIT : VCMFARM__FILM__STATE__GONE;
    f->retry_ms = 20;
    f->message = "dropped by the lying coordinator";
    return;
  }
  size_t at = offset < total ? (size_t)offset : total, n = total - at < SERVE_CHUNK ? total - at : SERVE_CHUNK;
  int second = offset == SERVE_CHUNK;
  if (how == PAST && at + n == total) n += 10;
  f->state = VCMFARM__FILM__STATE__CHUNK;
  f->offset = how == OFFSET && second ? offset + 1 : offset;
  f->data = (ProtobufCBinaryData){n, film + at};
  f->total_size = how == SIZE && second ? total + 1 : total;
  f->hash = (ProtobufCBinaryData){32, hash};
  if (how == HASH) hash[5] ^= 1;
  if (how == FLIP && second) film[at + 100] ^= 1; /* restored by the caller */
  if (how == SNAPSHOT && second) f->snapshot = 78;
}

static int serve(const char *url, const vf_wire_key *key, const char *mode_name, const char *path) {
  mode how = GOOD;
  while ((size_t)how < sizeof mode_names / sizeof *mode_names && strcmp(mode_names[how], mode_name) != 0) how++;
  uint8_t *film;
  size_t len;
  if ((size_t)how == sizeof mode_names / sizeof *mode_names || vf_file_read_all(path, (size_t)1 << 30, &film, &len) != VF_OK ||
      len < 3 * SERVE_CHUNK) {
    fprintf(stderr, "farm_fetch_peer: unknown mode '%s', or %s is not a film of at least 3 chunks\n", mode_name, path);
    return 2;
  }
  int sock = nn_socket(AF_SP, NN_REP), timeout = 10000;
  nn_setsockopt(sock, NN_SOL_SOCKET, NN_RCVTIMEO, &timeout, sizeof timeout);
  if (sock < 0 || nn_bind(sock, url) < 0) {
    fprintf(stderr, "farm_fetch_peer: cannot bind %s: %s\n", url, nn_strerror(nn_errno()));
    return 2;
  }
  for (unsigned k = 0;; k++) {
    void *frame = NULL;
    int n = nn_recv(sock, &frame, NN_MSG, 0);
    if (n < 0) break; /* no request for 10 s */
    Vcmfarm__Envelope *q = NULL;
    vf_wire_stamp stamp;
    int err = vf_message_unpack(key, NULL, frame, (size_t)n, &q, &stamp);
    nn_freemsg(frame);
    if (err != VF_OK || q->body_case != VCMFARM__ENVELOPE__BODY_FETCH) {
      fprintf(stderr, "farm_fetch_peer: expected only fetch requests\n");
      vf_message_free(q);
      return 1;
    }
    if (how == STOP && k == 1) { /* the client waits for a reply that never comes */
      vf_message_free(q);
      continue;
    }
    Vcmfarm__Envelope r = VCMFARM__ENVELOPE__INIT;
    Vcmfarm__Film f = VCMFARM__FILM__INIT;
    uint8_t hash[32];
    spoil(how, k, q->fetch->offset, film, len, &f, hash);
    r.body_case = VCMFARM__ENVELOPE__BODY_FILM;
    r.film = &f;
    uint8_t *out;
    size_t out_len;
    if (vf_message_pack(key, &stamp, &r, &out, &out_len, NULL) == VF_OK) {
      nn_send(sock, out, out_len, 0);
      free(out);
    }
    if (how == FLIP && q->fetch->offset == SERVE_CHUNK) film[SERVE_CHUNK + 100] ^= 1;
    vf_message_free(q);
  }
  nn_close(sock);
  free(film);
  return 0;
}

int main(int argc, char **argv) {
  vf_wire_key key;
  int serving = argc == 6 && strcmp(argv[1], "--serve") == 0;
  int sizing = argc == 5 && strcmp(argv[1], "--chunks") == 0;
  char **a = argv + sizing; /* URL KEYFILE JOB */
  unsigned long long job = 0;
  if ((!serving && (argc != 4 + sizing || sscanf(a[3], "%llu", &job) != 1)) || sodium_init() < 0 ||
      vf_wire_key_load(argv[serving ? 3 : 2 + sizing], &key) != VF_OK) {
    fprintf(stderr, "usage: farm_fetch_peer URL KEYFILE JOB | farm_fetch_peer --chunks URL KEYFILE JOB | "
                    "farm_fetch_peer --serve URL KEYFILE MODE FILM\n");
    return 2;
  }
  if (serving) return serve(argv[2], &key, argv[4], argv[5]);
  return sizing ? chunks(a[1], &key, job) : client(a[1], &key, job);
}
