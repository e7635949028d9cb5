"""monitor_node on a rig's own topics: a channel map's topics subscribed, rows to the monitor.

Each topic the map names is subscribed once it is on the graph, with the message type the
graph says it has (its Python messages must be installed: `sensor_msgs` is), at a
best-effort QoS that hears reliable and best-effort publishers alike.  Every message goes
to an `importing.live.LiveChannels`, whose new grid rows go to the monitor as telemetry.
A topic not on the graph yet is tried again at every heartbeat (`subscribe_ready`).

A message without a header stamp (std_msgs/Float64, or a map with ``stamps: log``) is
timed by when the middleware received it (`received_at`), as rosbag2 records its log
time, not by when the callback ran: a callback that waited behind a busy executor would
crowd a burst of samples into one instant.  Under ``use_sim_time`` it is the node's clock.
"""

from __future__ import annotations

import functools
import importlib
import json
from typing import Any, Callable, Mapping

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.subscription import MessageInfo

from ..errors import ConfigError, EmaPhmError
from ..importing.channel_map import ChannelMap, load_channel_map
from ..importing.importer import provenance
from ..importing.live import (
    RESTART_S,
    LiveChannels,
    Mark,
    listed_rule,
    longest_listed,
    longest_segment,
    marker_runs,
    span_rule,
    window_samples,
)
from ..monitor.health_monitor import HealthMonitor
from ..monitor.outputs import Outputs
from ..physics.parameters import ActuatorParameters
from ..telemetry.wire import StreamId

#: Heard from reliable and best-effort publishers; deep enough for a rig's samples while a fit
#: holds the interpreter: 10 s at 2 kHz.  With 1000 (0.5 s), beside two busy processes on a
#: 2-core machine, test_the_monitor_cuts_a_rigs_excitation_segments_as_the_import_does failed
#: 3 of 3 runs (twice the second segment never completed, once its k differed); 0 of 3 with
#: 20000.  A full queue of 20000 JointStates costs ~2 MB.
RIG_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=20000, reliability=ReliabilityPolicy.BEST_EFFORT
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


def received_at(node: Node, info: MessageInfo) -> int:
    """When a message arrived [ns]: the middleware's receive time, the node's sim time."""
    clock = node.get_clock()
    received = int(info.get("received_timestamp") or 0)
    if received <= 0 or getattr(clock, "ros_time_is_active", False):
        return clock.now().nanoseconds
    return received


def stream_of(cmap: ChannelMap) -> StreamId | None:
    """The stream's identity the map gives (None without a hardware_id: anonymous)."""
    ident = cmap.identity
    if not ident.hardware_id:
        return None
    return StreamId(hardware_id=ident.hardware_id, run_id=ident.run_id or "run")


def run_info(cmap: ChannelMap, actuator: ActuatorParameters, window_duration: float) -> str:
    """The run_info that gives the monitor its window geometry and the channels' provenance.

    A map whose windows are by excitation makes them the command's excitation segments, up to
    `importing.live.LONGEST_SEGMENT_S` long (`span_assembler`); by ``times`` or ``marker``, the
    listed or marked windows (`listed_assembler`); by length: windows of `window_duration`.
    """
    span, listed = span_rule(cmap), listed_rule(cmap)
    info: dict[str, Any] = {
        "sample_rate": float(actuator.acquisition.sample_rate),
        "samples_per_window": window_samples(actuator, window_duration),
        "channels": provenance(cmap),
        "channel_map": cmap.source,
    }
    if span is not None:
        info["samples_per_window"] = longest_segment(actuator)
        info["windows"] = span.as_info()
    if listed is not None:
        info["samples_per_window"] = longest_listed(actuator, listed)
        info["windows"] = listed.as_info()
    return json.dumps(info)


