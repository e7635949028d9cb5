"""The QoS a recorded bag claims for each topic is the QoS the nodes really publish with."""

from __future__ import annotations

import time

import pytest
import yaml

rclpy = pytest.importorskip("rclpy")

from rclpy.qos import DurabilityPolicy, ReliabilityPolicy  # noqa: E402

from ema_phm.ros.ema_node import EmaNode  # noqa: E402
from ema_phm.ros.monitor_node import RECORD_TOPICS, MonitorNode  # noqa: E402
from ema_phm.ros.runtime import InProcessGraph  # noqa: E402
from ema_phm.telemetry.wire import TOPIC_TYPES  # noqa: E402

_DURABILITY = {
    DurabilityPolicy.TRANSIENT_LOCAL: "transient_local",
    DurabilityPolicy.VOLATILE: "volatile",
}
_RELIABILITY = {
    ReliabilityPolicy.RELIABLE: "reliable",
    ReliabilityPolicy.BEST_EFFORT: "best_effort",
}


def test_monitor_bag_carries_the_offered_qos_of_every_published_topic(ros_domain_id, tmp_path):
    bag = tmp_path / "rec"
    graph = InProcessGraph(ros_domain_id)
    graph.start()
    try:
        monitor = graph.add(MonitorNode, record_bag=str(bag))
        graph.add(EmaNode, wait_for_subscribers=50, max_windows=1)  # publishers, never sends
        published: dict[str, list] = {}
        deadline = time.monotonic() + 20.0
        while time.monotonic() < deadline:
            published = {t: monitor.get_publishers_info_by_topic(t) for t in TOPIC_TYPES}
            if all(published[t] for t in TOPIC_TYPES):
                break
            time.sleep(0.05)
    finally:
        graph.close()
    assert all(published[t] for t in TOPIC_TYPES), {t: len(v) for t, v in published.items()}
    meta = yaml.safe_load((bag / "metadata.yaml").read_text(encoding="utf-8"))
    offered = {
        t["topic_metadata"]["name"]: t["topic_metadata"]["offered_qos_profiles"]
        for t in meta["rosbag2_bagfile_information"]["topics_with_message_count"]
    }
    assert set(offered) == set(RECORD_TOPICS)
    for topic, profiles in offered.items():
        assert profiles, f"{topic}: offered_qos_profiles is empty"
        for info in published[topic]:
            qos = info.qos_profile
            # discovery reports no depth (0): the depth is checked in test_bag_qos.py
            got = (_DURABILITY[qos.durability], _RELIABILITY[qos.reliability])
            assert [(p["durability"], p["reliability"]) for p in profiles] == [got], topic
