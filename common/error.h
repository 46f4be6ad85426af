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

#define VF_ERRNO_MAP(XX)                                                   \
  XX(EINVAL, "invalid argument")                                           \
  XX(ENOMEM, "out of memory")                                              \
  XX(EIO, "input/output error")                                            \
  XX(ENOENT, "no such file")                                               \
  XX(EUSAGE, "bad command line")                                           \
  XX(ESCENE, "invalid scene")                                              \
  XX(EMESH, "invalid mesh file")                                           \
  XX(ETEXTURE, "invalid or unreadable texture")                            \
  XX(EEXR, "invalid or unreadable EXR file")                               \
  XX(EFILM, "invalid film")                                                \
  XX(EMISMATCH, "films or inputs do not match")                            \
  XX(EOVERLAP, "iteration ranges overlap")                                 \
  XX(EEMBREE, "Embree error")                                              \
  XX(ENONFINITE, "non-finite value")                                       \
  XX(EPROTO, "malformed message")                                          \
  XX(EVERSION, "protocol version mismatch")                                \
  XX(EAUTH, "message authentication failed")                               \
  XX(ETIMEDOUT, "timed out")                                               \
  XX(ENET, "network error")                                                \
  XX(EREFUSED, "refused by the peer")                                      \
  XX(EBUSY, "in use by another process")                                 \
  XX(EREPLAY, "replayed or stale message")                                \
  XX(ENOJOB, "no such job")

enum {
  VF_OK = 0,
#define XX(code, _) VF_##code,
  VF_ERRNO_FIRST_ = -1000,
  VF_ERRNO_MAP(XX)
#undef XX
};

/* The fixed message of an error code ("invalid scene"); never NULL. */
const char *vf_strerror(int err);

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
