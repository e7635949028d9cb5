"""The true fault vector over a window, from what the simulated actuator announced."""

from __future__ import annotations

import math
from collections import deque
from typing import Any, Mapping

import numpy as np

from ..domain.faults import validate
from ..errors import EmaPhmError

#: (k_since_t, k) pairs kept from run_info.
HISTORY_LENGTH = 64


class GroundTruth:
    """k_true per window: run_info's k history, else the last ground-truth message."""

    def __init__(self) -> None:
        self._history: deque[tuple[float, np.ndarray]] = deque(maxlen=HISTORY_LENGTH)
        self._latest: np.ndarray | None = None

    def note_run_info(self, info: Mapping[str, Any]) -> None:
        """Remember run_info's k_true from k_since_t on (a malformed entry is ignored)."""
        if "k_true" not in info:
            return
        try:
            since = float(info.get("k_since_t", 0.0))
            if math.isfinite(since):
                self._history.append((since, validate(info["k_true"])))
        except (EmaPhmError, TypeError, ValueError, OverflowError):
            pass

    def note_message(self, k: np.ndarray) -> None:
        """The latest ground-truth message (already validated)."""
        self._latest = k

    def over(self, t0: float, t1: float) -> np.ndarray | None:
        """The true k over [t0, t1]; None if it changed inside the window or is unknown."""
        eps = 1e-9 + 1e-6 * abs(t1)
        history = sorted(self._history, key=lambda entry: entry[0])
        if history:
            if any(t0 + eps < since < t1 - eps for since, _ in history):
                return None
            before = [k for since, k in history if since <= t0 + eps]
            if before:
                return before[-1]
        return self._latest
