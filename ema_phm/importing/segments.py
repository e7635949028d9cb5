"""Where the windows are in a stretch of grid samples (the map's ``windows`` rule).

Each function returns (first, last) sample indices, inclusive, in the stretch.

- ``length``: consecutive windows of ``seconds`` each (a shorter tail is left out);
- ``times``: the listed [start, end] times, in seconds from the recording's start, in the
  order they end; a window not wholly inside the stretch belongs to another stretch or
  spans a gap;
- ``marker``: the runs where the marker is non-zero, at least ``min_duration_s`` long;
- ``excitation``: where the command moves, pauses shorter than ``max_pause_s`` joined,
  widened by ``settle_s`` on each side, at least ``min_duration_s`` long
  (`domain.excitation_spans`, the rig test's rule too).
"""

from __future__ import annotations

import numpy as np

from ..domain.excitation_spans import excitation_spans, runs
from ..telemetry.listed_assembler import grid_index, listed_order
from .channel_map import WindowRule


def by_length(n: int, rate: float, seconds: float) -> list[tuple[int, int]]:
    """Consecutive windows of `seconds` (round(seconds * rate) steps) in n samples."""
    steps = max(1, round(seconds * rate))
    return [(a, a + steps) for a in range(0, n - steps, steps)]


def by_times(
    t: np.ndarray, rate: float, times: tuple[tuple[float, float], ...]
) -> list[tuple[int, int]]:
    """The listed windows wholly inside the stretch's grid times `t`, in the order they end.

    Each time at its nearest grid sample (`grid_index`, as a live stream cuts them).
    """
    first = grid_index(float(t[0]), rate)
    out = []
    for a, b in listed_order(times):
        ia, ib = grid_index(a, rate) - first, grid_index(b, rate) - first
        if ia >= 0 and ib < t.size:
            out.append((ia, ib))
    return out


def by_marker(marker: np.ndarray, rate: float, min_duration_s: float) -> list[tuple[int, int]]:
    """Runs where the marker is non-zero, at least `min_duration_s` long."""
    return [(a, b) for a, b in runs(marker != 0) if (b - a) / rate >= min_duration_s]


def by_excitation(command: np.ndarray, rate: float, rule: WindowRule) -> list[tuple[int, int]]:
    """The excitation segments of a command (`domain.excitation_spans`)."""
    return excitation_spans(
        command,
        rate,
        max_pause_s=rule.max_pause_s,
        settle_s=rule.settle_s,
        min_duration_s=rule.min_duration_s,
    )


def windows_in(
    rule: WindowRule, t: np.ndarray, rate: float, command: np.ndarray, marker: np.ndarray | None
) -> list[tuple[int, int]]:
    """The windows of one stretch by `rule`."""
    if rule.by == "length":
        return by_length(t.size, rate, rule.seconds)
    if rule.by == "times":
        return by_times(t, rate, rule.times)
    if rule.by == "marker":
        assert marker is not None
        return by_marker(marker, rate, rule.min_duration_s)
    return by_excitation(command, rate, rule)
