"""monitor_lifecycle_node through the lifecycle services, as a lifecycle manager reaches it.

The node runs as its executable; this test process calls ``~/change_state`` and
``~/get_state`` and watches the graph: configure builds (services appear), activate subscribes
the inputs and fits what ema_node sends, deactivate unsubscribes, cleanup removes what
configure made, shutdown ends it; a bad file at configure leaves it unconfigured and alive.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from node_processes import ONE_WINDOW, start_node, stop_node

pytest.importorskip("rclpy")

NODE = "/monitor_node"


class Manager:
    """A lifecycle manager's view of one node: its states, transitions and the graph."""

    def __init__(self, domain: int) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor

        self.ctx = Context()
        rclpy.init(context=self.ctx, domain_id=domain)
        self.node = rclpy.create_node("lifecycle_probe", context=self.ctx)
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)
        self.health: list[Any] = []

    def call(self, srv_type: Any, name: str, request: Any) -> Any:
        client = self.node.create_client(srv_type, name)
        try:
            assert client.wait_for_service(timeout_sec=60.0), f"{name} is not served"
            future = client.call_async(request)
            self.executor.spin_until_future_complete(future, timeout_sec=60.0)
            assert future.done(), f"{name} did not answer"
            return future.result()
        finally:
            self.node.destroy_client(client)

    def state(self) -> str:
        from lifecycle_msgs.srv import GetState

        return self.call(GetState, f"{NODE}/get_state", GetState.Request()).current_state.label

    def transition(self, name: str) -> bool:
        from lifecycle_msgs.msg import Transition
        from lifecycle_msgs.srv import ChangeState

        tid = getattr(Transition, f"TRANSITION_{name.upper()}")
        request = ChangeState.Request(transition=Transition(id=tid))
        return bool(self.call(ChangeState, f"{NODE}/change_state", request).success)

    def services(self) -> set[str]:
        return {s for s, _ in self.node.get_service_names_and_types() if s.startswith(NODE + "/")}

    def wait(self, condition: Any, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if condition():
                return True
            self.executor.spin_once(timeout_sec=0.1)
        return condition()

    def telemetry_subscribers(self) -> int:
        return self.node.count_subscribers("/ema/telemetry")

    def listen_to_health(self) -> None:
        from std_msgs.msg import Float64MultiArray

        from ema_phm.ros.common import OUTPUT_QOS

        self.node.create_subscription(
            Float64MultiArray, "/ema/health", self.health.append, OUTPUT_QOS
        )

    def close(self) -> None:
        import rclpy

        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.ctx)


@pytest.fixture
def manager(ros_domain_id: int) -> Iterator[Manager]:
    m = Manager(ros_domain_id)
    try:
        yield m
    finally:
        m.close()


def test_configure_activate_deactivate_cleanup_shutdown(
    manager: Manager, ros_domain_id: int
) -> None:
    node = start_node("monitor_lifecycle_node", ros_domain_id, "warm_up:=false")
    try:
        assert manager.state() == "unconfigured"
        assert f"{NODE}/list_parameters" in manager.services()  # ros2 param reaches it already
        assert f"{NODE}/commission" not in manager.services()

        assert manager.transition("configure") and manager.state() == "inactive"
        assert manager.wait(lambda: f"{NODE}/commission" in manager.services(), 10.0)
        assert manager.telemetry_subscribers() == 0, "inactive: no inputs yet"

        assert manager.transition("activate") and manager.state() == "active"
        assert manager.wait(lambda: manager.telemetry_subscribers() == 1, 10.0)

        assert manager.transition("deactivate") and manager.state() == "inactive"
        assert manager.wait(lambda: manager.telemetry_subscribers() == 0, 10.0)

        assert manager.transition("activate") and manager.state() == "active"
        assert manager.wait(lambda: manager.telemetry_subscribers() == 1, 10.0)
        assert manager.transition("deactivate")

        assert manager.transition("cleanup") and manager.state() == "unconfigured"
        assert manager.wait(lambda: f"{NODE}/commission" not in manager.services(), 10.0)

        assert manager.transition("configure") and manager.state() == "inactive"  # again
        assert manager.transition("activate")
        assert manager.transition("active_shutdown") and manager.state() == "finalized"
        assert manager.wait(lambda: manager.telemetry_subscribers() == 0, 10.0)
    finally:
        code, err = stop_node(node)
    assert code == 0, err


def test_a_bad_file_at_configure_leaves_it_unconfigured_with_the_reason(
    manager: Manager, ros_domain_id: int, tmp_path: Path
) -> None:
    missing = tmp_path / "no_such_actuator.yaml"
    node = start_node("monitor_lifecycle_node", ros_domain_id, f"actuator_file:={missing}")
    try:
        assert manager.state() == "unconfigured"
        assert not manager.transition("configure")
        assert manager.state() == "unconfigured"
        assert f"{NODE}/commission" not in manager.services()
        assert not manager.transition("configure"), "the same file fails the same way"
        assert node.poll() is None, "a failed configure is reported, not a dead process"
    finally:
        code, err = stop_node(node)
    assert code == 0, err
    assert "configure failed: actuator_file:" in err and str(missing) in err


def test_an_active_node_fits_what_the_actuator_sends(manager: Manager, ros_domain_id: int) -> None:
    manager.listen_to_health()
    node = start_node(
        "monitor_lifecycle_node", ros_domain_id, "warm_up:=false", "max_evaluations:=300"
    )
    ema = None
    try:
        assert manager.transition("configure") and manager.transition("activate")
        ema = start_node("ema_node", ros_domain_id, *ONE_WINDOW)
        assert manager.wait(lambda: bool(manager.health), 240.0), "no health from the window"
        assert manager.transition("deactivate")
        assert manager.state() == "inactive"
    finally:
        if ema is not None:
            stop_node(ema)
        code, err = stop_node(node)
    assert code == 0, err
