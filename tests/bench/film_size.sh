#!/usr/bin/env bash
# Film files before (format version 1) and after (version 2): bytes per pixel, write and
# read seconds of noisy vcm films at 1920x1080 and 3840x2160 (docs/BENCHMARKS.md, "Films").
#
#   bash tests/bench/film_size.sh [BUILD_DIR] [RUNS]       defaults: build 5
#
# The films are real renders, `vcmfarm render cornell --direct -R WxH -n 2 -l 4`, made once
# and kept in BUILD_DIR/bench/films/ (the 4K one takes a few minutes on 2 cores). Each is
# written and read RUNS times in each version by tests/bench/bench_film, in the same
# directory (the build's file system).
set -euo pipefail
build=${1:-build}
runs=${2:-5}
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
"$build/tests/bench_film" "$runs" "$films" "$films/cornell-vcm-1920x1080.exr" "$films/cornell-vcm-3840x2160.exr"
