"""Bags record the QoS our publishers offer, so `ros2 bag play` replays run_info latched."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from ema_phm.domain.window import CHANNELS, Window
from ema_phm.telemetry import bags
from ema_phm.telemetry.qos import TOPIC_QOS
from ema_phm.telemetry.wire import (
    DIAGNOSTICS_TOPIC,
    GROUND_TRUTH_TOPIC,
    RUN_INFO_TOPIC,
    TELEMETRY_TOPIC,
    TOPIC_TYPES,
)


def _offered(path: Path) -> dict[str, list[dict]]:
    """Topic -> offered_qos_profiles, read back from metadata.yaml as rosbag2 would."""
    meta = yaml.safe_load((path / "metadata.yaml").read_text(encoding="utf-8"))
    return {
        t["topic_metadata"]["name"]: t["topic_metadata"]["offered_qos_profiles"]
        for t in meta["rosbag2_bagfile_information"]["topics_with_message_count"]
    }


def test_recorder_writes_latched_and_volatile_profiles(tmp_path):
    topics = {t: TOPIC_TYPES[t] for t in (RUN_INFO_TOPIC, TELEMETRY_TOPIC, DIAGNOSTICS_TOPIC)}
    topics["/other"] = TOPIC_TYPES[RUN_INFO_TOPIC]  # not ours: nothing claimed for it
    with bags.BagRecorder(tmp_path / "rec", topics=topics):
        pass
    offered = _offered(tmp_path / "rec")
    (info,) = offered[RUN_INFO_TOPIC]
    assert info["durability"] == "transient_local" and info["reliability"] == "reliable"
    assert info["history"] == "keep_last" and info["depth"] == 1
    (tel,) = offered[TELEMETRY_TOPIC]
    assert tel["durability"] == "volatile" and tel["depth"] == TOPIC_QOS[TELEMETRY_TOPIC].depth
    assert offered[DIAGNOSTICS_TOPIC][0]["durability"] == "volatile"
    assert offered["/other"] == []


def test_written_window_reads_back_with_its_qos(tmp_path):
    """write_window -> rosbags' reader: the connections carry the profiles they were given."""
    from rosbags.interfaces import QosDurability
    from rosbags.rosbag2 import Reader

    t = np.arange(201) / 2000.0
    rows = np.zeros((201, len(CHANNELS)))
    rows[:, 0] = t
    window = Window.from_matrix(
        rows, meta={"sample_rate": 2000.0}, k_true=np.array([0.0] * 6 + [0.5, 0.5])
    )
    path = bags.write_window(tmp_path / "w", window)
    with Reader(path) as reader:
        durability = {
            c.topic: [q.durability for q in c.ext.offered_qos_profiles] for c in reader.connections
        }
    assert durability[RUN_INFO_TOPIC] == [QosDurability.TRANSIENT_LOCAL]
    assert durability[GROUND_TRUTH_TOPIC] == [QosDurability.TRANSIENT_LOCAL]
    assert durability[TELEMETRY_TOPIC] == [QosDurability.VOLATILE]


def test_every_topic_the_nodes_publish_is_recorded_with_its_qos(tmp_path):
    """The typed topics (/ema/window_batch, /ema/actuator_health, ...) used to get []."""
    with bags.BagRecorder(tmp_path / "rec", topics=TOPIC_TYPES):
        pass
    offered = _offered(tmp_path / "rec")
    assert set(offered) == set(TOPIC_TYPES)
    for topic, profiles in offered.items():
        spec = TOPIC_QOS[topic]
        (p,) = profiles
        assert (p["depth"], p["reliability"], p["history"]) == (
            spec.depth,
            "reliable",
            "keep_last",
        )
        assert p["durability"] == ("transient_local" if spec.latched else "volatile"), topic
