#!/usr/bin/env bash
# The film tools as a user meets them: real renders of split iteration ranges merge into
# the render of all of them, for every algorithm; every damaged EXR (OpenEXR's corpus and
# randomly corrupted copies of a film) is refused by every subcommand that reads one, with
# exit status 2, a message naming the file, no output, no crash and within 5 s; every valid
# RGB image of the corpus serves as a reference for itself; bad command lines are refused.
# Usage: test_film_tools.sh VCMFARM CORPUS_DIR
set -u

# Every subcommand that reads an EXR, one line per way of running it on a damaged file:
# BAD is the damaged file, GOOD a valid film (furnace, 24x16, iterations [2,4)), OUT.ext an
# output that must not be written. To hold another subcommand to the same rules (continue,
# info, plot...), append its line here, e.g. "info BAD" or "plot BAD -o OUT.png".
readers=(
  "merge -q -o OUT.exr GOOD BAD"
  "bake BAD -o OUT.png"
  "errors GOOD BAD"
  "diff BAD GOOD -o OUT.png"
  "continue BAD -n 1 -q -o OUT.exr"
  "continue GOOD --reference BAD -n 1 -q -o OUT.exr"
  "info BAD"
  "info --json BAD"
  "plot BAD -o OUT.png"
)
algorithms="vcm bpt pt lt ppm bpm"
corrupted_copies=100
# VF_CORPUS_STRIDE=K (tests/sanitize.sh sets 3): reader r takes the damaged files and the
# corrupted copies whose index is r modulo K, so that each file is still read by one
# reader in K (3 of the 9), and the sanitized pass, where a process costs three times the
# release's to start, runs a K-th of the ~2,600 processes. The release pass runs them all.
stride=${VF_CORPUS_STRIDE:-1}
case "$stride" in [1-9]) ;; *) echo "VF_CORPUS_STRIDE: '$stride', expected 1 to 9"; exit 2 ;; esac

vcmfarm="$1"
corpus="$2"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
out="$tmp/out"
mkdir -p "$out"
shopt -s nullglob # a glob that matches nothing is nothing (run_reader's files written)
# In sanitizer builds: fontconfig (under cairo's text API, used by diff) keeps a few hundred
# bytes it never frees; that is not ours to fix, and any other leak still fails the test.
echo "leak:libfontconfig.so" >"$tmp/lsan.supp"
export LSAN_OPTIONS="suppressions=$tmp/lsan.supp${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
passed=0
failed=0

check() { # name, result (0 = pass)
  if [ "$2" -eq 0 ]; then passed=$((passed + 1)); echo "ok   $1"; else failed=$((failed + 1)); echo "FAIL $1"; fi
}

# ---- merging real renders equals rendering at once ----

# One number of the object `errors --json` prints: rmse_all for rmse.all, or a top-level
# key such as mean_reference.
json_field() { # json text, field
  case "$2" in
  rmse_all) jq -r .rmse.all <<<"$1" ;;
  *) jq -r ".$2" <<<"$1" ;;
  esac
}

for a in $algorithms; do
  r="$tmp/$a"
  "$vcmfarm" render cornell -a "$a" -R 64x64 -n 2 -k 0 -q -o "$r.0.exr" &&
    "$vcmfarm" render cornell -a "$a" -R 64x64 -n 2 -k 2 -q -o "$r.2.exr" &&
    "$vcmfarm" render cornell -a "$a" -R 64x64 -n 4 -k 0 -q -o "$r.all.exr" &&
    "$vcmfarm" merge -q -o "$r.merged.exr" "$r.2.exr" "$r.0.exr"
  ok=$?
  if [ $ok -eq 0 ]; then
    json=$("$vcmfarm" errors --json "$r.merged.exr" "$r.all.exr")
    rmse=$(json_field "$json" rmse_all)
    mean=$(json_field "$json" mean_reference)
    echo "  $a: merged [0,2)+[2,4) vs [0,4): RMSE $rmse, mean $mean"
    ok=$(awk -v e="$rmse" -v m="$mean" 'BEGIN { print (m > 0 && e <= 1e-5 * m) ? 0 : 1 }')
  fi
  check "$a: merge of [0,2) and [2,4) equals the render of [0,4)" "$ok"
