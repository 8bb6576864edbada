#!/usr/bin/env bash
# Starts the Dask scheduler of a moonbot cluster in the foreground and writes its address to
# SCHEDULER_FILE (on a filesystem every node and the driver see). Run it on one node:
#
#     cluster/plain/start-scheduler.sh /shared/moonbot/scheduler.json
#
# Environment: SCHEDULER_HOST (interface address to listen on; default: all), SCHEDULER_PORT
# (default 8786; 0 = any free port), DASHBOARD_ADDRESS (default :8787), IDLE_TIMEOUT (shut down
# after this long without clients or tasks; default 1h).
set -euo pipefail
[ $# -eq 1 ] || { echo "usage: $0 SCHEDULER_FILE" >&2; exit 2; }
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
args=(--scheduler-file "$1" --port "${SCHEDULER_PORT:-8786}"
      --dashboard-address "${DASHBOARD_ADDRESS:-:8787}" --idle-timeout "${IDLE_TIMEOUT:-1h}")
[ -n "${SCHEDULER_HOST:-}" ] && args+=(--host "$SCHEDULER_HOST")
exec dask scheduler "${args[@]}"