class MappedInputs:
    """The map's topics on `node`: rows to `on_rows`, a bad message's text to `on_error`.

    A map whose windows are by marker also gives each of the marker's runs, once it has
    ended, to `on_mark` (after its last row).
    """

    def __init__(  # noqa: PLR0913 - the node's three outlets and its guard
        self,
        node: Node,
        live: LiveChannels,
        on_rows: Callable[[Any], None],
        on_error: Callable[[str, str], None],
        guard: Callable[[str, Callable[..., None]], Callable[..., None]],
        *,
        run_info: str = "",
        on_mark: Callable[[Mark], None] | None = None,
    ) -> None:
        """`guard(where, callback)`: the callback as the node runs it (a fault is reported).

        `run_info`: what the monitor is told of the stream before its first rows.
        """
        self.node, self.live, self.guard, self.run_info = node, live, guard, run_info
        self.on_rows, self.on_error, self.on_mark = on_rows, on_error, on_mark
        self.runs = marker_runs(live.cmap, live.rate)
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
                    cls, topic, self._callback(topic), RIG_QOS, callback_group=self._group
                )
            )
            self.pending.remove(topic)
        return list(self.pending)

    def _callback(self, topic: str) -> Callable[[Any, MessageInfo], None]:
        """The subscription callback of `topic`, guarded; rclpy gives it the message info."""
        handler = self.guard(f"reading {topic}", functools.partial(self._on_message, topic))

        def on_message(msg: Any, info: MessageInfo) -> None:  # two parameters: info is given
            handler(msg, info)

        return on_message

    def _on_message(self, topic: str, msg: Any, info: MessageInfo) -> None:
        restarts = self.live.restarts
        try:
            self.live.add(topic, msg, received_at(self.node, info))
            rows, marker = self.live.rows_and_marker()
        except EmaPhmError as exc:
            self.on_error(f"reading {topic}", str(exc))
            return
        if self.live.restarts != restarts:
            self.on_error(
                f"reading {topic}",
                f"its time went back more than {RESTART_S:g} s (a restarted rig or a looped "
                "recording): the stream starts over",
            )
        if self.runs is None:
            if rows.shape[0]:
                self.on_rows(rows)
            return
        for piece in self.runs.split(rows, marker):
            if isinstance(piece, Mark):
                if self.on_mark is not None:
                    self.on_mark(piece)
            elif piece.shape[0]:
                self.on_rows(piece)

    def close(self) -> None:
        """Unsubscribe from every topic (they are pending again)."""
        for sub in self.subscriptions:
            self.node.destroy_subscription(sub)
        self.subscriptions = []
        self.pending = sorted(self.live.topics)
        self.started = False


def mapped_inputs_of(  # noqa: PLR0913, PLR0917 - the node's parts the inputs feed
    node: Node,
    values: Mapping[str, Any],
    actuator: ActuatorParameters,
    monitor: HealthMonitor,
    emit: Callable[[Outputs], None],
    on_rows: Callable[[Any, StreamId | None], None],
    guard: Callable[[str, Callable[..., None]], Callable[..., None]],
) -> MappedInputs | None:
    """A rig's topics through the `channel_map_file` parameter (None: ema_phm's own topics).

    Rows go to `on_rows`; a bad message, and each marked window, to `monitor`, whose
    outputs go to `emit`.
    """
    if not values["channel_map_file"]:
        return None
    cmap = load_channel_map(str(values["channel_map_file"]))
    stream = stream_of(cmap)
    duration = values["window_duration"]
    aligned = window_samples(actuator, duration) if cmap.windows.by == "length" else None
    return MappedInputs(
        node,
        LiveChannels(cmap, actuator, aligned),
        on_rows=lambda rows: on_rows(rows, stream),
        on_error=lambda where, why: emit(monitor.on_malformed_telemetry(f"{where}: {why}")),
        guard=guard,
        run_info=run_info(cmap, actuator, duration),
        on_mark=lambda m: emit(monitor.on_window_marked(m.t0, m.t1, stream)),
    )
