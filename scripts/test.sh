#!/usr/bin/env bash
# Set up .venv (if needed) and run the test suite with pytest.
# Extra arguments go to pytest; with no test path among them, all of test/ runs.
set -euo pipefail
ROOT="$(cd -- "$(dirname -- "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/setup_env.sh"
bash "$ROOT/scripts/system_packages.sh"
cd "$ROOT"

default=(test)
for arg in "$@"; do
    case "$arg" in
        -*) ;;
        *) if [ -e "${arg%%::*}" ]; then default=(); fi ;;
    esac
done

rc=0
"$ROOT/.venv/bin/python" -m pytest -q "${default[@]}" "$@" || rc=$?
if [ "$rc" -eq 5 ]; then
    echo "test.sh: error: pytest collected no tests; that counts as a failure" >&2
    exit 1
fi
exit "$rc"
