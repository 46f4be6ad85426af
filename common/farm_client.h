/* The connecting side of the farm protocol: a nanomsg REQ socket to the coordinator's REP
 * socket, used by workers and by the submit/status/fetch/cancel commands.
 *
 * nanomsg errors enter our code here and become VF_ENET. Each call sends one request and
 * waits for its reply; nanomsg reconnects by itself (with backoff up to 5 s) when the
 * coordinator goes away, and a call that gets no valid reply in time fails with
 * VF_ETIMEDOUT, after which the next call may simply be made (a REQ socket drops the
 * outstanding request when a new one is sent). Not thread-safe: one client per thread. */
#ifndef VF_FARM_CLIENT_H
#define VF_FARM_CLIENT_H

#include "message.h"

typedef struct vf_farm_client vf_farm_client;

/* Connects (asynchronously: no error when nobody listens yet). The key is copied.
 * *out is written only on success; VF_ENET with a detail naming the URL otherwise. */
int vf_farm_client_open(const char *url, const vf_wire_key *key, vf_farm_client **out);
void vf_farm_client_close(vf_farm_client *client);

/* Sends request (its protocol_version is set here) as a new frame (fresh nonce and clock,
 * common/wire.h: calling again after a timeout is never a replay) and waits up to
 * timeout_ms for the reply, which *reply receives (free with vf_message_free) on success,
 * whatever its body, Error included; only the reply bound to this request's nonce opens.
 * VF_ETIMEDOUT when no reply came, VF_EVERSION / VF_EAUTH / VF_EPROTO when the reply was
 * refused (see vf_message_unpack); VF_EAUTH "the coordinator at URL refused the key" when
 * the reply is the coordinator's refusal of a request it could not authenticate
 * (vf_wire_refusal: this client's key is not the farm's). */
int vf_farm_call(vf_farm_client *client, Vcmfarm__Envelope *request, int timeout_ms, Vcmfarm__Envelope **reply);

/* vf_farm_call that also insists on a reply with body `expected`: a reply of type Error
 * becomes VF_EREFUSED (VF_EVERSION for a version refusal, VF_ENOJOB for a job the
 * coordinator does not have) with the coordinator's message as detail, any other
 * unexpected body VF_EPROTO; *reply is written only on success. */
int vf_farm_request(vf_farm_client *client, Vcmfarm__Envelope *request, Vcmfarm__Envelope__BodyCase expected,
                    int timeout_ms, Vcmfarm__Envelope **reply);

/* Waits until the connection nanomsg makes in the background is up: VF_OK at once when it
 * is. VF_ENET "no coordinator answered at URL" when, for VF_FARM_CONNECT_MS (or timeout_ms
 * if shorter), nothing accepts connections there (no socket file, a refused TCP
 * connection: a coordinator that is down; one that starts meanwhile is found, the wait
 * connects anew every 50 ms), VF_ETIMEDOUT when a connection is being made but is not up
 * after timeout_ms.
 * For the commands of a user, who should not wait for a coordinator that is down; a
 * worker waits for its coordinator instead. */
#define VF_FARM_CONNECT_MS 800
int vf_farm_client_wait_connected(vf_farm_client *client, int timeout_ms);

/* The URL given to vf_farm_client_open (borrowed). */
const char *vf_farm_client_url(const vf_farm_client *client);

#endif
