#include "sessions.h"

#include "../../common/clock.h"
#include "../../common/error.h"

#include <pthread.h>
#include <sodium.h>
#include <stdlib.h>
#include <string.h>

#define NONCES 64
#define SESSIONS 64

_Static_assert(crypto_auth_hmacsha256_KEYBYTES == sizeof(vf_wire_key), "the farm key is an HMAC-SHA-256 key");

typedef struct {
  uint8_t bytes[32];
  double expires; /* vf_seconds_now(); 0: free */
} secret;

struct vf_sessions {
  pthread_mutex_t lock;
  vf_wire_key key;
  secret nonces[NONCES], sessions[SESSIONS];
  unsigned next_nonce, next_session;
};

int vf_sessions_create(const vf_wire_key *key, vf_sessions **out) {
  if (sodium_init() < 0) return vf_error_set(VF_ENOMEM, "libsodium cannot start");
  vf_sessions *s = calloc(1, sizeof *s);
  if (s == NULL) return vf_error_set(VF_ENOMEM, "out of memory");
  pthread_mutex_init(&s->lock, NULL);
  s->key = *key;
  *out = s;
  return VF_OK;
}

void vf_sessions_destroy(vf_sessions *s) {
  if (s == NULL) return;
  pthread_mutex_destroy(&s->lock);
  sodium_memzero(s, sizeof *s); /* the key and every token */
  free(s);
}

static void to_hex(const uint8_t bytes[32], char text[VF_SESSION_TEXT]) { sodium_bin2hex(text, VF_SESSION_TEXT, bytes, 32); }

/* 64 hex digits exactly into bytes; 0 for anything else. */
static int from_hex(const char *text, uint8_t bytes[32]) {
  size_t n = 0;
  if (text == NULL || strlen(text) != 64) return 0;
  return sodium_hex2bin(bytes, 32, text, 64, NULL, &n, NULL) == 0 && n == 32;
}

/* The live entry holding these bytes, found in time independent of where (or whether). */
static secret *find(secret *table, unsigned count, const uint8_t bytes[32], double now) {
  secret *found = NULL;
  for (unsigned i = 0; i < count; i++)
    if (sodium_memcmp(table[i].bytes, bytes, 32) == 0 && table[i].expires > now) found = &table[i];
  return found;
}

static void add(secret *table, unsigned count, unsigned *next, double lifetime, char text[VF_SESSION_TEXT]) {
  secret *e = &table[*next];
  *next = (*next + 1) % count;
  randombytes_buf(e->bytes, sizeof e->bytes);
  e->expires = vf_seconds_now() + lifetime;
  to_hex(e->bytes, text);
}

void vf_sessions_nonce(vf_sessions *s, char nonce[VF_SESSION_TEXT]) {
  pthread_mutex_lock(&s->lock);
  add(s->nonces, NONCES, &s->next_nonce, VF_NONCE_SECONDS, nonce);
  pthread_mutex_unlock(&s->lock);
}

int vf_sessions_open(vf_sessions *s, const char *nonce, const char *proof, char token[VF_SESSION_TEXT]) {
  uint8_t nonce_bytes[32], tag[32];
  if (!from_hex(nonce, nonce_bytes) || !from_hex(proof, tag)) return 0;
  char message[sizeof VF_SESSION_PROOF_PREFIX + 64];
  snprintf(message, sizeof message, "%s%s", VF_SESSION_PROOF_PREFIX, nonce);
  for (char *c = message + sizeof VF_SESSION_PROOF_PREFIX - 1; *c; c++) /* the digits as the server wrote them */
    if (*c >= 'A' && *c <= 'F') *c = (char)(*c - 'A' + 'a');
  pthread_mutex_lock(&s->lock);
  int ok = 0;
  secret *e = find(s->nonces, NONCES, nonce_bytes, vf_seconds_now());
  if (e) {
    e->expires = 0.0; /* spent, whatever the proof */
    ok = crypto_auth_hmacsha256_verify(tag, (const unsigned char *)message, strlen(message), s->key.bytes) == 0;
    if (ok) add(s->sessions, SESSIONS, &s->next_session, VF_SESSION_SECONDS, token);
  }
  pthread_mutex_unlock(&s->lock);
  return ok;
}

int vf_sessions_check(vf_sessions *s, const char *token) {
  uint8_t bytes[32];
  if (!from_hex(token, bytes)) return 0;
  pthread_mutex_lock(&s->lock);
  int ok = find(s->sessions, SESSIONS, bytes, vf_seconds_now()) != NULL;
  pthread_mutex_unlock(&s->lock);
  return ok;
}

void vf_sessions_close(vf_sessions *s, const char *token) {
  uint8_t bytes[32];
  if (!from_hex(token, bytes)) return;
  pthread_mutex_lock(&s->lock);
  secret *e = find(s->sessions, SESSIONS, bytes, vf_seconds_now());
  if (e) e->expires = 0.0;
  pthread_mutex_unlock(&s->lock);
}
