"""Pace a simulated stream against the wall clock (`realtime_factor` simulated s per wall s)."""

from __future__ import annotations

import time
from typing import Callable

import numpy as np

#: Behind by more than this [s]: re-anchor instead of sending a burst to catch up.
MAX_LAG_S = 1.0


class Pacer:
    """How long to wait before sending samples up to simulated time t; 0 = as fast as possible."""

    def __init__(
        self, realtime_factor: float, *, clock: Callable[[], float] = time.monotonic
    ) -> None:
        self.realtime_factor = realtime_factor
        self._clock = clock
        self._wall0: float | None = None
        self._sim0 = 0.0
        self._lag_s: float | None = None
        self._lag_reported = False

    def delay(self, t_first: float, t_last: float) -> float:
        """Seconds to wait before sending samples t_first .. t_last (wall time reaching t_last)."""
        if self.realtime_factor <= 0:
            return 0.0
        now = self._clock()
        if self._wall0 is None:
            self._wall0, self._sim0 = now, t_first
        target = self._wall0 + (t_last - self._sim0) / self.realtime_factor
        if target > now:
            return target - now
        if now - target > MAX_LAG_S:
            self._lag_s = now - target
            self._wall0, self._sim0 = now, t_last
        return 0.0

    def wall_at(self, t: np.ndarray) -> np.ndarray | None:
        """The wall times [s, this pacer's clock] of simulated times t (None: not started)."""
        if self._wall0 is None or self.realtime_factor <= 0:
            return None
        return self._wall0 + (np.asarray(t, dtype=np.float64) - self._sim0) / self.realtime_factor

    def first_lag(self) -> float | None:
        """The lag [s] of the first re-anchoring, once (for a single warning); None otherwise."""
        if self._lag_s is None or self._lag_reported:
            return None
        self._lag_reported = True
        return self._lag_s
