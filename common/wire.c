#include "wire.h"

#include "atomic_file.h"
#include "error.h"
#include "file.h"

#include <errno.h>
#include <fcntl.h>
#include <sodium.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

_Static_assert(crypto_auth_KEYBYTES == sizeof(vf_wire_key), "key size (versions 1 to 7)");
_Static_assert(crypto_auth_BYTES == VF_WIRE_LEGACY_TAG_SIZE, "tag size (versions 1 to 7)");
_Static_assert(crypto_kdf_KEYBYTES == sizeof(vf_wire_key), "the farm key is a crypto_kdf master key");
_Static_assert(crypto_aead_xchacha20poly1305_ietf_KEYBYTES == 32, "cipher key size");
_Static_assert(crypto_aead_xchacha20poly1305_ietf_NPUBBYTES == VF_WIRE_NONCE_SIZE, "nonce size");
_Static_assert(crypto_aead_xchacha20poly1305_ietf_ABYTES == VF_WIRE_TAG_SIZE, "tag size");

/* The first version framed as common/wire.h says; the earlier ones used HMAC in clear. */
#define FIRST_SEALED_VERSION 8u
#define KDF_CONTEXT "vcmfarm8"
enum { SUBKEY_REQUEST = 1, SUBKEY_REPLY = 2 };

static int sodium_ready(void) {
  if (sodium_init() < 0) return vf_error_set(VF_EINVAL, "libsodium failed to initialise");
  return VF_OK;
}

int vf_wire_key_load(const char *path, vf_wire_key *key) {
  struct stat st;
  if (stat(path, &st) != 0)
    return vf_error_set(errno == ENOENT ? VF_ENOENT : VF_EIO, "key file %s: %s", path, strerror(errno));
  if (st.st_mode & 077)
    return vf_error_set(VF_EINVAL, "key file %s: readable by others than its owner (chmod 600 %s)", path, path);
  uint8_t *text;
  size_t len;
  int err = vf_file_read_all(path, 4096, &text, &len);
  if (err != VF_OK) return err;
  while (len > 0 && (text[len - 1] == '\n' || text[len - 1] == '\r' || text[len - 1] == ' ')) len--;
  vf_wire_key k;
  size_t bin_len = 0;
  const char *end = NULL;
  if (len != 2 * sizeof k.bytes ||
      sodium_hex2bin(k.bytes, sizeof k.bytes, (const char *)text, len, NULL, &bin_len, &end) != 0 ||
      bin_len != sizeof k.bytes) {
    err = vf_error_set(VF_EINVAL, "key file %s: expected 64 hexadecimal digits (make one with vcmfarm keygen)", path);
  } else {
    *key = k;
  }
  sodium_memzero(text, len);
  sodium_memzero(&k, sizeof k);
  free(text);
  return err;
}

int vf_wire_key_generate(const char *path) {
  int err = sodium_ready();
  if (err != VF_OK) return err;
  vf_atomic_file file;
  if ((err = vf_atomic_open_mode(&file, path, 0600)) != VF_OK)
    return vf_error_set(err, "key file %s", vf_error_detail(err));
  uint8_t k[32];
  char hex[65];
  randombytes_buf(k, sizeof k);
  sodium_bin2hex(hex, sizeof hex, k, sizeof k);
  hex[64] = '\n';
  /* exactly 0600 whatever the umask: vf_wire_key_load refuses anything else */
  if (fchmod(file.fd, 0600) != 0) err = vf_error_set(VF_EIO, "%s: chmod: %s", path, strerror(errno));
  if (err == VF_OK) err = vf_atomic_pwrite(&file, hex, sizeof hex, 0);
  if (err == VF_OK) err = vf_atomic_commit_new(&file);
  else vf_atomic_abort(&file);
  sodium_memzero(k, sizeof k);
  sodium_memzero(hex, sizeof hex);
  return err == VF_OK ? VF_OK : vf_error_set(err, "key file %s", vf_error_detail(err));
}

static void put_u32(uint8_t *p, uint32_t v) {
  p[0] = (uint8_t)(v >> 24);
  p[1] = (uint8_t)(v >> 16);
  p[2] = (uint8_t)(v >> 8);
  p[3] = (uint8_t)v;
}

static uint32_t get_u32(const uint8_t *p) {
  return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | (uint32_t)p[3];
}

