#!/usr/bin/env bash
# Film files in the format before the exact sums (version 3: 48-bit hi/lo float pairs) and
# after (version 4: exact fixed-point sums): bytes per pixel, write and read seconds of noisy
# vcm films at 1920x1080 and 3840x2160 (docs/BENCHMARKS.md, "Films: exact sums").
#
#   bash tests/bench/film_size.sh [BUILD_DIR] [RUNS] [OLD_BUILD_DIR]    defaults: build 5
#
# The films are real renders, `vcmfarm render cornell --direct -R WxH -n 2 -l 4`, made once
# and kept in BUILD_DIR/bench/films/ (the 4K one takes a few minutes on 2 cores). Each is
# written and read RUNS times in each version by BUILD_DIR's tests/bench_film, the versions
# alternating run by run, in the same directory (the build's file system). With
# OLD_BUILD_DIR (a build of the commit before the exact sums, with this bench_film.c), its
# own renders of the same films are written and read as version 3 by its bench_film, one
# run of each build in turn so that both see the machine's load alike: the old code's own
# figures (the new build's version 3 includes converting the fixed-point sums to doubles).
# Prints the medians per build, film and version.
set -euo pipefail
build=${1:-build}
runs=${2:-5}
old=${3:-}
films="$build/bench/films"
mkdir -p "$films"
for size in 1920x1080 3840x2160; do
  film="$films/cornell-vcm-$size.exr"
  if [ ! -f "$film" ]; then
    echo "rendering $film" >&2
    "$build/vcmfarm" render cornell --direct -R "$size" -n 2 -l 4 -q -o "$film"
  fi
done
lscpu | grep "Model name" || true
nproc
if [ -z "$old" ]; then
  "$build/tests/bench_film" "$runs" "$films" "$films/cornell-vcm-1920x1080.exr" "$films/cornell-vcm-3840x2160.exr"
  exit 0
fi
# The old build reads no version 4: it renders the same films itself (the same iterations,
# its double sums), kept beside the others.
for size in 1920x1080 3840x2160; do
  film="$films/cornell-vcm-$size.v3.exr"
  [ -f "$film" ] || "$old/vcmfarm" render cornell --direct -R "$size" -n 2 -l 4 -q -o "$film"
done
# One run of each build in turn, RUNS times, so that both see the machine's load alike;
# then the median of each figure per build, film and version.
uptime
for run in $(seq "$runs"); do
  "$build/tests/bench_film" 1 "$films" "$films/cornell-vcm-1920x1080.exr" "$films/cornell-vcm-3840x2160.exr" |
    grep '^| cornell' | sed 's/^/new /'
  VERSIONS=3 "$old/tests/bench_film" 1 "$films" "$films/cornell-vcm-1920x1080.v3.exr" \
    "$films/cornell-vcm-3840x2160.v3.exr" | grep '^| cornell' | sed 's/^/old /'
done | tee "$films/runs.txt"
uptime
python3 - "$films/runs.txt" <<'PY'
import re, statistics, sys
rows = {}
for line in open(sys.argv[1]):
    build, rest = line.split(" ", 1)
    f = [c.strip() for c in rest.strip().strip("|").split("|")]
    size, version, mb, bpp = f[1], f[2], float(f[3]), float(f[4])
    w = re.match(r"([\d.]+) \(([\d.]+)\)", f[5]); r = re.match(r"([\d.]+) \(([\d.]+)\)", f[6])
    rows.setdefault((size, build, version), []).append((mb, bpp, float(w[1]), float(w[2]), float(r[1]), float(r[2])))
print("| size | build | version | MB | bytes/px | write s | read s |")
print("|---|---|---|---|---|---|---|")
for (size, build, version), v in sorted(rows.items(), key=lambda k: (k[0][0] != "1920x1080", k[0][1] != "old", k[0][2])):
    m = [statistics.median(x[i] for x in v) for i in range(6)]
    print(f"| {size} | {build} | {version} | {m[0]:.1f} | {m[1]:.2f} | {m[2]:.2f} ({m[3]:.2f}) | {m[4]:.2f} ({m[5]:.2f}) |")
print(f"medians of {len(v)} runs; seconds of wall time (process CPU time, all threads)")
PY