done

# three pieces, in any order, and a film baked and compared with its source
r="$tmp/vcm"
"$vcmfarm" render cornell -R 64x64 -n 1 -k 1 -q -o "$r.1.exr"
"$vcmfarm" render cornell -R 64x64 -n 1 -k 3 -q -o "$r.3.exr"
"$vcmfarm" render cornell -R 64x64 -n 1 -k 0 -q -o "$r.0.exr"
"$vcmfarm" render cornell -R 64x64 -n 1 -k 2 -q -o "$r.2.exr"
"$vcmfarm" merge -q -o "$r.four.exr" "$r.3.exr" "$r.0.exr" "$r.2.exr" "$r.1.exr"
check "merge of four single iterations succeeds" $?
rmse=$(json_field "$("$vcmfarm" errors --json "$r.four.exr" "$r.all.exr")" rmse_all)
check "four single iterations equal [0,4) (RMSE $rmse)" "$(awk -v e="$rmse" 'BEGIN { print (e <= 1e-9) ? 0 : 1 }')"
"$vcmfarm" bake "$r.all.exr" -o "$r.baked.exr" && "$vcmfarm" bake "$r.all.exr" -o "$r.baked.png"
check "bake writes EXR and PNG" $?
rmse=$(json_field "$("$vcmfarm" errors --json "$r.baked.exr" "$r.all.exr")" rmse_all)
check "baked EXR equals the film's mean (RMSE $rmse)" "$([ "$rmse" = 0 ]; echo $?)"
"$vcmfarm" diff "$r.0.exr" "$r.all.exr" -o "$r.diff.png" 2>/dev/null
check "diff of one iteration against four writes a PNG" "$([ -s "$r.diff.png" ]; echo $?)"

# ---- refusals of bad command lines, with existing outputs left as they were ----

