"""The monitor on a rig's topics: its inputs remapped with -r, as the launch's *_topic do."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("rclpy")

ROOT = Path(__file__).resolve().parents[2]


def test_remapped_inputs_are_what_the_monitor_subscribes_to(ros_domain_id: int) -> None:
    import rclpy
    from rclpy.context import Context

    proc = subprocess.Popen(
        [sys.executable, "-m", "ema_phm.ros.monitor_node", "--ros-args", "-p", "warm_up:=false"]
        + ["-r", "ema/telemetry:=/rig/ema_telemetry", "-r", "ema/run_info:=/rig/ema_run_info"],
        env=dict(os.environ, ROS_DOMAIN_ID=str(ros_domain_id)),
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    ctx = Context()
    rclpy.init(context=ctx, domain_id=ros_domain_id)
    probe = rclpy.create_node("remap_probe", context=ctx)
    try:
        deadline = time.monotonic() + 60.0
        while time.monotonic() < deadline and probe.count_subscribers("/rig/ema_telemetry") < 1:
            time.sleep(0.2)
        assert probe.count_subscribers("/rig/ema_telemetry") == 1
        assert probe.count_subscribers("/rig/ema_run_info") == 1
        assert probe.count_subscribers("/ema/telemetry") == 0
        assert probe.count_subscribers("/ema/ground_truth") == 1  # not remapped: as it is
    finally:
        probe.destroy_node()
        rclpy.try_shutdown(context=ctx)
        proc.terminate()
        _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
