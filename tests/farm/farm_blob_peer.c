/* Helper of test_farm.sh's bad_blobs case (not a test by itself): a hostile or confused
 * peer of the blob messages (docs/PROTOCOL.md, "Files of scenes").
 *
 *   farm_blob_peer URL KEYFILE
 *
 * Run against a coordinator without jobs. Sends a blob whose bytes do not match its hash,
 * one with a malformed hash, transfers in chunks whose whole does not match, out of order,
 * past the size, above 4 GiB or with a chunk above 4 MiB, then jobs whose file tables name a blob the coordinator does
 * not have, a wrong size, a name with a control character, two equal names, or files for
 * a built-in scene; asks for blobs as an unknown worker and for one nobody sent. Checks
 * each is refused with a message naming the problem, that a good blob is stored, queried
 * and served back intact, and that no job was created.
 *
 *   farm_blob_peer --serve URL KEYFILE CACHE
 *
 * A lying coordinator for one worker (whose cache is CACHE): it leases a job whose scene
 * names one file and answers the worker's request for it with other bytes of the same
 * size. Checks that the worker fails the lease naming the file and the hash mismatch, and
 * kept nothing in its cache.
 *
 * Exit status 0 when every expectation held. */
#include "common/blob.h"
#include "common/error.h"
#include "common/farm_client.h"
#include "common/message.h"
#include "common/settings.h"

#include <nanomsg/nn.h>
#include <nanomsg/reqrep.h>
#include <sodium.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int failures;

static void expect(int cond, const char *what) {
  printf("%s %s\n", cond ? "ok  " : "FAIL", what);
  if (!cond) failures++;
}

/* Sends q; 1 when the reply is an Error of `code` whose message contains `needle`. */
static int refused(vf_farm_client *c, Vcmfarm__Envelope *q, Vcmfarm__ErrorCode code, const char *needle) {
  Vcmfarm__Envelope *reply;
  if (vf_farm_call(c, q, 10000, &reply) != VF_OK) return 0;
  int ok = reply->body_case == VCMFARM__ENVELOPE__BODY_ERROR && reply->error->code == code &&
           strstr(reply->error->message, needle) != NULL;
  printf("     %s\n", reply->body_case == VCMFARM__ENVELOPE__BODY_ERROR ? reply->error->message : vf_message_name(reply));
  vf_message_free(reply);
  return ok;
}

/* One chunk [offset, offset + len) of a blob of `total` bytes in transfer `transfer`; with
 * a needle, 1 when refused with it, else 1 when accepted. */
static int put_chunk(vf_farm_client *c, const uint8_t *hash, size_t hash_len, uint64_t transfer, uint64_t offset,
                     uint64_t total, const void *data, size_t len, const char *needle) {
  Vcmfarm__BlobPut m = VCMFARM__BLOB_PUT__INIT;
  m.hash = (ProtobufCBinaryData){hash_len, (uint8_t *)hash};
  m.data = (ProtobufCBinaryData){len, (uint8_t *)data};
  m.offset = offset;
  m.total_size = total;
  m.transfer_id = transfer;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_BLOB_PUT;
  q.blob_put = &m;
  if (needle) return refused(c, &q, VCMFARM__ERROR_CODE__ERROR_BAD_REQUEST, needle);
  if (vf_farm_request(c, &q, VCMFARM__ENVELOPE__BODY_RESULT_ACK, 10000, &reply) != VF_OK) return 0;
  int ok = reply->result_ack->accepted;
  printf("     %s\n", reply->result_ack->message);
  vf_message_free(reply);
  return ok;
}

/* A whole blob in one chunk. */
static int put(vf_farm_client *c, const uint8_t *hash, size_t hash_len, const void *data, size_t len,
               const char *needle) {
  return put_chunk(c, hash, hash_len, 1, 0, len, data, len, needle);
}

