"""scripts/env.sh: the pip environment as a ROS 2 prefix, traffic on 127.0.0.1."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
VENV = ROOT / ".venv"

pytestmark = pytest.mark.skipif(
    Path(sys.prefix).resolve() != VENV.resolve(), reason="runs in the repository's .venv only"
)


def _sourced(script: str, env: dict[str, str] | None = None) -> dict[str, str]:
    """The environment after running `script` (bash) from the repository root."""
    out = subprocess.run(
        ["bash", "-c", f"{script} && env -0"],
        cwd=ROOT,
        env=env if env is not None else dict(os.environ),
        capture_output=True,
        check=True,
    ).stdout.decode()
    return dict(line.split("=", 1) for line in out.split("\0") if "=" in line)


def test_env_sh_sets_the_prefix_once_and_the_loopback_profile():
    env = {k: v for k, v in os.environ.items() if k != "AMENT_PREFIX_PATH"}
    env["AMENT_PREFIX_PATH"] = "/opt/ros/kilted"
    after = _sourced(". scripts/env.sh && . scripts/env.sh", env)
    assert after["AMENT_PREFIX_PATH"] == f"{VENV}:/opt/ros/kilted"  # once, in front
    assert after["VIRTUAL_ENV"] == str(VENV)
    assert Path(after["FASTDDS_DEFAULT_PROFILES_FILE"]).is_file()
    assert after["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SYSTEM_DEFAULT"
    assert after["RMW_IMPLEMENTATION"] == "rmw_fastrtps_cpp"


def test_ros2_run_finds_the_node_through_the_prefix(ros_domain_id, monkeypatch):
    """What `ros2 run ema_phm ema_node` does: prefix from the ament index, then lib/ema_phm."""
    from ament_index_python import get_package_prefix

    env = _sourced(". scripts/env.sh")
    env["ROS_DOMAIN_ID"] = str(ros_domain_id)
    monkeypatch.setenv("AMENT_PREFIX_PATH", env["AMENT_PREFIX_PATH"])
    prefix = get_package_prefix("ema_phm")
    assert Path(prefix).resolve() == VENV.resolve()
    exe = Path(prefix) / "lib" / "ema_phm" / "ema_node"
    assert os.access(exe, os.X_OK)
    args = ["max_windows:=1", "duration:=0.1", "realtime_factor:=0.0"]
    proc = subprocess.run(
        [str(exe), "--ros-args"] + [x for a in args for x in ("-p", a)],
        env=env,
        check=False,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr  # ema_node exits by itself after max_windows
    assert "telemetry stopped (max_windows)" in proc.stderr
