"""WindowIntake: telemetry held until run_info, bounded; a new geometry discards the window."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ema_phm.errors import ConfigError
from ema_phm.telemetry import window_intake
from ema_phm.telemetry.window_assembler import Completed, Discarded
from ema_phm.telemetry.window_intake import WindowIntake
from ema_phm.telemetry.wire import StreamId


def rows(j0: int, n: int, fs: float = 2000.0) -> np.ndarray:
    out = np.zeros((n, 7))
    out[:, 0] = np.arange(j0, j0 + n) / fs
    return out


def info(n: int) -> str:
    return json.dumps({"sample_rate": 2000.0, "samples_per_window": n})


def test_rows_before_run_info_complete_a_window_once_it_arrives():
    intake = WindowIntake()
    assert intake.add_rows(rows(0, 101)) == [] and not intake.has_geometry
    update = intake.accept_run_info(info(100))
    assert update.new_geometry and [type(e) for e in update.events] == [Completed]


def test_same_geometry_only_updates_run_info():
    intake = WindowIntake()
    intake.accept_run_info(info(100))
    intake.add_rows(rows(0, 50))
    update = intake.accept_run_info(
        json.dumps({"sample_rate": 2000.0, "samples_per_window": 100, "x": 1})
    )
    assert not update.new_geometry and intake.run_info["x"] == 1 and intake.samples_collected == 50


def test_new_geometry_discards_the_window_being_assembled():
    intake = WindowIntake()
    intake.accept_run_info(info(100))
    intake.add_rows(rows(0, 50))
    events = intake.accept_run_info(info(200)).events
    assert (
        len(events) == 1 and isinstance(events[0], Discarded) and "200 samples" in events[0].reason
    )


def test_bad_run_info_changes_nothing():
    intake = WindowIntake()
    with pytest.raises(ConfigError):
        intake.accept_run_info(info(10**9))
    assert not intake.has_geometry and intake.run_info == {}


def test_pending_telemetry_is_bounded(monkeypatch):
    monkeypatch.setattr(window_intake, "PENDING_MESSAGES", 3)
    intake = WindowIntake()
    for i in range(5):
        intake.add_rows(rows(100 * i, 100))
    events = intake.accept_run_info(info(100)).events  # samples 200..499 kept: windows from 200
    assert [e.j0 for e in events if isinstance(e, Completed)] == [200, 300]


A, B = StreamId("ema-1", "run-a"), StreamId("ema-1", "run-b")


def test_a_window_comes_from_one_stream_only():
    """Issue 17 item 5: two publishers on one topic, alternate messages: no window completes.

    Each mixed one is discarded naming both streams.
    """
    intake = WindowIntake()
    intake.accept_run_info(info(100))
    events = []
    for m in range(8):  # 8 messages of 25 samples, the streams alternating
        events += intake.add_rows(rows(m * 25, 25), A if m % 2 == 0 else B)
    assert not any(isinstance(e, Completed) for e in events)
    discarded = [e for e in events if isinstance(e, Discarded)]
    assert discarded and intake.stream_changes == 7
    assert "ema-1 (run run-b) after stream ema-1 (run run-a)" in discarded[0].reason


def test_one_stream_completes_and_a_new_run_starts_cleanly():
    intake = WindowIntake()
    intake.accept_run_info(info(100))
    assert [type(e) for e in intake.add_rows(rows(0, 101), A)] == [Completed]
    assert intake.stream_changes == 0 and intake.stream == A
    intake.add_rows(rows(0, 50), B)  # a restarted source: its window boundary, its own windows
    assert intake.stream_changes == 1 and intake.stream == B
    assert [type(e) for e in intake.add_rows(rows(50, 51), B)] == [Completed]


def test_stream_of_messages_held_before_run_info_is_kept():
    intake = WindowIntake()
    intake.add_rows(rows(0, 60), A)
    intake.add_rows(rows(60, 41), B)
    update = intake.accept_run_info(info(100))
    assert not any(isinstance(e, Completed) for e in update.events) and intake.stream == B