/* A JSON job (the coordinator does not parse the text) with one file entry. */
static int submit_refused(vf_farm_client *c, int builtin, const char *name, const uint8_t *hash, uint64_t size,
                          int twice, const char *needle) {
  vf_settings s;
  char settings[512];
  uint8_t scene_hash[32] = {7};
  vf_settings_default(&s);
  s.width = s.height = 16;
  vf_settings_format(&s, settings, sizeof settings);
  Vcmfarm__BlobRef ref = VCMFARM__BLOB_REF__INIT, *refs[2] = {&ref, &ref};
  ref.name = (char *)name;
  ref.hash = (ProtobufCBinaryData){32, (uint8_t *)hash};
  ref.size = size;
  Vcmfarm__Scene scene = VCMFARM__SCENE__INIT;
  scene.source_case = builtin ? VCMFARM__SCENE__SOURCE_BUILTIN : VCMFARM__SCENE__SOURCE_JSON;
  if (builtin) scene.builtin = "cornell";
  else scene.json = "{\"shapes\": [{\"type\": \"mesh\", \"file\": \"m.ply\"}]}";
  scene.n_files = twice ? 2 : 1;
  scene.files = refs;
  Vcmfarm__SubmitJob m = VCMFARM__SUBMIT_JOB__INIT;
  m.name = "hostile";
  m.scene = &scene;
  m.scene_hash = (ProtobufCBinaryData){32, scene_hash};
  m.settings = settings;
  m.iterations = 4;
  m.priority = 1;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_SUBMIT;
  q.submit = &m;
  return refused(c, &q, VCMFARM__ERROR_CODE__ERROR_BAD_REQUEST, needle);
}

static Vcmfarm__Envelope *blob_request(vf_farm_client *c, uint64_t worker_id, const uint8_t *hash, uint64_t offset) {
  Vcmfarm__BlobRequest m = VCMFARM__BLOB_REQUEST__INIT;
  m.worker_id = worker_id;
  m.offset = offset;
  m.hash = (ProtobufCBinaryData){32, (uint8_t *)hash};
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_BLOB_REQUEST;
  q.blob_request = &m;
  return vf_farm_call(c, &q, 10000, &reply) == VF_OK ? reply : NULL;
}

/* ---- --serve: a coordinator that sends a worker the wrong bytes ---- */

