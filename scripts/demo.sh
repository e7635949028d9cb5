#!/usr/bin/env bash
# Set up .venv (if needed) and run the main job on the bundled defaults.
# Extra arguments go to `ema-phm demo`.
set -euo pipefail
ROOT="$(cd -- "$(dirname -- "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/setup_env.sh"
cd "$ROOT"
exec "$ROOT/.venv/bin/ema-phm" demo "$@"
