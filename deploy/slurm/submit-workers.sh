#!/usr/bin/env bash
# Submits N vcmfarm workers as one Slurm job array and prints the array's job id.
#
#   submit-workers.sh -n N -c URL -k KEYFILE [-t THREADS] [-b VCMFARM] [-- SBATCH_OPTIONS...]
#
#   -n N         array tasks (workers); Slurm runs as many at once as the cluster fits
#   -c URL       the coordinator, tcp://HOST:PORT
#   -k KEYFILE   the farm key (vcmfarm keygen), mode 0600, readable on the compute nodes
#   -t THREADS   CPUs per worker (sbatch --cpus-per-task; the worker renders with as many
#                threads); default 1
#   -b VCMFARM   the vcmfarm binary on the compute nodes (default: vcmfarm on PATH)
#   after --      passed to sbatch as they are: --partition, --time, --output, --qos, ...
#
# Cancel one worker with `scancel JOBID_TASK`, all of them with `scancel JOBID`.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
usage() { sed -n '2,15s/^# \{0,1\}//p' "$0"; }

count="" url="" key="" threads=1 binary=""
while getopts "n:c:k:t:b:h" opt; do
  case "$opt" in
  n) count="$OPTARG" ;;
  c) url="$OPTARG" ;;
  k) key="$OPTARG" ;;
  t) threads="$OPTARG" ;;
  b) binary="$OPTARG" ;;
  h) usage; exit 0 ;;
  *) usage >&2; exit 2 ;;
  esac
done
shift $((OPTIND - 1))
if [ -z "$count" ] || [ -z "$url" ] || [ -z "$key" ]; then
  echo "submit-workers: -n, -c and -k are required" >&2
  usage >&2
  exit 2
fi
case "$count$threads" in *[!0-9]*) echo "submit-workers: -n and -t take positive integers" >&2; exit 2 ;; esac
[ "$count" -ge 1 ] && [ "$threads" -ge 1 ] || { echo "submit-workers: -n and -t must be at least 1" >&2; exit 2; }
[ -r "$key" ] || { echo "submit-workers: cannot read key file $key" >&2; exit 2; }
key="$(cd "$(dirname "$key")" && pwd)/$(basename "$key")"

export VCMFARM_CONNECT="$url" VCMFARM_SECRET="$key"
[ -z "$binary" ] || export VCMFARM="$binary"
exec sbatch --parsable --array="0-$((count - 1))" --cpus-per-task="$threads" "$@" \
  "$here/vcmfarm-worker.sbatch"
