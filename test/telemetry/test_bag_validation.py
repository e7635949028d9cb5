"""Our recordings checked by other readers, as `ros2 bag info` would see them.

rosbag2's own reader (rosbag2_py, C++) has no PyPI wheel for this Python (there is no
``ros-rosbag2-py`` on the registry), so the checks are the `mcap` library's validating
readers (every CRC, the summary and its indexes), `mcap_ros2`'s decoder (messages
decoded from the schemas embedded in the file alone), and `rosbags` reading the
directory as a rosbag2 bag; ``metadata.yaml`` must agree with the ``.mcap``.
"""

from __future__ import annotations

import zlib
from pathlib import Path

import numpy as np
import yaml
from mcap.reader import make_reader
from mcap.records import DataEnd, Footer
from mcap.stream_reader import StreamReader
from mcap_ros2.decoder import DecoderFactory
from rosbags.rosbag2 import Reader
from typed_helpers import full_report, rows

from ema_phm.domain.window import CHANNELS
from ema_phm.telemetry import bags, typed
from ema_phm.telemetry.wire import (
    ACTUATOR_HEALTH_TOPIC,
    DIAGNOSTICS_TOPIC,
    RUN_INFO_TOPIC,
    TELEMETRY_TOPIC,
    TOPIC_TYPES,
    WINDOW_BATCH_TOPIC,
)


def recording(path: Path) -> dict[str, int]:
    """A recording of every topic type we use, over several chunks; messages per topic."""
    store = bags.TYPESTORE
    classes = typed.rosbags_classes(store)
    sent: dict[str, int] = {}
    topics = {t: TOPIC_TYPES[t] for t in (RUN_INFO_TOPIC, TELEMETRY_TOPIC, DIAGNOSTICS_TOPIC)}
    topics |= {t: TOPIC_TYPES[t] for t in (WINDOW_BATCH_TOPIC, ACTUATOR_HEALTH_TOPIC)}
    diag = store.types["diagnostic_msgs/msg/DiagnosticArray"]
    header = store.types["std_msgs/msg/Header"]
    stamp = store.types["builtin_interfaces/msg/Time"]

    def put(rec: bags.BagRecorder, topic: str, msg: object, t: int) -> None:
        rec.write(topic, msg, bags.EPOCH_OFFSET_NS + t)
        sent[topic] = sent.get(topic, 0) + 1

    with bags.BagRecorder(path, topics=topics) as rec:
        put(rec, RUN_INFO_TOPIC, bags.string_msg('{"sample_rate": 2000.0}'), 0)
        for i in range(12):
            block = np.full((50, len(CHANNELS)), float(i))
            put(rec, TELEMETRY_TOPIC, bags.float64_multiarray(block, ["samples", "channels"]), i)
            if i % 4 == 3:
                put(rec, WINDOW_BATCH_TOPIC, typed.telemetry_batch(classes, rows(20), i), i)
                put(
                    rec, ACTUATOR_HEALTH_TOPIC, typed.actuator_health(classes, full_report(), i), i
                )
                h = header(stamp=stamp(sec=i, nanosec=0), frame_id="")
                put(rec, DIAGNOSTICS_TOPIC, diag(header=h, status=[]), i)
                rec.flush()  # a chunk every 4 batches
    return sent


def test_our_recording_passes_the_mcap_librarys_validation(tmp_path: Path) -> None:
    sent = recording(tmp_path / "rec")
    mcap = tmp_path / "rec" / "rec.mcap"
    with mcap.open("rb") as f:  # every record, chunk CRCs and the data-section CRC checked
        records = list(StreamReader(f, validate_crcs=True).records)
    (data_end,) = [r for r in records if isinstance(r, DataEnd)]
    (footer,) = [r for r in records if isinstance(r, Footer)]
    assert data_end.data_section_crc != 0 and footer.summary_crc != 0
    raw = mcap.read_bytes()  # the summary CRC (the library reads but does not check it)
    footer_at = len(raw) - 8 - 29
    assert footer.summary_crc == zlib.crc32(raw[footer_at : footer_at + 25], zlib.crc32(
        raw[footer.summary_start : footer_at]
    ))  # fmt: skip
    with mcap.open("rb") as f:
        reader = make_reader(f, validate_crcs=True, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        assert len(summary.chunk_indexes) == summary.statistics.chunk_count >= 3
        assert reader.get_header().profile == "ros2"
        by_topic: dict[str, int] = {}
        for schema, channel, _message, decoded in reader.iter_decoded_messages():
            assert schema is not None and schema.encoding == "ros2msg"
            assert channel.message_encoding == "cdr" and decoded is not None
            by_topic[channel.topic] = by_topic.get(channel.topic, 0) + 1
    assert by_topic == sent


def test_metadata_yaml_agrees_with_the_mcap_and_rosbags_reads_it(tmp_path: Path) -> None:
    sent = recording(tmp_path / "rec")
    mcap = tmp_path / "rec" / "rec.mcap"
    text = (tmp_path / "rec" / "metadata.yaml").read_text(encoding="utf-8")
    info = yaml.safe_load(text)["rosbag2_bagfile_information"]
    with mcap.open("rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        embedded = {m.name: m.metadata for m in reader.iter_metadata()}
    stats = summary.statistics
    assert info["storage_identifier"] == "mcap" and info["relative_file_paths"] == [mcap.name]
    assert info["message_count"] == stats.message_count == sum(sent.values())
    assert info["starting_time"]["nanoseconds_since_epoch"] == stats.message_start_time
    assert info["duration"]["nanoseconds"] == stats.message_end_time - stats.message_start_time
    channels = {c.topic: c for c in summary.channels.values()}
    meta_topics = {t["topic_metadata"]["name"]: t for t in info["topics_with_message_count"]}
    assert set(meta_topics) == set(channels) == set(sent)
    for topic, entry in meta_topics.items():
        ch = channels[topic]
        tm = entry["topic_metadata"]
        assert entry["message_count"] == stats.channel_message_counts[ch.id] == sent[topic]
        assert tm["type"] == summary.schemas[ch.schema_id].name == TOPIC_TYPES[topic]
        assert tm["type_description_hash"] == ch.metadata["topic_type_hash"] != ""
        assert tm["offered_qos_profiles"], topic
        assert yaml.safe_load(ch.metadata["offered_qos_profiles"]) == tm["offered_qos_profiles"]
    # rosbag2 keeps metadata.yaml's content inside the .mcap too
    assert yaml.safe_load(embedded["rosbag2"]["serialized_metadata"]) == info
    with Reader(tmp_path / "rec") as bag:  # rosbags, through metadata.yaml, as a rosbag2 bag
        assert {c.topic: c.msgcount for c in bag.connections} == sent
        assert all(c.ext.offered_qos_profiles for c in bag.connections)
        store = bags.typestore_for(bag.connections)
        n = sum(1 for c, _t, raw in bag.messages() if store.deserialize_cdr(raw, c.msgtype))
    assert n == sum(sent.values())
