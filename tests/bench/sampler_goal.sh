#!/usr/bin/env bash
# Issue 21's goal, measured rather than extrapolated: pt on cornell-diffuse at 64 x 64 to a
# relative RMSE of 0.02 with each sampler, three seeds, the samplers interleaved:
#
#     bash tests/bench/sampler_goal.sh [BUILD_DIR]
#
# Independent numbers need about 6,000 iterations there, so they run 8192; the sobol
# sampler 2048. Uses sampler.sh's reference (run that first) and prints the table of
# sampler_report.py for these films.
set -euo pipefail
build=$(cd "${1:-build}" && pwd)
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
out=$build/bench/sampler-goal
mkdir -p "$out"
cp -f "$build/bench/sampler/ref-cornell-diffuse.exr" "$out/"
for rep in 1 2 3; do
  for sampler in independent sobol; do
    n=8192; [ $sampler = sobol ] && n=2048
    "$build/vcmfarm" render cornell-diffuse --direct -j 1 -R 64x64 -r 0.024 -q -a pt -s $((rep * 1000 + 7)) \
      --sampler $sampler -n $n --reference "$out/ref-cornell-diffuse.exr" --checkpoint-interval 0.25 \
      -o "$out/cornell-diffuse-pt-$sampler-$rep.exr"
  done
done
python3 "$here/sampler_report.py" "$build/vcmfarm" "$out" cornell-diffuse pt 3
"$build/vcmfarm" plot "$out/cornell-diffuse-pt-independent-1.exr" "$out/cornell-diffuse-pt-sobol-1.exr" \
  -o "$here/../../docs/plots/sampler-goal.png"
