"""The QoS of each topic, without rclpy: what the nodes offer, bags record and `play` publishes.

Every topic is reliable, keep-last.  ``/ema/run_info`` and ``/ema/ground_truth`` are
latched (transient local, depth 1), so a subscriber that joins late still gets the
last one; telemetry is deep (1000) so a burst at realtime_factor 0 is not dropped.
`ema_phm.ros.common` builds the rclpy profiles from these, `ema_phm.telemetry.bags`
writes them to a bag's ``metadata.yaml`` as ``offered_qos_profiles`` (so that
``ros2 bag play`` replays the latched topics latched).
"""

from __future__ import annotations

from dataclasses import dataclass

from .wire import (
    ACTUATOR_HEALTH_TOPIC,
    DIAGNOSTICS_TOPIC,
    GROUND_TRUTH_TOPIC,
    HEALTH_TOPIC,
    RUN_INFO_TOPIC,
    TELEMETRY_BATCH_TOPIC,
    TELEMETRY_SAMPLE_TOPIC,
    TELEMETRY_TOPIC,
    WINDOW_BATCH_TOPIC,
    WINDOW_TOPIC,
)


@dataclass(frozen=True)
class TopicQos:
    """Reliable, keep-last `depth`; `latched` = transient local, else volatile."""

    depth: int
    latched: bool = False


#: Telemetry: deep, so a burst at realtime_factor 0 is not dropped.
TELEMETRY = TopicQos(depth=1000)
#: run_info and ground truth: the last one kept for late joiners.
LATCHED = TopicQos(depth=1, latched=True)
#: Health, diagnostics, fitted windows.
OUTPUT = TopicQos(depth=100)

#: The QoS of every ema_phm topic (canonical names, as in bags), typed ones included.
TOPIC_QOS: dict[str, TopicQos] = {
    TELEMETRY_TOPIC: TELEMETRY,
    TELEMETRY_BATCH_TOPIC: TELEMETRY,
    TELEMETRY_SAMPLE_TOPIC: TELEMETRY,
    WINDOW_BATCH_TOPIC: OUTPUT,
    ACTUATOR_HEALTH_TOPIC: OUTPUT,
    GROUND_TRUTH_TOPIC: LATCHED,
    RUN_INFO_TOPIC: LATCHED,
    WINDOW_TOPIC: OUTPUT,
    HEALTH_TOPIC: OUTPUT,
    DIAGNOSTICS_TOPIC: OUTPUT,
}


def qos_of(topic: str, *, latched: bool | None = None) -> TopicQos:
    """The QoS of `topic`; a topic not in `TOPIC_QOS` gets OUTPUT (or LATCHED if `latched`)."""
    known = TOPIC_QOS.get(topic)
    if known is not None:
        return known
    return LATCHED if latched else OUTPUT
