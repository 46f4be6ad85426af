#!/usr/bin/env bash
# Films and the files around them, as careless use meets them: no command replaces one of
# its own inputs with something else, and two vcmfarm processes never write one film at
# the same time (common/file_lock.h): the second is refused with exit status 2, naming the
# process that holds the film, and the first one's work is kept whole. A holder killed by
# SIGKILL leaves no lock behind.
#
#   test_film_locks.sh VCMFARM
set -u
vcmfarm="$1"
tmp=$(mktemp -d)
bg=""
trap '[ -n "$bg" ] && kill -9 "$bg" 2>/dev/null; rm -rf "$tmp"' EXIT
passed=0
failed=0
check() { # name, condition result (0 = pass)
  if [ "$2" -eq 0 ]; then passed=$((passed + 1)); echo "ok   $1"; else failed=$((failed + 1)); echo "FAIL $1"; fi
}
refused() { # name, expected substring, command...: exit 2 with that message
  local name="$1" expected="$2" status
  shift 2
  "$@" >"$tmp/stdout" 2>"$tmp/stderr"
  status=$?
  [ "$status" -eq 2 ] && grep -qF -- "$expected" "$tmp/stderr"
  local ok=$?
  [ "$ok" -eq 0 ] || { echo "  exit $status; stderr:"; sed 's/^/    /' "$tmp/stderr"; }
  check "$name" "$ok"
}
iterations() { "$vcmfarm" info --json "$1" | jq -r .iteration_count; }
# Waits until a background command holds the lock of film $1 (its lock file exists).
await_lock() {
  local lock deadline=$((SECONDS + 30))
  lock="$(dirname "$1")/.$(basename "$1").vcmfarm-lock"
  until [ -e "$lock" ]; do
    [ "$SECONDS" -lt "$deadline" ] || return 1
    sleep 0.05
  done
}

r=(-R 32x32 -q)
"$vcmfarm" render furnace --direct -n 2 "${r[@]}" -o "$tmp/film.exr" || exit 1
"$vcmfarm" render furnace --direct -n 2 -k 1000000000 "${r[@]}" -o "$tmp/other.exr" || exit 1
cp "$tmp/film.exr" "$tmp/keep.exr"

# ---- a command's output is never one of its inputs ----
refused "bake FILM -o FILM" "is the FILM file" "$vcmfarm" bake "$tmp/keep.exr" -o "$tmp/keep.exr"
ln -s "$tmp/keep.exr" "$tmp/link.exr"
refused "bake FILM -o a link to FILM" "is the FILM file" "$vcmfarm" bake "$tmp/keep.exr" -o "$tmp/link.exr"
cmp -s "$tmp/keep.exr" "$tmp/film.exr"
check "the film baked onto itself is unchanged" $?
refused "render -o REF --reference REF" "is the --reference file" \
  "$vcmfarm" render furnace -n 1 "${r[@]}" --reference "$tmp/keep.exr" -o "$tmp/keep.exr"
refused "continue --reference F (F being the output)" "is the --reference file" \
  "$vcmfarm" continue "$tmp/keep.exr" -n 1 -q --reference "$tmp/keep.exr"
cmp -s "$tmp/keep.exr" "$tmp/film.exr"
check "the reference is unchanged" $?

# ---- one writer per film ----
# A continue that runs for a while holds the film; a second continue and a merge into it
# are refused while it runs, and its iterations all arrive.
# Other names of the film (issue 41): a symbolic link and a hard link reach the same file
# and its lock.
ln -s "$tmp/film.exr" "$tmp/soft.exr"
ln "$tmp/film.exr" "$tmp/hard.exr"
"$vcmfarm" continue "$tmp/film.exr" -t 4 -j 1 -q &
bg=$!
await_lock "$tmp/film.exr"
check "the first continue holds the film" $?
refused "a continue of a symbolic link to the film" "is being written by another vcmfarm process (pid $bg: continue)" \
  "$vcmfarm" continue "$tmp/soft.exr" -n 1 -q
refused "a continue of a hard link to the film" "is being written by another vcmfarm process under another name" \
  "$vcmfarm" continue "$tmp/hard.exr" -n 1 -q
refused "merge -o a hard link to the film" "is being written by another vcmfarm process" \
  "$vcmfarm" merge -q -o "$tmp/hard.exr" "$tmp/hard.exr" "$tmp/other.exr"
[ -L "$tmp/soft.exr" ]
check "the symbolic link is left as it was" $?
refused "a second continue of the same film" "is being written by another vcmfarm process (pid $bg: continue)" \
  "$vcmfarm" continue "$tmp/film.exr" -n 1 -q
refused "merge -o FILM FILM OTHER beside a continue of FILM" "is being written by another vcmfarm process" \
  "$vcmfarm" merge -q -o "$tmp/film.exr" "$tmp/film.exr" "$tmp/other.exr"
refused "render -o FILM beside a continue of FILM" "is being written by another vcmfarm process" \
  "$vcmfarm" render furnace -n 1 "${r[@]}" -o "$tmp/film.exr"
wait "$bg"
check "the first continue finished" $?
bg=""
n=$(iterations "$tmp/film.exr")
[ "$n" -gt 2 ]
check "the film kept the first continue's iterations ($n)" $?
[ ! -e "$tmp/.film.exr.vcmfarm-lock" ]
check "the lock file is gone after the holder ended" $?
"$vcmfarm" merge -q -o "$tmp/film.exr" "$tmp/film.exr" "$tmp/other.exr"
check "merge into the film once it is free" $?
[ "$(iterations "$tmp/film.exr")" -eq $((n + 2)) ]
check "the merge added the other film's iterations" $?

# A holder killed with SIGKILL: the kernel drops its lock, the next writer proceeds.
"$vcmfarm" continue "$tmp/film.exr" -t 30 -j 1 -q &
bg=$!
await_lock "$tmp/film.exr"
kill -9 "$bg"
wait "$bg" 2>/dev/null
bg=""
"$vcmfarm" continue "$tmp/film.exr" -n 1 -q
check "a continue after the holder was killed" $?

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
