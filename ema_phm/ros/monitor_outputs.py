"""monitor_node's outputs: what its HealthMonitor decided, published and logged in order.

`MonitorOutputs` owns the node's publishers (/ema/window, /ema/window_batch, /ema/health,
/diagnostics, /ema/actuator_health) and turns one `Outputs` into messages and log lines;
the windows to fit go to the `submit` function it is given (the node's worker).
"""

from __future__ import annotations

import dataclasses
from typing import Any, Callable

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node
from rclpy.publisher import Publisher
from std_msgs.msg import Float64MultiArray

from ..diagnosis import health
from ..monitor import status_texts
from ..monitor.health_monitor import HealthMonitor, Job, LogLine, Outputs
from ..telemetry.typed import HealthReport, extras_of
from ..telemetry.wire import (
    ACTUATOR_HEALTH_TOPIC,
    DIAGNOSTICS_TOPIC,
    HEALTH_TOPIC,
    WINDOW_BATCH_TOPIC,
    WINDOW_TOPIC,
    encode_health,
    encode_telemetry,
)
from .common import OUTPUT_QOS, to_rclpy
from .typed_messages import ActuatorHealth, TelemetryBatch, actuator_health, telemetry_batch

#: The task part of the DiagnosticStatus name (`status_name`).
STATUS_TASK = "actuator"
#: The topics monitor_node publishes on, with their message types (in the order it creates them).
OUTPUT_TOPICS: tuple[tuple[str, Any], ...] = (
    (WINDOW_TOPIC, Float64MultiArray),
    (HEALTH_TOPIC, Float64MultiArray),
    (DIAGNOSTICS_TOPIC, DiagnosticArray),
    (WINDOW_BATCH_TOPIC, TelemetryBatch),
    (ACTUATOR_HEALTH_TOPIC, ActuatorHealth),
)


def status_name(node_name: str) -> str:
    """DiagnosticStatus.name of a monitor: its fully qualified node name, then the task.

    Unique per node, as diagnostic_updater's "node: task", which drops the leading slash
    (diagnostic_aggregator splits names on "/"): 'left/monitor_node: actuator'.
    """
    return f"{node_name.lstrip('/')}: {STATUS_TASK}"


def diagnostic_array(
    status: status_texts.HealthStatus, stamp: Any, *, name: str | None = None
) -> DiagnosticArray:
    """One HealthStatus as a DiagnosticArray stamped `stamp` (named `name` if given)."""
    msg = DiagnosticArray()
    msg.header.stamp = stamp
    msg.status = [
        DiagnosticStatus(
            level=bytes([status.level]),
            name=status.name if name is None else name,
            message=status.message,
            hardware_id=status.hardware_id,
            values=[KeyValue(key=k, value=v) for k, v in status.values],
        )
    ]
    return msg


class MonitorOutputs:
    """The publishers of a monitor node and how one `Outputs` goes out on them."""

    def __init__(self, node: Node, service: HealthMonitor) -> None:
        self._node, self._service = node, service
        self.status_name = status_name(node.get_fully_qualified_name())
        self._pubs: dict[str, Publisher] = {
            topic: node.create_publisher(msg_type, topic, OUTPUT_QOS)
            for topic, msg_type in OUTPUT_TOPICS
        }
        self._last_fit: health.Assessment | None = None
        #: set once the node closes: publishing failures are then expected, not news
        self.closed = False

    def destroy(self) -> None:
        """Destroy the publishers (a managed node's cleanup); nothing is published after."""
        self.closed = True
        for pub in self._pubs.values():
            self._node.destroy_publisher(pub)
        self._pubs = {}

    def emit(self, out: Outputs, submit: Callable[[Job], None]) -> None:
        """Publish and log what the HealthMonitor decided, in its order; `submit` each job."""
        now_ns = self._node.get_clock().now().nanoseconds
        for job in out.jobs:  # every window scheduled, in order (one message may complete several)
            window = encode_telemetry(job.matrix, cycle=job.cycle)  # a replay's cycle
            self._publish(WINDOW_TOPIC, to_rclpy(window))
            batch = telemetry_batch(job.matrix, self._stamp_origin_ns(), job.stream)
            self._publish(WINDOW_BATCH_TOPIC, batch)
            submit(job)
        if out.health is not None:
            self._publish(HEALTH_TOPIC, to_rclpy(encode_health(out.health)))
        if out.status is not None:
            stamp = self._node.get_clock().now().to_msg()
            self._publish(
                DIAGNOSTICS_TOPIC, diagnostic_array(out.status, stamp, name=self.status_name)
            )
        if out.assessment is not None:
            self._last_fit = out.assessment
        if out.status is not None or out.assessment is not None:
            self._publish(ACTUATOR_HEALTH_TOPIC, actuator_health(self._report(out), now_ns))
        for line in out.logs:
            self._log(line)

    def _stamp_origin_ns(self) -> int:
        """The stream's t = 0 on the ROS clock (run_info ``stamp_origin_ns``; 0 if not given)."""
        origin = self._service.run_info.get("stamp_origin_ns", 0)
        return origin if isinstance(origin, int) and abs(origin) < 2**62 else 0

    def _report(self, out: Outputs) -> HealthReport:
        """What /ema/actuator_health says for `out`: its status, with the last fit's k."""
        a, status = out.assessment, out.status
        if status is not None:
            level, message, hardware_id = status.level, status.message, status.hardware_id
        elif a is not None:
            level, message, hardware_id = a.level, a.message, self._service.hardware_id
        else:
            raise ValueError("no status and no fit to report")
        fit = a if a is not None else self._last_fit
        extras, prognosis = extras_of(fit), self._service.prognosis
        if prognosis is not None:
            extras = dataclasses.replace(
                extras,
                rul=prognosis.remaining_life(),
                no_degradation_detected=prognosis.no_degradation_detected,
            )
        return HealthReport(
            level=level,
            message=message,
            hardware_id=hardware_id,
            assessed=a is not None,
            assessment=fit,
            extras=extras,
        )

    def _log(self, line: LogLine) -> None:
        # one call site per severity: rclpy refuses to change the severity of a call site
        logger = self._node.get_logger()
        if line.severity == "error":
            logger.error(line.text)
        elif line.severity == "warning":
            logger.warning(line.text)
        elif line.severity == "info":
            logger.info(line.text)
        else:
            logger.debug(line.text)

    def _publish(self, topic: str, msg: Any) -> None:
        publisher = self._pubs.get(topic)
        if publisher is None:  # destroyed (a managed node cleaned up): nothing goes out
            return
        try:
            publisher.publish(msg)
        except Exception as exc:  # noqa: BLE001 - publishing while the context shuts down
            if self._node.context.ok() and not self.closed:
                self._node.get_logger().error(f"publish on {publisher.topic_name} failed: {exc}")
