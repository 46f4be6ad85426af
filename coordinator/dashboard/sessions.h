/* Who may act through the dashboard (docs/PROTOCOL.md, "Dashboard"): whoever holds the
 * farm key, proved without sending it.
 *
 * The page asks for a nonce (32 random bytes, as 64 hex digits, valid VF_NONCE_SECONDS
 * and once), computes HMAC-SHA-256 under the farm key of "vcmfarm-dashboard-session:"
 * followed by the nonce's hex digits (WebCrypto, from the key the user pastes; the page
 * never stores it and never sends it), and sends nonce and proof back. The proof is checked
 * in constant time (libsodium crypto_auth_hmacsha256_verify; the prefix keeps it from
 * ever being any other message's tag: frames use HMAC-SHA-512/256, common/wire.h) and the
 * nonce is spent whatever the outcome; a good proof gets a session token (32 random
 * bytes, 64 hex digits) valid VF_SESSION_SECONDS, which every action carries in a header.
 * Tables are bounded (the oldest entry makes room), so a flood of requests costs nothing
 * but the sessions it pushes out. Thread-safe. */
#ifndef VF_SESSIONS_H
#define VF_SESSIONS_H

#include "../../common/wire.h"

#include <stddef.h>

#define VF_NONCE_SECONDS 60.0
#define VF_SESSION_SECONDS 3600.0
#define VF_SESSION_TEXT 65 /* 64 hex digits and a NUL */
#define VF_SESSION_PROOF_PREFIX "vcmfarm-dashboard-session:"

typedef struct vf_sessions vf_sessions;

/* A table for this key (copied). VF_ENOMEM. */
int vf_sessions_create(const vf_wire_key *key, vf_sessions **out);
void vf_sessions_destroy(vf_sessions *sessions); /* NULL is a no-op; wipes the key */

/* A fresh nonce, as text, into nonce. */
void vf_sessions_nonce(vf_sessions *sessions, char nonce[VF_SESSION_TEXT]);

/* Spends the nonce and, when proof (64 hex digits) is its HMAC, writes a new token.
 * Returns 1 then, 0 for an unknown, spent or expired nonce or a wrong proof (no detail:
 * a guesser learns nothing). */
int vf_sessions_open(vf_sessions *sessions, const char *nonce, const char *proof, char token[VF_SESSION_TEXT]);

/* 1 when token is a session's that has not expired, else 0. */
int vf_sessions_check(vf_sessions *sessions, const char *token);

/* Ends the token's session (signing out); no-op for an unknown token. */
void vf_sessions_close(vf_sessions *sessions, const char *token);

#endif
