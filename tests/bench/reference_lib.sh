# Long reference renders for the time-against-error benchmarks (convergence.sh,
# mis_beta.sh), sourced. A reference is cached in CACHE under a name that holds the scene's
# content hash, the algorithm, the resolution and its length, so a changed scene never
# meets a stale reference and the scripts share what they made.
#
#   ref=$(cached_reference VCMFARM CACHE SCENE ALGORITHM SECONDS RES RENDER_OPTIONS...)
#
# RES names the (square) resolution in the file name; RENDER_OPTIONS (-R, -r, ...) are
# passed to both renders. --direct keeps an older build from going through its in-process
# farm; a newer one renders the same without it.
cached_reference() {
  local vcmfarm="$1" cache="$2" scene="$3" algorithm="$4" seconds="$5" res="$6"
  shift 6
  local probe hash ref
  probe=$(mktemp -u "$cache/probe-XXXXXX.exr")
  # One iteration to learn the scene's content hash.
  "$vcmfarm" render "$scene" --direct -a pt -n 1 "$@" -q -o "$probe"
  hash=$("$vcmfarm" info --json "$probe" | jq -r .scene_hash | cut -c1-16)
  rm -f "$probe"
  ref=$cache/ref-$(basename "$scene")-$hash-$algorithm-$res-${seconds}s.exr # a file's scene by its name
  if [ ! -f "$ref" ]; then
    echo "  $scene: reference, $algorithm for $seconds s" >&2
    "$vcmfarm" render "$scene" --direct -a "$algorithm" -s 1000 -t "$seconds" --checkpoint-interval 0 "$@" -q \
      -o "$ref"
  fi
  echo "$ref"
}
