#!/usr/bin/env bash
# The fuzz targets of tests/fuzz (libFuzzer, with AddressSanitizer and UBSan), built with
# clang in a build directory of their own and run SECONDS each on a copy of their seed
# corpus (tests/fuzz/corpus/TARGET). A crash, leak, timeout or sanitizer report fails,
# and libFuzzer leaves the input that caused it in the build directory's artifacts/.
# clang comes from deploy/install-deps.sh; without it the test fails, it does not skip.
#
#   test_fuzz.sh SOURCE_DIR BUILD_DIR SECONDS
set -u
src="$1"
build="$2"
seconds="${3:-20}"
fail() { echo "FAIL test_fuzz: $*"; exit 1; }
command -v clang >/dev/null || fail "clang is not installed (bash deploy/install-deps.sh)"
targets="fuzz_message fuzz_film fuzz_texture fuzz_scene fuzz_blob"
# A build directory left by an older configuration (g++ for the C++ file) is made anew.
if [ -f "$build/CMakeCache.txt" ] && ! grep -q '^CMAKE_CXX_COMPILER:.*clang++$' "$build/CMakeCache.txt"; then
  rm -rf "$build"
fi
if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$src" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DVF_FUZZ=ON \
    >"$build.configure.log" 2>&1 || { cat "$build.configure.log"; fail "cannot configure the fuzz build"; }
fi
cmake --build "$build" --target $targets -j2 >"$build.build.log" 2>&1 ||
  { tail -40 "$build.build.log"; fail "cannot build the fuzz targets"; }
# The film reader goes through a file: keep its scratch files in memory.
export TMPDIR=/dev/shm
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$build/artifacts"
# Two targets at a time (each fuzzer is one process on one core; ctest gives this test the
# machine's two): each target's exit status is kept beside its log and read once both are done.
run_target() { # target
  local t="$1"
  mkdir "$work/$t"
  cp "$src/tests/fuzz/corpus/$t"/* "$work/$t"/
  "$build/tests/fuzz/$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$build/artifacts/$t-" "$work/$t" >"$work/$t.log" 2>&1
  echo $? >"$work/$t.status"
}
set -- $targets
while [ $# -gt 0 ]; do
  run_target "$1" &
  [ $# -gt 1 ] && run_target "$2" &
  wait
  shift $(($# > 1 ? 2 : 1))
done
status=0
for t in $targets; do
  if [ "$(cat "$work/$t.status" 2>/dev/null)" = 0 ]; then
    runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$work/$t.log")
    echo "ok   $t: $runs executions in $seconds s, no finding"
  else
    tail -30 "$work/$t.log"
    echo "FAIL $t (inputs in $build/artifacts)"
    status=1
  fi
done
exit $status
