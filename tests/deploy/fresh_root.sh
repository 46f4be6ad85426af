#!/usr/bin/env bash
# The README's two set-up commands on a fresh Debian 12 root: debootstrap
# --variant=minbase bookworm, proc and sys mounted, nothing else installed. CI runs on a
# machine where things were installed by hand, so only this shows that the commands
# install what they need.
#
#   bash tests/deploy/fresh_root.sh [WORK_DIR]        (as root; WORK_DIR: /var/tmp/vcmfarm-fresh)
#
# The pristine root is made once (WORK_DIR/pristine) and copied for every run, so each
# run starts from nothing installed. The checkout's committed HEAD is cloned into the
# copy, as CI clones main; the OpenEXR corpus beside the checkout (../shared/exr-corpus)
# is copied beside the clone when present, as the tests look for it there. The root gets
# this machine's network as it is, not packages: its resolver, /sys with its cgroup
# hierarchy (as on a booted machine, where slurmd needs it), and the extra CA certificates
# the host's environment names in NODE_EXTRA_CA_CERTS (the npm registry is reached through
# an egress proxy that signs with them). The two
# commands are read from README.md, so the check runs what the README says, and each one's
# output goes to WORK_DIR/command-N.log. Exit 0 only when both commands exit 0 and the
# first has written cornell.exr and cornell.png.
# The whole script is one function, read before it runs: editing the file during a run
# (the run takes a quarter of an hour) cannot change what the run does.
main() {
  set -euo pipefail
  [ "$(id -u)" -eq 0 ] || { echo "fresh_root.sh: debootstrap and chroot need root" >&2; exit 2; }
  repo=$(git -C "$(dirname "$0")/.." rev-parse --show-toplevel)
  work=${1:-/var/tmp/vcmfarm-fresh}
  mirror=${VF_DEBIAN_MIRROR:-http://deb.debian.org/debian}
  root="$work/root"
  mkdir -p "$work"

  if ! command -v debootstrap >/dev/null; then
    echo "fresh_root: installing debootstrap"
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq debootstrap >/dev/null
  fi
  if [ ! -f "$work/pristine/.vcmfarm-complete" ]; then
    rm -rf "$work/pristine"
    echo "fresh_root: debootstrap --variant=minbase bookworm ($mirror)"
    debootstrap --variant=minbase bookworm "$work/pristine" "$mirror" >"$work/debootstrap.log" 2>&1 ||
      { tail -20 "$work/debootstrap.log" >&2; exit 1; }
    touch "$work/pristine/.vcmfarm-complete"
  fi

  unmount() {
    # Daemons a test left behind (munged, slurmd) keep the mounts busy: end every process
    # whose root is inside this one first.
    local pid
    for pid in $(ls /proc | grep -E '^[0-9]+$'); do
      [ "$(readlink "/proc/$pid/root" 2>/dev/null)" = "$root" ] && kill -9 "$pid" 2>/dev/null
    done
    sleep 0.5
    umount -R "$root/sys" 2>/dev/null || umount -R -l "$root/sys" 2>/dev/null || true
    umount "$root/proc" 2>/dev/null || umount -l "$root/proc" 2>/dev/null || true
    # And whatever a test mounted inside (`ip netns add` bind-mounts /run/netns), deepest
    # first: a mount left there would stop the next run's removal of the copy.
    local m
    for m in $(findmnt -rn -o TARGET | grep "^$root/" | sort -r || true); do
      umount "$m" 2>/dev/null || umount -l "$m" 2>/dev/null || true
    done
  }
  if [ -d "$root" ]; then
    unmount
    rm -rf --one-file-system "$root"
  fi
  cp -a "$work/pristine" "$root"
  trap unmount EXIT
  mount -t proc proc "$root/proc"
  mount --rbind /sys "$root/sys"
  mount --make-rslave "$root/sys"
  cp /etc/resolv.conf "$root/etc/resolv.conf"
  extra_ca=()
  if [ -n "${NODE_EXTRA_CA_CERTS:-}" ] && [ -f "$NODE_EXTRA_CA_CERTS" ]; then
    cp "$NODE_EXTRA_CA_CERTS" "$root/etc/vcmfarm-host-extra-ca.pem"
    extra_ca=(NODE_EXTRA_CA_CERTS=/etc/vcmfarm-host-extra-ca.pem)
  fi

  mkdir -p "$root/src"
  git clone --quiet "$repo" "$root/src/vcmfarm"
  commit=$(git -C "$root/src/vcmfarm" rev-parse --short HEAD)
  corpus="$repo/../shared/exr-corpus"
  [ -d "$corpus" ] && mkdir -p "$root/src/shared" && cp -a "$corpus" "$root/src/shared/exr-corpus"

  # The README's set-up commands: its indented lines that start with the install script.
  mapfile -t commands < <(grep -E '^    bash deploy/install-deps\.sh' "$repo/README.md" | sed 's/^    //')
  [ ${#commands[@]} -eq 2 ] || { echo "fresh_root: README.md has ${#commands[@]} set-up commands, not 2" >&2; exit 1; }

  echo "fresh_root: commit $commit in $root"
  status=0
  for i in 0 1; do
    n=$((i + 1))
    echo "fresh_root: command $n: ${commands[$i]}"
    start=$SECONDS
    set +e
    chroot "$root" /usr/bin/env -i PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
      HOME=/root TERM=dumb "${extra_ca[@]}" /bin/bash -c "cd /src/vcmfarm && ${commands[$i]}" >"$work/command-$n.log" 2>&1
    rc=$?
    set -e
    echo "fresh_root: command $n: exit $rc after $((SECONDS - start)) s (log $work/command-$n.log)"
    tail -n 12 "$work/command-$n.log" | sed 's/^/  | /'
    if [ "$i" -eq 0 ]; then
      for f in cornell.exr cornell.png; do
        [ -s "$root/src/vcmfarm/$f" ] || { echo "fresh_root: command 1 did not write $f"; rc=1; }
      done
    fi
    [ "$rc" -eq 0 ] || status=1
  done
  [ "$status" -eq 0 ] && echo "fresh_root: PASS, both README commands on a fresh Debian 12 root ($commit)" ||
    echo "fresh_root: FAIL ($commit)"
  exit "$status"
}
main "$@"
