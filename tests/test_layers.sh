#!/usr/bin/env bash
# The layering rule (docs/ARCHITECTURE.md, "Layers"), checked on the sources:
#   proto/, common/   the bottom: include nothing above them;
#   worker/           includes common/ and proto/, never coordinator/ or cli/;
#   coordinator/      includes common/ and proto/, never worker/ or cli/;
#   cli/              the command-line layer: the only one that sees both roles.
# The libraries keep the same rule: vf_coordinator links no worker code and vf_worker no
# coordinator code, and the third-party libraries of one role stay in it (Embree and Assimp
# in the worker, libuv in the coordinator, cairo in the command line).
#
#   test_layers.sh SOURCE_DIR
set -u
src="$1"
failed=0
fail() { echo "FAIL $*"; failed=1; }

# allowed folders for the quoted includes of each layer
allowed() {
  case "$1" in
  proto) echo "proto" ;;
  common) echo "common proto" ;;
  worker) echo "worker common proto" ;;
  coordinator) echo "coordinator common proto" ;;
  esac
}
# system headers that belong to another layer
forbidden_system() {
  case "$1" in
  proto | common) echo "embree3/ assimp/ uv.h cairo" ;;
  worker) echo "uv.h cairo" ;;
  coordinator) echo "embree3/ assimp/ cairo" ;;
  esac
}

checked=0
for layer in proto common worker coordinator; do
  for file in "$src/$layer"/*.c "$src/$layer"/*.h; do
    [ -e "$file" ] || continue
    checked=$((checked + 1))
    rel=${file#"$src"/}
    while IFS= read -r line; do
      if [[ $line =~ ^[[:space:]]*#[[:space:]]*include[[:space:]]*\"([^\"]+)\" ]]; then
        path=${BASH_REMATCH[1]}
        # generated protobuf code is included as "proto/vcmfarm.pb-c.h" from the build tree
        if [[ $path == proto/* ]]; then
          target=proto
        else
          target=$(realpath -m --relative-to="$src" "$(dirname "$file")/$path")
          target=${target%%/*}
        fi
        ok=0
        for a in $(allowed "$layer"); do [ "$target" = "$a" ] && ok=1; done
        [ "$ok" -eq 1 ] || fail "$rel includes \"$path\": $layer/ may include only $(allowed "$layer")"
      elif [[ $line =~ ^[[:space:]]*#[[:space:]]*include[[:space:]]*\<([^\>]+)\> ]]; then
        path=${BASH_REMATCH[1]}
        for bad in $(forbidden_system "$layer"); do
          [[ $path == "$bad"* ]] && fail "$rel includes <$path>, which belongs to another layer"
        done
      fi
    done <"$file"
  done
done

# The libraries: what each layer's CMakeLists.txt links.
links() { # folder: the words of its target_link_libraries lines
  sed -n '/target_link_libraries/,/)/p' "$src/$1/CMakeLists.txt" | tr -s ' ()' '\n'
}
check_links() { # folder, forbidden words...
  local folder="$1" word
  shift
  for word in "$@"; do
    links "$folder" | grep -qx -- "$word" && fail "$folder/CMakeLists.txt links $word"
  done
}
check_links common vf_worker vf_coordinator vf_cli embree PkgConfig::ASSIMP PkgConfig::LIBUV PkgConfig::CAIRO
check_links worker vf_coordinator vf_cli PkgConfig::LIBUV PkgConfig::CAIRO
check_links coordinator vf_worker vf_cli embree PkgConfig::ASSIMP PkgConfig::CAIRO

[ "$checked" -gt 50 ] || fail "only $checked files found under $src: wrong source directory?"
[ "$failed" -eq 0 ] && echo "ok   test_layers: $checked files of proto/, common/, worker/ and coordinator/ keep the layering rule"
exit "$failed"
