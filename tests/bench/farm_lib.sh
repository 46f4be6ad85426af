# Shared set-up of the farm benchmarks (farm.sh, render_farm.sh, scene_files.sh), sourced:
# a private temporary directory, a farm key and an ipc:// URL in it, and every process
# started (appended to `pids`) killed and the directory removed on exit.
#
#   vcmfarm=BUILD/vcmfarm; source farm_lib.sh; farm_setup NAME
#   client status --json          # a client subcommand against that coordinator

farm_cleanup() {
  for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null; done
  wait 2>/dev/null
  rm -rf "$tmp"
}

farm_setup() { # name
  tmp=$(mktemp -d "/tmp/vf-bench-$1-XXXXXX")
  pids=()
  trap farm_cleanup EXIT
  "$vcmfarm" keygen "$tmp/key" >/dev/null || exit 1
  url="ipc://$tmp/c.sock"
}

# CLIENT_TIMEOUT: seconds a client waits for the coordinator (default 5).
client() { "$vcmfarm" "$@" --coordinator "$url" --secret "$tmp/key" --timeout "${CLIENT_TIMEOUT:-5}"; }
