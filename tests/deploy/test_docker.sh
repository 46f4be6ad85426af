#!/usr/bin/env bash
# deploy/docker/Dockerfile cannot be built here (no container engine), so its package
# lists are checked against this machine, which builds from the same Debian 12 packages:
#  - runtime stage: the packages that own the libraries the built vcmfarm and its modules
#    (libvf_*.so beside it in the build tree: common/module.h) need directly (their NEEDED
#    entries, through ldd and dpkg -S), exactly, with libc6 implied; and every library of
#    ldd's full closures belongs to a package those pull in through their Depends
#    (apt-cache depends --recurse), so the image has all it loads and nothing more; and
#    every module is built and copied where vcmfarm looks for it (../lib/vcmfarm/);
#  - build stage: every package of deploy/install-deps.sh that a build needs (the ones
#    only tests need are named below), and a COPY of every source directory the build adds.
#
#   test_docker.sh VCMFARM SOURCE_DIR
set -u
vcmfarm="$1"
src="$2"
dockerfile="$src/deploy/docker/Dockerfile"
for tool in ldd dpkg-query objdump apt-cache; do
  command -v "$tool" >/dev/null || { echo "SKIP test_docker: $tool not found"; exit 77; }
done
fail() { echo "FAIL test_docker: $*"; exit 1; }
words() { tr ' ' '\n' | grep -v '^$' | sort -u; }

# The package list of the apt-get install in stage $1 ("build" or "runtime").
stage_packages() {
  awk -v stage="$1" '
    /^FROM / { in_stage = ($0 ~ (" AS " stage "$")) }
    in_stage && /apt-get install/ { taking = 1 }
    taking {
      line = $0; sub(/&&.*/, "", line); gsub(/\\/, "", line)
      n = split(line, w, /[ \t]+/)
      for (i = 1; i <= n; i++) if (w[i] ~ /^[a-z0-9][a-z0-9.+-]+$/ && w[i] != "apt-get" && w[i] != "install") print w[i]
      if ($0 ~ /&& *rm / || $0 !~ /\\$/) taking = 0
    }' "$dockerfile" | grep -v '^DEBIAN_FRONTEND' | sort -u
}
owner() { # library path -> Debian package
  local p
  p=$(dpkg -S "$1" 2>/dev/null || dpkg -S "$(readlink -f "$1")" 2>/dev/null) || return 1
  echo "${p%%:*}"
}

runtime=$(stage_packages runtime)
build=$(stage_packages build)
[ -n "$runtime" ] && [ -n "$build" ] || fail "no package lists found in $dockerfile"
echo "runtime stage: $(echo $runtime)"

# Direct needs: NEEDED sonames of the program and the module, resolved by ldd.
modules=("$(dirname "$vcmfarm")"/libvf_*.so)
[ -f "${modules[0]}" ] || fail "no module (libvf_*.so) beside $vcmfarm"
objects=("$vcmfarm" "${modules[@]}")
direct=""
for object in "${objects[@]}"; do
  declare -A path=()
  while read -r name _ file _; do [ -n "$file" ] && path[$name]=$file; done < <(ldd "$object" | grep '=>')
  for soname in $(objdump -p "$object" | awk '/NEEDED/ {print $2}'); do
    case "$soname" in ld-linux*) continue ;; esac # the dynamic loader: libc6's
    [ -n "${path[$soname]:-}" ] || fail "ldd does not resolve $soname of $object"
    pkg=$(owner "${path[$soname]}") || fail "no package owns ${path[$soname]}"
    direct="$direct $pkg"
  done
  unset path
done
direct=$(echo "$direct" | words | grep -v -x libc6) # libc6 is in every Debian image
echo "needed:        $(echo $direct)"
missing=$(comm -23 <(echo "$direct") <(echo "$runtime"))
extra=$(comm -13 <(echo "$direct") <(echo "$runtime"))
[ -z "$missing" ] || fail "the runtime stage lacks $(echo $missing) (ldd ${objects[*]})"
[ -z "$extra" ] || fail "the runtime stage installs $(echo $extra), which neither vcmfarm nor its modules link"

# Transitive needs: every library ldd loads comes with the runtime packages' dependencies.
closure=$(apt-cache depends --recurse --no-recommends --no-suggests --no-conflicts --no-breaks \
  --no-replaces --no-enhances $runtime 2>/dev/null | grep -v '^ ' | sed 's/:any$//' | words)
[ -n "$closure" ] || fail "apt-cache depends found nothing (run apt-get update)"
loaded=$(for object in "${objects[@]}"; do ldd "$object" | awk '/=>/ {print $3}'; done | sort -u)
for lib in $loaded; do
  pkg=$(owner "$lib") || fail "no package owns $lib"
  sed 's/:.*//' <<<"$pkg" | grep -q -x -F -f - <(echo "$closure") ||
    fail "$lib ($pkg) is loaded but not pulled in by the runtime stage's packages"
done
echo "all $(echo "$loaded" | wc -l) libraries that ldd loads come from the runtime stage's packages"
targets=$(grep -o -- '--target vcmfarm[a-z_ ]*' "$dockerfile")
for m in "${modules[@]}"; do
  name=$(basename "$m" .so) # libvf_NAME: target vf_NAME
  grep -q -w -- "${name#lib}" <<<"$targets" || fail "the image does not build the module ${name#lib} ($m)"
done
grep -q -x 'COPY --from=build /src/build/libvf_\*.so /usr/local/lib/vcmfarm/' "$dockerfile" ||
  fail "the image does not copy the modules to /usr/local/lib/vcmfarm/"
echo "the image builds and copies all ${#modules[@]} modules"

# The build stage installs what deploy/install-deps.sh installs to build.
test_only="slurm-wlm munge systemd python3 jq curl chromium assimp-testmodels clang libclang-rt-14-dev iproute2"  # used by tests and benchmarks only (nodejs and npm too: outside the list)
deps=$(sed -n '/^packages=(/,/^)/p' "$src/deploy/install-deps.sh" | sed -e 's/#.*//' -e 's/packages=(//' -e 's/)//' | words)
for p in $test_only; do deps=$(grep -v -x "$p" <<<"$deps"); done
missing=$(comm -23 <(echo "$deps") <(echo "$build"))
[ -z "$missing" ] || fail "the build stage lacks $(echo $missing) from deploy/install-deps.sh"
echo "build stage: all $(echo "$deps" | wc -l) build packages of deploy/install-deps.sh"
# The build stage copies every directory the top-level CMakeLists.txt adds.
for dir in $(sed -n 's/^add_subdirectory(\([a-z_]*\))$/\1/p' "$src/CMakeLists.txt"); do
  grep -q -x "COPY $dir $dir" "$dockerfile" || fail "the build stage does not COPY $dir, which CMakeLists.txt adds"
done
echo "build stage: copies every directory CMakeLists.txt adds"
grep -q '^FROM debian:12-slim AS build$' "$dockerfile" && grep -q '^FROM debian:12-slim AS runtime$' "$dockerfile" ||
  fail "the stages are not debian:12-slim"
echo "ok   test_docker"