expect_refusal() { # name, expected stderr substring, command... (may write only to $out)
  local name="$1" expected="$2"
  shift 2
  rm -f "$out"/*
  echo "precious" >"$out/kept"
  "$@" >/dev/null 2>"$tmp/stderr"
  local status=$? ok=0
  [ "$status" -eq 2 ] || { echo "  exit status $status, expected 2"; ok=1; }
  grep -qF -- "$expected" "$tmp/stderr" || { echo "  stderr lacks '$expected':"; sed 's/^/    /' "$tmp/stderr"; ok=1; }
  [ "$(ls "$out")" = kept ] || { echo "  files written: $(ls "$out" | tr '\n' ' ')"; ok=1; }
  [ "$(cat "$out/kept")" = precious ] || { echo "  existing output overwritten"; ok=1; }
  check "$name" $ok
}

good="$tmp/good.exr"
"$vcmfarm" render furnace -R 24x16 -n 2 -k 2 -q -o "$good"
"$vcmfarm" render furnace -R 24x16 -n 2 -k 0 -q -o "$tmp/base.exr"
"$vcmfarm" render furnace -R 24x16 -n 2 -k 0 -s 9 -q -o "$tmp/seed9.exr"
"$vcmfarm" render furnace -R 24x16 -n 2 -k 1 -q -o "$tmp/mid.exr"
"$vcmfarm" render furnace -R 16x16 -n 2 -k 0 -q -o "$tmp/small.exr"
"$vcmfarm" render cornell -R 24x16 -n 2 -k 0 -q -o "$tmp/cornell.exr"

expect_refusal "merge: overlap names both files" "mid.exr: iterations [1,3) overlap $good's [2,4)" \
  "$vcmfarm" merge -o "$out/kept" "$good" "$tmp/base.exr" "$tmp/mid.exr"
expect_refusal "merge: other scene" "cornell.exr: rendered from a different scene than $tmp/base.exr" \
  "$vcmfarm" merge -o "$out/kept" "$tmp/base.exr" "$tmp/cornell.exr"
expect_refusal "merge: other seed" "seed=9 vs seed=1" "$vcmfarm" merge -o "$out/kept" "$good" "$tmp/seed9.exr"
expect_refusal "merge: other resolution" "size 16x16 differs from" \
  "$vcmfarm" merge -o "$out/kept" "$good" "$tmp/small.exr"
expect_refusal "merge: one input" "at least two" "$vcmfarm" merge -o "$out/kept" "$good"
expect_refusal "merge: no output" "missing -o" "$vcmfarm" merge "$good" "$tmp/base.exr"
expect_refusal "merge: missing input" "no-such.exr" "$vcmfarm" merge -o "$out/kept" "$good" "$tmp/no-such.exr"
expect_refusal "bake: unknown output type" ".exr or .png" "$vcmfarm" bake "$good" -o "$out/kept.tif"
expect_refusal "bake: exposure for EXR" "PNG output only" "$vcmfarm" bake "$good" -o "$out/kept.exr" -e 1
expect_refusal "bake: plain image is not a film" "baked.exr: not a vcmfarm film" \
  "$vcmfarm" bake "$r.baked.exr" -o "$out/kept.png"
expect_refusal "errors: sizes differ" "is 24x16" "$vcmfarm" errors "$good" "$tmp/small.exr"
expect_refusal "errors: bad window" "--window" "$vcmfarm" errors --window 1,2,x,4 "$good" "$good"
expect_refusal "errors: window outside" "outside the 24x16 image" "$vcmfarm" errors --window 20,0,8,8 "$good" "$good"
expect_refusal "errors: one input" "expected IMAGE and REF" "$vcmfarm" errors "$good"
expect_refusal "diff: output not PNG" "must be a .png" "$vcmfarm" diff "$good" "$good" -o "$out/kept"
expect_refusal "diff: bad scale" "--scale" "$vcmfarm" diff "$good" "$good" -o "$out/kept.png" -s -1
expect_refusal "diff: sizes differ" "16x16" "$vcmfarm" diff "$good" "$tmp/small.exr" -o "$out/kept.png"
for c in merge bake errors diff; do
  "$vcmfarm" "$c" --help | grep -q "usage: vcmfarm $c"
  check "$c --help" $?
  expect_refusal "$c: unknown option" "vcmfarm $c: unknown option '--frobnicate'; try 'vcmfarm $c --help'" \
    "$vcmfarm" "$c" --frobnicate
done

# ---- damaged files ----

# Runs reader template $1 on bad file $2; reports problems and returns 0 if it was refused
# properly, 1 if not, 3 if it was accepted (allowed only where the caller says so).
run_reader() {
  local -a args=()
  local word
  for word in $1; do
    case "$word" in
    BAD) args+=("$2") ;;
    GOOD) args+=("$good") ;;
    OUT.*) args+=("$out/out.${word#OUT.}") ;;
    *) args+=("$word") ;;
    esac
  done
  # Thousands of calls: only the reader and its timeout are processes (the checks are bash's
  # own), so that the test's time is the readers'.
  local -a written=("$out"/* "$out"/.[!.]*)
  [ ${#written[@]} -eq 0 ] || rm -f -- "${written[@]}"
  timeout 5 "$vcmfarm" "${args[@]}" >/dev/null 2>"$tmp/stderr"
  local status=$? message=""
  IFS= read -r -d '' message <"$tmp/stderr"
  if [[ $message == *Sanitizer* || $message == *"runtime error"* ]]; then
    echo "  '$1' on $2: sanitizer report"
    return 1
  fi
  case $status in
  0) return 3 ;;
  2) ;;
  124) echo "  '$1' on $2: took more than 5 s"; return 1 ;;
  *) echo "  '$1' on $2: exit status $status"; sed 's/^/    /' "$tmp/stderr"; return 1 ;;
  esac
  if [[ $message != *"$2"* ]]; then
    echo "  '$1' on $2: message does not name the file:"
    sed 's/^/    /' "$tmp/stderr"
    return 1
  fi
  written=("$out"/* "$out"/.[!.]*)
  if [ ${#written[@]} -ne 0 ]; then
    echo "  '$1' on $2: wrote ${written[*]##*/}"
    return 1
  fi
  return 0
}

