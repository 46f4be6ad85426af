#!/usr/bin/env bash
# The dashboard's HTTP endpoints (docs/PROTOCOL.md, "Dashboard") with curl, against a real
# coordinator (--http 127.0.0.1:0) and worker over ipc:// in a temporary directory: the
# page and its script; the status JSON's shape, one job's with its convergence log, the
# events; a preview PNG; every action refused through GET (405), without a token (401),
# with a bad one (403); a sign-in with a wrong proof and a replayed nonce refused, with
# the right proof (HMAC-SHA-256 under the key, computed here by python3) a token that
# changes the priority, pauses and resumes the job, fetches the film and the baked PNG and
# cancels the job; a foreign Host refused (421). curl and python3 are dependencies (deploy/install-deps.sh): missing,
# the test fails.
#
#   test_dashboard_http.sh VCMFARM
set -u
vcmfarm="$1"
fail_label=test_dashboard_http
source "$(dirname "$0")/../../farm/farm_test_lib.sh"
farm_test_tmp dash-http
for tool in curl python3; do command -v "$tool" >/dev/null || fail "$tool not found (bash deploy/install-deps.sh)"; done

farm_test_key
"$vcmfarm" coordinator --listen "$url" --state "$tmp/state" --secret "$key" --checkpoint-interval 0.5 \
  --http 127.0.0.1:0 >"$tmp/coordinator.log" 2>&1 &
pids+=($!)
dashboard_address
"$vcmfarm" worker --connect "$url" --secret "$key" --threads 1 --name w1 --test-iteration-delay 100 --ship-interval 0.3 \
  >"$tmp/worker.log" 2>&1 &
pids+=($!)
"$vcmfarm" submit cornell -R 32x32 --iterations 100000 --coordinator "$url" --secret "$key" >"$tmp/submit.log" 2>&1 ||
  fail "submit"

code() { curl -s -o "$tmp/body" -w '%{http_code}' "$@"; }
expect() { # what, expected code, curl arguments...
  local what="$1" want="$2"
  shift 2
  local got
  got=$(code "$@")
  [ "$got" = "$want" ] || fail "$what: HTTP $got, expected $want: $(head -c 300 "$tmp/body")"
  echo "ok   $what: $got $(head -c 100 "$tmp/body" | tr -d '\n' | LC_ALL=C tr -c '[:print:]' '.')"
}
json() { python3 -c "import json,sys; d=json.load(open('$tmp/body')); $1"; }

expect "the page" 200 "$base/"
grep -q '<script src="/dashboard.js"' "$tmp/body" || fail "the page does not load its script"
expect "the script" 200 "$base/dashboard.js"
expect "status" 200 "$base/api/status"
json 'assert set(["time","coordinator","iterations_per_second","workers_busy","jobs","workers","events"]) <= set(d), d.keys()' ||
  fail "status lacks fields"
# The job has merged parts and checkpointed them: wait for a log entry with an error.
for _ in $(seq 200); do
  code "$base/api/jobs/1" >/dev/null
  json 'assert any(e["estimated_rmse"] for e in d["jobs"][0].get("convergence", []))' 2>/dev/null && break
  sleep 0.1
done
expect "one job" 200 "$base/api/jobs/1"
json 'j=d["jobs"][0]; assert j["id"]==1 and j["state"]=="running" and j["convergence"][-1]["estimated_rmse"] > 0, j' ||
  fail "the job's status has no convergence log"
expect "status names the worker" 200 "$base/api/status"
json 'w=d["workers"]; assert len(w)==1 and w[0]["name"]=="w1" and w[0]["state"] in ("busy","idle"), w' || fail "workers"
expect "an unknown job" 404 "$base/api/jobs/99"
expect "events" 200 "$base/api/events"
json 'assert any(e["kind"]=="worker_registered" for e in d["events"]), d' || fail "no worker_registered event"
expect "preview" 200 "$base/api/jobs/1/preview.png?exposure=1&size=16"
head -c 8 "$tmp/body" | od -An -tx1 | grep -q '89 50 4e 47 0d 0a 1a 0a' || fail "the preview is not a PNG"
expect "preview with a bad exposure" 400 "$base/api/jobs/1/preview.png?exposure=abc"
expect "a foreign Host" 421 -H "Host: attacker.example" "$base/api/status"

