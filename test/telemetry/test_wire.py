"""The wire codec (ema_phm.telemetry.wire).

Round trips through real bags, malformed layouts refused, and the topic names spelled out in one
module only.
"""

from __future__ import annotations

import ast
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest

import ema_phm
from ema_phm.domain.faults import N_K
from ema_phm.domain.window import CHANNELS
from ema_phm.errors import BagError, WindowError
from ema_phm.telemetry import wire
from ema_phm.telemetry.bags import (
    ROSBAGS_CLASSES,
    BagRecorder,
    read_messages,
    serialize,
    string_msg,
)
from ema_phm.telemetry.window_assembler import read_fitted_windows

RNG = np.random.default_rng(8)
ROWS = RNG.normal(size=(13, len(CHANNELS)))
K = np.array([0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 1.0])
HEALTH = RNG.normal(size=len(wire.HEALTH_FIELDS))

# topic, value, encoder, decoder, expected (labels, sizes, strides)
LAYOUTS: list[
    tuple[str, np.ndarray, Callable[[Any], wire.ArrayParts], Callable[..., Any], tuple]
] = [
    (
        wire.TELEMETRY_TOPIC,
        ROWS,
        wire.encode_telemetry,
        wire.decode_telemetry,
        (("samples", "channels"), (13, 8), (104, 8)),
    ),
    (
        wire.WINDOW_TOPIC,
        ROWS,
        wire.encode_telemetry,
        wire.decode_telemetry,
        (("samples", "channels"), (13, 8), (104, 8)),
    ),
    (
        wire.GROUND_TRUTH_TOPIC,
        K,
        wire.encode_ground_truth,
        wire.decode_ground_truth,
        (("k",), (8,), (8,)),
    ),
    (
        wire.HEALTH_TOPIC,
        HEALTH,
        wire.encode_health,
        lambda msg, topic: np.array(list(wire.decode_health(msg, topic=topic).values())),
        ((wire.HEALTH_LABEL,), (34,), (34,)),
    ),
]


@pytest.mark.parametrize(
    "topic, value, encode, decode, layout", LAYOUTS, ids=[x[0] for x in LAYOUTS]
)
def test_round_trip_through_a_bag(
    tmp_path: Path,
    topic: str,
    value: np.ndarray,
    encode: Callable,
    decode: Callable,
    layout: tuple,
) -> None:
    parts = encode(value)
    assert (parts.labels, parts.sizes, parts.strides, parts.data_offset) == (*layout, 0)
    with BagRecorder(tmp_path / "bag", topics={topic: wire.TOPIC_TYPES[topic]}) as rec:
        rec.write(topic, wire.to_message(parts, ROSBAGS_CLASSES), 1)
    [(read_topic, msgtype, _t, msg)] = list(read_messages(tmp_path / "bag"))
    assert (read_topic, msgtype) == (topic, wire.FLOAT64_MULTIARRAY)
    assert wire.parts_of(msg).labels == layout[0] and wire.parts_of(msg).strides == layout[2]
    decoded = decode(msg, topic=topic)
    assert decoded.dtype == np.float64
    np.testing.assert_array_equal(decoded, value)


def test_run_info_round_trip(tmp_path: Path) -> None:
    meta = {"sample_rate": 2000.0, "k_true": np.full(N_K, 0.25), "seed": np.int64(3)}
    with BagRecorder(tmp_path / "bag", topics={wire.RUN_INFO_TOPIC: wire.STRING}) as rec:
        rec.write(wire.RUN_INFO_TOPIC, string_msg(wire.encode_run_info(meta)), 1)
    [(_topic, msgtype, _t, msg)] = list(read_messages(tmp_path / "bag"))
    assert msgtype == wire.TOPIC_TYPES[wire.RUN_INFO_TOPIC] == wire.STRING
    assert wire.encode_run_info(meta) == msg.data
    assert '"k_true": [0.25, 0.25' in msg.data and '"seed": 3' in msg.data


