#!/usr/bin/env bash
# Run launch/ema_phm.launch.py and launch/two_actuators.launch.py with ROS 2 launch and check
# what they do.  Needs a ROS 2 install (launch and launch_ros have no PyPI wheels, so CI
# cannot run this; test/ros/test_launch_files.py checks the files' structure instead).
#
#   bash scripts/check_launch.sh            # ros2 on PATH, or ROS_SETUP / /opt/ros/$ROS_DISTRO
#
# The nodes are this repository's .venv executables (`ros2 run`-style wrappers in
# .venv/lib/ema_phm, found through AMENT_PREFIX_PATH); `ros2 launch` runs in the ROS
# install's Python.  The ROS setup puts its site-packages on PYTHONPATH, which the venv's
# Python must not see (another Python version), so the launch is wrapped in one that unsets
# PYTHONPATH for the processes it starts.  Traffic stays on 127.0.0.1
# (config/fastdds_localhost.xml).
#
# Checks: (1) one actuator with max_windows:=1 records a bag with a health result and the
# launch ends by itself after ema_node exits; (2) two actuators publish health on
# /left/ema/health and /right/ema/health.
set -euo pipefail
ROOT="$(cd -- "$(dirname -- "${BASH_SOURCE[0]}")/.." && pwd)"
die() { echo "check_launch: error: $*" >&2; exit 2; }

if ! command -v ros2 >/dev/null 2>&1; then
    setup="${ROS_SETUP:-/opt/ros/${ROS_DISTRO:-kilted}/setup.bash}"
    [ -f "$setup" ] || die "no ros2 on PATH and no $setup; install ROS 2 or set ROS_SETUP"
    set +u
    # shellcheck disable=SC1090
    . "$setup"
    set -u
fi
ros2 pkg prefix launch_ros >/dev/null 2>&1 || die "launch_ros is not installed in this ROS 2"

bash "$ROOT/scripts/setup_env.sh"
export AMENT_PREFIX_PATH="$ROOT/.venv:${AMENT_PREFIX_PATH:-}"
export RMW_IMPLEMENTATION=rmw_fastrtps_cpp
export FASTDDS_DEFAULT_PROFILES_FILE="$ROOT/config/fastdds_localhost.xml"
export ROS_AUTOMATIC_DISCOVERY_RANGE=SYSTEM_DEFAULT
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$((RANDOM % 100 + 1))}"
ros2 pkg prefix ema_phm >/dev/null || die "ema_phm not found on AMENT_PREFIX_PATH"

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

wrap() {  # a launch file that includes share/ema_phm/launch/$1 with PYTHONPATH unset
    cat > "$work/wrap_$1" <<PY
from launch import LaunchDescription
from launch.actions import IncludeLaunchDescription, UnsetEnvironmentVariable
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch.substitutions import PathJoinSubstitution
from launch_ros.substitutions import FindPackageShare


def generate_launch_description():
    return LaunchDescription([
        UnsetEnvironmentVariable("PYTHONPATH"),
        IncludeLaunchDescription(PythonLaunchDescriptionSource(
            PathJoinSubstitution([FindPackageShare("ema_phm"), "launch", "$1"]))),
    ])
PY
    echo "$work/wrap_$1"
}

echo "check_launch: (1) one actuator, one window, recording"
one="$(wrap ema_phm.launch.py)"
rc=0
timeout 600 ros2 launch "$one" max_windows:=1 realtime_factor:=0.0 max_evaluations:=200 \
    grace_s:=30 record_bag:="$work/one" > "$work/one.log" 2>&1 || rc=$?
[ "$rc" -eq 0 ] || { tail -40 "$work/one.log"; die "ema_phm.launch.py: exit $rc (124 = did not end)"; }
grep -q "ema_node ended" "$work/one.log" || { tail -40 "$work/one.log"; die "no OnProcessExit"; }
"$ROOT/.venv/bin/python" - "$work/one" <<'PY' || die "the recording has no health result"
import sys
from ema_phm.telemetry import bags
n = sum(1 for t, *_ in bags.read_messages(sys.argv[1], ["/ema/health"]))
print(f"check_launch: {sys.argv[1]} holds {n} /ema/health message(s)")
sys.exit(0 if n >= 1 else 1)
PY

echo "check_launch: (2) two actuators side by side"
two="$(wrap two_actuators.launch.py)"
ros2 launch "$two" realtime_factor:=4.0 max_evaluations:=200 > "$work/two.log" 2>&1 &
launch_pid=$!
for side in left right; do
    if ! timeout 300 ros2 topic echo --once "/$side/ema/health" > "$work/$side.txt" 2>&1; then
        kill -INT "$launch_pid" 2>/dev/null || true
        wait "$launch_pid" || true
        tail -40 "$work/two.log"
        die "no health on /$side/ema/health"
    fi
    echo "check_launch: /$side/ema/health received"
done
kill -INT "$launch_pid"
wait "$launch_pid" || true
echo "check_launch: ok"