for action in cancel remove priority film image pause resume; do
  expect "GET $action" 405 "$base/api/jobs/1/$action"
  expect "$action without a token" 401 -X POST "$base/api/jobs/1/$action"
  expect "$action with a bad token" 403 -X POST -H "X-Vcmfarm-Session: $(printf '%064d' 7)" "$base/api/jobs/1/$action"
done
expect "status through POST" 405 -X POST "$base/api/status"

proof() { # nonce -> HMAC-SHA-256 under the farm key, hex
  python3 -c "import hmac,hashlib,sys; k=bytes.fromhex(open(sys.argv[1]).read().strip());
print(hmac.new(k, b'vcmfarm-dashboard-session:' + sys.argv[2].encode(), hashlib.sha256).hexdigest())" "$key" "$1"
}
expect "a nonce" 200 -X POST "$base/api/session/nonce"
nonce=$(json 'print(d["nonce"])')
wrong=$(printf '%064d' 0)
expect "a wrong proof" 403 -X POST -d "{\"nonce\":\"$nonce\",\"proof\":\"$wrong\"}" "$base/api/session"
expect "the right proof of a spent nonce" 403 -X POST -d "{\"nonce\":\"$nonce\",\"proof\":\"$(proof "$nonce")\"}" \
  "$base/api/session"
expect "a nonce" 200 -X POST "$base/api/session/nonce"
nonce=$(json 'print(d["nonce"])')
expect "the right proof" 200 -X POST -d "{\"nonce\":\"$nonce\",\"proof\":\"$(proof "$nonce")\"}" "$base/api/session"
token=$(json 'print(d["token"])')
[ ${#token} -eq 64 ] || fail "the token is not 64 hex digits: $token"
auth=(-X POST -H "X-Vcmfarm-Session: $token")
expect "priority 0 refused" 400 "${auth[@]}" -d '{"priority":0}' "$base/api/jobs/1/priority"
expect "priority 5" 200 "${auth[@]}" -d '{"priority":5}' "$base/api/jobs/1/priority"
expect "the priority shows" 200 "$base/api/jobs/1"
json 'assert d["jobs"][0]["priority"]==5, d["jobs"][0]["priority"]' || fail "priority not changed"
expect "the film" 200 "${auth[@]}" -o "$tmp/film.exr" "$base/api/jobs/1/film"
curl -s "${auth[@]}" -o "$tmp/film.exr" "$base/api/jobs/1/film"
"$vcmfarm" info "$tmp/film.exr" >"$tmp/info.log" 2>&1 || fail "the fetched film does not read: $(cat "$tmp/info.log")"
expect "the baked image" 200 "${auth[@]}" "$base/api/jobs/1/image?exposure=0.5"
head -c 8 "$tmp/body" | od -An -tx1 | grep -q '89 50 4e 47' || fail "the baked image is not a PNG"
expect "resume while not paused" 409 "${auth[@]}" "$base/api/jobs/1/resume"
expect "pause" 200 "${auth[@]}" "$base/api/jobs/1/pause"
json 'assert "paused job 1: no new leases" in d["message"], d' || fail "pause said: $(cat "$tmp/body")"
expect "the job is paused" 200 "$base/api/jobs/1"
json 'j=d["jobs"][0]; assert j["state"]=="paused" and j["paused"] is True, j["state"]' || fail "not paused"
expect "pause again" 409 "${auth[@]}" "$base/api/jobs/1/pause"
expect "pause of no job" 404 "${auth[@]}" "$base/api/jobs/99/pause"
expect "resume" 200 "${auth[@]}" "$base/api/jobs/1/resume"
expect "the job's events" 200 "$base/api/events"
json 'k=[e["kind"] for e in d["events"]]; assert "job_paused" in k and "job_resumed" in k and "priority_changed" in k, k' ||
  fail "the events lack the pause, the resume or the priority: $(cat "$tmp/body")"
expect "remove while running" 409 "${auth[@]}" "$base/api/jobs/1/remove"
expect "cancel" 200 "${auth[@]}" "$base/api/jobs/1/cancel"
expect "the job is cancelled" 200 "$base/api/jobs/1"
json 'assert d["jobs"][0]["state"]=="cancelled", d["jobs"][0]["state"]' || fail "not cancelled"
expect "cancel again" 409 "${auth[@]}" "$base/api/jobs/1/cancel"
expect "sign out" 200 "${auth[@]}" "$base/api/session/close"
expect "the token after signing out" 403 "${auth[@]}" "$base/api/jobs/1/remove"
echo "ok   test_dashboard_http"
