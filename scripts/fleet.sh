#!/usr/bin/env bash
# Set up .venv (if needed), then one fleet end to end: simulate a fleet (UNITS units x WINDOWS
# flights, unless FLEET already exists), ingest it on an embedded Dask cluster (one worker
# per core) into STORE, print the units ranked by risk, and write the HTML report.
#
# Usage: [UNITS=N] [WINDOWS=N] [SEED=S] [FLEET=DIR] [STORE=FILE] bash scripts/fleet.sh [ARGS...]
# Environment variables (read by this script, not by ema-phm):
#   UNITS    units of a new fleet (default 40)
#   WINDOWS  flights per unit of a new fleet (default 10)
#   SEED     seed of a new fleet (default 0)
#   FLEET    the fleet folder (default fleet_demo/fleet); UNITS, WINDOWS and SEED only
#            matter when it does not exist yet
#   STORE    the results store (default fleet_demo/fleet.sqlite); the report goes beside it
# ARGS go to `ema-phm fleet ingest` (e.g. --workers 2 --max-evaluations 300).
# Run it again after a kill: the ingest goes on from what the store holds.
set -euo pipefail
usage() {
    sed -n '/^# Usage:/,/^# ARGS go to/s/^# \{0,1\}//p' "${BASH_SOURCE[0]}"
}
if [ "${1:-}" = "-h" ] || [ "${1:-}" = "--help" ]; then
    usage
    exit 0
fi
ROOT="$(cd -- "$(dirname -- "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/setup_env.sh"
cd "$ROOT"
FLEET="${FLEET:-fleet_demo/fleet}"
STORE="${STORE:-fleet_demo/fleet.sqlite}"
EMA="$ROOT/.venv/bin/ema-phm"
mkdir -p "$(dirname -- "$STORE")"
echo "fleet.sh: FLEET=$FLEET STORE=$STORE UNITS=${UNITS:-40} WINDOWS=${WINDOWS:-10}" \
    "SEED=${SEED:-0} (environment variables; bash scripts/fleet.sh --help)" >&2
if [ ! -e "$FLEET" ]; then
    "$EMA" fleet simulate --out "$FLEET" --units "${UNITS:-40}" --windows "${WINDOWS:-10}" \
        --seed "${SEED:-0}"
fi
rc=0
"$EMA" fleet ingest "$FLEET" --store "$STORE" "$@" || rc=$?  # 1: a unit failed; the rest stand
[ "$rc" -le 1 ] || exit "$rc"
"$EMA" fleet status --store "$STORE"
"$EMA" fleet report --store "$STORE" --out "${STORE%.*}.html"
exit "$rc"