def test_one_decoder_serves_rclpy_messages() -> None:
    """Rosbags encodes, rclpy decodes the CDR, the same decoder reads the rclpy message."""
    serialization = pytest.importorskip("rclpy.serialization")
    std_msgs = pytest.importorskip("std_msgs.msg")
    raw = serialize(
        wire.FLOAT64_MULTIARRAY, wire.to_message(wire.encode_telemetry(ROWS), ROSBAGS_CLASSES)
    )
    msg = serialization.deserialize_message(raw, std_msgs.Float64MultiArray)
    np.testing.assert_array_equal(wire.decode_telemetry(msg), ROWS)
    assert wire.parts_of(msg).labels == ("samples", "channels")


def test_data_offset_is_honoured() -> None:
    parts = wire.encode_telemetry(ROWS[:2])
    shifted = wire.ArrayParts(
        parts.labels,
        parts.sizes,
        parts.strides,
        np.concatenate([[99.0, 98.0], parts.data]),
        data_offset=2,
    )
    np.testing.assert_array_equal(
        wire.decode_telemetry(wire.to_message(shifted, ROSBAGS_CLASSES)), ROWS[:2]
    )


def test_decoded_rows_are_a_copy() -> None:
    msg = wire.to_message(wire.encode_telemetry(ROWS), ROSBAGS_CLASSES)
    wire.decode_telemetry(msg)[0, 0] = 1e9
    assert msg.data[0] == ROWS[0, 0]


@pytest.mark.parametrize(
    "topic, data, labels, decode, found, expected",
    [
        (
            wire.TELEMETRY_TOPIC,
            np.zeros((4, 6)),
            ["samples", "channels"],
            wire.decode_telemetry,
            "sizes [4, 6]",
            "[n, 7]",
        ),
        (
            wire.WINDOW_TOPIC,
            np.zeros(14),
            ["samples"],
            wire.decode_telemetry,
            "sizes [14]",
            "[n, 7]",
        ),
        (
            wire.GROUND_TRUTH_TOPIC,
            np.zeros(5),
            ["k"],
            wire.decode_ground_truth,
            "5 values",
            "expected 8 values",
        ),
        (
            wire.HEALTH_TOPIC,
            np.zeros(14),
            ["h"],
            wire.decode_health,
            "14 values",
            "expected 34 values",
        ),
    ],
    ids=["telemetry-6-channels", "window-1-D", "ground-truth-5", "health-14"],
)
def test_malformed_layout_names_topic_found_and_expected(
    topic: str, data: np.ndarray, labels: list[str], decode: Callable, found: str, expected: str
) -> None:
    msg = wire.to_message(wire.encode_array(data, labels), ROSBAGS_CLASSES)
    with pytest.raises(WindowError) as err:
        decode(msg, topic=topic)
    text = str(err.value)
    assert text.startswith(f"{topic} message has layout") and found in text and expected in text


def test_telemetry_with_missing_values_is_refused() -> None:
    msg = wire.to_message(wire.encode_telemetry(ROWS), ROSBAGS_CLASSES)
    msg.data = msg.data[:-1]
    with pytest.raises(WindowError, match=r"sizes \[13, 8\].*103 values"):
        wire.decode_telemetry(msg)


@pytest.mark.parametrize(
    "encode, value, shape",
    [
        (wire.encode_telemetry, np.zeros((3, 6)), "(3, 6)"),
        (wire.encode_telemetry, np.zeros(7), "(7,)"),
        (wire.encode_ground_truth, np.zeros(7), "(7,)"),
        (wire.encode_health, np.zeros(16), "(16,)"),
        (wire.encode_health, np.zeros(15), "(15,)"),  # the fit-only layout is read, not written
    ],
)
def test_encoders_refuse_wrong_shapes(encode: Callable, value: np.ndarray, shape: str) -> None:
    with pytest.raises(
        WindowError, match=rf"got shape {shape}".replace("(", r"\(").replace(")", r"\)")
    ):
        encode(value)


def test_bad_fitted_window_layout_names_bag_topic_and_sizes(tmp_path: Path) -> None:
    with BagRecorder(tmp_path / "bag", topics={wire.WINDOW_TOPIC: wire.FLOAT64_MULTIARRAY}) as rec:
        rec.write(
            wire.WINDOW_TOPIC,
            wire.to_message(wire.encode_array(np.zeros((3, 5)), ["s", "c"]), ROSBAGS_CLASSES),
            1,
        )
    with pytest.raises(BagError) as err:
        read_fitted_windows(tmp_path / "bag")
    assert all(
        s in str(err.value)
        for s in (
            str(tmp_path / "bag"),
            wire.WINDOW_TOPIC,
            "message 0",
            "sizes [3, 5]",
            "expected sizes [n, 8]",
        )
    )


