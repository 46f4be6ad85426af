#!/usr/bin/env bash
# `vcmfarm render` against `vcmfarm render --direct` (the same render since render lost its
# in-process farm; --direct is kept for scripts): wall time, CPU time (user + system: less
# sensitive than wall time to other work on the machine) and peak memory (maximum resident
# set), from /usr/bin/time -v, of the same render, in alternated pairs so that the
# machine's drift hits both alike, and the two films compared bit for bit
# (tests/farm/farm_compare.c --exact). With OTHER_BUILD, each pair also times that build's
# `render` (for contrast: a build from before the change rendered through its in-process
# coordinator and worker). Prints a Markdown table and the medians.
#
#   bash tests/bench/render_pairs.sh BUILD [PAIRS] [OTHER_BUILD]     default 5 pairs
#   SCENE, RESOLUTION, ITERATIONS override cornell, 1920x1080, 6.
set -u
build="$1"
pairs="${2:-5}"
other="${3:-}"
scene="${SCENE:-cornell}"
resolution="${RESOLUTION:-1920x1080}"
iterations="${ITERATIONS:-6}"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/renderer_lib.sh" # median

# run LABEL VCMFARM ARGS...: one timed render; appends "WALL_S CPU_S MIB" to $tmp/LABEL.
run() {
  local label="$1" vcmfarm="$2"
  shift 2
  /usr/bin/time -v -o "$tmp/time" "$vcmfarm" render "$scene" -R "$resolution" -n "$iterations" "$@" \
    2>"$tmp/$label.log" || { cat "$tmp/$label.log" "$tmp/time" >&2; exit 1; }
  awk -F': ' '/Elapsed \(wall clock\)/ {n = split($2, t, ":"); s = 0; for (i = 1; i <= n; i++) s = s * 60 + t[i]}
              /User time|System time/ {cpu += $2}
              /Maximum resident set size/ {kb = $2} END {printf "%.2f %.2f %.0f\n", s, cpu, kb / 1024}' \
    "$tmp/time" >>"$tmp/$label"
}
column() { awk -v k="$2" '{print $k}' "$tmp/$1" | median; }

echo "$scene $resolution, $iterations iterations, $(nproc) CPUs ($(lscpu | sed -n 's/^Model name: *//p' | head -n 1)), $pairs pairs"
echo "load average at the start: $(cut -d' ' -f1-3 /proc/loadavg)"
echo
header="| pair | render wall s | CPU s | MiB | --direct wall s | CPU s | MiB |"
[ -n "$other" ] && header="$header other build's render wall s | CPU s | MiB |"
header="$header load |"
echo "$header"
echo "$header" | sed 's/[^|]*|/---|/g; s/^---//'
for pair in $(seq "$pairs"); do
  # Alternated within the pairs too: odd pairs start with render, even ones with --direct.
  if [ $((pair % 2)) -eq 1 ]; then
    run render "$build/vcmfarm" -o "$tmp/render.exr"
    run direct "$build/vcmfarm" --direct -o "$tmp/direct.exr"
  else
    run direct "$build/vcmfarm" --direct -o "$tmp/direct.exr"
    run render "$build/vcmfarm" -o "$tmp/render.exr"
  fi
  "$build/tests/farm_compare" --exact "$tmp/render.exr" "$tmp/direct.exr" "[0,$iterations)" >"$tmp/compare" ||
    { cat "$tmp/compare" >&2; exit 1; }
  cells() { tail -n 1 "$tmp/$1" | sed 's/ / | /g'; }
  line="| $pair | $(cells render) | $(cells direct) |"
  if [ -n "$other" ]; then
    run other "$other/vcmfarm" -o "$tmp/other.exr"
    line="$line $(cells other) |"
  fi
  echo "$line $(cut -d' ' -f1 /proc/loadavg) |"
done
echo
medians() { printf "%s s wall, %s s CPU, %s MiB" "$(column "$1" 1)" "$(column "$1" 2)" "$(column "$1" 3)"; }
printf "medians: render %s; --direct %s" "$(medians render)" "$(medians direct)"
[ -n "$other" ] && printf "; other build's render %s" "$(medians other)"
echo
echo "films of render and --direct: equal bit for bit in every pair"
