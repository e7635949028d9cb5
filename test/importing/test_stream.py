"""`ema-phm import --stream`: a bag read once in time order gives the whole-log import's windows.

The same windows (starts, lengths, samples to float rounding) by excitation and by length,
across a gap; windows given while the bag is still being read (what bounds the memory);
what a stream cannot cut refused in one line; a failure mid-bag leaves nothing written.
"""

from __future__ import annotations

import dataclasses
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from helpers import run_cli

from bench.harness import rig_forms
from ema_phm.domain.faults import NOMINAL
from ema_phm.domain.window import Window
from ema_phm.errors import ConfigError
from ema_phm.importing import importer, stream
from ema_phm.importing.channel_map import parse_channel_map
from ema_phm.importing.importer import import_recordings
from ema_phm.physics.commands import CommandSpec
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator import real_ema as hf
from ema_phm.telemetry.bags import read_window

ACTUATOR = ActuatorParameters.default()
CHANNELS = ("command", "theta_u", "theta_m", "omega_m", "i3eq", "temperature")
GAP = (3.3, 3.4)  # s of the log with no message: inside the second rest
MARKER_TOPIC = "/rig/testing"


@pytest.fixture(scope="module")
def two_chirps() -> Window:
    """Rest 0.5 s, a 1 s chirp, rest 2 s, the same chirp: 4.5 s."""
    w = hf.simulate(NOMINAL, command=CommandSpec(duration=1.0)).window.without_truth()
    w = dataclasses.replace(w, temperature=np.full(w.n, 31.5))
    a = rig_forms.with_rest(w, 0.5)
    cols = {
        c: np.concatenate([getattr(a, c), np.full(3000, getattr(a, c)[-1]), getattr(a, c)])
        for c in ("command", "load", "theta_u", "theta_m", "omega_m", "i3eq", "temperature")
    }
    n = cols["command"].size
    return Window(t=np.arange(n) * a.dt, **cols, meta={})


