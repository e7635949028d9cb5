"""monitor_node on a rig's own topics (`channel_map_file`), started as `ros2 run` starts it.

This process plays the rig: one `sensor_msgs/JointState` per sample on /joint_states (the
surface, the motor and the surface's command as joints; the motor's effort is its current),
header-stamped, published after the node is up (it subscribes once the topic appears).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from node_processes import start_node, stop_node

pytest.importorskip("rclpy")
pytest.importorskip("sensor_msgs")

RIG_MAP = {
    "version": 1,
    "identity": {"hardware_id": "rig-9"},
    "channels": {
        "command": {"topic": "/joint_states", "joint": "surface_command", "field": "position"},
        "load": "unknown",
        "theta_u": {"topic": "/joint_states", "joint": "surface", "field": "position"},
        "theta_m": {"topic": "/joint_states", "joint": "motor", "field": "position"},
        "omega_m": {"topic": "/joint_states", "joint": "motor", "field": "velocity"},
        "i3eq": {"topic": "/joint_states", "joint": "motor", "field": "effort", "unit": "A"},
        "temperature": "unknown",
    },
}


def _publish_window(node, publisher, executor) -> None:
    """One simulated 1 s chirp, sample by sample, at about real time."""
    from sensor_msgs.msg import JointState

    from ema_phm.domain.faults import NOMINAL
    from ema_phm.physics.commands import CommandSpec
    from ema_phm.simulator import real_ema

    w = real_ema.simulate(NOMINAL, command=CommandSpec(duration=1.0)).window
    start = node.get_clock().now().nanoseconds
    for i in range(w.n):
        msg = JointState()
        ns = start + round(w.t[i] * 1e9)
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(ns, 1_000_000_000)
        msg.name = ["surface", "motor", "surface_command"]
        msg.position = [float(w.theta_u[i]), float(w.theta_m[i]), float(w.command[i])]
        msg.velocity = [0.0, float(w.omega_m[i]), 0.0]
        msg.effort = [0.0, float(w.i3eq[i]), 0.0]
        publisher.publish(msg)
        if i % 20 == 19:
            executor.spin_once(timeout_sec=0.0)
            time.sleep(0.01)


def _run_rig(domain: int, folder: Path, node_hardware_id: str) -> tuple[list, list[str]]:
    """The monitor_node process fed one window of the rig: its /ema/health, its messages."""
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

    from ema_phm.ros.common import OUTPUT_QOS

    (folder / "rig_map.yaml").write_text(yaml.safe_dump(RIG_MAP), encoding="utf-8")
    params = [
        f"channel_map_file:={folder / 'rig_map.yaml'}",
        "window_duration:=0.4",
        f"hardware_id:={node_hardware_id}",
        "warm_up:=false",
        "max_evaluations:=100",
        "prognostics:=false",
    ]
    monitor = start_node("monitor_node", domain, *params)
    ctx = Context()
    rclpy.init(context=ctx, domain_id=domain)
    rig = rclpy.create_node("rig", context=ctx)
    health: list[Float64MultiArray] = []
    said: list[str] = []
    rig.create_subscription(Float64MultiArray, "/ema/health", health.append, OUTPUT_QOS)
    rig.create_subscription(
        DiagnosticArray,
        "/diagnostics",
        lambda m: said.extend(s.message for s in m.status),
        OUTPUT_QOS,
    )
    publisher = rig.create_publisher(JointState, "/joint_states", 1000)
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(rig)
    try:
        deadline = time.monotonic() + 90.0
        while rig.count_subscribers("/joint_states") < 1 and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.2)
        assert rig.count_subscribers("/joint_states") == 1, "monitor_node never subscribed"
        _publish_window(rig, publisher, executor)
        deadline = time.monotonic() + (120.0 if node_hardware_id == "rig-9" else 8.0)
        while not health and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.2)
        return health, said
    finally:
        executor.shutdown()
        rig.destroy_node()
        rclpy.try_shutdown(context=ctx)
        code, err = stop_node(monitor)
        assert code == 0, err


def test_the_monitor_fits_windows_cut_from_a_rigs_joint_states(ros_domain_id, tmp_path: Path):
    health, _ = _run_rig(ros_domain_id, tmp_path, "rig-9")
    assert health, "no /ema/health: no window was cut from /joint_states"
    k = np.asarray(health[0].data[:8])
    assert np.all((k >= 0.0) & (k <= 1.0))


def test_a_rig_of_another_hardware_id_is_not_judged(ros_domain_id, tmp_path: Path):
    health, said = _run_rig(ros_domain_id, tmp_path, "ema-other")
    assert not health
    assert any("not the unit this monitor watches" in m and "rig-9" in m for m in said), said
