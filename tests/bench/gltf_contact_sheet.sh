#!/usr/bin/env bash
# A contact sheet of every glTF file of Debian's assimp-testmodels (/usr/share/assimp/
# models/glTF2): each file rendered as it is (default camera and light where it has none)
# at 160x120, in path order, four to a row; the files vcmfarm refuses listed with the
# reason, one a line, in OUT.txt. Writes OUT.png and OUT.txt.
#
#   gltf_contact_sheet.sh VCMFARM OUT [ITERATIONS]
set -u
vcmfarm="$1"
out="$2"
iterations="${3:-64}"
root=/usr/share/assimp/models/glTF2
[ -d "$root" ] || { echo "$root not installed (apt-get install assimp-testmodels)"; exit 77; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
: >"$out.txt"
cells=()
k=0
while IFS= read -r file; do
  k=$((k + 1))
  name=${file#"$root"/}
  if "$vcmfarm" render "$file" -R 160x120 -n "$iterations" -q -o "$tmp/$k.exr" --preview "$tmp/$k.png" 2>"$tmp/err"; then
    cells+=("$tmp/$k.png")
    echo "rendered  $name" >>"$out.txt"
  else
    echo "refused   $name: $(grep 'vcmfarm render:' "$tmp/err" | sed 's/^vcmfarm render: //' | head -1)" >>"$out.txt"
  fi
done < <(find "$root" \( -name '*.gltf' -o -name '*.glb' \) | sort)
python3 "$(dirname "$0")/contact_sheet.py" "$out.png" 4 "${cells[@]}"
echo "$(grep -c ^rendered "$out.txt") rendered, $(grep -c ^refused "$out.txt") refused: $out.png, $out.txt"