def _bag(  # noqa: PLR0913 - one rig's ways of logging
    path: Path,
    w: Window,
    gap: tuple[float, float] | None = None,
    back_at: int = -1,
    *,
    jitter_s: float = 0.0,
    pause_after: float | None = None,
    stamps_ns: int = 0,
    slow_temperature: tuple[float, float] | None = None,
    marker_on: tuple[tuple[float, float], ...] | None = None,
    marker_on_change: bool = False,
) -> Path:
    """`w` as a rig's bag, in the ways a rig's log differs from a clean one.

    `gap`: no message in it [s]; `back_at`: that sample's JointState stamped 2 s early;
    `jitter_s`: header stamps' RMS jitter; `pause_after`: every message after it [s] logged
    and stamped 25 s later (a paused rig); `stamps_ns`: added to every header stamp (another
    clock); `slow_temperature`: the temperature at 100 Hz, none in that span [s];
    `marker_on`: a std_msgs/Bool on `MARKER_TOPIC` at 100 Hz, true inside these spans [s]
    (`marker_on_change`: only its first message and those that change it).
    """
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_KILTED)
    with Writer(path, version=9) as writer:
        conns = {
            topic: writer.add_connection(topic, kind, typestore=store)
            for topic, kind in rig_forms.RIG_TOPICS.items()
        }
        marker = writer.add_connection(MARKER_TOPIC, "std_msgs/msg/Bool", typestore=store)
        last_marker = None
        for i, (topic, sent, received) in enumerate(rig_forms.rig_messages(w, jitter_s=jitter_s)):
            msg, t = sent, (received - rig_forms.START_NS) * 1e-9
            if gap is not None and gap[0] < t < gap[1]:
                continue
            if slow_temperature and topic == "/motor/temperature":
                if i // 4 % 20 or slow_temperature[0] < t < slow_temperature[1]:
                    continue
            shift = 25_000_000_000 if pause_after is not None and t > pause_after else 0
            back = 2_000_000_000 if i // 4 == back_at and topic == "/joint_states" else 0
            if hasattr(msg, "header") and (shift or back or stamps_ns):
                ns = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
                ns += shift - back + stamps_ns
                stamp = dataclasses.replace(msg.header.stamp, sec=ns // 10**9, nanosec=ns % 10**9)
                msg = dataclasses.replace(msg, header=dataclasses.replace(msg.header, stamp=stamp))
            data = store.serialize_cdr(msg, rig_forms.RIG_TOPICS[topic])
            writer.write(conns[topic], received + shift, data)
            if marker_on is not None and i % 80 == 3:  # after each 20th sample's messages
                value = any(a <= t <= b for a, b in marker_on)
                if not marker_on_change or value != last_marker:
                    on = store.types["std_msgs/msg/Bool"](data=value)
                    writer.write(marker, received, store.serialize_cdr(on, "std_msgs/msg/Bool"))
                last_marker = value
    return path


def _map(by: dict) -> dict:
    return {**rig_forms.JOINT_STATES_MAP, "windows": by}


def _both(
    bag: Path, by: dict, tmp_path: Path, channels: dict | None = None, reports: list | None = None
) -> tuple[list[Window], list[Window]]:
    m = _map(by)
    m["channels"] = {**m["channels"], **(channels or {})}
    cmap = parse_channel_map(m, where="map.yaml")
    out = []
    for streamed in (False, True):
        report = import_recordings(
            [bag], cmap, ACTUATOR, tmp_path / f"{streamed}", stream=streamed
        )
        out.append([read_window(p) for p in sorted(report.written)])
        if reports is not None:
            reports.append(report.sources[0])
    return out[0], out[1]


def _same(whole: list[Window], streamed: list[Window]) -> None:
    assert len(whole) == len(streamed) > 0
    for a, b in zip(whole, streamed, strict=True):
        assert a.n == b.n
        assert a.meta["source_start_s"] == pytest.approx(b.meta["source_start_s"], abs=1e-9)
        assert a.meta["cycle"] == b.meta["cycle"]
        for c in CHANNELS:
            x, y = getattr(a, c), getattr(b, c)
            assert np.max(np.abs(x - y)) < 1e-6 * max(1.0, float(np.max(np.abs(x)))), c


@pytest.mark.parametrize(
    ("by", "count"),
    [({"by": "excitation"}, 2), ({"by": "length", "seconds": 0.5}, 6 + 2)],
)
def test_a_streamed_bag_gives_the_whole_log_windows(by, count, two_chirps, tmp_path):
    bag = _bag(tmp_path / "rig", two_chirps, gap=GAP)
    whole, streamed = _both(bag, by, tmp_path)
    assert len(streamed) == count  # length: 0-3.3 s and 3.4-4.5 s
    _same(whole, streamed)
    for w in streamed:  # no window spans the gap
        start = w.meta["source_start_s"]
        assert start + w.duration <= GAP[0] or start >= GAP[1] - 1e-9


#: Every mapped channel from a header-stamped topic (a rig whose stamps are on its own clock).
STAMPED = {
    "command": {"topic": "/joint_states", "joint": "surface", "field": "position"},
    "i3eq": {"topic": "/motor/temperature", "field": "temperature", "unit": "A"},
}


@pytest.mark.parametrize(
    ("how", "channels"),
    [
        ({"pause_after": 2.5}, None),  # 25 s without a message (review of f234114: lost rows)
        ({"stamps_ns": -rig_forms.START_NS + 10**9}, STAMPED),  # stamps far behind log time
        ({"jitter_s": 2e-5}, None),  # the grid's origin: the first sample less its delay
        ({"slow_temperature": (2.0, 2.8)}, None),  # a slow series' own gap is a gap
    ],
    ids=["pause", "another-clock", "jitter", "slow-gap"],
)
@pytest.mark.parametrize(
    "by",
    [
        {"by": "excitation"},
        {"by": "length", "seconds": 0.5},
        {"by": "times", "times": [[0.3, 1.2], [2.0, 2.5], [3.5, 4.4]]},
    ],
    ids=["excitation", "length", "times"],
)
def test_a_rigs_untidy_bag_streams_as_it_imports_whole(how, channels, by, two_chirps, tmp_path):
    bag = _bag(tmp_path / "rig", two_chirps, **how)
    whole, streamed = _both(bag, by, tmp_path, channels)
    _same(whole, streamed)


def test_a_window_too_short_is_counted_not_fatal(two_chirps, tmp_path):
    bag = _bag(tmp_path / "rig", two_chirps)
    by = {"by": "excitation", "min_duration_s": 0.001, "settle_s": 0.0}
    cmap = parse_channel_map(_map(by), where="map.yaml")
    short = dataclasses.replace(two_chirps, command=two_chirps.command.copy())
    short.command[:] = 0.0
    short.command[1000:1010] = 0.01  # a 5 ms blip: a segment of 10 samples
    blip = _bag(tmp_path / "blip", short)
    reports = [
        import_recordings([blip, bag], cmap, ACTUATOR, tmp_path / f"{s}", stream=s).sources
        for s in (False, True)
    ]
    assert [r.too_short for r in reports[0]] == [r.too_short for r in reports[1]] == [1, 0]


def test_the_first_window_comes_before_the_bag_is_read(two_chirps, tmp_path, monkeypatch):
    """What bounds the memory: a window is given as soon as it is complete."""
    bag = _bag(tmp_path / "rig", two_chirps)
    read: list[float] = []
    messages = stream.bag_messages

    def counted(*args, **kwargs):
        for m in messages(*args, **kwargs):
            read.append(m.ns * 1e-9)
            yield m

    monkeypatch.setattr(stream, "bag_messages", counted)
    cmap = parse_channel_map(_map({"by": "excitation"}), where="map.yaml")
    windows = stream.stream_windows(bag, cmap, ACTUATOR, stream.StreamCounts())
    first, _start = next(windows)
    assert first.duration == pytest.approx(1.2, abs=0.01)  # 0.1 s settling each side
    assert read[-1] < 2.8  # the first chirp ends at 1.5 s; the bag runs to 4.5 s
    assert len(list(windows)) == 1


def test_listed_times_stream_as_they_import_whole(two_chirps, tmp_path):
    """Windows across the gap or past the log's end are dropped and counted, both ways."""
    bag = _bag(tmp_path / "rig", two_chirps, gap=GAP)
    times = [[0.3, 1.2], [2.0, 2.5], [3.2, 3.6], [3.5, 4.4], [4.0, 9.0]]
    reports: list = []
    whole, streamed = _both(bag, {"by": "times", "times": times}, tmp_path, reports=reports)
    _same(whole, streamed)
    assert [round(w.meta["source_start_s"], 3) for w in streamed] == [0.3, 2.0, 3.5]
    assert [w.n for w in streamed] == [1801, 1001, 1801]
    assert [r.windows_dropped for r in reports] == [2, 2]


def test_a_marker_topics_runs_stream_as_they_import_whole(two_chirps, tmp_path):
    """Runs shorter than min_duration_s left out; a run across the gap split by it."""
    runs = ((0.4, 1.6), (2.0, 2.2), (3.0, 4.2))
    bag = _bag(tmp_path / "rig", two_chirps, gap=GAP, marker_on=runs)
    by = {"by": "marker", "marker": {"topic": MARKER_TOPIC, "field": "data"}}
    whole, streamed = _both(bag, by, tmp_path)
    _same(whole, streamed)
    starts = [w.meta["source_start_s"] for w in streamed]
    assert starts == pytest.approx([0.4, 3.4], abs=0.06)  # 3.0-3.3 s: shorter than 0.5 s
    assert streamed[0].duration == pytest.approx(1.2, abs=0.02)


@pytest.mark.parametrize(
    "times",
    [
        [[2.0, 2.5], [0.3, 1.2], [0.3, 2.4]],  # out of order, overlapping: numbered as they end
        [[0.30025, 1.20075], [2.00075, 2.50025]],  # ends half-way between grid times
        [[0.1002, 3.1003]],  # 3.0001 s: its ends round apart (longer than its rounded length)
    ],
    ids=["order", "half-way", "rounding"],
)
def test_listed_times_off_the_grid_stream_as_they_import_whole(times, two_chirps, tmp_path):
    """Review of 1b7cc36: each case differed (cycles, a sample, a window dropped)."""
    bag = _bag(tmp_path / "rig", two_chirps)
    _same(*_both(bag, {"by": "times", "times": times}, tmp_path))


def test_a_marker_sent_only_when_it_changes_streams_as_it_imports_whole(two_chirps, tmp_path):
    """Its last message at 3 s: the rows after it are still rows (before: lost)."""
    runs = ((0.4, 1.6), (3.0, 9.0))
    bag = _bag(tmp_path / "rig", two_chirps, marker_on=runs, marker_on_change=True)
    by = {"by": "marker", "marker": {"topic": MARKER_TOPIC, "field": "data"}}
    whole, streamed = _both(bag, by, tmp_path)
    _same(whole, streamed)
    assert [round(w.duration, 1) for w in streamed] == [1.2, 1.5]


def test_a_marker_run_at_the_end_of_the_bag_is_a_window(two_chirps, tmp_path):
    bag = _bag(tmp_path / "rig", two_chirps, marker_on=((3.5, 9.0),))
    by = {"by": "marker", "marker": {"topic": MARKER_TOPIC, "field": "data"}}
    whole, streamed = _both(bag, by, tmp_path)
    _same(whole, streamed)
    assert len(streamed) == 1 and streamed[0].duration == pytest.approx(1.0, abs=0.02)


def test_a_table_is_not_streamed_and_the_command_says_so(two_chirps, tmp_path):
    table = rig_forms.table(tmp_path / "rig.csv", two_chirps)
    (tmp_path / "map.yaml").write_text(yaml.safe_dump(rig_forms.TABLE_MAP))
    args = ["import", str(table), "--map", str(tmp_path / "map.yaml"), "--out", "out"]
    done = subprocess.run(
        [sys.executable, "-m", "ema_phm.tools.cli", *args, "--stream"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 2
    assert len(done.stderr.strip().splitlines()) == 1
    assert "--stream reads ROS 2 bags" in done.stderr and "rig.csv" in done.stderr
    assert not (tmp_path / "out").exists()


def test_time_stepping_back_mid_bag_leaves_nothing_written(two_chirps, tmp_path, monkeypatch):
    """Refused as the whole-log import refuses it, after the first window was staged."""
    bag = _bag(tmp_path / "rig", two_chirps, back_at=7000)  # 3.5 s: after the first chirp
    cmap = parse_channel_map(_map({"by": "excitation"}), where="map.yaml")
    staged = []
    add = importer._Staging.add
    monkeypatch.setattr(importer._Staging, "add", lambda *a: staged.append(add(*a)))
    with pytest.raises(ConfigError, match="time does not increase"):
        import_recordings([bag], cmap, ACTUATOR, tmp_path / "out", stream=True)
    assert len(staged) == 1
    with pytest.raises(ConfigError, match="time does not increase"):
        import_recordings([bag], cmap, ACTUATOR, tmp_path / "out", stream=False)
    assert not (tmp_path / "out").exists()


def test_fleet_ingest_streams_a_rigs_bags_through_the_map(two_chirps, tmp_path, capsys):
    _bag(tmp_path / "logs" / "rig", two_chirps)
    (tmp_path / "map.yaml").write_text(yaml.safe_dump(rig_forms.JOINT_STATES_MAP))
    store = str(tmp_path / "fleet.sqlite")
    fit = ["--store", store, "--workers", "0", "--max-evaluations", "60"]
    code, _, err = run_cli(capsys, "fleet", "ingest", str(tmp_path / "logs"), "--stream", *fit)
    assert code == 2 and err.count("\n") == 1 and "--stream reads a rig's bags" in err
    args = ["fleet", "ingest", str(tmp_path / "logs"), "--map", str(tmp_path / "map.yaml")]
    code, text, err = run_cli(capsys, *args, "--stream", *fit)
    assert code == 0, err
    assert "2 recordings written" in text
    code, text, err = run_cli(capsys, "fleet", "status", "--store", store, "--json")
    assert code == 0 and "rig-1" in text