def test_topic_names_are_spelled_out_only_in_wire() -> None:
    names = {topic for topic in wire.TOPIC_TYPES}
    assert names == {
        "/ema/telemetry",
        "/ema/ground_truth",
        "/ema/run_info",
        "/ema/window",
        "/ema/health",
        "/diagnostics",
        "/ema/telemetry_batch",
        "/ema/telemetry_sample",
        "/ema/window_batch",
        "/ema/actuator_health",
    }
    package = Path(ema_phm.__file__).parent
    found = {}
    for path in sorted(package.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        hits = sorted(
            {
                node.value
                for node in ast.walk(tree)
                if isinstance(node, ast.Constant) and node.value in names
            }
        )
        if hits:
            found[path.relative_to(package).as_posix()] = hits
    assert found == {"telemetry/wire.py": sorted(names)}


def test_health_of_the_fit_only_layout_decodes_with_nan_rul() -> None:
    old = wire.ArrayParts(
        labels=(",".join(wire.HEALTH_FIELDS_FIT),),
        sizes=(15,),
        strides=(15,),
        data=np.arange(15.0),
    )
    d = wire.decode_health(wire.to_message(old, ROSBAGS_CLASSES))
    assert list(d) == list(wire.HEALTH_FIELDS)
    assert [d[f] for f in wire.HEALTH_FIELDS_FIT] == list(np.arange(15.0))
    assert all(np.isnan(d[f]) for f in wire.HEALTH_RUL_FIELDS)
    bad = wire.ArrayParts(labels=("x",), sizes=(20,), strides=(20,), data=np.zeros(20))
    with pytest.raises(WindowError, match="expected 34 values"):
        wire.decode_health(wire.to_message(bad, ROSBAGS_CLASSES))


def test_stream_identity_round_trips_in_the_samples_label() -> None:
    sid = wire.StreamId("left aileron #2", "9f3c")
    rows = np.zeros((3, len(CHANNELS)))
    msg = wire.to_message(wire.encode_telemetry(rows, sid), ROSBAGS_CLASSES)
    assert msg.layout.dim[0].label.startswith("samples ")
    assert wire.decode_stream(msg) == sid
    np.testing.assert_array_equal(wire.decode_telemetry(msg), rows)  # the layout is unchanged
    anonymous = wire.to_message(wire.encode_telemetry(rows), ROSBAGS_CLASSES)
    assert anonymous.layout.dim[0].label == "samples" and wire.decode_stream(anonymous) is None


@pytest.mark.parametrize(
    "label",
    [
        'samples {"hardware_id": "a"}',
        "samples {not json",
        'samples {"hardware_id": "", "run_id": "r"}',
    ],
)
def test_a_malformed_stream_identity_is_a_named_error(label: str) -> None:
    msg = wire.to_message(wire.encode_telemetry(np.zeros((1, len(CHANNELS)))), ROSBAGS_CLASSES)
    msg.layout.dim[0].label = label
    with pytest.raises(WindowError, match="stream identity"):
        wire.decode_stream(msg)


def test_a_windows_cycle_round_trips_in_the_samples_label() -> None:
    rows = np.zeros((3, len(CHANNELS)))
    sid = wire.StreamId("rig-1", "life-1")
    for stream in (None, sid):
        msg = wire.to_message(wire.encode_telemetry(rows, stream, 7), ROSBAGS_CLASSES)
        assert wire.cycle_of_label(msg.layout.dim[0].label) == 7
        assert wire.decode_stream(msg) == stream  # a cycle alone is an anonymous stream
    plain = wire.to_message(wire.encode_telemetry(rows, sid), ROSBAGS_CLASSES)
    assert wire.cycle_of_label(plain.layout.dim[0].label) is None
    for bad in ('samples {"cycle": -1}', 'samples {"cycle": 1.5}', 'samples {"cycle": true}'):
        with pytest.raises(WindowError, match="cycle"):
            wire.cycle_of_label(bad)
