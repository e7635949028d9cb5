"""Live excitation segments: the offline rule's windows, whatever the batches."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ema_phm.domain.excitation_spans import excitation_spans
from ema_phm.domain.window import CHANNELS
from ema_phm.errors import ConfigError
from ema_phm.telemetry.span_assembler import SpanAssembler, SpanRule
from ema_phm.telemetry.window_assembler import Completed, Discarded

FS = 1000.0
RULE = SpanRule(max_pause_s=0.25, settle_s=0.2, min_duration_s=0.5, first_cycle=3)


def command_with_moves(moves: list[tuple[float, float]], total_s: float) -> np.ndarray:
    """A still command moving (a sine burst) over each (start, end) [s]."""
    t = np.arange(round(total_s * FS)) / FS
    c = np.full(t.size, 0.1)
    for a, b in moves:
        on = (t >= a) & (t < b)
        c[on] += 0.05 * np.sin(2 * np.pi * 3.0 * (t[on] - a))
    return c


def rows_of(command: np.ndarray, j0: int = 0) -> np.ndarray:
    rows = np.zeros((command.size, len(CHANNELS)))
    rows[:, 0] = (j0 + np.arange(command.size)) / FS
    rows[:, 1] = command
    rows[:, 2] = j0 + np.arange(command.size)  # a marker to find each row again
    return rows


def fed(assembler: SpanAssembler, rows: np.ndarray, seed: int) -> list[Completed | Discarded]:
    rng = np.random.default_rng(seed)
    events: list[Completed | Discarded] = []
    i = 0
    while i < rows.shape[0]:
        n = int(rng.integers(1, 400))
        events += assembler.feed(rows[i : i + n])
        i += n
    return events


def offline(command: np.ndarray) -> list[tuple[int, int]]:
    return excitation_spans(
        command, FS, max_pause_s=RULE.max_pause_s, settle_s=RULE.settle_s, min_duration_s=0.5
    )


# moves: a long one, two joined by a short pause, two whose settle times meet half-way,
# one too short to keep, and one running into the end of the stretch
MOVES = [(0.5, 2.0), (3.0, 3.6), (3.75, 4.4), (5.0, 5.8), (6.1, 6.7), (7.5, 7.55), (8.5, 9.9)]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_live_segments_are_the_offline_windows_whatever_the_batches(seed):
    command = command_with_moves(MOVES, 10.0)
    assembler = SpanAssembler(FS, 20_000, RULE)
    events = fed(assembler, rows_of(command), seed)
    events += assembler.feed(rows_of(command[:10], j0=command.size + 500))  # a gap: stretch ends
    got = [(int(e.data[0, 2]), int(e.data[-1, 2])) for e in events if isinstance(e, Completed)]
    assert got == offline(command) and len(got) == 5
    assert [e.cycle for e in events] == [3, 4, 5, 6, 7]
    assert [e.j0 for e in events] == [a for a, _ in got]


def test_a_segment_is_given_once_the_command_rests_long_enough():
    command = command_with_moves([(0.5, 2.0)], 10.0)
    assembler = SpanAssembler(FS, 20_000, RULE)
    end = offline(command)[0][1]
    wait = round((RULE.max_pause_s + 2 * RULE.settle_s) * FS)
    assert not assembler.feed(rows_of(command[: end + wait + 1]))
    (event,) = assembler.feed(rows_of(command[end + wait + 1 : end + wait + 2], j0=end + wait + 1))
    assert isinstance(event, Completed) and event.data.shape[0] == end - offline(command)[0][0] + 1
    assert assembler.pending_samples <= round(RULE.settle_s * FS) + 2  # still rows are let go


@pytest.mark.parametrize("cuts", [[6400, 7500], [6000, 6400, 7500], list(range(100, 10_000, 100))])
def test_a_segment_longer_than_the_longest_is_discarded_and_its_rest_dropped(cuts):
    """Whatever the batches: one Discarded for the long motion, the next segment kept.

    A batch holding the end of the long motion, its rest and the next move used to drop the
    next segment as if it were the long one's rest (an independent review found it).
    """
    command = command_with_moves([(0.5, 6.0), (7.0, 8.0)], 10.0)
    assembler = SpanAssembler(FS, 2000, RULE)
    events, start = [], 0
    for stop in [*cuts, command.size]:
        events += assembler.feed(rows_of(command[start:stop], j0=start))
        start = stop
    assert len(events) == 2, events
    assert isinstance(events[0], Discarded) and "longer than 2 s" in events[0].reason
    assert isinstance(events[1], Completed)
    assert (int(events[1].data[0, 2]), int(events[1].data[-1, 2])) == offline(command)[1]
    assert assembler.pending_samples < 2100  # memory stays bounded by the longest


def test_rest_that_drifts_by_rounding_is_no_move_whatever_the_batches():
    """A filtered constant wobbles by ~1e-17: no phantom segment of rest (review)."""
    rng = np.random.default_rng(0)
    command = command_with_moves([(0.5, 2.0), (4.0, 5.0)], 10.0)
    command += 1e-12 * rng.standard_normal(command.size)
    assembler = SpanAssembler(FS, 2000, RULE)
    events = []
    for start in range(0, command.size, 20):
        events += assembler.feed(rows_of(command[start : start + 20], j0=start))
    got = [(int(e.data[0, 2]), int(e.data[-1, 2])) for e in events if isinstance(e, Completed)]
    assert got == offline(command) and len(events) == 2


@pytest.mark.parametrize("breaker", ["step back", "off the grid", "reset"])
def test_whatever_breaks_the_stream_ends_the_stretch_as_a_gap_does(breaker):
    command = command_with_moves([(0.5, 2.0)], 3.0)
    assembler = SpanAssembler(FS, 20_000, RULE)
    assert not assembler.feed(rows_of(command[:2400]))  # done moving, not rested long enough
    if breaker == "reset":
        events = assembler.reset("another stream")
    else:
        rows = rows_of(command[:10]) if breaker == "step back" else rows_of(command[:1], 2400)
        rows[:, 0] += 0.0 if breaker == "step back" else 0.4 / FS
        events = assembler.feed(rows)
    (event,) = events
    assert isinstance(event, Completed)
    assert (int(event.data[0, 2]), int(event.data[-1, 2])) == offline(command[:2400])[0]


def test_the_cycles_go_on_when_the_run_info_changes_the_rule():
    from ema_phm.telemetry.window_intake import WindowIntake

    command = command_with_moves([(0.5, 1.5), (3.0, 4.0)], 6.0)
    intake = WindowIntake()
    info = {"sample_rate": FS, "samples_per_window": 20_000, "windows": RULE.as_info()}
    intake.accept_run_info(json.dumps(info))
    (first,) = intake.add_rows(rows_of(command[:2500]))
    info["windows"] = {**RULE.as_info(), "settle_s": 0.15}
    assert intake.accept_run_info(json.dumps(info)).new_geometry
    (second,) = intake.add_rows(rows_of(command[2500:], j0=2500))
    assert (first.cycle, second.cycle) == (3, 4)


@pytest.mark.parametrize(
    "windows, message",
    [
        ({"by": "marker"}, "by 'marker'"),
        ({"by": "excitation", "settle_s": "x"}, "settle_s must be a number, got 'x'"),
        ({"by": "excitation", "max_pause_s": -1}, "max_pause_s must be >= 0"),
        ({"by": "excitation", "first_cycle": 1.5}, "first_cycle must be a whole number"),
        ([1], "must be an object"),
    ],
)
def test_a_bad_windows_rule_in_run_info_is_refused_by_name(windows, message):
    with pytest.raises(ConfigError, match=message):
        SpanRule.from_info(windows)


def test_a_rule_round_trips_through_run_info():
    assert SpanRule.from_info(RULE.as_info()) == RULE
    assert SpanRule.from_info({"by": "length", "seconds": 2}) is None
