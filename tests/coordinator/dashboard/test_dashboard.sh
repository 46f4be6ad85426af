#!/usr/bin/env bash
# The web dashboard end to end in a real browser: a coordinator with --http on a loopback
# port and a worker over ipc:// run a cornell job slowed by --test-iteration-delay;
# Debian's chromium, headless, driven by playwright-core (tests/coordinator/dashboard/browser/drive.js, from
# the npm registry at the version in tests/coordinator/dashboard/browser/package-lock.json), opens the page and
# checks that the job's progress rises, its preview changes between two screenshots, the
# plots are drawn with numbered axes, the worker is listed with its tags, an action without
# a session is refused, and with the farm key the job is paused, resumed, given priority 3
# and cancelled through the page (each in the Events panel), then removed once Remove's
# question is accepted (declined first: it stays).
#
#   test_dashboard.sh VCMFARM SOURCE_DIR WORK_DIR
#
# node, npm and chromium are dependencies (deploy/install-deps.sh): without them, or when
# npm cannot install playwright-core, the test fails, never skips. SCREENSHOTS=DIR writes
# the page's pictures there (docs/dashboard.png, docs/dashboard-job.png come from it).
set -u
vcmfarm="$1"
src="$2"
work="$3"
fail_label=test_dashboard
source "$(dirname "$0")/../../farm/farm_test_lib.sh"
farm_test_tmp dash
command -v node >/dev/null && command -v npm >/dev/null ||
  fail "node and npm not found (Debian packages nodejs and npm: bash deploy/install-deps.sh)"
chromium=$(command -v chromium) || fail "chromium not found (Debian package chromium: bash deploy/install-deps.sh)"

# Install once per lock file into the build tree.
mkdir -p "$work"
cp "$src/package.json" "$src/package-lock.json" "$src/drive.js" "$work/"
if ! cmp -s "$src/package-lock.json" "$work/node_modules/.vcmfarm-lock" 2>/dev/null; then
  (cd "$work" && npm ci --no-audit --no-fund --loglevel=error) >"$work/npm.log" 2>&1 ||
    { cat "$work/npm.log"; fail "npm ci could not install playwright-core (above)"; }
  cp "$src/package-lock.json" "$work/node_modules/.vcmfarm-lock"
fi

farm_test_key
"$vcmfarm" coordinator --listen "$url" --state "$tmp/state" --secret "$key" --checkpoint-interval 1 \
  --http 127.0.0.1:0 >"$tmp/coordinator.log" 2>&1 &
pids+=($!)
dashboard_address
"$vcmfarm" worker --connect "$url" --secret "$key" --threads 1 --name w1 --tags night --test-iteration-delay 150 \
  --ship-interval 0.5 >"$tmp/worker.log" 2>&1 &
pids+=($!)
"$vcmfarm" submit cornell -R 96x96 --iterations 3000 --coordinator "$url" --secret "$key" >"$tmp/submit.log" 2>&1 ||
  fail "submit"

out=$(cd "$work" && node drive.js "$base" "$key" "$chromium" ${SCREENSHOTS:+"$SCREENSHOTS"} 2>&1)
status=$?
echo "$out"
[ $status -eq 0 ] || fail "the page did not pass (above)"
for action in paused resumed cancelled removed; do
  grep -q "job 1 $action from the dashboard" "$tmp/coordinator.log" || fail "the coordinator did not log job 1 $action"
done
grep -q "job 1: priority 1 -> 3 (dashboard)" "$tmp/coordinator.log" || fail "the coordinator did not log the priority"
[ "$(grep -c "job 1 removed from the dashboard" "$tmp/coordinator.log")" = 1 ] || fail "job 1 was removed more than once"
echo "ok   test_dashboard"
