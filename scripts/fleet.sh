#!/usr/bin/env bash
# Set up .venv (if needed), then one fleet end to end: simulate a fleet (40 units x 10
# flights, unless FLEET already exists), ingest it on an embedded Dask cluster (one worker
# per core) into STORE, print the units ranked by risk, and write the HTML report.
# Env: FLEET (default fleet_demo/fleet), STORE (default fleet_demo/fleet.sqlite),
#      UNITS, WINDOWS, SEED (of a new fleet).  Extra arguments go to `ema-phm fleet ingest`.
# Run it again after a kill: the ingest goes on from what the store holds.
set -euo pipefail
ROOT="$(cd -- "$(dirname -- "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/setup_env.sh"
cd "$ROOT"
FLEET="${FLEET:-fleet_demo/fleet}"
STORE="${STORE:-fleet_demo/fleet.sqlite}"
EMA="$ROOT/.venv/bin/ema-phm"
mkdir -p "$(dirname -- "$STORE")"
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
