#!/usr/bin/env bash
# deploy/k8s: every manifest validates against the Kubernetes API schemas (tests/deploy/k8s/
# validate.js: kubernetes-models' JSON schemas and TypeScript types, both generated from
# the official OpenAPI definitions, from the npm registry at the versions in
# tests/deploy/k8s/package-lock.json), and the validator is shown to catch a misspelt field, a
# wrong type and worker threads that do not match the CPU request.
#
#   test_k8s.sh DEPLOY_DIR SOURCE_DIR WORK_DIR
#
# node and npm are dependencies (deploy/install-deps.sh installs them): without them, or
# when npm cannot install the validator's packages, the test fails, so that manifests that
# were never validated are never reported as passing.
set -u
manifests="$1/k8s"
src="$2"
work="$3"
fail() { echo "FAIL test_k8s: $*"; exit 1; }
command -v node >/dev/null && command -v npm >/dev/null ||
  fail "node and npm not found (Debian packages nodejs and npm: bash deploy/install-deps.sh)"

# Install once per lock file into the build tree.
mkdir -p "$work"
cp "$src/package.json" "$src/package-lock.json" "$src/validate.js" "$work/"
if ! cmp -s "$src/package-lock.json" "$work/node_modules/.vcmfarm-lock" 2>/dev/null; then
  (cd "$work" && npm ci --no-audit --no-fund --loglevel=error) >"$work/npm.log" 2>&1 ||
    { cat "$work/npm.log"; fail "npm ci could not install the validator's packages (above)"; }
  cp "$src/package-lock.json" "$work/node_modules/.vcmfarm-lock"
fi

(cd "$work" && node validate.js "$manifests"/*.yaml) || fail "deploy/k8s does not validate"

tmp=$(mktemp -d /tmp/vf-k8s-XXXXXX)
trap 'rm -rf "$tmp"' EXIT
expect_invalid() { # what, expected message part, sed script applied to workers.yaml
  sed "$3" "$manifests/workers.yaml" >"$tmp/workers.yaml"
  cmp -s "$tmp/workers.yaml" "$manifests/workers.yaml" && fail "$1: the edit changed nothing"
  out=$(cd "$work" && node validate.js "$tmp/workers.yaml")
  [ $? -ne 0 ] || fail "$1 was not caught"
  grep -q -- "$2" <<<"$out" || fail "$1: expected '$2' in: $out"
  echo "caught  $1: $(grep -m1 INVALID <<<"$out")"
}
expect_invalid "a misspelt field" "'\"replica\"' does not exist" 's/^  replicas: 3$/  replica: 3/'
expect_invalid "a wrong type" "must be string" 's/secretName: vcmfarm-key/secretName: 7/'
expect_invalid "a missing required field" "containers/0 must have required property name" 's/^        - name: worker$/        -/'
expect_invalid "threads unlike the CPU request" "must equal requests.cpu" 's/--threads=4/--threads=8/'
echo "ok   test_k8s"
