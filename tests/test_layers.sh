#!/usr/bin/env bash
# The layering rule (docs/ARCHITECTURE.md, "Layers"), checked on the sources and on the
# built libraries, over every .c and .h file of the tree:
#   proto/, common/     the bottom: include nothing above them;
#   worker/scene/       the scene model and loader (vf_scene): common/ and proto/ only;
#   worker/render/      the renderer (vf_render): worker/scene/'s model, common/, proto/;
#   worker/             the daemon (vf_worker): worker/render/, worker/scene/, common/, proto/;
#   coordinator/        (and coordinator/dashboard/) common/ and proto/, never worker/;
#   cli/                the command-line layer: the only one that sees both roles.
# System headers stay with their role: Embree in the renderer; cJSON, Assimp, expat and the
# image decoders in the scene library; libuv and libmicrohttpd in the coordinator; cairo in the
# command line. The built libraries keep the same rule by their undefined symbols: the
# renderer references no cJSON, Assimp, PNG, JPEG or nanomsg symbol, the scene library no
# Embree symbol, the coordinator no worker code; the program links none of the libraries
# its modules wrap (common/module.h); and no two files of the scene library
# call each other, directly or round a cycle. Every folder opens its CMakeLists.txt with a
# comment naming its role.
#
#   test_layers.sh SOURCE_DIR BUILD_DIR
set -u
src="$1"
build="${2:-}"
failed=0
fail() { echo "FAIL $*"; failed=1; }