static int serve(const char *url, const vf_wire_key *key, const char *cache) {
  static const char mesh[] = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                             "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                             "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  char lie[sizeof mesh], settings[512];
  uint8_t hash[32], scene_hash[32] = {0};
  memcpy(lie, mesh, sizeof mesh);
  lie[sizeof mesh - 3] = '1'; /* "3 0 1 1": same size, other bytes */
  vf_blob_hash(mesh, sizeof mesh, hash);
  vf_settings s;
  vf_settings_default(&s);
  s.width = s.height = 16;
  vf_settings_format(&s, settings, sizeof settings);
  int sock = nn_socket(AF_SP, NN_REP), timeout = 30000;
  nn_setsockopt(sock, NN_SOL_SOCKET, NN_RCVTIMEO, &timeout, sizeof timeout);
  if (sock < 0 || nn_bind(sock, url) < 0) {
    fprintf(stderr, "farm_blob_peer: cannot bind %s: %s\n", url, nn_strerror(nn_errno()));
    return 2;
  }
  int leased = 0, released = 0, served = 0;
  while (!released) {
    void *frame = NULL;
    int n = nn_recv(sock, &frame, NN_MSG, 0);
    if (n < 0) break; /* no request for 30 s */
    Vcmfarm__Envelope *q = NULL;
    vf_wire_stamp stamp;
    int err = vf_message_unpack(key, NULL, frame, (size_t)n, &q, &stamp);
    nn_freemsg(frame);
    if (err != VF_OK) break;
    Vcmfarm__Envelope r = VCMFARM__ENVELOPE__INIT;
    Vcmfarm__Registered registered = VCMFARM__REGISTERED__INIT;
    Vcmfarm__Lease lease = VCMFARM__LEASE__INIT;
    Vcmfarm__Scene scene = VCMFARM__SCENE__INIT;
    Vcmfarm__BlobRef ref = VCMFARM__BLOB_REF__INIT, *refs[1] = {&ref};
    Vcmfarm__Idle idle = VCMFARM__IDLE__INIT;
    Vcmfarm__Blob blob = VCMFARM__BLOB__INIT;
    Vcmfarm__HeartbeatAck hb = VCMFARM__HEARTBEAT_ACK__INIT;
    Vcmfarm__ResultAck ack = VCMFARM__RESULT_ACK__INIT;
    switch (q->body_case) {
    case VCMFARM__ENVELOPE__BODY_REGISTER:
      registered.worker_id = 1;
      registered.heartbeat_ms = 1000;
      registered.timeout_ms = 15000;
      r.body_case = VCMFARM__ENVELOPE__BODY_REGISTERED;
      r.registered = &registered;
      break;
    case VCMFARM__ENVELOPE__BODY_LEASE_REQUEST:
      if (leased++) {
        idle.retry_ms = 100;
        r.body_case = VCMFARM__ENVELOPE__BODY_IDLE;
        r.idle = &idle;
        break;
      }
      ref.name = "m.ply";
      ref.hash = (ProtobufCBinaryData){32, hash};
      ref.size = sizeof mesh;
      scene.source_case = VCMFARM__SCENE__SOURCE_JSON;
      scene.json = "{\"camera\": {\"position\": [0, 0, 5], \"target\": [0, 0, 0], \"fov\": 40},"
                   " \"materials\": {\"w\": {\"diffuse\": [0.5, 0.5, 0.5]}},"
                   " \"shapes\": [{\"type\": \"mesh\", \"file\": \"m.ply\", \"material\": \"w\", \"emission\": [1, 1, 1]}]}";
      scene.n_files = 1;
      scene.files = refs;
      lease.lease_id = 9;
      lease.job_id = 1;
      lease.scene = &scene;
      lease.scene_hash = (ProtobufCBinaryData){32, scene_hash};
      lease.settings = settings;
      lease.begin = 0;
      lease.end = 1;
      r.body_case = VCMFARM__ENVELOPE__BODY_LEASE;
      r.lease = &lease;
      break;
    case VCMFARM__ENVELOPE__BODY_BLOB_REQUEST:
      served++;
      blob.hash = q->blob_request->hash;
      blob.data = (ProtobufCBinaryData){sizeof lie, (uint8_t *)lie};
      blob.total_size = sizeof lie;
      r.body_case = VCMFARM__ENVELOPE__BODY_BLOB;
      r.blob = &blob;
      break;
    case VCMFARM__ENVELOPE__BODY_HEARTBEAT:
      hb.lease_valid = 1;
      r.body_case = VCMFARM__ENVELOPE__BODY_HEARTBEAT_ACK;
      r.heartbeat_ack = &hb;
      break;
    case VCMFARM__ENVELOPE__BODY_RELEASE:
      printf("     the worker released lease %016llx: %s\n", (unsigned long long)q->release->lease_id,
             q->release->failure);
      expect(q->release->lease_id == 9 && strstr(q->release->failure, "file 'm.ply'") &&
                 strstr(q->release->failure, "not to its name"),
             "a worker sent bytes that do not match the blob's hash fails the lease, naming the file");
      released = 1;
      ack.accepted = 1;
      ack.message = "released";
      r.body_case = VCMFARM__ENVELOPE__BODY_RESULT_ACK;
      r.result_ack = &ack;
      break;
    default:
      expect(0, "the worker sends only register, lease, blob, heartbeat and release requests");
      released = 1;
    }
    uint8_t *out;
    size_t out_len;
    if (r.body_case != VCMFARM__ENVELOPE__BODY__NOT_SET && vf_message_pack(key, &stamp, &r, &out, &out_len, NULL) == VF_OK) {
      nn_send(sock, out, out_len, 0);
      free(out);
    }
    vf_message_free(q);
  }
  expect(served == 1, "the worker asked for the blob once");
  expect(released, "the worker released its lease");
  expect(!vf_blob_store_has(cache, hash, NULL), "the wrong bytes were not kept in the worker's cache");
  nn_close(sock);
  return failures ? 1 : 0;
}

