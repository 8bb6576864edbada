#!/usr/bin/env bash
# Starts K moonbot worker processes on this node in the foreground, each with one Dask thread
# (a task at a time) while the C++ core renders on several threads. Run it on every node:
#
#     cluster/plain/start-workers.sh /shared/moonbot/scheduler.json        # K = 1: the core uses all CPUs
#     cluster/plain/start-workers.sh /shared/moonbot/scheduler.json 4      # K = 4 processes
#
# K > 1 processes share the node's CPUs: set render.threads = CPUs / K in the config you generate
# with, or they oversubscribe. With PIN=1 each process is instead pinned (taskset) to its own
# slice of CPUs, and render.threads: 0 (the default) follows the slice. See README.md, "Sizing".
#
# Environment: MEMORY_LIMIT per process (default: auto = the node's RAM / K), LOCAL_DIR (scratch;
# default: /tmp), LIFETIME (recycle a process after this long, e.g. 4h; default: never),
# WORKER_HOST (interface address to listen on), PIN (0 or 1, default 0).
set -euo pipefail
[ $# -ge 1 ] && [ $# -le 2 ] || { echo "usage: $0 SCHEDULER_FILE [K]" >&2; exit 2; }
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
scheduler_file=$1
k=${2:-1}
[[ "$k" =~ ^[1-9][0-9]*$ ]] || { echo "K: must be a positive integer, got '$k'" >&2; exit 2; }
args=(--scheduler-file "$scheduler_file" --nthreads 1 --memory-limit "${MEMORY_LIMIT:-auto}"
      --local-directory "${LOCAL_DIR:-/tmp}")
[ -n "${WORKER_HOST:-}" ] && args+=(--host "$WORKER_HOST")
[ -n "${LIFETIME:-}" ] && args+=(--lifetime "$LIFETIME" --lifetime-stagger 10m --lifetime-restart)

if [ "${PIN:-0}" != 1 ] || [ "$k" -eq 1 ]; then
    exec dask worker "${args[@]}" --nworkers "$k"
fi
# PIN=1: K single-process workers, worker i on CPUs [i*n/K, (i+1)*n/K) of the ones this shell may use.
mapfile -t cpus < <(taskset -cp $$ | sed 's/.*: //' | tr ',' '\n' |
                    awk -F- '{ if (NF == 2) for (c = $1; c <= $2; c++) print c; else print $1 }')
n=${#cpus[@]}
[ "$k" -le "$n" ] || { echo "K = $k is more than the $n CPUs this shell may use" >&2; exit 2; }
pids=()
trap 'kill "${pids[@]}" 2>/dev/null; wait' INT TERM EXIT
for ((i = 0; i < k; i++)); do
    slice=$(IFS=,; echo "${cpus[*]:$((i * n / k)):$(((i + 1) * n / k - i * n / k))}")
    taskset -c "$slice" dask worker "${args[@]}" --nworkers 1 &
    pids+=($!)
done
wait
