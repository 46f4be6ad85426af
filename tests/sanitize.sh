#!/usr/bin/env bash
# The test suite again, built with AddressSanitizer (its leak check on) and
# UndefinedBehaviorSanitizer, in build-sanitize/: an out-of-bounds access, a use after
# free, a leak or undefined behaviour anywhere a test reaches ends that test with the
# report. .ci/run runs it after the README's test command.
#
#   bash tests/sanitize.sh
#
# Left out: test_docker, which checks that the container's runtime stage holds every
# library the release binary links, and a sanitized binary links the sanitizers'; test_fuzz,
# whose targets are built with the sanitizers in a clang build of their own whichever build
# runs it; bench_convergence_quick, a benchmark's smoke test that renders for a fixed wall
# time (the renderer's paths run sanitized in test_vcm, test_render, test_surface and
# test_stress); test_layers and test_k8s, which run no code of ours (the sources' includes
# and the libraries' symbols; the manifests against Kubernetes' schemas) and would say here
# what they said in the release pass. test_vcm runs its agreement with the default sampler
# only here, and test_film_tools_cli reads each damaged file with a third of its readers
# (VF_CORPUS_STRIDE: a sanitized process costs about 125 ms to start, a release one 45).
# tests/lsan.supp names the leaks not ours (fontconfig's caches, through cairo; OpenVDB on a
# damaged file); the summary of suppressions used stays off, so that commands whose stderr
# a test reads line by line (test_cli) print only their own lines.
#
#   bash tests/sanitize.sh [--build-only]   # --build-only: configure and build, run nothing
set -euo pipefail
cd "$(dirname "$0")/.."
flags="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer"
cmake -S . -B build-sanitize -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_FLAGS="$flags" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined"
cmake --build build-sanitize -j2
[ "${1:-}" = --build-only ] && exit 0
LSAN_OPTIONS="suppressions=$PWD/tests/lsan.supp:print_suppressions=0" ASAN_OPTIONS="detect_leaks=1" \
  UBSAN_OPTIONS="print_stacktrace=1" VF_CORPUS_STRIDE=3 \
  ctest --test-dir build-sanitize -j2 --output-on-failure \
  -E '^(test_docker|test_fuzz|bench_convergence_quick|test_layers|test_k8s)$'