# The layer of a file or folder path relative to src: the deepest named one it is under.
layer_of() {
  case "$1" in
  worker/render | worker/render/*) echo worker/render ;;
  worker/scene | worker/scene/*) echo worker/scene ;;
  worker | worker/*) echo worker ;;
  coordinator | coordinator/*) echo coordinator ;;
  common | common/*) echo common ;;
  proto | proto/*) echo proto ;;
  cli | cli/*) echo cli ;;
  *) echo other ;;
  esac
}
# the layers each layer's quoted includes may reach
allowed() {
  case "$1" in
  proto) echo "proto" ;;
  common) echo "common proto" ;;
  worker/scene) echo "worker/scene common proto" ;;
  worker/render) echo "worker/render worker/scene common proto" ;;
  worker) echo "worker worker/render worker/scene common proto" ;;
  coordinator) echo "coordinator common proto" ;;
  cli) echo "cli worker worker/render worker/scene coordinator common proto" ;;
  esac
}
# system headers that belong to another layer
forbidden_system() {
  case "$1" in
  proto | common) echo "embree3/ assimp/ jpeglib.h expat.h uv.h cairo microhttpd.h" ;;
  worker/scene) echo "embree3/ nanomsg/ uv.h cairo microhttpd.h" ;;
  worker/render) echo "assimp/ cjson/ png.h jpeglib.h expat.h nanomsg/ uv.h cairo microhttpd.h" ;;
  worker) echo "embree3/ assimp/ png.h jpeglib.h expat.h uv.h cairo microhttpd.h" ;;
  coordinator) echo "embree3/ assimp/ png.h jpeglib.h expat.h cairo" ;;
  cli) echo "embree3/ assimp/ expat.h uv.h microhttpd.h" ;;
  esac
}

checked=0
while IFS= read -r -d '' file; do
  rel=${file#"$src"/}
  layer=$(layer_of "$rel")
  checked=$((checked + 1))
  while IFS= read -r line; do
    if [[ $line =~ ^[[:space:]]*#[[:space:]]*include[[:space:]]*\"([^\"]+)\" ]]; then
      path=${BASH_REMATCH[1]}
      # generated protobuf code is included as "proto/vcmfarm.pb-c.h" from the build tree
      if [[ $path == proto/* ]]; then
        target=proto
      else
        target=$(layer_of "$(realpath -m --relative-to="$src" "$(dirname "$file")/$path")")
      fi
      ok=0
      for a in $(allowed "$layer"); do [ "$target" = "$a" ] && ok=1; done
      [ "$ok" -eq 1 ] || fail "$rel includes \"$path\" ($target/): $layer/ may include only $(allowed "$layer")"
    elif [[ $line =~ ^[[:space:]]*#[[:space:]]*include[[:space:]]*\<([^\>]+)\> ]]; then
      path=${BASH_REMATCH[1]}
      for bad in $(forbidden_system "$layer"); do
        [[ $path == "$bad"* ]] && fail "$rel includes <$path>, which belongs to another layer"
      done
    fi
  done <"$file"
done < <(find "$src/proto" "$src/common" "$src/worker" "$src/coordinator" "$src/cli" -type f \( -name '*.c' -o -name '*.h' \) -print0)

# Every file counted: the walk above must see exactly the tree's sources.
expected=$(find "$src/proto" "$src/common" "$src/worker" "$src/coordinator" "$src/cli" -type f \( -name '*.c' -o -name '*.h' \) | wc -l)
[ "$checked" -eq "$expected" ] || fail "checked $checked files of $expected"
[ "$checked" -gt 150 ] || fail "only $checked files found under $src: wrong source directory?"

# Every source folder says what it is, in the first line of its CMakeLists.txt.
while IFS= read -r -d '' dir; do
  ls "$dir"/*.c "$dir"/*.h >/dev/null 2>&1 || continue
  rel=${dir#"$src"/}
  if [ ! -f "$dir/CMakeLists.txt" ]; then
    fail "$rel/ has sources but no CMakeLists.txt naming its role"
  elif ! head -1 "$dir/CMakeLists.txt" | grep -q '^# '; then
    fail "$rel/CMakeLists.txt does not open with a comment naming the folder's role"
  fi
done < <(find "$src/proto" "$src/common" "$src/worker" "$src/coordinator" "$src/cli" -type d -print0)

# The libraries: what each folder's CMakeLists.txt links.
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
check_links common vf_worker vf_render vf_scene vf_coordinator vf_cli embree PkgConfig::ASSIMP PkgConfig::LIBUV PkgConfig::CAIRO
check_links worker/scene vf_render vf_worker vf_coordinator vf_cli embree PkgConfig::NANOMSG PkgConfig::LIBUV PkgConfig::CAIRO
check_links worker/render vf_worker vf_coordinator vf_cli PkgConfig::CJSON PkgConfig::ASSIMP PkgConfig::PNG PkgConfig::JPEG PkgConfig::NANOMSG PkgConfig::LIBUV PkgConfig::CAIRO
check_links worker vf_coordinator vf_cli PkgConfig::LIBUV PkgConfig::CAIRO
check_links coordinator vf_worker vf_render vf_scene vf_cli embree PkgConfig::ASSIMP PkgConfig::CAIRO

# The built libraries, by the symbols their objects leave undefined.
if [ -n "$build" ]; then
  undefined() { # library path: the symbols its objects need from outside it
    comm -23 <(nm -u "$1" 2>/dev/null | awk 'NF >= 2 && $(NF-1) == "U" {print $NF}' | sort -u) \
      <(nm --defined-only "$1" 2>/dev/null | awk 'NF == 3 {print $3}' | sort -u)
  }
  check_symbols() { # library, description, regex of forbidden symbols
    local lib="$build/$1" bad
    if [ ! -f "$lib" ]; then
      fail "$lib not built"
      return
    fi
    bad=$(undefined "$lib" | grep -E "$3" | head -5 | tr '\n' ' ')
    [ -z "$bad" ] || fail "$1 references $2 symbols: $bad"
  }
  check_symbols worker/render/libvf_render.a "cJSON, Assimp, PNG, JPEG, expat or nanomsg" '^(cJSON_|ai[A-Z]|png_|jpeg_|XML_|nn_)'
  check_symbols worker/scene/libvf_scene.a "Embree or nanomsg" '^(rtc[A-Z]|nn_)'
  check_symbols coordinator/libvf_coordinator.a "Embree, Assimp or worker" '^(rtc[A-Z]|ai[A-Z]|vf_(vcm|accel|bsdf|scene|worker|render)_)'
  check_symbols common/libvf_common.a "Embree, Assimp, libuv or worker" '^(rtc[A-Z]|ai[A-Z]|uv_|vf_(vcm|accel|bsdf|scene|worker|render)_)'

  # The program links none of the libraries its modules wrap (common/module.h): a command
  # loads Embree, Assimp, cairo, libmicrohttpd or OpenVDB only when it uses them.
  if [ -f "$build/vcmfarm" ]; then
    needed=$(objdump -p "$build/vcmfarm" | awk '/NEEDED/ {print $2}' | grep -E '^lib(embree|assimp|cairo|microhttpd|openvdb|tbb)' | tr '\n' ' ')
    [ -z "$needed" ] || fail "vcmfarm links $needed(modules' libraries, common/module.h)"
  else
    fail "$build/vcmfarm not built"
  fi

  # No call cycle among the scene library's files: an edge a -> b when an object of a
  # leaves undefined a symbol that b defines.
  cycle=$(nm -A "$build/worker/scene/libvf_scene.a" 2>/dev/null | python3 -c '
import re, sys
defs, uses = {}, {}
for line in sys.stdin:
    m = re.match(r"[^:]*:([^:]*):\s*[0-9a-f]*\s+(\w)\s+(\S+)$", line.rstrip())
    if not m:
        continue
    obj, kind, sym = m.groups()
    obj = obj.replace(".c.o", ".c")
    if kind in "TDBRV":
        defs[sym] = obj
    elif kind == "U":
        uses.setdefault(obj, set()).add(sym)
graph = {o: {defs[s] for s in ss if s in defs and defs[s] != o} for o, ss in uses.items()}
state = {}
def visit(node, path):
    state[node] = 1
    for nxt in sorted(graph.get(node, ())):
        if state.get(nxt) == 1:
            return path[path.index(nxt):] + [nxt] if nxt in path else path + [nxt]
        if nxt not in state:
            found = visit(nxt, path + [nxt])
            if found:
                return found
    state[node] = 2
    return None
for node in sorted(graph):
    if node not in state:
        found = visit(node, [node])
        if found:
            print(" -> ".join(found))
            break
print("objects", len(defs) and len(set(defs.values())), file=sys.stderr)
' 2>"$build/.layers_objects")
  [ -z "$cycle" ] || fail "worker/scene/ files call each other round a cycle: $cycle"
  objects=$(awk '{print $2}' "$build/.layers_objects")
  rm -f "$build/.layers_objects"
  [ "${objects:-0}" -gt 10 ] || fail "the scene library's call graph has only ${objects:-0} objects: not built?"
fi

[ "$failed" -eq 0 ] && echo "ok   test_layers: $checked files of proto/, common/, worker/, coordinator/ and cli/ keep the layering rule"
exit "$failed"
