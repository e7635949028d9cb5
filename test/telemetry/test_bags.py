"""Tests of ema_phm.telemetry.bags: rosbag2/MCAP round trips, independent decoding, errors."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from ema_phm.domain.faults import N_K
from ema_phm.domain.window import CHANNELS, Window
from ema_phm.errors import BagError
from ema_phm.telemetry import bags
from ema_phm.telemetry.bags import (
    EPOCH_OFFSET_NS,
    GROUND_TRUTH_TOPIC,
    RUN_INFO_TOPIC,
    TELEMETRY_TOPIC,
    BagRecorder,
    float64_multiarray,
    read_messages,
    read_window,
    serialize,
    string_msg,
    write_window,
)

F64 = "std_msgs/msg/Float64MultiArray"
META = {
    "sample_rate": 1000.0,
    "command": {"kind": "chirp", "amp": 0.1},
    "seed": 7,
    "version": "0.1.0",
}


def synthetic(n: int = 1234, *, k: bool = True, meta: dict | None = None, seed: int = 0) -> Window:
    rng = np.random.default_rng(seed)
    data = rng.normal(size=(n, len(CHANNELS)))
    data[:, 0] = 3.25 + np.arange(n) * 1e-3
    return Window.from_matrix(
        data, k_true=rng.uniform(0, 1, N_K) if k else None, meta=META if meta is None else meta
    )


def only_mcap(bag: Path) -> Path:
    (mcap,) = bag.glob("*.mcap")
    return mcap


def test_round_trip_exact(tmp_path: Path) -> None:
    w = synthetic()
    out = write_window(tmp_path / "bag", w, samples_per_message=100)
    assert out == tmp_path / "bag"
    r = read_window(out)
    assert r.n == 1234
    assert np.array_equal(r.matrix(), w.matrix())
    assert np.array_equal(r.k_true, w.k_true)
    assert r.meta == META


def test_log_times_and_write_order(tmp_path: Path) -> None:
    w = synthetic(250)
    write_window(tmp_path / "bag", w, samples_per_message=100)
    msgs = list(read_messages(tmp_path / "bag"))
    assert [m[0] for m in msgs] == [RUN_INFO_TOPIC, GROUND_TRUTH_TOPIC] + [TELEMETRY_TOPIC] * 3
    tele = [m[2] for m in msgs if m[0] == TELEMETRY_TOPIC]
    assert tele == [EPOCH_OFFSET_NS + round(w.t[i] * 1e9) for i in (0, 100, 200)]


def test_non_monotonic_time_keeps_sample_order(tmp_path: Path) -> None:
    data = np.random.default_rng(3).normal(
        size=(333, len(CHANNELS))
    )  # random t: batches out of time order
    w = Window.from_matrix(data)
    write_window(tmp_path / "bag", w, samples_per_message=10)
    assert np.array_equal(read_window(tmp_path / "bag").matrix(), data)


def test_existing_path_refused(tmp_path: Path) -> None:
    target = tmp_path / "bag"
    target.mkdir()
    with pytest.raises(BagError, match="exists") as err:
        write_window(target, synthetic())
    assert str(target) in str(err.value)
    assert list(target.iterdir()) == []


def test_metadata_yaml_says_mcap(tmp_path: Path) -> None:
    write_window(tmp_path / "bag", synthetic())
    meta = (tmp_path / "bag" / "metadata.yaml").read_text()
    assert "storage_identifier: mcap" in meta
    assert only_mcap(tmp_path / "bag").name in meta


def test_independent_mcap_reader(tmp_path: Path) -> None:
    w = synthetic()
    write_window(tmp_path / "bag", w, samples_per_message=100)
    seen: dict[str, int] = {}
    rows = []
    with only_mcap(tmp_path / "bag").open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, message, ros in reader.iter_decoded_messages(log_time_order=True):
            seen[channel.topic] = seen.get(channel.topic, 0) + 1
            if channel.topic == TELEMETRY_TOPIC:
                assert schema.name == F64 and message.log_time >= EPOCH_OFFSET_NS
                d = ros.layout.dim
                assert [(x.label, x.size, x.stride) for x in d] == [
                    ("samples", d[0].size, d[0].size * len(CHANNELS)),
                    ("channels", len(CHANNELS), len(CHANNELS)),
                ]
                rows.append(np.asarray(ros.data, dtype=np.float64).reshape(-1, len(CHANNELS)))
            elif channel.topic == GROUND_TRUTH_TOPIC:
                assert [(x.label, x.size) for x in ros.layout.dim] == [("k", N_K)]
                assert np.array_equal(np.asarray(ros.data), w.k_true)
            elif channel.topic == RUN_INFO_TOPIC:
                assert schema.name == "std_msgs/msg/String" and '"seed": 7' in ros.data
    assert seen == {RUN_INFO_TOPIC: 1, GROUND_TRUTH_TOPIC: 1, TELEMETRY_TOPIC: 13}
    assert np.array_equal(np.concatenate(rows), w.matrix())


def test_no_ground_truth_no_meta(tmp_path: Path) -> None:
    write_window(tmp_path / "bag", synthetic(k=False, meta={}))
    r = read_window(tmp_path / "bag")
    assert r.k_true is None and r.meta == {}
    assert {m[0] for m in read_messages(tmp_path / "bag")} == {TELEMETRY_TOPIC}


def test_recorded_bag_extra_topics_last_ground_truth(tmp_path: Path) -> None:
    w = synthetic(300, k=False, meta={})
    topics = {
        TELEMETRY_TOPIC: F64,
        GROUND_TRUTH_TOPIC: F64,
        "/diagnostics": "diagnostic_msgs/msg/DiagnosticArray",
    }
    ts = bags.TYPESTORE.types
    with BagRecorder(tmp_path / "bag", topics=topics) as rec:
        rec.write(GROUND_TRUTH_TOPIC, float64_multiarray(np.zeros(N_K), ["k"]), 10)
        for i in range(0, 300, 64):
            rec.write(
                TELEMETRY_TOPIC,
                float64_multiarray(w.matrix()[i : i + 64], ["samples", "channels"]),
                100 + i,
            )
            rec.write(
                "/diagnostics",
                ts["diagnostic_msgs/msg/DiagnosticArray"](
                    header=ts["std_msgs/msg/Header"](
                        stamp=ts["builtin_interfaces/msg/Time"](sec=0, nanosec=i), frame_id=""
                    ),
                    status=[],
                ),
                100 + i,
            )
        rec.write(GROUND_TRUTH_TOPIC, float64_multiarray(np.full(N_K, 0.5), ["k"]), 1000)
    r = read_window(tmp_path / "bag")
    assert np.array_equal(r.matrix(), w.matrix())
    assert np.array_equal(r.k_true, np.full(N_K, 0.5))
    assert r.meta == {}


def test_recorder_raw_round_trip_and_close_twice(tmp_path: Path) -> None:
    blob = serialize("std_msgs/msg/String", string_msg("hello"))
    padded = blob + b"\x00\x00\x00"  # rclpy-style trailing padding
    arr = serialize(F64, float64_multiarray(np.arange(6.0).reshape(2, 3), ["a", "b"]))
    rec = BagRecorder(tmp_path / "bag", topics={"/s": "std_msgs/msg/String", "/a": F64})
    rec.write_raw("/s", blob, 5)
    rec.write_raw("/s", padded, 6)
    rec.write_raw("/a", arr, 7)
    rec.close()
    rec.close()
    with pytest.raises(BagError, match="closed"):
        rec.write_raw("/s", blob, 8)
    raw = {}
    with only_mcap(tmp_path / "bag").open("rb") as f:
        for _, channel, message in make_reader(f).iter_messages():
            raw.setdefault(channel.topic, []).append(message.data)
    assert raw == {"/s": [blob, padded], "/a": [arr]}  # bytes stored untouched
    got = list(read_messages(tmp_path / "bag"))
    assert [(m[0], m[2]) for m in got] == [("/s", 5), ("/s", 6), ("/a", 7)]
    assert got[0][3].data == "hello" and got[1][3].data == "hello"
    assert np.array_equal(got[2][3].data, np.arange(6.0))
    assert list(read_messages(tmp_path / "bag", topics=["/a"]))[0][1] == F64


def test_recorder_rejects_unknown_topic_and_type(tmp_path: Path) -> None:
    with pytest.raises(BagError, match="unknown message type"):
        BagRecorder(tmp_path / "x", topics={"/a": "nope_msgs/msg/Nope"})
    with (
        BagRecorder(tmp_path / "bag", topics={"/a": F64}) as rec,
        pytest.raises(BagError, match="no topic"),
    ):
        rec.write_raw("/b", b"\x00\x01\x00\x00", 0)


def test_library_does_not_import_rclpy() -> None:
    code = "import sys, ema_phm.telemetry.bags; assert 'rclpy' not in sys.modules"
    subprocess.run(
        [sys.executable, "-c", code],
        check=True,
        cwd=Path(__file__).parents[2],
        env={"PYTHONPATH": str(Path(__file__).parents[2])},
    )


# ---- errors -----------------------------------------------------------------------------------


def assert_bag_error(path: Path, *words: str) -> None:
    with pytest.raises(BagError) as err:
        read_window(path)
    msg = str(err.value)
    assert "\n" not in msg
    for word in words:
        assert word in msg, msg


def test_error_missing_path(tmp_path: Path) -> None:
    assert_bag_error(tmp_path / "nothing", "does not exist", "nothing")


def test_error_text_file(tmp_path: Path) -> None:
    p = tmp_path / "notes.txt"
    p.write_text("not a bag\n")
    assert_bag_error(p, "not a rosbag2 bag", "notes.txt")


def test_error_empty_dir_and_junk_dir(tmp_path: Path) -> None:
    (tmp_path / "empty").mkdir()
    assert_bag_error(tmp_path / "empty", "metadata.yaml")
    junk = tmp_path / "junk"
    junk.mkdir()
    (junk / "metadata.yaml").write_text("{{{: [ not yaml\n\t- x")
    (junk / "x.mcap").write_bytes(b"garbage")
    assert_bag_error(junk, "cannot open bag", "junk")


def test_error_foreign_mcap_file(tmp_path: Path) -> None:
    p = tmp_path / "fake.mcap"
    p.write_bytes(b"hello world, definitely not mcap")
    assert_bag_error(p, "cannot open bag", "fake.mcap")


def test_error_truncated_mcap(tmp_path: Path) -> None:
    write_window(tmp_path / "bag", synthetic())
    mcap = only_mcap(tmp_path / "bag")
    blob = mcap.read_bytes()
    mcap.write_bytes(blob[: len(blob) // 2])
    assert_bag_error(tmp_path / "bag", "truncated", "bag")


def test_error_no_telemetry_topic(tmp_path: Path) -> None:
    with BagRecorder(tmp_path / "bag", topics={RUN_INFO_TOPIC: "std_msgs/msg/String"}) as rec:
        rec.write(RUN_INFO_TOPIC, string_msg("{}"), 1)
    assert_bag_error(tmp_path / "bag", "no /ema/telemetry topic")


def test_error_telemetry_without_messages(tmp_path: Path) -> None:
    with BagRecorder(tmp_path / "bag", topics={TELEMETRY_TOPIC: F64}):
        pass
    assert_bag_error(tmp_path / "bag", TELEMETRY_TOPIC, "no messages")


def test_error_bad_layout(tmp_path: Path) -> None:
    with BagRecorder(tmp_path / "bag", topics={TELEMETRY_TOPIC: F64}) as rec:
        rec.write(
            TELEMETRY_TOPIC, float64_multiarray(np.zeros((4, 7)), ["samples", "channels"]), 1
        )
        rec.write(
            TELEMETRY_TOPIC, float64_multiarray(np.zeros((4, 6)), ["samples", "channels"]), 2
        )
    assert_bag_error(tmp_path / "bag", TELEMETRY_TOPIC, "message 1", "[4, 6]", "24 values")


def test_error_bad_ground_truth_size(tmp_path: Path) -> None:
    with BagRecorder(
        tmp_path / "bag", topics={TELEMETRY_TOPIC: F64, GROUND_TRUTH_TOPIC: F64}
    ) as rec:
        rec.write(
            TELEMETRY_TOPIC, float64_multiarray(np.zeros((4, 7)), ["samples", "channels"]), 1
        )
        rec.write(GROUND_TRUTH_TOPIC, float64_multiarray(np.zeros(5), ["k"]), 2)
    assert_bag_error(tmp_path / "bag", GROUND_TRUTH_TOPIC, "5 values")


def test_error_wrong_type(tmp_path: Path) -> None:
    with BagRecorder(tmp_path / "bag", topics={TELEMETRY_TOPIC: "std_msgs/msg/String"}) as rec:
        rec.write(TELEMETRY_TOPIC, string_msg("x"), 1)
    assert_bag_error(tmp_path / "bag", "type std_msgs/msg/String", F64)


def test_error_run_info_not_json(tmp_path: Path) -> None:
    with BagRecorder(
        tmp_path / "bag", topics={TELEMETRY_TOPIC: F64, RUN_INFO_TOPIC: "std_msgs/msg/String"}
    ) as rec:
        rec.write(RUN_INFO_TOPIC, string_msg("{oops"), 0)
        rec.write(
            TELEMETRY_TOPIC, float64_multiarray(np.zeros((4, 7)), ["samples", "channels"]), 1
        )
    assert_bag_error(tmp_path / "bag", RUN_INFO_TOPIC, "JSON")


def test_error_fewer_messages_than_metadata(tmp_path: Path) -> None:
    write_window(tmp_path / "bag", synthetic(), samples_per_message=100)
    meta = tmp_path / "bag" / "metadata.yaml"
    text = meta.read_text()
    assert text.count("message_count: 13\n") == 1  # the telemetry topic's count
    meta.write_text(text.replace("message_count: 13\n", "message_count: 14\n"))
    assert_bag_error(tmp_path / "bag", "truncated", "13 messages", "says 14")


def test_read_window_prefers_the_fitted_window_topic(tmp_path):
    """A monitor recording holds telemetry spanning several windows plus /ema/window.

    read_window returns exactly the last fitted window and the truth logged before it.
    """
    from ema_phm.telemetry.bags import (
        FLOAT64_MULTIARRAY,
        GROUND_TRUTH_TOPIC,
        TELEMETRY_TOPIC,
        WINDOW_TOPIC,
        BagRecorder,
        float64_multiarray,
        read_window,
    )

    rng = np.random.default_rng(1)
    stream = rng.standard_normal((300, 7))  # the legacy layout: no temperature channel
    stream[:, 0] = np.arange(300) * 1e-3
    win = stream[100:201]
    topics = {
        TELEMETRY_TOPIC: FLOAT64_MULTIARRAY,
        WINDOW_TOPIC: FLOAT64_MULTIARRAY,
        GROUND_TRUTH_TOPIC: FLOAT64_MULTIARRAY,
    }
    with BagRecorder(tmp_path / "rec", topics=topics) as rec:
        rec.write(GROUND_TRUTH_TOPIC, float64_multiarray(np.full(N_K, 0.1), ["k"]), 1)
        for i in range(0, 300, 50):
            rec.write(
                TELEMETRY_TOPIC,
                float64_multiarray(stream[i : i + 50], ["samples", "channels"]),
                10 + i,
            )
        rec.write(WINDOW_TOPIC, float64_multiarray(win, ["samples", "channels"]), 400)
        rec.write(GROUND_TRUTH_TOPIC, float64_multiarray(np.full(N_K, 0.2), ["k"]), 500)
    w = read_window(tmp_path / "rec")
    np.testing.assert_array_equal(w.matrix()[:, :7], win)
    assert np.isnan(w.temperature).all()  # legacy messages: temperature unknown
    np.testing.assert_array_equal(w.k_true, np.full(N_K, 0.1))


def test_a_recordings_windows_replay_with_the_cycles_the_monitor_gave_them(tmp_path):
    """Windows cut by excitation (lengths differ) keep their cycles; old ones go by time.

    By time (start over length) the 0.1 s window at 0.25 s and the 0.2 s one at 0.5 s
    take the same cycle (a repeat, which a prognosis does not count).
    """
    from ema_phm.telemetry.bag_codec import ROSBAGS_CLASSES
    from ema_phm.telemetry.bags import (
        FLOAT64_MULTIARRAY,
        WINDOW_TOPIC,
        BagRecorder,
        float64_multiarray,
    )
    from ema_phm.telemetry.cycle_bags import read_cycle_windows
    from ema_phm.telemetry.wire import encode_telemetry, to_message

    def rows(t0: float, n: int) -> np.ndarray:
        out = np.zeros((n, len(CHANNELS)))
        out[:, 0] = t0 + np.arange(n) * 1e-3
        return out

    spans = [(0.25, 101), (0.5, 201)]
    with BagRecorder(tmp_path / "new", topics={WINDOW_TOPIC: FLOAT64_MULTIARRAY}) as rec:
        for cycle, (t0, n) in enumerate(spans, 4):
            rec.write(
                WINDOW_TOPIC,
                to_message(encode_telemetry(rows(t0, n), cycle=cycle), ROSBAGS_CLASSES),
                cycle,
            )
    assert [w.meta["cycle"] for w in read_cycle_windows(tmp_path / "new")] == [4, 5]
    with BagRecorder(tmp_path / "old", topics={WINDOW_TOPIC: FLOAT64_MULTIARRAY}) as rec:
        for i, (t0, n) in enumerate(spans):
            rec.write(WINDOW_TOPIC, float64_multiarray(rows(t0, n), ["samples", "channels"]), i)
    old = [w.meta["cycle"] for w in read_cycle_windows(tmp_path / "old")]
    assert old[0] == old[1]  # by time: a repeat


# ---- FIFOs and other non-regular files --------------------------------------------------------


def returns_within(seconds: float, fn, *args):
    """fn(*args) in a daemon thread; fails the test if it has not returned in time (blocked)."""
    import threading

    box: dict[str, object] = {}

    def run() -> None:
        try:
            box["value"] = fn(*args)
        except BaseException as exc:  # noqa: BLE001 - handed to the test below
            box["error"] = exc

    t = threading.Thread(target=run, daemon=True)
    t.start()
    t.join(seconds)
    assert not t.is_alive(), f"{fn.__name__}{args} still blocked after {seconds} s"
    if "error" in box:
        raise box["error"]  # type: ignore[misc]
    return box.get("value")


def test_fifo_is_refused_before_opening(tmp_path: Path) -> None:
    direct = tmp_path / "x.mcap"
    os.mkfifo(direct)
    in_bag = tmp_path / "bag"
    write_window(in_bag, synthetic(200))
    only_mcap(in_bag).unlink()
    os.mkfifo(in_bag / "bag.mcap")
    meta_fifo = tmp_path / "bag2"
    write_window(meta_fifo, synthetic(200))
    (meta_fifo / "metadata.yaml").unlink()
    os.mkfifo(meta_fifo / "metadata.yaml")
    killed = tmp_path / "killed"  # no metadata.yaml: the recovery path must refuse it too
    killed.mkdir()
    os.mkfifo(killed / "killed.mcap")
    for target, named in (
        (direct, direct),
        (in_bag, in_bag / "bag.mcap"),
        (meta_fifo, meta_fifo / "metadata.yaml"),
        (killed, killed / "killed.mcap"),
    ):
        for reader in (read_window, lambda p: list(read_messages(p)), bags.recover_bag):
            with pytest.raises(BagError) as err:
                returns_within(10, reader, target)
            assert f"{named} is a FIFO (named pipe), not a regular file" in str(err.value)


# ---- ground truth ------------------------------------------------------------------------------


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -0.25, 1.5])
def test_bad_ground_truth_is_refused_at_read_time(tmp_path: Path, bad: float) -> None:
    k = np.full(N_K, 0.5)
    k[3] = bad
    with BagRecorder(
        tmp_path / "bag", topics={TELEMETRY_TOPIC: F64, GROUND_TRUTH_TOPIC: F64}
    ) as rec:
        rec.write(GROUND_TRUTH_TOPIC, float64_multiarray(k, ["k"]), 1)
        rec.write(
            TELEMETRY_TOPIC, float64_multiarray(np.zeros((4, 7)), ["samples", "channels"]), 2
        )
    assert_bag_error(
        tmp_path / "bag", str(tmp_path / "bag"), GROUND_TRUTH_TOPIC, f"k4 = {bad!r}", "[0, 1]"
    )
