"""monitor_node's recording: everything received and published, as raw bytes, to a bag.

`NodeRecording` opens the rosbag2 MCAP bag of the `record_bag` parameter, subscribes
(raw) to the node's own outputs so the bag holds the bytes that were on the wire, and is
handed the raw inputs by the node (`write`).  A failed write (disk full) is logged once
and the recording stops; nothing goes to /diagnostics (that would be recorded again).
"""

from __future__ import annotations

import functools
import sys
from typing import Any

from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node

from ..errors import EmaPhmError
from ..telemetry.recording import open_recording
from ..telemetry.wire import (
    ACTUATOR_HEALTH_TOPIC,
    DIAGNOSTICS_TOPIC,
    GROUND_TRUTH_TOPIC,
    HEALTH_TOPIC,
    RUN_INFO_TOPIC,
    TELEMETRY_BATCH_TOPIC,
    TELEMETRY_TOPIC,
    TOPIC_TYPES,
    WINDOW_BATCH_TOPIC,
    WINDOW_TOPIC,
)
from .common import OUTPUT_QOS
from .monitor_outputs import OUTPUT_TOPICS

#: Topics (and types) of a recording, in the order the bag lists them.
RECORD_TOPICS: dict[str, str] = {
    topic: TOPIC_TYPES[topic]
    for topic in (
        RUN_INFO_TOPIC,
        GROUND_TRUTH_TOPIC,
        TELEMETRY_TOPIC,
        TELEMETRY_BATCH_TOPIC,
        WINDOW_TOPIC,
        HEALTH_TOPIC,
        DIAGNOSTICS_TOPIC,
        WINDOW_BATCH_TOPIC,
        ACTUATOR_HEALTH_TOPIC,
    )
}


class NodeRecording:
    """The bag of one monitor node ('' template: none, and every call is a no-op)."""

    def __init__(self, node: Node, template: str, log_name: str) -> None:
        """Open the bag `template` names (refusing an existing one) and record the outputs."""
        self._node, self._log_name = node, log_name
        self._recorder: Any = None
        self.path = ""
        self.recorded: dict[str, int] = {}  # messages written to the bag, per topic
        self.closed = False  # set by `close`: a late failure is then not news
        if not template:
            return
        self._recorder, self.path = open_recording(template, RECORD_TOPICS)
        group = ReentrantCallbackGroup()
        for topic, msg_type in OUTPUT_TOPICS:
            node.create_subscription(
                msg_type,
                topic,
                functools.partial(self.write, topic),
                OUTPUT_QOS,
                raw=True,
                callback_group=group,
            )

    def write(self, topic: str, raw: bytes) -> None:
        """Write one serialized message of `topic`, stamped with the node's clock."""
        recorder = self._recorder
        if recorder is None or recorder.failed:  # stopped (e.g. disk full): said once already
            return
        try:
            recorder.write_raw(topic, raw, self._node.get_clock().now().nanoseconds)
            self.recorded[topic] = self.recorded.get(topic, 0) + 1
        except Exception as exc:  # noqa: BLE001 - logged only: reporting on /diagnostics would be recorded again
            if not self.closed:
                self._node.get_logger().error(f"recording {topic}: {type(exc).__name__}: {exc}")

    def close(self) -> None:
        """Finish the bag (once; later calls do nothing) and say so."""
        self.closed = True
        recorder, self._recorder = self._recorder, None
        if recorder is None:
            return
        try:
            recorder.close()
            self._say(f"bag {self.path} closed")
        except EmaPhmError as exc:
            self._say(str(exc), error=True)

    def _say(self, text: str, *, error: bool = False) -> None:
        """Log, also once the context is gone (rosout is then unavailable)."""
        if not self._node.context.ok():
            print(f"[{'ERROR' if error else 'INFO'}] [{self._log_name}]: {text}", file=sys.stderr)
        elif error:  # one severity per call site
            self._node.get_logger().error(text)
        else:
            self._node.get_logger().info(text)
