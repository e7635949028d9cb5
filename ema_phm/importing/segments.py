"""Where the windows are in a stretch of grid samples (the map's ``windows`` rule).

Each function returns (first, last) sample indices, inclusive, in the stretch.

- ``length``: consecutive windows of ``seconds`` each (a shorter tail is left out);
- ``times``: the listed [start, end] times, in seconds from the recording's start; a window
  not wholly inside the stretch belongs to another stretch or spans a gap;
- ``marker``: the runs where the marker is non-zero, at least ``min_duration_s`` long;
- ``excitation``: where the command moves (a sample-to-sample change above `STILL_SHARE`
  of its range in the stretch), pauses shorter than ``max_pause_s`` joined, widened by
  ``settle_s`` on each side, at least ``min_duration_s`` long.
"""

from __future__ import annotations

import numpy as np

from .channel_map import WindowRule

#: A command change below this share of its range in the stretch is no move.
STILL_SHARE = 1e-4


def by_length(n: int, rate: float, seconds: float) -> list[tuple[int, int]]:
    """Consecutive windows of `seconds` (round(seconds * rate) steps) in n samples."""
    steps = max(1, round(seconds * rate))
    return [(a, a + steps) for a in range(0, n - steps, steps)]


def by_times(t: np.ndarray, times: tuple[tuple[float, float], ...]) -> list[tuple[int, int]]:
    """The listed windows wholly inside the stretch's times `t`."""
    out = []
    half = 0.5 * (t[1] - t[0])
    for a, b in times:
        if a >= t[0] - half and b <= t[-1] + half:
            out.append((int(np.argmin(np.abs(t - a))), int(np.argmin(np.abs(t - b)))))
    return out


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) of each run of True."""
    m = np.concatenate([[False], mask.astype(bool), [False]])
    edges = np.flatnonzero(np.diff(m.astype(np.int8)))
    return [(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def by_marker(marker: np.ndarray, rate: float, min_duration_s: float) -> list[tuple[int, int]]:
    """Runs where the marker is non-zero, at least `min_duration_s` long."""
    return [(a, b) for a, b in runs(marker != 0) if (b - a) / rate >= min_duration_s]


def by_excitation(command: np.ndarray, rate: float, rule: WindowRule) -> list[tuple[int, int]]:
    """The excitation segments of a command (see the module docstring)."""
    span = float(np.ptp(command)) if command.size else 0.0
    if span <= 0.0:
        return []
    moving = np.abs(np.diff(command)) > STILL_SHARE * span
    out: list[tuple[int, int]] = []
    pause = round(rule.max_pause_s * rate)
    for a, b in runs(moving):
        if out and a - out[-1][1] <= pause:
            out[-1] = (out[-1][0], b + 1)
        else:
            out.append((a, b + 1))
    pad = round(rule.settle_s * rate)
    last = command.size - 1
    widened = [(max(0, a - pad), min(last, b + pad)) for a, b in out]
    for i in range(1, len(widened)):  # two windows never share a sample: meet half-way
        if widened[i][0] <= widened[i - 1][1]:
            mid = (out[i - 1][1] + out[i][0]) // 2
            widened[i - 1] = (widened[i - 1][0], mid)
            widened[i] = (mid + 1, widened[i][1])
    return [(a, b) for a, b in widened if (b - a) / rate >= rule.min_duration_s]


def windows_in(
    rule: WindowRule, t: np.ndarray, rate: float, command: np.ndarray, marker: np.ndarray | None
) -> list[tuple[int, int]]:
    """The windows of one stretch by `rule`."""
    if rule.by == "length":
        return by_length(t.size, rate, rule.seconds)
    if rule.by == "times":
        return by_times(t, rule.times)
    if rule.by == "marker":
        assert marker is not None
        return by_marker(marker, rate, rule.min_duration_s)
    return by_excitation(command, rate, rule)
