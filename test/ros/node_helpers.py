"""What the in-process node tests share: a probe node, polling, service calls (graph: conftest)."""

from __future__ import annotations

import threading
import time

from diagnostic_msgs.msg import DiagnosticArray
from std_msgs.msg import Float64MultiArray, String

from ema_phm.ros.common import LATCHED_QOS, OUTPUT_QOS, TELEMETRY_QOS
from ema_phm.ros.runtime import InProcessGraph
from ema_phm.telemetry import wire


def wait_until(pred, timeout: float, step: float = 0.01) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if pred():
            return True
        time.sleep(step)
    return pred()


class Listener:
    """A plain node in graph `g` that keeps what its subscriptions (`_add`) hear."""

    def __init__(self, g: InProcessGraph, name: str) -> None:
        from rclpy.node import Node

        self.node = Node(name, context=g.context)
        g.nodes.append(self.node)
        g.executor.add_node(self.node)
        self.lock = threading.Lock()

    def _add(self, into: list):
        def cb(msg):
            with self.lock:
                into.append(msg)

        return cb


class Probe(Listener):
    """A plain node that listens to everything the two nodes publish."""

    def __init__(self, g: InProcessGraph) -> None:
        super().__init__(g, "probe")
        self.telemetry: list[Float64MultiArray] = []
        self.truth: list[Float64MultiArray] = []
        self.info: list[str] = []
        self.health: list[Float64MultiArray] = []
        self.diag: list[DiagnosticArray] = []
        self.windows: list[Float64MultiArray] = []
        sub = self.node.create_subscription
        sub(Float64MultiArray, wire.TELEMETRY_TOPIC, self._add(self.telemetry), TELEMETRY_QOS)
        sub(Float64MultiArray, wire.GROUND_TRUTH_TOPIC, self._add(self.truth), LATCHED_QOS)
        sub(String, wire.RUN_INFO_TOPIC, self._add(self.info), LATCHED_QOS)
        sub(Float64MultiArray, wire.HEALTH_TOPIC, self._add(self.health), OUTPUT_QOS)
        sub(DiagnosticArray, wire.DIAGNOSTICS_TOPIC, self._add(self.diag), OUTPUT_QOS)
        sub(Float64MultiArray, wire.WINDOW_TOPIC, self._add(self.windows), OUTPUT_QOS)

    def statuses(self) -> list:
        with self.lock:
            return [s for m in self.diag for s in m.status]


def trigger(probe_node, name: str):
    from std_srvs.srv import Trigger

    client = probe_node.create_client(Trigger, f"/monitor_node/{name}")
    assert client.wait_for_service(timeout_sec=10.0), name
    fut = client.call_async(Trigger.Request())
    assert wait_until(fut.done, 10.0), name
    return fut.result()
