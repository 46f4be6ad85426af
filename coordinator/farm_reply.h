/* The reply the farm builds to one request: the envelope and storage for every body it may
 * carry, so that a handler fills in what it answers without allocating the common parts.
 * The caller (the event loop, a test) packs r->env and then releases the reply. The
 * handlers (coordinator/workers.h, leases.h, results.h, jobs.h, blobs.h) write into it. */
#ifndef VF_FARM_REPLY_H
#define VF_FARM_REPLY_H

#include "../common/message.h"

#include <stdint.h>

typedef struct vf_farm_reply {
  Vcmfarm__Envelope env;
  /* The handler took the request and answers later (farm->reply_later): send nothing now. */
  int deferred;
  Vcmfarm__Registered registered;
  Vcmfarm__Lease lease;
  Vcmfarm__Scene scene;
  Vcmfarm__Idle idle;
  Vcmfarm__HeartbeatAck heartbeat_ack;
  Vcmfarm__ResultAck result_ack;
  Vcmfarm__Submitted submitted;
  Vcmfarm__Status status;
  Vcmfarm__Film film;
  Vcmfarm__Error error;
  char text[1024];
  /* owned by the reply */
  Vcmfarm__JobStatus *job_status, **job_status_ptrs;
  Vcmfarm__WorkerStatus *worker_status, **worker_status_ptrs;
  uint8_t *film_bytes;
  Vcmfarm__ConvergenceEntry *log, **log_ptrs;
  Vcmfarm__Event *events, **event_ptrs; /* every job's and the farm's; texts borrowed from the farm */
  char **tag_ptrs; /* jobs' requirements and workers' tags (version 10); texts borrowed from the farm */
  /* ---- files of scenes by content hash (coordinator/blobs.h) ---- */
  Vcmfarm__BlobHave blob_have;
  Vcmfarm__Blob blob;
  ProtobufCBinaryData *missing;                 /* owned array; data borrowed from the request */
  uint8_t *blob_bytes;                          /* owned */
  Vcmfarm__BlobRef *file_refs, **file_ref_ptrs; /* owned; the lease's Scene.files */
  Vcmfarm__BlobRef allocation;                  /* the lease's allocation (version 11); hash borrowed from the job */
} vf_farm_reply;

/* An empty reply (no body yet), holding nothing. */
void vf_farm_reply_init(vf_farm_reply *reply);
/* Makes the reply an Error with this code and message. The reply may be uninitialised (a
 * request refused before decoding); what it owned is not freed (release it first). */
void vf_farm_reply_error(vf_farm_reply *reply, Vcmfarm__ErrorCode code, const char *message);
/* The same with a formatted message. */
void vf_farm_reply_errorf(vf_farm_reply *reply, Vcmfarm__ErrorCode code, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
/* The wire code of an error code of common/error.h, from its table: INPUT errors are
 * ERROR_BAD_REQUEST (fix the request), SYSTEM errors ERROR_INTERNAL (the coordinator
 * failed; the same request may succeed later); VF_EVERSION is ERROR_VERSION and VF_ENOJOB
 * ERROR_UNKNOWN_JOB. */
Vcmfarm__ErrorCode vf_farm_wire_code(int err);
/* Makes the reply the Error of err: its wire code and its detail (vf_error_detail). Every
 * handler answers a failed call this way, so one code always means one thing. */
void vf_farm_reply_fail(vf_farm_reply *reply, int err);
/* A ResultAck; message may be reply->text itself. */
void vf_farm_reply_ack(vf_farm_reply *reply, int accepted, const char *message);
/* Frees what the reply owns and leaves it empty (as vf_farm_reply_init). */
void vf_farm_reply_release(vf_farm_reply *reply);

#endif
