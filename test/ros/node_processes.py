"""The node executables as processes of their own, as `ros2 run` starts them (for tests)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: ema_node's parameters for one window, sent as fast as it can once a monitor listens.
ONE_WINDOW = ("max_windows:=1", "realtime_factor:=0.0", "wait_for_subscribers:=1")


def start_node(
    module: str, domain: int, *params: str, remaps: tuple[str, ...] = ()
) -> subprocess.Popen:
    """`python -m ema_phm.ros.<module> --ros-args -p P... -r R...` on ROS domain `domain`."""
    ros_args = [x for p in params for x in ("-p", p)] + [x for r in remaps for x in ("-r", r)]
    return subprocess.Popen(
        [sys.executable, "-m", f"ema_phm.ros.{module}"]
        + (["--ros-args", *ros_args] if ros_args else []),
        env=dict(os.environ, ROS_DOMAIN_ID=str(domain), PYTHONUNBUFFERED="1"),
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )


def stop_node(proc: subprocess.Popen) -> tuple[int | None, str]:
    """SIGTERM (if still running), then its exit code and stderr; None: killed after 30 s."""
    if proc.poll() is None:
        proc.terminate()
    try:
        _, err = proc.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
        return None, err
    return proc.returncode, err
