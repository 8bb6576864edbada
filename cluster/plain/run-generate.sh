#!/usr/bin/env bash
# Renders a sweep on the running cluster whose scheduler wrote SCHEDULER_FILE, then collects and
# prints its throughput (OUT/stats/). Run it anywhere that sees SCHEDULER_FILE and OUT:
#
#     cluster/plain/run-generate.sh configs/synbag-1.0.yaml /shared/synbag /shared/moonbot/scheduler.json
#
# Rerunning it resumes: tasks already complete in OUT are not rendered again.
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: $0 CONFIG OUT SCHEDULER_FILE" >&2; exit 2; }
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
moonbot generate "$1" --out "$2" --scheduler-file "$3"
moonbot stats "$2"