int main(int argc, char **argv) {
  if (argc == 5 && strcmp(argv[1], "--serve") == 0) {
    vf_wire_key key;
    if (sodium_init() < 0 || vf_wire_key_load(argv[3], &key) != VF_OK) return 2;
    return serve(argv[2], &key, argv[4]);
  }
  if (argc != 3) {
    fprintf(stderr, "usage: farm_blob_peer URL KEYFILE | farm_blob_peer --serve URL KEYFILE CACHE\n");
    return 2;
  }
  vf_wire_key key;
  vf_farm_client *c;
  if (sodium_init() < 0 || vf_wire_key_load(argv[2], &key) != VF_OK || vf_farm_client_open(argv[1], &key, &c) != VF_OK) {
    fprintf(stderr, "farm_blob_peer: %s\n", vf_error_detail(VF_EINVAL));
    return 2;
  }
  static const char mesh[] = "ply\nformat ascii 1.0\nelement vertex 0\nend_header\n";
  uint8_t good[32], unknown[32];
  vf_blob_hash(mesh, sizeof mesh, good);
  randombytes_buf(unknown, sizeof unknown);

  expect(put(c, unknown, 32, mesh, sizeof mesh, "not to its name"), "a blob whose bytes do not match its hash is refused");
  expect(put(c, good, 31, mesh, sizeof mesh, "31 bytes"), "a blob with a 31-byte hash is refused");
  /* Transfers in chunks (version 4). */
  size_t half = sizeof mesh / 2;
  expect(put_chunk(c, unknown, 32, 7, 0, sizeof mesh, mesh, half, NULL) &&
             put_chunk(c, unknown, 32, 7, half, sizeof mesh, mesh + half, sizeof mesh - half, "not to its name"),
         "chunks whose whole does not match the hash are refused with the last one");
  expect(put_chunk(c, good, 32, 8, 0, sizeof mesh, mesh, half, NULL) &&
             put_chunk(c, good, 32, 8, half + 1, sizeof mesh, mesh + half + 1, 3, "the transfer holds"),
         "a chunk out of order is refused");
  expect(put_chunk(c, good, 32, 9, 0, 10, mesh, 20, "pass its"), "a chunk past the blob's size is refused");
  expect(put_chunk(c, good, 32, 9, 0, (uint64_t)5 << 30, mesh, 20, "at most"), "a blob above 4 GiB is refused");
  uint8_t *huge = calloc(1, VF_BLOB_CHUNK_BYTES + 1);
  expect(huge && put_chunk(c, good, 32, 9, 0, VF_BLOB_CHUNK_BYTES + 1, huge, VF_BLOB_CHUNK_BYTES + 1, "a chunk of"),
         "a chunk above 4 MiB is refused");
  free(huge);
  expect(put_chunk(c, good, 32, 8, half, sizeof mesh, mesh + half, sizeof mesh - half, NULL),
         "a good blob sent in two chunks is stored (its transfer went on after the refused chunk)");

  ProtobufCBinaryData asked[2] = {{32, good}, {32, unknown}};
  Vcmfarm__BlobQuery bq = VCMFARM__BLOB_QUERY__INIT;
  bq.n_hashes = 2;
  bq.hashes = asked;
  Vcmfarm__Envelope q = VCMFARM__ENVELOPE__INIT, *reply;
  q.body_case = VCMFARM__ENVELOPE__BODY_BLOB_QUERY;
  q.blob_query = &bq;
  int ok = vf_farm_request(c, &q, VCMFARM__ENVELOPE__BODY_BLOB_HAVE, 10000, &reply) == VF_OK;
  expect(ok && reply->blob_have->n_missing == 1 && memcmp(reply->blob_have->missing[0].data, unknown, 32) == 0,
         "a query lists exactly the blob the coordinator lacks");
  if (ok) vf_message_free(reply);

  expect(submit_refused(c, 0, "m.ply", unknown, sizeof mesh, 0, "has no blob"),
         "a job naming a blob the coordinator does not have is refused");
  expect(submit_refused(c, 0, "m.ply", good, sizeof mesh + 1, 0, "bytes, the blob"),
         "a job giving a file another size than its blob's is refused");
  expect(submit_refused(c, 0, "m\n.ply", good, sizeof mesh, 0, "control character"),
         "a job naming a file with a control character is refused");
  expect(submit_refused(c, 0, "m.ply", good, sizeof mesh, 1, "named twice"),
         "a job naming one file twice is refused");
  expect(submit_refused(c, 1, "m.ply", good, sizeof mesh, 0, "built-in scene has no files"),
         "a built-in scene with files is refused");

  Vcmfarm__Envelope *b = blob_request(c, 12345, good, 0);
  expect(b && b->body_case == VCMFARM__ENVELOPE__BODY_ERROR &&
             b->error->code == VCMFARM__ERROR_CODE__ERROR_UNKNOWN_WORKER,
         "an unknown worker gets no blob");
  vf_message_free(b);
  Vcmfarm__Register reg = VCMFARM__REGISTER__INIT;
  reg.name = "farm_blob_peer";
  q.body_case = VCMFARM__ENVELOPE__BODY_REGISTER;
  q.register_ = &reg;
  uint64_t worker_id = 0;
  if (vf_farm_request(c, &q, VCMFARM__ENVELOPE__BODY_REGISTERED, 10000, &reply) == VF_OK) {
    worker_id = reply->registered->worker_id;
    vf_message_free(reply);
  }
  b = blob_request(c, worker_id, unknown, 0);
  expect(b && b->body_case == VCMFARM__ENVELOPE__BODY_ERROR && strstr(b->error->message, "has no blob"),
         "a blob nobody sent is answered with an error naming it");
  if (b && b->body_case == VCMFARM__ENVELOPE__BODY_ERROR) printf("     %s\n", b->error->message);
  vf_message_free(b);
  b = blob_request(c, worker_id, good, 0);
  expect(b && b->body_case == VCMFARM__ENVELOPE__BODY_BLOB && b->blob->data.len == sizeof mesh &&
             b->blob->total_size == sizeof mesh && memcmp(b->blob->data.data, mesh, sizeof mesh) == 0,
         "the stored blob is served back intact");
  vf_message_free(b);
  b = blob_request(c, worker_id, good, 5);
  expect(b && b->body_case == VCMFARM__ENVELOPE__BODY_BLOB && b->blob->offset == 5 &&
             b->blob->data.len == sizeof mesh - 5 && memcmp(b->blob->data.data, mesh + 5, sizeof mesh - 5) == 0,
         "a chunk from an offset is served");
  vf_message_free(b);
  b = blob_request(c, worker_id, good, sizeof mesh + 1);
  expect(b && b->body_case == VCMFARM__ENVELOPE__BODY_ERROR && strstr(b->error->message, "past"),
         "a chunk past the end is refused");
  vf_message_free(b);

  Vcmfarm__StatusRequest sr = VCMFARM__STATUS_REQUEST__INIT;
  q.body_case = VCMFARM__ENVELOPE__BODY_STATUS_REQUEST;
  q.status_request = &sr;
  int alive = vf_farm_request(c, &q, VCMFARM__ENVELOPE__BODY_STATUS, 10000, &reply) == VF_OK;
  expect(alive && reply->status->n_jobs == 0, "the coordinator still answers and created no job");
  if (alive) vf_message_free(reply);
  vf_farm_client_close(c);
  return failures ? 1 : 0;
}