int64_t vf_wire_now_ms(void) {
  struct timespec ts;
  clock_gettime(CLOCK_REALTIME, &ts);
  return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

/* The cipher key of one direction, derived from the farm key; the caller wipes it. */
static void subkey(const vf_wire_key *key, int request, uint8_t out[32]) {
  crypto_kdf_derive_from_key(out, 32, request ? SUBKEY_REQUEST : SUBKEY_REPLY, KDF_CONTEXT, key->bytes);
}

/* Associated data: the frame's header, and for a reply the nonce of its request. */
static size_t associated_data(const uint8_t *header, const vf_wire_stamp *request, uint8_t *ad) {
  memcpy(ad, header, VF_WIRE_HEADER_SIZE);
  if (request == NULL) return VF_WIRE_HEADER_SIZE;
  memcpy(ad + VF_WIRE_HEADER_SIZE, request->nonce, VF_WIRE_NONCE_SIZE);
  return VF_WIRE_HEADER_SIZE + VF_WIRE_NONCE_SIZE;
}

/* A reply to a frame of version 1 to 7 (a version refusal) in the layout of those versions,
 * under the key they knew, so that the old peer opens it and reports the mismatch. */
static int seal_legacy(const vf_wire_key *key, const uint8_t *payload, size_t len, uint8_t **frame,
                       size_t *frame_len) {
  size_t total = VF_WIRE_LEGACY_HEADER_SIZE + len + VF_WIRE_LEGACY_TAG_SIZE;
  uint8_t *f = malloc(total);
  if (f == NULL) return vf_error_set(VF_ENOMEM, "no memory for a %zu-byte message", total);
  memcpy(f, VF_WIRE_MAGIC, 4);
  put_u32(f + 4, VF_PROTOCOL_VERSION);
  put_u32(f + 8, (uint32_t)len);
  if (len > 0) memcpy(f + VF_WIRE_LEGACY_HEADER_SIZE, payload, len);
  crypto_auth(f + VF_WIRE_LEGACY_HEADER_SIZE + len, f, VF_WIRE_LEGACY_HEADER_SIZE + len, key->bytes);
  *frame = f;
  *frame_len = total;
  return VF_OK;
}

int vf_wire_seal(const vf_wire_key *key, const vf_wire_stamp *request, const uint8_t *payload, size_t len,
                 uint8_t **frame, size_t *frame_len, vf_wire_stamp *stamp) {
  if (len > VF_WIRE_MAX_PAYLOAD)
    return vf_error_set(VF_EINVAL, "message of %zu bytes exceeds the limit of %zu", len, VF_WIRE_MAX_PAYLOAD);
  int err = sodium_ready();
  if (err != VF_OK) return err;
  if (request != NULL && request->version < FIRST_SEALED_VERSION) return seal_legacy(key, payload, len, frame, frame_len);
  size_t total = VF_WIRE_OVERHEAD + len;
  uint8_t *f = malloc(total);
  if (f == NULL) return vf_error_set(VF_ENOMEM, "no memory for a %zu-byte message", total);
  vf_wire_stamp s = {VF_PROTOCOL_VERSION, vf_wire_now_ms(), {0}};
  randombytes_buf(s.nonce, sizeof s.nonce);
  memcpy(f, VF_WIRE_MAGIC, 4);
  put_u32(f + 4, VF_PROTOCOL_VERSION);
  put_u32(f + 8, (uint32_t)len);
  put_u32(f + 12, (uint32_t)((uint64_t)s.sent_ms >> 32));
  put_u32(f + 16, (uint32_t)s.sent_ms);
  memcpy(f + 20, s.nonce, VF_WIRE_NONCE_SIZE);
  uint8_t ad[VF_WIRE_HEADER_SIZE + VF_WIRE_NONCE_SIZE], k[32];
  size_t ad_len = associated_data(f, request, ad);
  subkey(key, request == NULL, k);
  crypto_aead_xchacha20poly1305_ietf_encrypt_detached(f + VF_WIRE_HEADER_SIZE, f + VF_WIRE_HEADER_SIZE + len, NULL,
                                                      payload, len, ad, ad_len, NULL, s.nonce, k);
  sodium_memzero(k, sizeof k);
  *frame = f;
  *frame_len = total;
  if (stamp) *stamp = s;
  return VF_OK;
}

/* A frame of version 1 to 7: authenticated as those versions did, then refused as another
 * version (it says nothing else we could use). */
static int open_legacy(const vf_wire_key *key, uint32_t version, const uint8_t *frame, size_t len,
                       vf_wire_stamp *stamp) {
  if (len < VF_WIRE_LEGACY_HEADER_SIZE + VF_WIRE_LEGACY_TAG_SIZE)
    return vf_error_set(VF_EPROTO, "frame of %zu bytes is shorter than a version %u header and tag", len, version);
  uint32_t length = get_u32(frame + 8);
  if ((size_t)length != len - VF_WIRE_LEGACY_HEADER_SIZE - VF_WIRE_LEGACY_TAG_SIZE)
    return vf_error_set(VF_EPROTO, "version %u frame of %zu bytes does not match its payload length %u", version,
                        len, length);
  if (crypto_auth_verify(frame + VF_WIRE_LEGACY_HEADER_SIZE + length, frame, VF_WIRE_LEGACY_HEADER_SIZE + length,
                         key->bytes) != 0)
    return vf_error_set(VF_EAUTH, "authentication failed: the peer does not hold this farm's key");
  if (stamp) *stamp = (vf_wire_stamp){version, 0, {0}};
  return vf_error_set(VF_EVERSION, "peer speaks protocol version %u, this vcmfarm speaks version %u", version,
                      VF_PROTOCOL_VERSION);
}

const uint8_t vf_wire_refusal[VF_WIRE_REFUSAL_SIZE] = {'V', 'C', 'M', 'F', 0, 0, 0, FIRST_SEALED_VERSION};

int vf_wire_is_refusal(const uint8_t *frame, size_t len) {
  return len == VF_WIRE_REFUSAL_SIZE && memcmp(frame, vf_wire_refusal, VF_WIRE_REFUSAL_SIZE) == 0;
}

int vf_wire_knows_refusal(const uint8_t *frame, size_t len) {
  return len >= VF_WIRE_LEGACY_HEADER_SIZE && memcmp(frame, VF_WIRE_MAGIC, 4) == 0 &&
         get_u32(frame + 4) >= FIRST_SEALED_VERSION;
}

int vf_wire_open(const vf_wire_key *key, const vf_wire_stamp *request, const uint8_t *frame, size_t len,
                 uint8_t **payload, size_t *payload_len, vf_wire_stamp *stamp) {
  if (len < VF_WIRE_LEGACY_HEADER_SIZE)
    return vf_error_set(VF_EPROTO, "frame of %zu bytes is shorter than a header", len);
  if (memcmp(frame, VF_WIRE_MAGIC, 4) != 0) return vf_error_set(VF_EPROTO, "not a vcmfarm frame (bad magic)");
  uint32_t version = get_u32(frame + 4), length = get_u32(frame + 8);
  if (length > VF_WIRE_MAX_PAYLOAD)
    return vf_error_set(VF_EPROTO, "payload length %u exceeds the limit of %zu", length, VF_WIRE_MAX_PAYLOAD);
  int err = sodium_ready();
  if (err != VF_OK) return err;
  if (version < FIRST_SEALED_VERSION) return open_legacy(key, version, frame, len, stamp);
  if (len < VF_WIRE_OVERHEAD)
    return vf_error_set(VF_EPROTO, "frame of %zu bytes is shorter than header and tag (%u bytes)", len,
                        VF_WIRE_OVERHEAD);
  if ((size_t)length != len - VF_WIRE_OVERHEAD)
    return vf_error_set(VF_EPROTO, "frame of %zu bytes does not match its payload length %u", len, length);
  vf_wire_stamp s = {version, (int64_t)((uint64_t)get_u32(frame + 12) << 32 | get_u32(frame + 16)), {0}};
  memcpy(s.nonce, frame + 20, VF_WIRE_NONCE_SIZE);
  uint8_t *p = malloc(length ? length : 1);
  if (p == NULL) return vf_error_set(VF_ENOMEM, "no memory for a %u-byte message", length);
  uint8_t ad[VF_WIRE_HEADER_SIZE + VF_WIRE_NONCE_SIZE], k[32];
  size_t ad_len = associated_data(frame, request, ad);
  subkey(key, request == NULL, k);
  int bad = crypto_aead_xchacha20poly1305_ietf_decrypt_detached(p, NULL, frame + VF_WIRE_HEADER_SIZE, length,
                                                                frame + VF_WIRE_HEADER_SIZE + length, ad, ad_len,
                                                                s.nonce, k);
  sodium_memzero(k, sizeof k);
  if (bad) {
    free(p);
    return vf_error_set(VF_EAUTH, request == NULL
                                      ? "authentication failed: the peer does not hold this farm's key"
                                      : "authentication failed: not the reply to this request, or the peer does "
                                        "not hold this farm's key");
  }
  if (version != VF_PROTOCOL_VERSION) {
    free(p);
    if (stamp) *stamp = s;
    return vf_error_set(VF_EVERSION, "peer speaks protocol version %u, this vcmfarm speaks version %u", version,
                        VF_PROTOCOL_VERSION);
  }
  *payload = p;
  *payload_len = length;
  if (stamp) *stamp = s;
  return VF_OK;
}
