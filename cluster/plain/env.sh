# Sourced by the scripts beside it: the repository, its venv and the shared Dask config. Override
# with MOONBOT_REPO (default: this checkout), MOONBOT_VENV (default: $MOONBOT_REPO/.venv, as
# ./dev.sh setup makes it) and DASK_CONFIG (default: $MOONBOT_REPO/cluster/dask.yaml).
MOONBOT_REPO=${MOONBOT_REPO:-$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)}
MOONBOT_VENV=${MOONBOT_VENV:-$MOONBOT_REPO/.venv}
export DASK_CONFIG=${DASK_CONFIG:-$MOONBOT_REPO/cluster/dask.yaml}
if [ ! -x "$MOONBOT_VENV/bin/dask" ] || [ ! -x "$MOONBOT_VENV/bin/moonbot" ]; then
    echo "no moonbot venv at $MOONBOT_VENV: run ./dev.sh setup in $MOONBOT_REPO (or set MOONBOT_VENV)" >&2
    exit 1
fi
export PATH="$MOONBOT_VENV/bin:$PATH"
