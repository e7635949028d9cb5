"""The live truth listener: the true k over a window, from what a simulated actuator announced.

Beside the monitor, not part of it: `monitor_node` feeds it /ema/ground_truth and the k history
of /ema/run_info and hands the monitor only `LiveTruth.over`, which the monitor calls after a
fit to report %err (eq. 6.4).  A real actuator announces no truth: `over` then gives None.
"""

from __future__ import annotations

import json
import math
from collections import deque
from typing import Any, Mapping

import numpy as np

from ..domain.faults import validate
from ..errors import EmaPhmError

#: (k_since_t, k) pairs kept from run_info.
HISTORY_LENGTH = 64


class LiveTruth:
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

    def note_run_info_text(self, text: str) -> None:
        """A run_info JSON text (one that does not parse is the monitor's to report)."""
        try:
            info = json.loads(text)
        except (TypeError, ValueError):
            return
        if isinstance(info, dict):
            self.note_run_info(info)

    def note_message(self, values: Any) -> str | None:
        """The latest ground-truth message; why it is ignored (None: taken)."""
        try:
            self._latest = validate(values)
        except EmaPhmError as exc:
            return str(exc)
        return None

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
