# free_port [TAKEN...]: prints a TCP port on this machine that no socket uses now, in any
# state, and that is none of TAKEN. Sourced by the test scripts that must name a port for a
# program which cannot be told to pick one (test_slurm.sh, test_systemd.sh).
#
# The port is taken below the kernel's ephemeral range (ip_local_port_range): a port inside
# it can become the local end of any outgoing connection between this check and the
# program's bind, which then fails with "Address already in use". Returns 1 when no port is
# found in 200 tries.
free_port() {
  local low=32768 high=60999 lo hi
  read -r low high 2>/dev/null </proc/sys/net/ipv4/ip_local_port_range
  if [ "$low" -gt 11024 ]; then
    lo=10000 hi=$((low - 1))
  elif [ "$high" -lt 64511 ]; then
    lo=$((high + 1)) hi=65535
  else
    lo=1024 hi=65535
  fi
  # Every socket's local address, ADDRESS:PORT in hex, is the second field of its line;
  # the header's second field is not hex and is skipped.
  local used=" $* " table address port
  for table in /proc/net/tcp /proc/net/tcp6; do
    [ -r "$table" ] || continue
    while read -r _ address _; do
      case "$address" in *:[0-9A-Fa-f][0-9A-Fa-f][0-9A-Fa-f][0-9A-Fa-f]) used+="$((16#${address##*:})) " ;; esac
    done <"$table"
  done
  for _ in $(seq 200); do
    port=$((lo + (RANDOM * 32768 + RANDOM) % (hi - lo + 1)))
    case "$used" in *" $port "*) continue ;; esac
    echo "$port"
    return 0
  done
  return 1
}
