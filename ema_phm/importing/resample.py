"""Series onto the actuator's acquisition grid, never across a gap.

- A **gap** in a series is a step between two samples longer than ``max_gap_s`` (the map's;
  default `GAP_STEPS` times that series' median step).  The **stretches** of a recording are
  the times every series covers without a gap; windows are cut inside one stretch only.
- The **grid** is ``t = j / sample_rate`` for the whole numbers j inside a stretch.
- A series sampled faster than the grid (its mean rate over the samples used above
  `OVERSAMPLED` x the grid's) is first put on a uniform grid at that mean rate (linear
  interpolation, which also takes out its jitter and its bursts: a topic timed by when it
  was received comes in bunches when its publisher or the network stalls), then
  low-passed by a zero-phase Butterworth of order `AA_ORDER` at
  `AA_CUTOFF` x the grid's rate (``scipy.signal.sosfiltfilt``: no delay, which the fit would
  read as a dynamic), then interpolated onto the grid.  A series at the grid's rate or slower
  is interpolated linearly.
"""

# Heavy libraries are imported where used: `ema-phm --help` stays fast.
# ruff: noqa: PLC0415

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np

from .sources import Series

#: Default gap: this many median steps of the series.
GAP_STEPS = 5.0
#: A series this much faster than the grid is low-passed before it is sampled.
OVERSAMPLED = 1.05
#: A series is on the grid when its median distance to a grid time is below this [steps].
ON_GRID = 0.05
#: A slower current is marked in a window only with this many samples in it, and this
#: share of them in one phase (`logged_first`).
MIN_LOGGED = 50
SAME_PHASE = 0.99
#: Anti-aliasing low-pass: cutoff as a share of the grid's rate, and order.
AA_CUTOFF = 0.45
AA_ORDER = 4


def median_step(s: Series) -> float:
    """The series' median sample step [s] (inf for one sample)."""
    return float(np.median(np.diff(s.t))) if s.t.size > 1 else float("inf")


def covered(s: Series, max_gap_s: float | None) -> list[tuple[float, float]]:
    """The intervals `s` covers, split at its gaps."""
    limit = max_gap_s if max_gap_s is not None else GAP_STEPS * median_step(s)
    cuts = np.flatnonzero(np.diff(s.t) > limit)
    starts = np.concatenate([[0], cuts + 1])
    ends = np.concatenate([cuts, [s.t.size - 1]])
    return [(float(s.t[a]), float(s.t[b])) for a, b in zip(starts, ends, strict=True) if b > a]


def stretches(series: Iterable[Series], max_gap_s: float | None) -> list[tuple[float, float]]:
    """The times every series covers without a gap, in order."""
    common: list[tuple[float, float]] | None = None
    for s in series:
        mine = covered(s, max_gap_s)
        common = mine if common is None else _intersect(common, mine)
    return common or []


def _intersect(
    a: Sequence[tuple[float, float]], b: Sequence[tuple[float, float]]
) -> list[tuple[float, float]]:
    """Intersection of two sorted lists of disjoint intervals."""
    out, i, j = [], 0, 0
    while i < len(a) and j < len(b):
        lo, hi = max(a[i][0], b[j][0]), min(a[i][1], b[j][1])
        if lo < hi:
            out.append((lo, hi))
        if a[i][1] < b[j][1]:
            i += 1
        else:
            j += 1
    return out


def grid(stretch: tuple[float, float], rate: float) -> np.ndarray:
    """The grid times t = j / rate inside `stretch`."""
    first = int(np.ceil(stretch[0] * rate - 1e-9))
    last = int(np.floor(stretch[1] * rate + 1e-9))
    return np.arange(first, last + 1, dtype=np.float64) / rate


def on_grid(s: Series, t: np.ndarray, rate: float) -> np.ndarray:
    """`s` sampled at the grid times `t` (all inside one of its gap-free intervals)."""
    margin = 2 * median_step(s)
    inside = (s.t >= t[0] - margin) & (s.t <= t[-1] + margin)
    ts, vs = s.t[inside], s.v[inside]
    if ts.size < 3 * (AA_ORDER + 1) * 2:
        return np.interp(t, ts, vs)
    # the mean step, not the median: under bursts the median is a burst's spacing
    step = float(ts[-1] - ts[0]) / (ts.size - 1)
    if 1.0 / step <= OVERSAMPLED * rate:
        return np.interp(t, ts, vs)
    from scipy.signal import butter, sosfiltfilt

    uniform = np.linspace(ts[0], ts[-1], ts.size)
    sos = butter(AA_ORDER, AA_CUTOFF * rate, fs=1.0 / step, output="sos")
    smooth = sosfiltfilt(sos, np.interp(uniform, ts, vs))
    return np.interp(t, uniform, smooth)


def logged_grid(s: Series, rate: float) -> tuple[int, np.ndarray] | None:
    """(m, grid indices of its samples) of a series logged on every m-th grid time, else None.

    m >= 2 is its usual step in grid samples.  None for any other series: faster, off the
    grid or irregular.  Which residue mod m a window's samples take is `logged_first`'s.
    """
    if s.t.size < 3:
        return None
    x = s.t * rate
    j = np.rint(x)
    if float(np.median(np.abs(x - j))) > ON_GRID:
        return None
    steps = np.diff(j)
    m = int(np.median(steps))
    if m < 2 or float(np.mean(steps == m)) < 0.9:
        return None
    return m, j.astype(np.int64)


def logged_first(logged: tuple[int, np.ndarray], first: int, last: int) -> int | None:
    """The window [first, last]'s (grid indices) first logged sample, from its start.

    None unless at least `MIN_LOGGED` samples fall in the window and `SAME_PHASE` of them
    are a whole number of steps m apart (a log whose phase moves, with a clock's drift or
    after a gap, is not marked: its samples would be taken for the interpolated ones).
    """
    m, j = logged
    inside = j[(j >= first) & (j <= last)] - first
    if inside.size < MIN_LOGGED:
        return None
    counts = np.bincount(inside % m, minlength=m)
    phase = int(counts.argmax())
    return phase if counts[phase] >= SAME_PHASE * inside.size else None


def held(s: Series, t: np.ndarray) -> np.ndarray:
    """`s` at the times `t` as a zero-order hold (a marker's last value; 0 before its first)."""
    i = np.searchsorted(s.t, t, side="right") - 1
    return np.where(i >= 0, s.v[np.clip(i, 0, s.t.size - 1)], 0.0)
