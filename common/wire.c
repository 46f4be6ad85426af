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
#include <unistd.h>

_Static_assert(crypto_auth_KEYBYTES == sizeof(vf_wire_key), "key size");
_Static_assert(crypto_auth_BYTES == VF_WIRE_TAG_SIZE, "tag size");

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

int vf_wire_seal(const vf_wire_key *key, const uint8_t *payload, size_t len, uint8_t **frame, size_t *frame_len) {
  if (len > VF_WIRE_MAX_PAYLOAD)
    return vf_error_set(VF_EINVAL, "message of %zu bytes exceeds the limit of %zu", len, VF_WIRE_MAX_PAYLOAD);
  int err = sodium_ready();
  if (err != VF_OK) return err;
  size_t total = VF_WIRE_HEADER_SIZE + len + VF_WIRE_TAG_SIZE;
  uint8_t *f = malloc(total);
  if (f == NULL) return vf_error_set(VF_ENOMEM, "no memory for a %zu-byte message", total);
  memcpy(f, VF_WIRE_MAGIC, 4);
  put_u32(f + 4, VF_PROTOCOL_VERSION);
  put_u32(f + 8, (uint32_t)len);
  if (len > 0) memcpy(f + VF_WIRE_HEADER_SIZE, payload, len);
  crypto_auth(f + VF_WIRE_HEADER_SIZE + len, f, VF_WIRE_HEADER_SIZE + len, key->bytes);
  *frame = f;
  *frame_len = total;
  return VF_OK;
}

int vf_wire_open(const vf_wire_key *key, const uint8_t *frame, size_t len, const uint8_t **payload,
                 size_t *payload_len) {
  if (len < VF_WIRE_HEADER_SIZE + VF_WIRE_TAG_SIZE)
    return vf_error_set(VF_EPROTO, "frame of %zu bytes is shorter than header and tag (%u bytes)", len,
                        VF_WIRE_HEADER_SIZE + VF_WIRE_TAG_SIZE);
  if (memcmp(frame, VF_WIRE_MAGIC, 4) != 0) return vf_error_set(VF_EPROTO, "not a vcmfarm frame (bad magic)");
  uint32_t version = get_u32(frame + 4), length = get_u32(frame + 8);
  if (length > VF_WIRE_MAX_PAYLOAD)
    return vf_error_set(VF_EPROTO, "payload length %u exceeds the limit of %zu", length, VF_WIRE_MAX_PAYLOAD);
  if ((size_t)length != len - VF_WIRE_HEADER_SIZE - VF_WIRE_TAG_SIZE)
    return vf_error_set(VF_EPROTO, "frame of %zu bytes does not match its payload length %u", len, length);
  int err = sodium_ready();
  if (err != VF_OK) return err;
  if (crypto_auth_verify(frame + VF_WIRE_HEADER_SIZE + length, frame, VF_WIRE_HEADER_SIZE + length, key->bytes) != 0)
    return vf_error_set(VF_EAUTH, "authentication failed: the peer does not hold this farm's key");
  if (version != VF_PROTOCOL_VERSION)
    return vf_error_set(VF_EVERSION, "peer speaks protocol version %u, this vcmfarm speaks version %u", version,
                        VF_PROTOCOL_VERSION);
  *payload = frame + VF_WIRE_HEADER_SIZE;
  *payload_len = length;
  return VF_OK;
}
