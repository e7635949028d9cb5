#!/usr/bin/env bash
# Create or refresh .venv/ at the repo root: pinned requirements plus ema_phm
# installed editable. Safe to run again: when .venv/.ema_phm_stamp matches the
# current inputs, no pip work is done.
#
# Env: PYTHON   interpreter to build the venv with (default: python3)
set -euo pipefail

ROOT="$(cd -- "$(dirname -- "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$ROOT/.venv"
VPY="$VENV/bin/python"
STAMP="$VENV/.ema_phm_stamp"
PYTHON="${PYTHON:-python3}"
MIN_PIP="23.1"   # oldest pip trusted for PEP 660 editable installs with --no-build-isolation

export PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_NO_INPUT=1

die() { echo "setup_env: error: $*" >&2; exit 1; }

# Inputs whose change needs pip: the pins, the build script, and which
# packages and subpackages exist (an editable install only maps those it saw),
# i.e. every __init__.py outside the venv and build outputs; and, for the build of
# the interface package, scripts/build_msgs.sh and every file of ema_phm_msgs/.
stamp_of() {
    {
        cat "$ROOT/requirements.txt" "$ROOT/setup.py" "$ROOT/scripts/build_msgs.sh"
        echo "ema_phm_msgs:"
        (cd "$ROOT" && find ema_phm_msgs -type f -print 2>/dev/null | LC_ALL=C sort \
            | while IFS= read -r f; do echo "$f"; cat "$f"; done || true)
        echo "packages:"
        (cd "$ROOT" && find . \( -path ./.venv -o -path ./build -o -path ./install -o -path ./log \
            -o -path ./.git -o -name '*.egg-info' \) -prune -o -name __init__.py -print 2>/dev/null \
            | LC_ALL=C sort || true)
    } | sha256sum | cut -d' ' -f1
}

if [ ! -x "$VPY" ]; then
    command -v "$PYTHON" >/dev/null 2>&1 || die "'$PYTHON' not found; install Python >= 3.10 (Debian: apt-get install python3 python3-venv)"
    "$PYTHON" -c 'import sys; sys.exit(0 if sys.version_info >= (3, 10) else 1)' \
        || die "Python >= 3.10 is needed, but '$PYTHON' is $("$PYTHON" -c 'import platform; print(platform.python_version())')"
    echo "setup_env: creating $VENV with $("$PYTHON" --version 2>&1)"
    "$PYTHON" -m venv "$VENV" \
        || die "'$PYTHON -m venv' failed; on Debian: apt-get install python3-venv"
fi

"$VPY" -c 'import sys; sys.exit(0 if sys.version_info >= (3, 10) else 1)' \
    || die "$VENV uses Python $("$VPY" -c 'import platform; print(platform.python_version())'), need >= 3.10; remove .venv and set PYTHON"

want="$(stamp_of)"
if [ -f "$STAMP" ] && [ "$(cat "$STAMP")" = "$want" ]; then
    exit 0
fi

cd "$ROOT"
if ! "$VPY" - "$MIN_PIP" <<'EOF'
import sys
try:
    import pip
except ImportError:
    sys.exit(1)
have = tuple(int(p) for p in pip.__version__.split(".")[:2] if p.isdigit())
need = tuple(int(p) for p in sys.argv[1].split("."))
sys.exit(0 if have >= need else 1)
EOF
then
    echo "setup_env: upgrading pip (need >= $MIN_PIP)"
    "$VPY" -m ensurepip --upgrade >/dev/null 2>&1 || true
    "$VPY" -m pip install --quiet --upgrade "pip>=$MIN_PIP"
fi

echo "setup_env: installing requirements.txt into .venv"
"$VPY" -m pip install --quiet -r requirements.txt
echo "setup_env: installing ema_phm (editable) into .venv"
# --no-build-isolation: build with the pinned setuptools from requirements.txt
"$VPY" -m pip install --quiet --no-deps --no-build-isolation -e .
# The typed messages (ema_phm_msgs/) built from the pinned ros-* wheels; a failure
# stops here with "build_msgs: error: ..." and no stamp, so the next run tries again.
bash "$ROOT/scripts/build_msgs.sh" "$VENV"

echo "$want" > "$STAMP"
echo "setup_env: .venv ready ($("$VPY" --version 2>&1))"
