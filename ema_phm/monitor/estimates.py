"""The counted windows' estimates: k and its interval per cycle, and the `History` of them.

An estimate's interval is its fit's 90 % `k_interval`, widened to hold k when k lies outside
it; a fit without one gives a zero-width interval and marks the history's intervals unknown
(nothing is invented).  Live the newest `max_windows` are kept; offline all of them.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..domain.faults import N_K
from ..prognostics.rul import History


@dataclass(frozen=True)
class Estimate:
    """One counted window's k and interval; `known`: the interval came from the fit.

    `unseen`: entries the window's recording could not show (index -> why).
    """

    cycle: float
    k: np.ndarray
    low: np.ndarray
    high: np.ndarray
    known: bool
    unseen: Mapping[int, str] = field(default_factory=dict)

    @classmethod
    def of(
        cls, cycle: float, k: Any, interval: Any = None, unseen: Mapping[int, str] | None = None
    ) -> Estimate:
        """From a fit's k and (N_K x 2) `k_interval` (None: a zero-width, unknown interval)."""
        k = np.asarray(k, dtype=np.float64)
        hidden = dict(unseen or {})
        if interval is None:
            return cls(float(cycle), k, k.copy(), k.copy(), False, hidden)
        iv = np.asarray(interval, dtype=np.float64).reshape(N_K, 2)
        return cls(float(cycle), k, np.minimum(iv[:, 0], k), np.maximum(iv[:, 1], k), True, hidden)


class Estimates:
    """The counted estimates in cycle order, the newest `max_windows` (None: all)."""

    def __init__(self, max_windows: int | None = None) -> None:
        """Keep the newest `max_windows` estimates (None: every one)."""
        self._entries: deque[Estimate] = deque(maxlen=max_windows)

    def __len__(self) -> int:
        """Estimates held."""
        return len(self._entries)

    def add(self, estimate: Estimate) -> None:
        """Append `estimate` (its cycle after the last one's: `window_rule` sees to it)."""
        self._entries.append(estimate)

    def clear(self) -> None:
        """Forget every estimate (a new run: a new life)."""
        self._entries.clear()

    def history(self) -> History:
        """The `History` of the estimates held (intervals unknown if any one's is)."""
        e = self._entries
        history = History.from_estimates(
            [x.cycle for x in e], [x.k for x in e], [x.low for x in e], [x.high for x in e]
        )
        if not all(x.known for x in e):
            history = replace(history, intervals_known=False)
        unseen: dict[int, str] = {}
        for x in e:  # a fault one window could not show has no trend to read
            for i, why in x.unseen.items():
                unseen.setdefault(i, why)
        return replace(history, unseen=unseen) if unseen else history
