# The renderer benchmarks' common measurements, sourced by renderer.sh, raw_ratio.sh and
# renderer_ab.sh so that they set a render against the same raw rate, measured the same way.

# The median of the numbers on standard input, one per line.
median() { sort -g | awk '{v[NR] = $1} END {print v[int((NR + 1) / 2)]}'; }

# bench_embree on SCENE with 2 threads and 2M rays per kind, into FILE:
#   raw_bench BUILD SCENE FILE
raw_bench() { "$1/tests/bench_embree" "$2" 2 2000000 >"$3"; }

# The single-ray mix (the raw rate issue 2 names) and the packet mix from raw_bench's FILE.
raw_mix() { sed -n 's/.*mix 15% .*: \([0-9.]*\) Mrays\/s.*/\1/p' "$1"; }
packet_mix() { sed -n 's/.*packet mix: \([0-9.]*\) Mrays\/s.*/\1/p' "$1"; }

# One render as the benchmarks time it: RESOLUTION (default 512x512), max path length 10,
# 2 threads, --direct, the film written only at the end (--checkpoint-interval 0); its
# report into LOG. The renderer's rate, as the raw rate's, leaves film writes out: a
# checkpoint due within the few iterations timed here (the first comes after 10 s) would
# weigh several times its share of a long render, where the default interval holds all of
# them to about 1% (cli/options.h; docs/BENCHMARKS.md, "Checkpoints at production size"):
#   [RESOLUTION=WxH] render_bench BUILD SCENE ALGORITHM ITERATIONS FILM LOG
render_bench() {
  "$1/vcmfarm" render "$2" --direct -a "$3" -n "$4" -j 2 -R "${RESOLUTION:-512x512}" -l 10 --checkpoint-interval 0 -o "$5" 2>"$6"
}

# "IT/S MRAYS/S" after the first iteration (the steady rate), from render_bench's LOG.
steady_rates() {
  sed -n 's/^after the first iteration: \([0-9.]*\) it\/s, \([0-9.]*\) Mrays\/s.*/\1 \2/p' "$1"
}
