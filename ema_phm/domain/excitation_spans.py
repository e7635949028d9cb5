"""Where a command moves: its excitation spans on a grid (the import's and the rig test's rule).

A span is where the command moves (a sample-to-sample change above `STILL_SHARE` of its range
in the stretch), pauses shorter than ``max_pause_s`` joined, widened by ``settle_s`` on each
side (two spans never share a sample: they meet half-way), at least ``min_duration_s`` long.
"""

from __future__ import annotations

import numpy as np

#: A command change below this share of its range in the stretch is no move.
STILL_SHARE = 1e-4


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) of each run of True."""
    m = np.concatenate([[False], mask.astype(bool), [False]])
    edges = np.flatnonzero(np.diff(m.astype(np.int8)))
    return [(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def excitation_spans(
    command: np.ndarray,
    rate: float,
    *,
    max_pause_s: float,
    settle_s: float,
    min_duration_s: float,
    scale: float | None = None,
) -> list[tuple[int, int]]:
    """(first, last) sample indices, inclusive, of where `command` moves (module docstring).

    `scale`: the range the still share is of (None: the command's own range).
    """
    span = scale if scale is not None else float(np.ptp(command)) if command.size else 0.0
    if span <= 0.0:
        return []
    moving = np.abs(np.diff(command)) > STILL_SHARE * span
    out: list[tuple[int, int]] = []
    pause = round(max_pause_s * rate)
    for a, b in runs(moving):
        if out and a - out[-1][1] <= pause:
            out[-1] = (out[-1][0], b + 1)
        else:
            out.append((a, b + 1))
    pad = round(settle_s * rate)
    last = command.size - 1
    widened = [(max(0, a - pad), min(last, b + pad)) for a, b in out]
    for i in range(1, len(widened)):  # two windows never share a sample: meet half-way
        if widened[i][0] <= widened[i - 1][1]:
            mid = (out[i - 1][1] + out[i][0]) // 2
            widened[i - 1] = (widened[i - 1][0], mid)
            widened[i] = (mid + 1, widened[i][1])
    return [(a, b) for a, b in widened if (b - a) / rate >= min_duration_s]
