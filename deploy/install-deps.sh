#!/usr/bin/env bash
# Installs everything vcmfarm needs to build and test, from Debian 12's packages.
# Idempotent: packages already present are left as they are, and apt-get update runs
# only when something is missing.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config
  libembree-dev        # Embree 3: ray intersection
  libopenexr-dev       # OpenEXRCore: films, references, environment maps
  libuv1-dev           # coordinator event loop
  libnanomsg-dev       # coordinator <-> worker messaging
  libprotobuf-c-dev protobuf-c-compiler   # wire messages
  libcjson-dev         # scene files and --json output
  libexpat1-dev        # Mitsuba 3 XML scenes (worker/scene/xml.c)
  libassimp-dev        # mesh files (OBJ, PLY, glTF)
  libopenvdb-dev       # density grids of participating media (worker/scene/vdb.cpp)
  libboost-dev         #   whose headers include Boost's (libopenvdb-dev does not depend on it)
  libpng-dev           # previews and plots, PNG textures
  libjpeg-dev          # JPEG textures (worker/scene/texture.c; Debian's libjpeg62-turbo)
  libsodium-dev        # content hashes, message encryption and authentication
  libcairo2-dev        # plots and legends (PNG with text)
  libmicrohttpd-dev    # the coordinator's web dashboard (--http)
  zlib1g-dev           # film chunks are ZIP-compressed in parallel (common/exr_chunk.c)
  slurm-wlm munge      # tests/deploy/test_slurm.sh: a one-node Slurm cluster (deploy/slurm)
  systemd              # tests/deploy/test_systemd.sh: systemd-analyze verify (deploy/systemd)
  python3              # tests/bench/convergence_report.py (standard library only)
  jq                   # tests/bench/convergence.sh, tests/cli/test_film_tools.sh: fields of --json output
  clang                # tests/test_fuzz.sh: the libFuzzer targets of tests/fuzz, with
  libclang-rt-14-dev   #   compiler-rt's libFuzzer, ASan and UBSan (only recommended by clang)
  curl                 # tests/coordinator/dashboard/test_dashboard_http.sh: the dashboard's endpoints
  chromium             # tests/coordinator/dashboard/test_dashboard.sh: the dashboard in a headless browser (playwright-core)
  assimp-testmodels    # tests/worker/scene/test_import.c: Khronos glTF 2.0 sample models as import smoke tests
  iproute2             # tests/farm/test_farm_netns.sh: network namespaces, a bridge and veth pairs (ip, tc)
)
# tests/deploy/test_k8s.sh validates deploy/k8s, and tests/coordinator/dashboard/test_dashboard.sh drives chromium, with
# packages from the npm registry (each test installs its own with npm ci). Debian's
# nodejs and npm are installed only where no node and npm are on the PATH: a machine
# with another Node.js (NodeSource's nodejs carries its own npm) keeps it.
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  packages+=(nodejs npm)
fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
echo "install-deps: installing ${missing[*]}"
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
