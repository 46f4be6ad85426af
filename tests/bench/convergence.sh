#!/usr/bin/env bash
# Time against error (issue 5, docs/BENCHMARKS.md "Time against error"):
#
#     bash tests/bench/convergence.sh quick|medium|full [BUILD_DIR]
#
# For every scene of the suite and every algorithm (vcm, bpt, pt, ppm, auto) it renders for
# a fixed wall time (`render --direct`: the render loop alone, no in-process farm) with
# --reference and --checkpoint-interval, so each film's convergence
# log holds its error against the reference over wall time and iterations. Then it prints
# (and writes to BUILD_DIR/bench/SIZE/report.md) the tables of docs/BENCHMARKS.md: time to
# fixed relative-RMSE targets and fitted convergence slopes, and draws one log-log plot per
# scene with `vcmfarm plot`. `medium` and `full` write their plots to docs/plots/; `quick`
# keeps its own in BUILD_DIR/bench/quick/plots/, so a smoke run never touches the committed
# figures.
#
# References are made here, never by hand: a long run of an algorithm other than the
# measured ones' family where one exists (bpt; vcm where only merging reaches every path,
# see below), with another seed, cached in BUILD_DIR/bench/cache/ under a name that holds
# the scene's content hash, the resolution and the reference's length. Their own noise (the
# film's no-reference estimate, docs/FILM.md) is reported and subtracted in the tables.
#
# `quick` is the CI smoke test (a few minutes): it checks loosely that every run wrote a
# film with a finite, falling error and no non-finite sample, and exits 1 otherwise.
set -euo pipefail

size=${1:-}
build=${2:-build}
[ -d "$build" ] && build=$(cd "$build" && pwd) # absolute: the references are linked from $out
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(cd "$here/../.." && pwd)
vcmfarm=$build/vcmfarm
source "$here/reference_lib.sh"

# SCENES="a b" limits a run to some of them (for example to redo one scene's figures).
scenes=${SCENES:-"cornell cornell-point cornell-sun cornell-env knot cornell-bulb cornell-diffuse cornell-glossy"}
algorithms=${ALGORITHMS:-"vcm bpt pt ppm auto"} # ALGORITHMS="a b" limits them
case "$size" in
  # resolution, seconds per measured run, seconds per reference, checkpoint interval
  quick)  res=64;  run_s=0.5; ref_s=2;  every=0.1 ;;
  medium) res=128; run_s=8;  ref_s=32;  every=0.25 ;;
  full)   res=128; run_s=30; ref_s=150; every=0.5 ;;
  *) echo "usage: bash tests/bench/convergence.sh quick|medium|full [BUILD_DIR]" >&2; exit 2 ;;
esac
[ -x "$vcmfarm" ] || { echo "convergence.sh: no $vcmfarm (build first, or pass BUILD_DIR)" >&2; exit 2; }

# The default radius factor 0.003 is set for 512 x 512: scaled by 512/res the radius keeps
# its size in pixels and its expected number of light vertices (n_VM r^2 is unchanged).
radius=$(awk -v r="$res" 'BEGIN { printf "%.6g", 0.003 * 512 / r }')
out=$build/bench/$size
cache=$build/bench/cache
plots=$out/plots
[ "$size" != quick ] && plots=$root/docs/plots
mkdir -p "$out" "$cache" "$plots"
common=(-R "${res}x${res}" -r "$radius")

# Delta lights next to specular surfaces make SDS paths (L S D S E) that no unbiased
# technique of ours samples (paper sec. 6.1, "Limitations"): their reference must merge.
# The lamp in glass of cornell-bulb sends all its light through glass: bpt reaches the room
# seen in the mirror only by chance emission hits, and a bpt reference stays noisy exactly
# where vcm and bpt differ (0.061 relative RMSE after 150 s), and favours bpt, whose runs
# miss the same paths. Its reference is bpm (merging and light tracing only: measured by
# none of the runs) and twelve times longer.
reference_algorithm() {
  case "$1" in cornell-point|cornell-sun) echo vcm ;; cornell-bulb) echo bpm ;; *) echo bpt ;; esac
}
reference_seconds() {
  case "$1" in cornell-bulb) [ "$size" = quick ] && echo "$ref_s" || echo $((12 * ref_s)) ;; *) echo "$ref_s" ;; esac
}
alpha_of() { [ "$1" = ppm ] && echo 0.6666666666666666 || echo 0.75; }

echo "convergence.sh $size: ${res}x${res}, ${run_s} s per run, references ${ref_s} s, radius factor $radius"
for scene in $scenes; do
  ref=$(cached_reference "$vcmfarm" "$cache" "$scene" "$(reference_algorithm "$scene")" \
    "$(reference_seconds "$scene")" "$res" "${common[@]}")
  ln -sf "$ref" "$out/$scene-reference.exr"
  for a in $algorithms; do
    echo "  $scene: $a for $run_s s"
    "$vcmfarm" render "$scene" --direct -a "$a" --alpha "$(alpha_of "$a")" -t "$run_s" --checkpoint-interval "$every" \
      --reference "$ref" "${common[@]}" -o "$out/$scene-$a.exr" 2> "$out/$scene-$a.log" ||
      { cat "$out/$scene-$a.log" >&2; exit 1; }
  done
  files=()
  for a in $algorithms; do files+=("$out/$scene-$a.exr"); done
  "$vcmfarm" plot "${files[@]}" -o "$plots/$scene.png" --x both
done

check=()
[ "$size" = quick ] && check=(--check)
python3 "$here/convergence_report.py" "$vcmfarm" "$out" "$size" "$scenes" "$algorithms" "${check[@]}" |
  tee "$out/report.md"