if [ -d "$corpus/Damaged" ]; then
  for r in "${!readers[@]}"; do
    reader=${readers[$r]}
    n=0 read=0 bad=0 start=$SECONDS
    for f in "$corpus"/Damaged/*; do
      n=$((n + 1))
      (((n - r) % stride == 0)) || continue
      read=$((read + 1))
      run_reader "$reader" "$f"
      rc=$?
      [ $rc -eq 3 ] && echo "  '$reader' accepted damaged $f"
      [ $rc -eq 0 ] || bad=$((bad + 1))
    done
    check "'$reader': $read of $n damaged corpus files refused ($bad not, $((SECONDS - start)) s)" \
      "$([ $bad -eq 0 ] && [ $n -ge 185 ] && [ $((read * stride)) -ge $((n - stride)) ]; echo $?)"
  done
else
  echo "note: $corpus/Damaged not found, damaged corpus cases skipped"
fi

# Corrupted copies of a valid film: truncated at a random offset, or 1-8 random bits
# flipped (half of them in the first 2000 bytes, where the header lives). A flipped copy
# may still be a valid film (a bit of a pixel or of render_seconds); a truncated one never.
RANDOM=4242
base_size=$(stat -c %s "$tmp/base.exr")
mkdir -p "$tmp/corrupt"
for ((c = 0; c < corrupted_copies; c++)); do
  copy="$tmp/corrupt/copy$c.exr"
  cp "$tmp/base.exr" "$copy"
  if ((c % 3 == 0)); then
    truncate -s $(((RANDOM << 15 | RANDOM) % base_size)) "$copy"
  else
    span=$base_size
    ((c % 3 == 1 && span > 2000)) && span=2000
    for ((k = 0; k <= RANDOM % 8; k++)); do
      off=$(((RANDOM << 15 | RANDOM) % span))
      byte=$(od -An -tu1 -j"$off" -N1 "$copy" | tr -d ' ')
      printf "\\$(printf %03o $((byte ^ (1 << (RANDOM % 8)))))" | dd of="$copy" bs=1 seek="$off" conv=notrunc status=none
    done
  fi
done
for r in "${!readers[@]}"; do
  reader=${readers[$r]}
  refused=0 accepted=0 bad=0 start=$SECONDS
  for ((c = 0; c < corrupted_copies; c++)); do
    (((c - r) % stride == 0)) || continue
    run_reader "$reader" "$tmp/corrupt/copy$c.exr"
    case $? in
    0) refused=$((refused + 1)) ;;
    3)
      accepted=$((accepted + 1))
      if ((c % 3 == 0)); then echo "  truncated copy$c.exr was accepted"; bad=$((bad + 1)); fi
      ;;
    *) bad=$((bad + 1)) ;;
    esac
  done
  check "'$reader': $((refused + accepted + bad)) of $corrupted_copies corrupted copies: $refused refused, $accepted still valid, $bad wrong ($((SECONDS - start)) s)" \
    "$([ $bad -eq 0 ]; echo $?)"
done

# ---- every valid RGB image of the corpus is its own reference ----

if [ -d "$corpus/TestImages" ]; then
  n=0 used=0 bad=0
  for f in "$corpus"/{TestImages,ScanLines,Tiles,DisplayWindow}/*.exr; do
    n=$((n + 1))
    json=$(timeout 5 "$vcmfarm" errors --json "$f" "$f" 2>"$tmp/stderr")
    status=$?
    if [ $status -eq 0 ]; then
      rmse=$(json_field "$json" rmse_all)
      if [ "$rmse" = 0 ]; then used=$((used + 1)); else echo "  $f: RMSE $rmse against itself"; bad=$((bad + 1)); fi
    elif [ $status -eq 2 ] && grep -qF "$f" "$tmp/stderr"; then
      echo "  not an RGB image: $(cat "$tmp/stderr")"
    else
      echo "  $f: exit status $status"
      bad=$((bad + 1))
    fi
  done
  check "corpus images against themselves: $used of $n read with RMSE 0, $bad wrong" "$([ $bad -eq 0 ] && [ $used -ge 1 ]; echo $?)"
else
  echo "note: $corpus/TestImages not found, valid corpus cases skipped"
fi

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
