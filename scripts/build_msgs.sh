#!/usr/bin/env bash
# Build the interface package ema_phm_msgs/ (ament_cmake + rosidl) into a virtual
# environment, from the PyPI ros-* wheels that requirements.txt pins (its section
# "build of ema_phm_msgs"). scripts/setup_env.sh runs this after installing
# requirements.txt; on a ROS 2 machine build ema_phm_msgs with colcon instead (README).
#
# Usage: scripts/build_msgs.sh [VENV]     (default: .venv at the repo root)
#
# Needs cmake >= 3.20 and a C and C++ compiler (Debian: apt-get install cmake g++).
# The wheels' exported CMake files name the include folders of the machine that built
# them (/opt/python/cpXY-cpXY/...); they are rewritten here, in the venv, to this
# venv's Python and numpy include folders (idempotent). The build runs in
# VENV/.ema_phm_msgs_build (log: build.log there) and installs into VENV: C/C++
# headers and libraries, the Python package ema_phm_msgs in site-packages, the .msg
# files and the ament index entries under VENV/share. Any failure stops with
# "build_msgs: error: ..." and a non-zero exit.
set -euo pipefail

ROOT="$(cd -- "$(dirname -- "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$(cd -- "${1:-$ROOT/.venv}" 2>/dev/null && pwd)" || {
    echo "build_msgs: error: no virtual environment at ${1:-$ROOT/.venv}; run scripts/setup_env.sh" >&2
    exit 1
}
VPY="$VENV/bin/python"
SRC="$ROOT/ema_phm_msgs"
BUILD="$VENV/.ema_phm_msgs_build"
LOG="$BUILD/build.log"

die() { echo "build_msgs: error: $*" >&2; exit 1; }

[ -x "$VPY" ] || die "$VPY not found; run scripts/setup_env.sh"
[ -f "$SRC/package.xml" ] || die "$SRC/package.xml not found"
command -v cmake >/dev/null 2>&1 || die "cmake not found (Debian: apt-get install cmake)"
command -v cc >/dev/null 2>&1 || command -v gcc >/dev/null 2>&1 \
    || die "no C compiler (cc/gcc) found (Debian: apt-get install gcc)"
command -v c++ >/dev/null 2>&1 || command -v g++ >/dev/null 2>&1 \
    || die "no C++ compiler (c++/g++) found (Debian: apt-get install g++)"
for pkg in ament_cmake rosidl_default_generators std_msgs builtin_interfaces action_msgs; do
    [ -d "$VENV/share/$pkg/cmake" ] \
        || die "$VENV/share/$pkg/cmake missing: install requirements.txt into $VENV first"
done

# The include folders the wheels should have exported: this venv's.
read -r PYINC NPINC < <("$VPY" -c '
import sysconfig, numpy
print(sysconfig.get_paths()["include"], numpy.get_include())') \
    || die "cannot ask $VPY for its Python and numpy include folders"
[ -f "$PYINC/Python.h" ] \
    || die "$PYINC/Python.h not found: the Python headers are needed (Debian: apt-get install python3-dev)"

# Rewrite the wheel builder's include folders in the exported CMake files (only
# files that still name them; a second run finds none).
mapfile -t stale < <(grep -rlE '/opt/python/cp3[0-9]+-cp3[0-9]+' "$VENV/share" \
    --include='*.cmake' 2>/dev/null || true)
if [ "${#stale[@]}" -gt 0 ]; then
    echo "build_msgs: fixing the include folders exported by ${#stale[@]} CMake files in $VENV/share"
    sed -i -E \
        -e "s#/opt/python/cp3[0-9]+-cp3[0-9]+/lib/python3\.[0-9]+/site-packages/numpy/_core/include#$NPINC#g" \
        -e "s#/opt/python/cp3[0-9]+-cp3[0-9]+/include/python3\.[0-9]+#$PYINC#g" \
        "${stale[@]}"
    if left=$(grep -rlE '/opt/python/cp3[0-9]+-cp3[0-9]+' "$VENV/share" --include='*.cmake'); then
        die "CMake files still name the wheel builder's folders after the fix: $left"
    fi
fi

rm -rf "$BUILD"
mkdir -p "$BUILD"
export AMENT_PREFIX_PATH="$VENV" PATH="$VENV/bin:$PATH"
jobs="$(nproc 2>/dev/null || echo 2)"
start=$SECONDS
run() {
    if ! "$@" >>"$LOG" 2>&1; then
        echo "build_msgs: error: '$*' failed; last lines of $LOG:" >&2
        tail -n 40 "$LOG" >&2
        exit 1
    fi
}
echo "build_msgs: building ema_phm_msgs into $VENV (log: $LOG)"
run cmake -S "$SRC" -B "$BUILD" \
    -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_INSTALL_PREFIX="$VENV" \
    -DCMAKE_PREFIX_PATH="$VENV" \
    -DPython3_EXECUTABLE="$VPY" \
    -DBUILD_TESTING=OFF
run cmake --build "$BUILD" -j "$jobs"
run cmake --install "$BUILD"

# The check that it works: import, and a CDR round trip through rclpy.
if ! out=$("$VPY" - 2>&1 <<'EOF'
from rclpy.serialization import deserialize_message, serialize_message

from ema_phm_msgs.msg import ActuatorHealth, TelemetryBatch, TelemetrySample

m = ActuatorHealth(hardware_id="check", level=ActuatorHealth.WARN)
m.friction.value = 0.25
back = deserialize_message(serialize_message(m), ActuatorHealth)
assert back.hardware_id == "check" and back.level == 1 and back.friction.value == 0.25, back
b = TelemetryBatch(i3eq=[1.0, 2.0])
assert list(deserialize_message(serialize_message(b), TelemetryBatch).i3eq) == [1.0, 2.0]
TelemetrySample()
EOF
); then
    die "ema_phm_msgs was built but does not work from $VPY: $out"
fi
echo "build_msgs: ema_phm_msgs built and installed in $((SECONDS - start)) s"
