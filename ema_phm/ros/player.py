"""Publish a recorded bag into a live ROS 2 graph (`ema-phm play`).

The reading and timing are `ema_phm.telemetry.player`; this module only publishes:
one publisher per topic with the QoS the recording says (run_info and ground truth
latched, telemetry deep), fed the recorded CDR bytes as they are.  `/ema/...` topics
are created relative to the node's namespace (`common.RelativeTopics`), so a
`namespace` moves them as it moves the nodes.
"""

from __future__ import annotations

import importlib
import threading
from dataclasses import dataclass
from typing import Any

import rclpy
from rclpy.context import Context
from rclpy.duration import Duration
from rclpy.node import Node

from ..errors import BagError
from ..telemetry.player import Record, Recording, check_rate, play
from ..telemetry.wire import TELEMETRY_TOPIC
from .common import RelativeTopics, qos_profile

NODE_NAME = "ema_phm_player"
#: s to wait for the subscribers to acknowledge the last messages before leaving.
ACK_TIMEOUT_S = 10.0


def message_class(msgtype: str) -> Any:
    """The rclpy class of 'pkg/msg/Type'; BagError if that package is not importable."""
    pkg, _, name = msgtype.partition("/msg/")
    try:
        return getattr(importlib.import_module(f"{pkg}.msg"), name)
    except (ImportError, AttributeError, ValueError):
        raise BagError(
            f"cannot publish {msgtype}: its Python message package {pkg!r} is not installed"
        ) from None


@dataclass(frozen=True)
class PlayResult:
    """What a replay did."""

    published: int
    subscribers: dict[str, int]  # per topic, when the replay ended
    unacknowledged: tuple[str, ...]  # topics whose last messages were not all acknowledged


class BagPlayer(RelativeTopics, Node):
    """One publisher per topic of a `Recording`, publishing raw CDR bytes."""

    def __init__(self, recording: Recording, **kwargs: Any) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.recording = recording
        self.publishers_by_topic = {
            t.name: self.create_publisher(message_class(t.msgtype), t.name, qos_profile(t.qos))
            for t in recording.topics.values()
        }

    def publish_record(self, rec: Record) -> None:
        """Publish one recorded message (its bytes, unchanged)."""
        self.publishers_by_topic[rec.topic].publish(rec.data)

    def wait_for_subscribers(self, topic: str, n: int, stop: threading.Event) -> bool:
        """Wait until `topic` has `n` subscriptions; False if `stop` came first."""
        pub = self.publishers_by_topic[topic]
        while pub.get_subscription_count() < n:
            if stop.wait(0.02):
                return False
        return True

    def wait_for_acks(self) -> tuple[str, ...]:
        """Wait until every subscriber has every message; the topics where some did not."""
        return tuple(
            topic
            for topic, pub in self.publishers_by_topic.items()
            if not pub.wait_for_all_acked(Duration(seconds=ACK_TIMEOUT_S))
        )


def play_bag(
    path: str,
    *,
    rate: float = 1.0,
    loop: bool = False,
    topics: list[str] | None = None,
    namespace: str = "",
    wait_for_subscribers: int = 1,
    stop: threading.Event | None = None,
    context: Context | None = None,
    on_waiting: Any = None,
) -> PlayResult:
    """Replay the bag at `path` into the graph of `context` (default: a new one).

    Before the first message, waits until the telemetry topic (or, if it is not played,
    the first topic) has `wait_for_subscribers` subscriptions (0: no wait); after the
    last, waits until every subscriber acknowledged everything (`ACK_TIMEOUT_S` at most).
    `stop` ends the replay early.  BagError / ConfigError for a bad bag or rate.
    """
    rate = check_rate(rate)
    recording = Recording.open(path, topics)
    stop = stop or threading.Event()
    own = context is None
    if own:
        context = Context()
        rclpy.init(context=context)
    try:
        node = BagPlayer(recording, context=context, namespace=namespace or None)
        try:
            return _run(
                node,
                recording,
                rate=rate,
                loop=loop,
                wait_for=wait_for_subscribers,
                stop=stop,
                on_waiting=on_waiting,
            )
        finally:
            node.destroy_node()
    finally:
        if own:
            rclpy.try_shutdown(context=context)


def _run(
    node: BagPlayer,
    recording: Recording,
    *,
    rate: float,
    loop: bool,
    wait_for: int,
    stop: threading.Event,
    on_waiting: Any,
) -> PlayResult:
    gate = TELEMETRY_TOPIC if TELEMETRY_TOPIC in recording.topics else next(iter(recording.topics))
    if wait_for > 0:
        if on_waiting is not None:
            on_waiting(node.publishers_by_topic[gate].topic_name, wait_for)
        if not node.wait_for_subscribers(gate, wait_for, stop):
            return PlayResult(0, _counts(node), ())
    sent = play(recording.records, node.publish_record, rate=rate, loop=loop, stop=stop)
    unacked = node.wait_for_acks() if not stop.is_set() else ()
    return PlayResult(sent, _counts(node), unacked)


def _counts(node: BagPlayer) -> dict[str, int]:
    return {
        pub.topic_name: pub.get_subscription_count() for pub in node.publishers_by_topic.values()
    }
