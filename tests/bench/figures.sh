#!/usr/bin/env bash
# Every figure and plot of docs/BENCHMARKS.md, from one command:
#
#     bash tests/bench/figures.sh [BUILD_DIR] [SIZE]      defaults: build full
#
# It runs, in the order of docs/BENCHMARKS.md, each benchmark its sections name (renderer
# throughput and the raw Embree rate, the hash grid, films, time against error, the farm)
# and writes what each prints to BUILD_DIR/bench/figures/NN-name.txt (the tables are
# Markdown, ready to replace those in the document); the time-against-error plots go to
# docs/plots/ (convergence.sh). SIZE is that of the time-against-error runs: `full` (up
# to about an hour, the size the document quotes), `medium`, or `quick` (minutes; its plots
# stay in the build directory, so a smoke run never touches the committed figures).
#
# Figures are only worth anything on an idle machine: the script refuses to start while
# the load average is above 0.5 unless FORCE=1.
set -euo pipefail

build=${1:-build}
size=${2:-full}
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(cd "$here/../.." && pwd)
case "$size" in quick|medium|full) ;; *) echo "usage: bash tests/bench/figures.sh [BUILD_DIR] [quick|medium|full]" >&2; exit 2 ;; esac
[ -x "$build/vcmfarm" ] || { echo "figures.sh: no $build/vcmfarm (build first, or pass BUILD_DIR)" >&2; exit 2; }
build=$(cd "$build" && pwd)
load=$(cut -d' ' -f1 /proc/loadavg)
if [ -z "${FORCE:-}" ] && awk -v l="$load" 'BEGIN { exit !(l > 0.5) }'; then
  echo "figures.sh: load average $load: the machine is busy, figures would be wrong (FORCE=1 to run anyway)" >&2
  exit 2
fi
out=$build/bench/figures
mkdir -p "$out"

step() { # name, command...
  local name=$1
  shift
  echo "== $name: $*"
  local start=$SECONDS
  { echo "\$ $*"; echo "# $(date -u +%Y-%m-%dT%H:%MZ), load average $(cut -d' ' -f1-3 /proc/loadavg)"; "$@"; } \
    >"$out/$name.txt" 2>&1 || { tail -n 30 "$out/$name.txt" >&2; echo "figures.sh: $name failed" >&2; exit 1; }
  echo "   $((SECONDS - start)) s -> $out/$name.txt"
}

cd "$root"
# Renderer throughput (issue 2) and the raw Embree rate beside it.
step 01-renderer bash tests/bench/renderer.sh "$build" cornell 12 5
step 02-embree "$build/tests/bench_embree" cornell 2 4000000
if command -v valgrind >/dev/null; then
  step 02b-instructions bash tests/bench/instructions.sh "$build"
else
  echo "== 02b-instructions: skipped, valgrind is not installed"
fi
step 03-hashgrid "$build/tests/worker/render/test_hashgrid" --bench
# Films (issue 3).
step 04-film "$build/tests/bench_film" 3
# Time against error (issue 5): tables in report.md, plots in docs/plots/.
step 05-convergence bash tests/bench/convergence.sh "$size" "$build"
cp "$build/bench/$size/report.md" "$out/05-convergence-report.md"
# Samplers (issue 21): both samplers side by side, and the goal measured.
step 05b-samplers bash tests/bench/sampler.sh "$build" 2
step 05c-sampler-goal bash tests/bench/sampler_goal.sh "$build"
# The farm (issue 4).
step 06-farm-merge "$build/tests/bench_farm" merge 5
step 07-farm-checkpoint env VF_TEST_VERBOSE=1 "$build/tests/coordinator/test_farm_checkpoint" "$build/vcmfarm"
step 08-farm-workers bash tests/bench/farm.sh "$build" 48 256x256
step 09-render-farm bash tests/bench/render_farm.sh "$build" 40 5 2
step 10-farm-simulated "$build/tests/bench_farm" simulate "$build/vcmfarm" 64 0 512
step 11-farm-simulated-paced "$build/tests/bench_farm" simulate "$build/vcmfarm" 64 1000 512
step 12-scene-files bash tests/bench/scene_files.sh "$build"
# Loading large scenes (issue 40): the showcase and a generated Mitsuba scene.
step 13-scene-load bash tests/bench/scene_load.sh "$build" 3
echo "figures.sh: every figure is in $out/; plots in $([ "$size" = quick ] && echo "$build/bench/quick/plots" || echo docs/plots)"
