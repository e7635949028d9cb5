"""What the live monitor's parts share: settings, counters, lock, and the parts themselves.

`HealthMonitor` (the calls from the node) and its `WindowFitter` (the worker's fits) act on
one `MonitorState`; its `lock` guards it (see `health_monitor` for which parts run outside).
"""

from __future__ import annotations

import threading
from typing import Any, Callable

import numpy as np

from ..diagnosis.isolation_settings import IsolationSettings
from . import status_texts
from .commissioning_guard import CommissioningGuard
from .policy import FitPolicy
from .result_log import ResultLog
from .status_board import StatusBoard
from .tracker import PrognosticSummary, PrognosticTracker
from .window_scheduler import WindowScheduler

#: The true k over a window [t0, t1] (None: unknown), from an evaluation listener beside the
#: monitor (`ema_phm.evaluation.live_truth.LiveTruth.over`); read after a fit, never before.
TruthLookup = Callable[[float, float], np.ndarray | None]


class MonitorState:
    """The settings, counters and lock, the parts (intake, status, commissioning, policy)."""

    def __init__(
        self,
        settings: IsolationSettings,
        *,
        hardware_id: str,
        commission_windows: int,
        tracker: PrognosticTracker | None,
        queue_depth: int,
        clock: Callable[[], float],
        truth: TruthLookup | None = None,
    ) -> None:
        """Without a unit file the monitor commissions itself from `commission_windows`."""
        self.settings = settings
        self.truth = truth  # after a fit only, for %err: an evaluation listener's, or None
        self.hardware_id = hardware_id
        self.tracker = tracker  # None: prognostics off
        self.clock = clock
        self.lock = threading.RLock()
        self.counters: dict[str, int] = dict.fromkeys(status_texts.COUNTERS, 0)
        self.result_log = ResultLog(self.lock)
        discards = self.result_log.discard_reasons
        self.windows = WindowScheduler(queue_depth, self.counters, discards, clock)
        # without a unit file, commission from the first windows (0: use the belief as given)
        self.guard = CommissioningGuard(0 if settings.unit_file else int(commission_windows))
        self.policy = FitPolicy()  # when to track, when to search again
        self.board = StatusBoard(self.context)

    @property
    def prognosis(self) -> PrognosticSummary | None:
        """The latest prognostic summary (None: prognostics off)."""
        return None if self.tracker is None else self.tracker.summary

    def context(self) -> status_texts.StatusContext:
        """What every status shows besides its cause: counters, settings, prognosis, stream."""
        return status_texts.StatusContext(
            hardware_id=self.hardware_id,
            counters=dict(self.counters),
            settings=self._reported_settings(),
            prognostics=self.prognosis,
            stream=self._stream_name(),
        )

    def _reported_settings(self) -> dict[str, Any]:
        """The settings, and what speaks against the belief (unit file, refused baselines)."""
        reported = self.settings.reported()
        warnings = [*self.settings.unit_warnings, *self.guard.warnings]
        if warnings:
            reported["unit_warnings"] = "; ".join(warnings)
        return reported

    def _stream_name(self) -> str:
        stream = self.windows.intake.stream
        if self.counters["stream_changes"] == 0 and stream is None:
            return ""  # an anonymous stream that never changed: nothing worth a key
        return "anonymous" if stream is None else str(stream)
