"""What a store says about a fleet: one `UnitView` per unit, ranked by risk.

`FleetView` is what `ema-phm fleet status` prints and `report.render_html` draws;
`summary.read_view` builds it from a store.  Plain data: no database, Dask or matplotlib here.
`shown_fault` decides the one entry the report names and plots for a unit; `no_rul_reason`
says why that entry has no RUL.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..diagnosis.health import assess
from ..domain.faults import NAMES, fault

#: Unit levels, worst first (the health levels of diagnostic_msgs, and UNKNOWN: nothing fitted).
LEVELS: tuple[str, ...] = ("ERROR", "WARN", "OK", "UNKNOWN")


@dataclass(frozen=True)
class Percentiles:
    """p5, p50, p95 of a remaining life (inf: not reached within what was sampled)."""

    p5: float
    p50: float
    p95: float

    def as_list(self) -> list[float | str]:
        """JSON-ready values (inf as the text 'inf')."""
        return [v if math.isfinite(v) else "inf" for v in (self.p5, self.p50, self.p95)]


@dataclass(frozen=True)
class WindowPoint:
    """One diagnosed window of a unit.

    `status`: 'counted' (its k joined the history), 'not_counted' (fitted, left out: the
    reason says why) or 'skipped' (not fitted: the reason says why).  k, k_low, k_high: the
    fit's k and 90 % interval per k entry (None when not fitted); k_true: the truth when the
    recording carries it.  `rul`: per degrading fault name, its RUL in cycles after this
    window.  `dominant`: the entry the window's verdict names (`health.assess`: the largest
    severity over its WARN threshold; '' when not fitted or not known).  `no_rul`: per fault
    without a RUL after this window, why, in words (`summary.no_rul_reasons`; empty when
    the window left no prognosis).
    """

    cycle: int
    status: str
    reason: str = ""
    level: str = ""  # the window's health level (OK/WARN/ERROR), '' when not fitted
    k: tuple[float, ...] | None = None
    k_low: tuple[float, ...] | None = None
    k_high: tuple[float, ...] | None = None
    k_true: tuple[float, ...] | None = None
    rul: dict[str, Percentiles] = field(default_factory=dict)
    dominant: str = ""
    no_rul: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class UnitView:
    """One unit: its level, the fault it names, that fault's RUL, and its window history.

    `fault`: the fault the monitor names for this unit (a `domain.faults` name) or None;
    `rul_cycles` / `rul_hours`: that fault's RUL after the last counted window, None when it
    has none (not degrading, or not enough windows yet).
    """

    unit_id: str
    run_id: str
    level: str  # one of LEVELS
    fault: str | None
    headline: str
    rul_cycles: Percentiles | None
    rul_hours: Percentiles | None
    last_cycle: int | None
    windows: int  # windows diagnosed (fitted or skipped)
    counted: int  # windows in the history
    commissioned: bool
    history: tuple[WindowPoint, ...] = ()

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary (without the history)."""
        return {
            "unit_id": self.unit_id,
            "run_id": self.run_id,
            "level": self.level,
            "fault": self.fault,
            "headline": self.headline,
            "rul_cycles": None if self.rul_cycles is None else self.rul_cycles.as_list(),
            "rul_hours": None if self.rul_hours is None else self.rul_hours.as_list(),
            "last_cycle": self.last_cycle,
            "windows": self.windows,
            "counted": self.counted,
            "commissioned": self.commissioned,
        }


def last_fitted(unit: UnitView) -> WindowPoint | None:
    """The unit's last fitted window (the one its level, fault and headline come from)."""
    fitted = [p for p in unit.history if p.k is not None]
    return fitted[-1] if fitted else None


def shown_fault(unit: UnitView) -> str | None:
    """The one entry the report names and plots for `unit` (None: nothing fitted).

    The fault the unit names; else the entry its last fitted window's verdict names, which
    the headline's words name too ("largest: ..."): `health.assess` decides it (the largest
    severity over its WARN threshold, among the entries whose interval is off healthy when
    any is).  A window stored without its verdict's entry is judged again the same way.
    """
    if unit.fault is not None and unit.fault in NAMES:
        return unit.fault
    last = last_fitted(unit)
    if last is None or last.k is None or len(last.k) != len(NAMES):
        return None
    if last.dominant in NAMES:
        return last.dominant
    interval = None
    if last.k_low is not None and last.k_high is not None:
        interval = np.column_stack([last.k_low, last.k_high])
    return NAMES[assess(last.k, k_interval=interval).dominant]


def no_rul_reason(unit: UnitView, name: str) -> str:
    """Why fault `name` has no RUL after the unit's last fitted window ('': it has one).

    The tracker's reason stored with that window (`WindowPoint.no_rul`); for a window stored
    without reasons, the fault table's for a fault that never has a RUL, else a sentence
    saying the store keeps none.
    """
    last = last_fitted(unit)
    if last is None:
        return ""
    why = last.no_rul.get(name, "")
    if why or last.no_rul or name in last.rul:  # reasons stored: no reason, a RUL
        return why
    if name in NAMES and fault(name).no_rul_because:
        return f"no RUL for this fault: {fault(name).no_rul_because}"
    return "no RUL yet (the store keeps no reason for this window)"


#: How a fault the recordings cannot show is said (`summary.no_rul_reasons`, `not_seen`).
NOT_SEEN = "not seen: "


def not_seen(unit: UnitView) -> dict[str, str]:
    """The faults the unit's recordings cannot show, with why (after its last fitted window)."""
    last = last_fitted(unit)
    if last is None:
        return {}
    return {name: why for name, why in last.no_rul.items() if why.startswith(NOT_SEEN)}


def risk_key(u: UnitView) -> tuple[int, float, float, str]:
    """Sort key, most at risk first: level, then RUL p5, then RUL p50, then the unit id."""
    rul = u.rul_cycles
    return (
        LEVELS.index(u.level),
        math.inf if rul is None else rul.p5,
        math.inf if rul is None else rul.p50,
        u.unit_id,
    )


@dataclass(frozen=True)
class FleetView:
    """Every unit of a store, ranked by `risk_key`; where it came from."""

    units: tuple[UnitView, ...]
    store: str  # the store's URL, password hidden
    schema_version: int
    created: str  # ISO 8601 UTC time the view was read

    def ranked(self) -> FleetView:
        """The same view with its units in risk order."""
        return FleetView(
            tuple(sorted(self.units, key=risk_key)), self.store, self.schema_version, self.created
        )

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready: where it came from and each unit's summary, in risk order."""
        return {
            "store": self.store,
            "schema_version": self.schema_version,
            "created": self.created,
            "units": [u.as_dict() for u in self.units],
        }
