"""The baseline a practitioner tries first: a straight line through the last severity estimates.

For each predicted fault: least squares through the last LAST_N (cycle, severity) estimates
of the history; a positive slope gives RUL = cycles from the last window until the line
reaches the fault's failure threshold (a point value, no interval), anything else "no
degradation".  Returns a `rul.Prognosis`, so the benchmark scores it on the same rows and
with the same metrics as `rul.prognose` (its RUL interval is a point: coverage means nothing).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ema_phm.prognostics.rul import (
    PREDICTED,
    FaultPrognosis,
    History,
    Percentiles,
    Prognosis,
    failure_thresholds,
)

#: Estimates the line goes through (the last ones of the history).
LAST_N = 5


def straight_line(history: History, **kw: Any) -> Prognosis:
    """The baseline's prognosis at the history's last cycle.

    Of `rul.prognose`'s keywords it reads cycle_hours, horizon_cycles and thresholds; the
    others belong to the Bayesian model and are ignored.
    """
    hours = float(kw.get("cycle_hours", 1.0))
    horizon = float(kw.get("horizon_cycles", 10.0))
    limits = failure_thresholds(kw.get("thresholds"))
    faults = tuple(_fault(history, i, limits[i], hours, horizon) for i in PREDICTED)
    return Prognosis(
        cycle=float(history.cycles[-1]),
        cycle_hours=hours,
        horizon_cycles=horizon,
        intervals_known=history.intervals_known,
        faults=faults,
    )


def _fault(history: History, i: int, limit: float, hours: float, horizon: float) -> FaultPrognosis:
    """One fault: a line through its last LAST_N severities, RUL where it reaches `limit`."""
    sev, _ = history.severity(i)
    common = {"index": i, "threshold": limit, "severity": float(sev[-1])}
    if sev.size < LAST_N:
        return FaultPrognosis(status="insufficient_data", message="fewer than 5", **common)
    t, s = history.cycles[-LAST_N:], sev[-LAST_N:]
    slope, intercept = np.polyfit(t, s, 1)
    if not slope > 0:
        return FaultPrognosis(status="no_degradation", message="slope <= 0", **common)
    # whole cycles to the first cycle at or past the threshold (as rul.prognose counts);
    # the tolerance keeps a crossing exactly on a cycle from rounding up past it
    rul = max(0.0, math.ceil((limit - intercept) / slope - float(t[-1]) - 1e-9))
    point = Percentiles(rul, rul, rul)
    return FaultPrognosis(
        status="degrading",
        message=f"straight line: RUL {rul:g} cycles",
        rul_cycles=point,
        rul_hours=point.scaled(hours),
        p_within_horizon=float(rul <= horizon),
        samples=np.array([rul]),
        **common,
    )
