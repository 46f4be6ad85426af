/* Error codes shared by every vcmfarm module.
 *
 * Functions that can fail return a negative int from the table below (0 on success).
 * A failing function may also record a detail sentence with vf_error_set(); the detail is
 * thread-local, belongs to the code it was recorded with, and names what was wrong
 * ("scene.json: shapes[2].material: unknown material 'gold'"). Errors from Embree, OpenEXR,
 * nanomsg, libuv and protobuf-c are translated into these codes once, where they enter our
 * code. */
#ifndef VF_ERROR_H
#define VF_ERROR_H

/* The table of error codes: each code, its fixed message, and whose fault it is: INPUT when
 * what was given (a file, a command line, a message, a request) is wrong and giving it again
 * fails again; SYSTEM when this machine or its link failed (memory, disk, network, Embree)
 * and the same request may succeed later. The coordinator answers a request from this
 * table (coordinator/farm_reply.h, vf_farm_wire_code), so that clients can tell a request
 * to fix from one to retry. */
#define VF_ERRNO_MAP(XX)                                \
  XX(EINVAL, "invalid argument", INPUT)                 \
  XX(ENOMEM, "out of memory", SYSTEM)                   \
  XX(EIO, "input/output error", SYSTEM)                 \
  XX(ENOENT, "no such file", INPUT)                     \
  XX(EUSAGE, "bad command line", INPUT)                 \
  XX(ESCENE, "invalid scene", INPUT)                    \
  XX(EMESH, "invalid mesh file", INPUT)                 \
  XX(ETEXTURE, "invalid or unreadable texture", INPUT)  \
  XX(EEXR, "invalid or unreadable EXR file", INPUT)     \
  XX(EFILM, "invalid film", INPUT)                      \
  XX(EMISMATCH, "films or inputs do not match", INPUT)  \
  XX(EOVERLAP, "iteration ranges overlap", INPUT)       \
  XX(EEMBREE, "Embree error", SYSTEM)                   \
  XX(ENONFINITE, "non-finite value", INPUT)             \
  XX(EPROTO, "malformed message", INPUT)                \
  XX(EVERSION, "protocol version mismatch", INPUT)      \
  XX(EAUTH, "message authentication failed", INPUT)     \
  XX(ETIMEDOUT, "timed out", SYSTEM)                    \
  XX(ENET, "network error", SYSTEM)                     \
  XX(EREFUSED, "refused by the peer", INPUT)            \
  XX(EBUSY, "in use by another process", SYSTEM)        \
  XX(EREPLAY, "replayed or stale message", INPUT)       \
  XX(ENOJOB, "no such job", INPUT)                      \
  XX(EMODULE, "a part of vcmfarm is not installed", SYSTEM)

enum {
  VF_OK = 0,
#define XX(code, _, __) VF_##code,
  VF_ERRNO_FIRST_ = -1000,
  VF_ERRNO_MAP(XX)
#undef XX
};

/* The fixed message of an error code ("invalid scene"); never NULL. */
const char *vf_strerror(int err);

/* 1 when err is an INPUT error of the table, 0 for a SYSTEM one and for codes outside it. */
int vf_error_is_input(int err);

/* Records a detail message for the calling thread, belonging to err, and returns err, so a
 * failing function can write `return vf_error_set(VF_ESCENE, "%s: ...", path);`. */
int vf_error_set(int err, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* The detail of err: the calling thread's last detail if it was recorded for this same code,
 * else the code's fixed message (vf_strerror). A function that returns a code without
 * recording a detail (a bare `return VF_ENOMEM;`) thus shows its code's message, not the
 * text of an earlier, unrelated error; ask with the code the failing call returned. (An
 * earlier detail of the very same code is still returned: a function that handles an error
 * and goes on may call vf_error_clear.) Valid until the next vf_error_set on this thread.
 * Wrapping is safe: vf_error_set(err, "files[3]: %s", vf_error_detail(err)). */
const char *vf_error_detail(int err);

/* The code the calling thread's current detail belongs to, VF_OK when there is none: for
 * callers that see a failure only as an exit status (tests of command functions), which
 * then ask vf_error_detail(vf_error_code()). */
int vf_error_code(void);

/* Forgets the calling thread's detail. */
void vf_error_clear(void);

#endif
