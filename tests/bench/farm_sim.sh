#!/bin/bash
# The simulated farm of docs/BENCHMARKS.md ("A coordinator for 1000 workers"): WORKERS
# simulated workers (default 1000) against a real coordinator, rendering a 1920x1080 job
# and then a 3840x2160 one for SECONDS each (default 300), `bench_farm simulate --film`.
#
#   bash tests/bench/farm_sim.sh BUILD [WORKERS [SECONDS]]
#
# The constants, measured on this machine and named in docs/BENCHMARKS.md:
#   ITERATION_1080, ITERATION_2160  seconds per vcm iteration of cornell (default
#                     settings) on one 2-core worker: 1 / the steady it/s that
#                     `vcmfarm render cornell --direct -R WxH -n 3` prints (median of 3)
#   ENCODE_1080, ENCODE_2160  seconds a worker's render threads wait while a part is
#                     encoded and framed ("worker (encode, frame)" of `bench_farm merge`)
# The jobs' films are real renders (`render --direct -n 1`), made once into BUILD/bench/.
set -eu
build=${1:?usage: farm_sim.sh BUILD [WORKERS [SECONDS]]}
workers=${2:-1000}
seconds=${3:-300}
: "${ITERATION_1080:=4.3}" "${ITERATION_2160:=17.5}" "${ENCODE_1080:=0.30}" "${ENCODE_2160:=1.2}"
mkdir -p "$build/bench"
for size in 1920x1080 3840x2160; do
  film="$build/bench/sim-$size.exr"
  [ -s "$film" ] || "$build/vcmfarm" render cornell --direct -R "$size" -n 1 -q -o "$film"
done
"$build/tests/bench_farm" simulate "$build/vcmfarm" --film "$build/bench/sim-1920x1080.exr" "$workers" "$seconds" \
  "$ITERATION_1080" "$ENCODE_1080"
"$build/tests/bench_farm" simulate "$build/vcmfarm" --film "$build/bench/sim-3840x2160.exr" "$workers" "$seconds" \
  "$ITERATION_2160" "$ENCODE_2160"
