"""monitor_node on a rig's own topics: a channel map's topics subscribed, rows to the monitor.

Each topic the map names is subscribed once it is on the graph, with the message type the
graph says it has (its Python messages must be installed: `sensor_msgs` is), at a
best-effort QoS that hears reliable and best-effort publishers alike.  Every message goes
to an `importing.live.LiveChannels`, whose new grid rows go to the monitor as telemetry.
A topic not on the graph yet is tried again at every heartbeat (`subscribe_ready`).
"""

from __future__ import annotations

import functools
import importlib
import json
from typing import Any, Callable

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

from ..errors import ConfigError, EmaPhmError
from ..importing.channel_map import ChannelMap
from ..importing.importer import provenance
from ..importing.live import RESTART_S, LiveChannels
from ..physics.parameters import ActuatorParameters
from ..telemetry.wire import StreamId

#: Heard from reliable and best-effort publishers; deep enough for a burst of samples.
RIG_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.BEST_EFFORT
)


def message_class(type_name: str) -> Any:
    """The Python class of a ROS type name (``sensor_msgs/msg/JointState``); ConfigError."""
    try:
        package, kind, name = type_name.split("/")
        return getattr(importlib.import_module(f"{package}.{kind}"), name)
    except (ValueError, ImportError, AttributeError):
        raise ConfigError(
            f"message type {type_name} is not installed for Python: install its package"
        ) from None


def stream_of(cmap: ChannelMap) -> StreamId | None:
    """The stream's identity the map gives (None without a hardware_id: anonymous)."""
    ident = cmap.identity
    if not ident.hardware_id:
        return None
    return StreamId(hardware_id=ident.hardware_id, run_id=ident.run_id or "run")


def run_info(cmap: ChannelMap, actuator: ActuatorParameters, window_duration: float) -> str:
    """The run_info that gives the monitor its window geometry and the channels' provenance."""
    rate = float(actuator.acquisition.sample_rate)
    info: dict[str, Any] = {
        "sample_rate": rate,
        "samples_per_window": max(2, round(window_duration * rate)),
        "channels": provenance(cmap),
        "channel_map": cmap.source,
    }
    return json.dumps(info)


class MappedInputs:
    """The map's topics on `node`: rows to `on_rows`, a bad message's text to `on_error`."""

    def __init__(
        self,
        node: Node,
        live: LiveChannels,
        on_rows: Callable[[Any], None],
        on_error: Callable[[str, str], None],
        guard: Callable[[str, Callable[..., None]], Callable[..., None]],
    ) -> None:
        """`guard(where, callback)`: the callback as the node runs it (a fault is reported)."""
        self.node, self.live, self.guard = node, live, guard
        self.on_rows, self.on_error = on_rows, on_error
        self.pending = sorted(live.topics)
        self.subscriptions: list[Any] = []
        self.started = False  # the node asked for the inputs (and gave the run_info)
        self._group = MutuallyExclusiveCallbackGroup()

    def subscribe_ready(self) -> list[str]:
        """Subscribe to the map's topics now on the graph; the topics still missing."""
        types = dict(self.node.get_topic_names_and_types())
        for topic in list(self.pending):
            if topic not in types:
                continue
            try:
                cls = message_class(types[topic][0])
            except ConfigError as exc:
                self.on_error(f"subscribing to {topic}", str(exc))
                continue
            self.subscriptions.append(
                self.node.create_subscription(
                    cls,
                    topic,
                    self.guard(f"reading {topic}", functools.partial(self._on_message, topic)),
                    RIG_QOS,
                    callback_group=self._group,
                )
            )
            self.pending.remove(topic)
        return list(self.pending)

    def _on_message(self, topic: str, msg: Any) -> None:
        restarts = self.live.restarts
        try:
            self.live.add(topic, msg, self.node.get_clock().now().nanoseconds)
            rows = self.live.rows()
        except EmaPhmError as exc:
            self.on_error(f"reading {topic}", str(exc))
            return
        if self.live.restarts != restarts:
            self.on_error(
                f"reading {topic}",
                f"its time went back more than {RESTART_S:g} s (a restarted rig or a looped "
                "recording): the stream starts over",
            )
        if rows.shape[0]:
            self.on_rows(rows)

    def close(self) -> None:
        """Unsubscribe from every topic (they are pending again)."""
        for sub in self.subscriptions:
            self.node.destroy_subscription(sub)
        self.subscriptions = []
        self.pending = sorted(self.live.topics)
        self.started = False
