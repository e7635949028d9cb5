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


def _rig_window():
    """The rig's 1 s chirp (the HF, noise-free)."""
    from ema_phm.domain.faults import NOMINAL
    from ema_phm.physics.commands import CommandSpec
    from ema_phm.simulator import real_ema

    return real_ema.simulate(NOMINAL, command=CommandSpec(duration=1.0)).window


def _offline_k(folder: Path) -> list[float]:
    """The first 0.4 s window of the rig's stream imported offline, fitted as the node fits it."""
    import dataclasses

    from ema_phm.diagnosis.isolation import isolate
    from ema_phm.diagnosis.isolation_settings import FitSettings
    from ema_phm.importing.channel_map import parse_channel_map
    from ema_phm.importing.importer import import_recordings
    from ema_phm.physics.parameters import ActuatorParameters
    from ema_phm.telemetry.bags import read_window

    w = _rig_window()
    cols = {
        "time_s": w.t,
        "command": w.command,
        "surface": w.theta_u,
        "motor": w.theta_m,
        "motor_speed": w.omega_m,
        "motor_current": w.i3eq,
    }
    import pyarrow as pa
    from pyarrow import csv

    with (folder / "rig.csv").open("wb") as f:
        csv.write_csv(pa.table(cols), f)
    table_map = {
        "version": 1,
        "identity": {"hardware_id": "rig-9"},
        "time": {"column": "time_s"},
        "windows": {"by": "length", "seconds": 0.4},
        "channels": {
            "command": {"column": "command"},
            "load": "unknown",
            "theta_u": {"column": "surface"},
            "theta_m": {"column": "motor"},
            "omega_m": {"column": "motor_speed"},
            "i3eq": {"column": "motor_current", "unit": "A"},
            "temperature": "unknown",
        },
    }
    cmap = parse_channel_map(table_map, where="m")
    report = import_recordings(
        [folder / "rig.csv"], cmap, ActuatorParameters.default(), folder / "offline"
    )
    first = read_window(sorted(report.written)[0])
    # the provenance the live run_info gives its windows (the map's own, not the table's)
    first = dataclasses.replace(first, meta={})
    res = isolate(first, **FitSettings(seed=0, max_evaluations=100).isolate_options(None))
    return [float(v) for v in res.k]


def _publish_window(node, publisher, executor) -> None:
    """One simulated 1 s chirp, sample by sample, at about real time."""
    from sensor_msgs.msg import JointState

    w = _rig_window()
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
        end = time.monotonic() + 1.0  # the match completes on both sides before sample 0
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.1)
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


def test_the_monitor_fits_a_rigs_joint_states_as_the_import_does(ros_domain_id, tmp_path: Path):
    health, _ = _run_rig(ros_domain_id, tmp_path, "rig-9")
    assert health, "no /ema/health: no window was cut from /joint_states"
    live = [float(v) for v in health[0].data[:8]]
    # the import's k: the live rows come from whole-nanosecond stamps, the table's from its
    # float times (1e-11 apart), which the phase of a near-zero eccentricity turns into 4e-8
    assert np.allclose(live, _offline_k(tmp_path), rtol=0, atol=1e-6)


def test_a_rig_of_another_hardware_id_is_not_judged(ros_domain_id, tmp_path: Path):
    health, said = _run_rig(ros_domain_id, tmp_path, "ema-other")
    assert not health
    assert any("not the unit this monitor watches" in m and "rig-9" in m for m in said), said
