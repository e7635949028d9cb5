"""What monitor_node takes in: remapped inputs (the launch's *_topic), typed telemetry batches."""

from __future__ import annotations

import time

import pytest
from node_processes import ONE_WINDOW, start_node, stop_node

pytest.importorskip("rclpy")


def test_remapped_inputs_are_what_the_monitor_subscribes_to(ros_domain_id: int) -> None:
    import rclpy
    from rclpy.context import Context

    remaps = ("ema/telemetry:=/rig/ema_telemetry", "ema/run_info:=/rig/ema_run_info")
    proc = start_node("monitor_node", ros_domain_id, "warm_up:=false", remaps=remaps)
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
        code, err = stop_node(proc)
    assert code == 0, err


def _health_k(domain: int, *monitor_params: str) -> list[float]:
    """K of the first /ema/health of a monitor_node fed one window by ema_node (processes)."""
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from std_msgs.msg import Float64MultiArray

    from ema_phm.ros.common import OUTPUT_QOS

    ctx = Context()
    rclpy.init(context=ctx, domain_id=domain)
    probe = rclpy.create_node("health_probe", context=ctx)
    got: list[Float64MultiArray] = []
    probe.create_subscription(Float64MultiArray, "/ema/health", got.append, OUTPUT_QOS)
    params = ["warm_up:=false", "max_evaluations:=300", *monitor_params]
    monitor = start_node("monitor_node", domain, *params)
    ema_params = [
        *ONE_WINDOW,
        "k:=[0.3,0.0,0.0,0.0,0.0,0.0,0.5,0.5]",
        "seed:=4",
        "noise_current:=0.1",
    ]
    ema = start_node("ema_node", domain, *ema_params)
    try:
        executor = SingleThreadedExecutor(context=ctx)
        executor.add_node(probe)
        deadline = time.monotonic() + 240.0
        while not got and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.2)
        executor.shutdown()
        assert got, "no /ema/health from the window"
        return [float(v) for v in got[0].data[:8]]
    finally:
        probe.destroy_node()
        rclpy.try_shutdown(context=ctx)
        for proc in (ema, monitor):
            stop_node(proc)


def test_typed_batches_give_the_fit_of_the_multiarray(ros_domain_id: int) -> None:
    """telemetry_input:=batch: the window from ema_phm_msgs/TelemetryBatch, the same k."""
    from_array = _health_k(ros_domain_id, "telemetry_input:=multiarray")
    # a domain of its own: the first pair's endpoints, still known to discovery until their
    # lease ends, must not count as the subscriber ema_node waits for (a loaded CI machine
    # sent the one window to the first monitor's ghost and no /ema/health came)
    from_batch = _health_k(ros_domain_id + 101, "telemetry_input:=batch")
    assert from_batch == from_array
    assert abs(from_batch[0] - 0.3) < 0.05  # the friction the actuator has


def test_another_units_stream_is_an_error_seen_from_another_process(ros_domain_id: int) -> None:
    """Issue 33: monitor_node (hardware_id ema_left) fed ema_node's ema_sim stream, as processes.

    /diagnostics, read by a third process's node as rqt would, says ERROR naming both ids.
    """
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor

    from ema_phm.ros.common import OUTPUT_QOS

    ctx = Context()
    rclpy.init(context=ctx, domain_id=ros_domain_id)
    probe = rclpy.create_node("diagnostics_probe", context=ctx)
    said: list = []
    probe.create_subscription(
        DiagnosticArray, "/diagnostics", lambda m: said.extend(m.status), OUTPUT_QOS
    )
    monitor = start_node("monitor_node", ros_domain_id, "warm_up:=false", "hardware_id:=ema_left")
    ema = start_node("ema_node", ros_domain_id, *ONE_WINDOW)
    words = "not the unit this monitor watches, hardware_id 'ema_left'"
    try:
        executor = SingleThreadedExecutor(context=ctx)
        executor.add_node(probe)
        deadline = time.monotonic() + 120.0
        while time.monotonic() < deadline and not any(words in s.message for s in said):
            executor.spin_once(timeout_sec=0.2)
        executor.shutdown()
        hit = [s for s in said if words in s.message]
        assert hit, [s.message for s in said][-3:]
        assert hit[0].level == bytes([2]) and "ema_sim" in hit[0].message  # ERROR, both named
        assert hit[0].hardware_id == "ema_left"
    finally:
        probe.destroy_node()
        rclpy.try_shutdown(context=ctx)
        for proc in (ema, monitor):
            stop_node(proc)
