#!/usr/bin/env bash
# Issue 41: a film is the same bit for bit however its iterations were rendered. `continue`
# (which reads its film back) and `render` with checkpoints every few milliseconds give the
# film of `render --direct` of the same iterations, compared with farm_compare --exact
# (every fixed-point sum equal). With the 48-bit hi/lo storage of format 3, continuing read
# the film back rounded and the 3000 + 3000 film differed from the 6000 one in hundreds of
# values.
#
#   test_exact.sh VCMFARM FARM_COMPARE
set -u
vcmfarm="$1"
compare="$2"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
passed=0
failed=0
check() { # name, command...
  local name="$1"
  shift
  if "$@" >"$tmp/out" 2>&1; then
    passed=$((passed + 1))
    echo "ok   $name"
  else
    failed=$((failed + 1))
    echo "FAIL $name"
    sed 's/^/    /' "$tmp/out"
  fi
}
r=(cornell -R 16x16 --seed 7 -j 1 -q)

"$vcmfarm" render "${r[@]}" --direct -n 6000 -o "$tmp/direct6000.exr" || exit 1
"$vcmfarm" render "${r[@]}" -n 3000 -o "$tmp/continued.exr" || exit 1
"$vcmfarm" continue "$tmp/continued.exr" -n 3000 -j 1 -q || exit 1
check "continue 3000 + 3000 equals --direct 6000 bit for bit" \
  "$compare" --exact "$tmp/continued.exr" "$tmp/direct6000.exr" "[0,6000)"

# A film with an allocation of camera sub-paths from its pilot (common/allocation.h): the
# continued film keeps it and is the one-go film.
"$vcmfarm" render "${r[@]}" --pilot 4 --direct -n 40 -o "$tmp/pilot40.exr" || exit 1
"$vcmfarm" render "${r[@]}" --pilot 4 -n 15 -o "$tmp/pilot15.exr" || exit 1
"$vcmfarm" continue "$tmp/pilot15.exr" -n 25 -j 1 -q || exit 1
check "a pilot's film: continue 15 + 25 equals --direct 40 bit for bit" \
  "$compare" --exact "$tmp/pilot15.exr" "$tmp/pilot40.exr" "[0,40)"
# auto with a pilot chooses by the candidates' pilots (vf_render_choose_algorithm), and the
# film is the chosen algorithm's with the allocation the choice made (its own pilot's, or
# merging per pixel), bit for bit.
"$vcmfarm" render cornell-glossy -R 16x16 --seed 7 -j 1 -a auto --pilot 4 -n 6 -o "$tmp/auto.exr" 2>"$tmp/auto.err" || exit 1
chosen=$("$vcmfarm" info --json "$tmp/auto.exr" | jq -r .algorithm)
check "auto with a pilot reports its choice and the film names it" \
  grep -Eq "^auto: pilots of 4 iterations .*; chose $chosen( merging in [0-9.]+% of pixels)?$" "$tmp/auto.err"
"$vcmfarm" render cornell-glossy -R 16x16 --seed 7 -j 1 -a "$chosen" --allocation-from "$tmp/auto.exr" -n 6 -q \
  -o "$tmp/chosen.exr" || exit 1
check "auto with a pilot: the film of the algorithm it chose ($chosen), bit for bit" \
  "$compare" --exact "$tmp/auto.exr" "$tmp/chosen.exr" "[0,6)"

# Many checkpoints, each a write of the whole film, and a continue in four steps.
"$vcmfarm" render "${r[@]}" -a bpt --direct -n 2000 -o "$tmp/direct2000.exr" || exit 1
"$vcmfarm" render "${r[@]}" -a bpt -n 500 --checkpoint-interval 0.001 -o "$tmp/steps.exr" || exit 1
for step in 1 2 3; do "$vcmfarm" continue "$tmp/steps.exr" -n 500 -j 1 -q --checkpoint-interval 0.001 || exit 1; done
check "bpt: render and three continues of 500 iterations, checkpointed often, equal --direct 2000 bit for bit" \
  "$compare" --exact "$tmp/steps.exr" "$tmp/direct2000.exr" "[0,2000)"

# Another seed, the sobol sampler (whose square_sum holds replicate sums), continued to -o.
s=(cornell -R 16x16 --seed 9 -j 1 -q --sampler sobol)
"$vcmfarm" render "${s[@]}" --direct -n 2000 -o "$tmp/sobol2000.exr" || exit 1
"$vcmfarm" render "${s[@]}" -n 1000 -o "$tmp/sobol_a.exr" || exit 1
"$vcmfarm" continue "$tmp/sobol_a.exr" -n 1000 -j 1 -q -o "$tmp/sobol_b.exr" || exit 1
check "sobol: render 1000 + continue 1000 elsewhere equal --direct 2000 bit for bit" \
  "$compare" --exact "$tmp/sobol_b.exr" "$tmp/sobol2000.exr" "[0,2000)"

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
