"""Live windows by times and by marker: the offline rule's windows, whatever the batches."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ema_phm.domain.window import CHANNELS
from ema_phm.errors import ConfigError
from ema_phm.importing import segments
from ema_phm.importing.live import Mark, MarkerRuns
from ema_phm.telemetry.listed_assembler import NOT_RECORDED, ListedAssembler, ListedRule
from ema_phm.telemetry.window_assembler import Completed, Discarded
from ema_phm.telemetry.window_intake import WindowIntake

FS = 1000.0


def rows_of(first: int, n: int) -> np.ndarray:
    """Rows, n of them, from grid index `first`; column 2 numbers each row to find it again."""
    rows = np.zeros((n, len(CHANNELS)))
    j = first + np.arange(n)
    rows[:, 0], rows[:, 2] = j / FS, j
    return rows


def fed(a: ListedAssembler, rows: np.ndarray, seed: int) -> list[Completed | Discarded]:
    """`rows` in batches of random sizes."""
    rng = np.random.default_rng(seed)
    events: list[Completed | Discarded] = []
    i = 0
    while i < rows.shape[0]:
        k = int(rng.integers(1, 300))
        events += a.feed(rows[i : i + k])
        i += k
    return events


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_listed_times_are_cut_whatever_the_batches(seed):
    rule = ListedRule("times", times=((2.0, 2.5), (0.5, 1.0)), first_cycle=4)
    a = ListedAssembler(FS, 2000, rule)
    events = fed(a, rows_of(0, 3000), seed)
    assert [type(e) for e in events] == [Completed, Completed]
    first, second = events
    assert (first.j0, first.cycle, second.j0, second.cycle) == (500, 4, 2000, 5)
    assert np.array_equal(first.data[:, 2], np.arange(500, 1001))
    assert np.array_equal(second.data[:, 2], np.arange(2000, 2501))
    assert a.waiting == 0


def test_a_listed_window_across_a_gap_or_before_the_stream_is_discarded():
    rule = ListedRule("times", times=((0.1, 0.3), (1.0, 1.5), (2.1, 2.4)))
    a = ListedAssembler(FS, 2000, rule)
    events = a.feed(rows_of(500, 700)) + a.feed(rows_of(1300, 1200))  # a gap 1.2-1.3 s
    assert [type(e) for e in events] == [Discarded, Discarded, Completed]
    assert all(e.reason.endswith(NOT_RECORDED) for e in events[:2])
    assert "0.1-0.3 s" in events[0].reason and "1-1.5 s" in events[1].reason
    assert events[2].j0 == 2100


def test_memory_is_bounded_and_a_too_long_window_is_discarded_with_its_length():
    a = ListedAssembler(FS, 1000, ListedRule("times", times=((50.0, 52.0),)))
    events = []
    for k in range(100):
        events += a.feed(rows_of(k * 600, 600))
        assert a.pending_samples <= 1000 + 1 + 600
    (event,) = events
    assert isinstance(event, Discarded) and "2 s long, longer than the longest fitted, 1 s" in (
        event.reason
    )


def test_a_marked_window_is_given_at_once_from_the_rows_held():
    a = ListedAssembler(FS, 1500, ListedRule("marker", min_duration_s=0.5, first_cycle=2))
    assert fed(a, rows_of(0, 2600), 0) == []
    (event,) = a.mark(1.0, 2.5)
    assert isinstance(event, Completed) and (event.j0, event.cycle) == (1000, 2)
    assert np.array_equal(event.data[:, 2], np.arange(1000, 2501))
    assert a.mark(3.0, 3.2) == []  # its rows are still to come
    (later,) = a.feed(rows_of(2600, 700))
    assert isinstance(later, Completed) and later.j0 == 3000 and later.cycle == 3


def test_memory_stays_bounded_when_marked_windows_come_often():
    """Review of 1b7cc36: a given window merged every row held into one block, never let go."""
    a = ListedAssembler(FS, 1000, ListedRule("marker"))
    for k in range(200):
        a.feed(rows_of(k * 250, 250))
        if k % 2:
            (event,) = a.mark((k * 250 - 200) / FS, (k * 250 + 240) / FS)
            assert isinstance(event, Completed) and event.data.shape[0] == 441
        assert a.pending_samples <= 2 * (1000 + 1)


def test_after_a_break_a_mark_of_lost_rows_is_discarded_and_a_restart_cuts_the_list_again():
    """Review of 1b7cc36: a restarted rig lost the list, and an old mark cut new rows.

    (A restart resets the assembler first; the old stream's open run is marked after.)
    """
    a = ListedAssembler(FS, 2000, ListedRule("marker"))
    a.feed(rows_of(0, 2000))
    a.reset("its time went back")
    (event,) = a.mark(1.0, 1.9)
    assert isinstance(event, Discarded) and "no rows held" in event.reason
    assert a.feed(rows_of(0, 3000)) == []  # nothing of the old mark from the new rows
    a = ListedAssembler(FS, 2000, ListedRule("times", times=((0.5, 1.0),)))
    once = a.feed(rows_of(0, 2500))
    a.reset("its time went back")
    again = a.feed(rows_of(0, 1500))
    assert [e.cycle for e in once + again] == [0, 1]


def test_a_restarted_stream_is_cut_by_the_list_again():
    a = ListedAssembler(FS, 2000, ListedRule("times", times=((0.5, 1.0),)))
    once = a.feed(rows_of(0, 1500))
    again = a.feed(rows_of(0, 1500))  # time back to 0: a restarted rig
    assert [e.cycle for e in once + again] == [0, 1]


def test_the_intake_cuts_by_the_run_infos_times_and_takes_marks_of_its_stream_only():
    info = {"sample_rate": FS, "samples_per_window": 2000}
    intake = WindowIntake()
    intake.accept_run_info(json.dumps({**info, "windows": {"by": "times", "times": [[0.5, 1]]}}))
    (event,) = intake.add_rows(rows_of(0, 1200))
    assert isinstance(event, Completed) and event.j0 == 500
    intake = WindowIntake()
    intake.accept_run_info(json.dumps({**info, "windows": {"by": "marker"}}))
    intake.add_rows(rows_of(0, 1200))
    assert intake.mark(0.2, 0.9, stream=None) != []
    from ema_phm.telemetry.wire import StreamId

    assert intake.mark(0.2, 0.9, stream=StreamId("other", "run")) == []


@pytest.mark.parametrize(
    ("windows", "says"),
    [
        ({"by": "times", "times": [[1.0, 0.5]]}, "0 <= start < end"),
        ({"by": "times", "times": "soon"}, "list of \\[start, end\\], got 'soon'"),
        ({"by": "marker", "min_duration_s": -1}, "min_duration_s must be in .*, got -1"),
        ({"by": "marker", "min_duration_s": 1e999}, "min_duration_s must be in .*, got inf"),
        ({"by": "times", "times": [[0, 1e308]]}, r"end <= 1e\+09 s"),
        ({"by": "times", "times": [], "first_cycle": -2}, "first_cycle .* got -2"),
    ],
)
def test_a_bad_listed_rule_is_refused_naming_the_value(windows, says):
    info = {"sample_rate": FS, "samples_per_window": 2000, "windows": windows}
    with pytest.raises(ConfigError, match=says):
        WindowIntake().accept_run_info(json.dumps(info))


@pytest.mark.parametrize("seed", range(6))
def test_marker_runs_are_the_offline_runs_whatever_the_batches(seed):
    """`MarkerRuns` against `segments.by_marker` on each stretch, a gap and the end included."""
    rng = np.random.default_rng(seed)
    n = 12000
    marker = np.repeat(rng.random(120) < 0.5, 100).astype(float)
    j = np.concatenate([np.arange(6000), np.arange(6200, 6200 + n - 6000)])  # a gap
    rows = np.zeros((n, len(CHANNELS)))
    rows[:, 0] = j / FS
    runs = MarkerRuns(FS, 0.25)
    marks: list[tuple[float, float]] = []
    i = 0
    while i < n:
        k = int(rng.integers(1, 400))
        pieces = runs.split(rows[i : i + k], marker[i : i + k])
        assert (
            sum(p.shape[0] for p in pieces if not isinstance(p, Mark)) == rows[i : i + k].shape[0]
        )
        marks += [(p.t0, p.t1) for p in pieces if isinstance(p, Mark)]
        i += k
    marks += [(m.t0, m.t1) for m in runs.end()]
    offline = []
    for lo, hi in ((0, 6000), (6000, n)):
        offline += [
            (j[lo + a] / FS, j[lo + b] / FS)
            for a, b in segments.by_marker(marker[lo:hi], FS, 0.25)
        ]
    assert np.allclose(np.asarray(marks).reshape(-1, 2), np.asarray(offline).reshape(-1, 2))
    assert len(offline) >= 3
