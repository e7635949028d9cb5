"""The baselines a practitioner tries first: a line, or a log-line, through the last estimates.

For each predicted fault, least squares through the last `last_n` (cycle, severity)
estimates of the history: `Line` fits the severity, `LogLinear` its logarithm (exponential
growth; severities below LOG_FLOOR are raised to it).  A rising fit gives the RUL = whole
cycles from the last window until the fit reaches the fault's failure threshold (a point
value, no interval: its coverage means nothing), anything else "no degradation".  Each is a
`monitor.predictor.Predictor` returning a `rul.Prognosis`, so the benchmark counts its
windows by the same policy and scores it with the same metrics as the project's model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ema_phm.prognostics.rul import (
    PREDICTED,
    FaultPrognosis,
    History,
    Percentiles,
    Prognosis,
    failure_thresholds,
)

#: Estimates the line goes through by default (the last ones of the history).
LAST_N = 5
#: Smallest severity the log-line takes the logarithm of.
LOG_FLOOR = 0.005


@dataclass(frozen=True)
class Line:
    """A straight line through the last `last_n` severities of each fault."""

    last_n: int = LAST_N
    log: bool = False
    horizon_cycles: float = 10.0

    @property
    def label(self) -> str:
        """How the table names it."""
        kind = "log-linear fit" if self.log else "straight line"
        return f"{kind} through the last {self.last_n} estimates"

    def predict(self, history: History, *, seed: int = 0) -> Prognosis:
        """The baseline's prognosis at the history's last cycle (`seed` unused: no sampling)."""
        limits = failure_thresholds(None)
        return Prognosis(
            cycle=float(history.cycles[-1]),
            cycle_hours=1.0,
            horizon_cycles=self.horizon_cycles,
            intervals_known=history.intervals_known,
            faults=tuple(self._fault(history, i, limits[i]) for i in PREDICTED),
        )

    def _fault(self, history: History, i: int, limit: float) -> FaultPrognosis:
        sev, _ = history.severity(i)
        common = {"index": i, "threshold": limit, "severity": float(sev[-1])}
        if sev.size < self.last_n:
            return FaultPrognosis(
                status="insufficient_data", message=f"fewer than {self.last_n}", **common
            )
        t, s = history.cycles[-self.last_n :], sev[-self.last_n :]
        target = limit
        if self.log:
            s, target = np.log(np.maximum(s, LOG_FLOOR)), math.log(limit)
        slope, intercept = np.polyfit(t, s, 1)
        if not slope > 0:
            return FaultPrognosis(status="no_degradation", message="slope <= 0", **common)
        # whole cycles to the first cycle at or past the threshold (as rul.prognose counts);
        # the tolerance keeps a crossing exactly on a cycle from rounding up past it
        rul = max(0.0, math.ceil((target - intercept) / slope - float(t[-1]) - 1e-9))
        point = Percentiles(rul, rul, rul)
        return FaultPrognosis(
            status="degrading",
            message=f"{self.label}: RUL {rul:g} cycles",
            rul_cycles=point,
            rul_hours=point,
            p_within_horizon=float(rul <= self.horizon_cycles),
            samples=np.array([rul]),
            **common,
        )
