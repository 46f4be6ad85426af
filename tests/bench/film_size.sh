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
# OLD_BUILD_DIR (a build of the commit before the exact sums), its own renders of the same
# films are written and read as version 3 by its bench_film right after: the old code's own
# figures (the new build's version 3 includes converting the fixed-point sums to doubles).
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
echo "new build ($build): versions 3 and 4"
"$build/tests/bench_film" "$runs" "$films" "$films/cornell-vcm-1920x1080.exr" "$films/cornell-vcm-3840x2160.exr"
if [ -n "$old" ]; then
  # The old build reads no version 4: it renders the same films itself (the same iterations,
  # its double sums), kept beside the others.
  for size in 1920x1080 3840x2160; do
    film="$films/cornell-vcm-$size.v3.exr"
    [ -f "$film" ] || "$old/vcmfarm" render cornell --direct -R "$size" -n 2 -l 4 -q -o "$film"
  done
  echo "old build ($old): version 3 from double sums"
  VERSIONS=3 "$old/tests/bench_film" "$runs" "$films" "$films/cornell-vcm-1920x1080.v3.exr" \
    "$films/cornell-vcm-3840x2160.v3.exr"
fi
