"""A store read back as a fleet: each unit's level, the fault it names, its RUL, its history.

What a unit names comes from its last counted window, as the live monitor reports it: the
window's health level and dominant fault (`health.assess_isolation`: a fault claimed past
its WARN severity), else a fault whose RUL alarm stands (`tracker.PrognosticSummary`:
imminent); its RUL is that fault's, when the prognosis calls it degrading.  A unit with no
counted window is UNKNOWN.
"""

from __future__ import annotations

import datetime
import math
from collections.abc import Mapping, Sequence
from typing import Any

from .store import Store
from .unit_job import Commissioned
from .view import LEVELS, FleetView, Percentiles, UnitView, WindowPoint


def _percentiles(d: Mapping[str, Any] | None) -> Percentiles | None:
    if not d:
        return None
    vals = [d.get(p) for p in ("p5", "p50", "p95")]
    return Percentiles(*(math.inf if v is None else float(v) for v in vals))


def _faults(prognosis: Mapping[str, Any] | None) -> dict[str, Mapping[str, Any]]:
    """Each degrading fault's entry of a tracker summary's prognosis."""
    inner = (prognosis or {}).get("prognosis") or {}
    return {f["fault"]: f for f in inner.get("faults", []) if f.get("status") == "degrading"}


def _point(r: Mapping[str, Any]) -> WindowPoint:
    iv = r["k_interval"]
    low = None if iv is None else tuple(float(a) for a, _ in iv)
    high = None if iv is None else tuple(float(b) for _, b in iv)
    rul = {}
    if r["status"] == "counted":
        for name, f in _faults(r["prognosis"]).items():
            p = _percentiles(f.get("rul_cycles"))
            if p is not None:
                rul[name] = p
    return WindowPoint(
        cycle=int(r["cycle"]),
        status=r["status"],
        reason=r["reason"],
        level=r["level"],
        k=None if r["k"] is None else tuple(r["k"]),
        k_low=low,
        k_high=high,
        k_true=None if r["k_true"] is None else tuple(r["k_true"]),
        rul=rul,
    )


def unit_view(
    unit_id: str, rows: Sequence[Mapping[str, Any]], com: Commissioned | None
) -> UnitView:
    """One unit from its stored windows (in the order diagnosed) and its commissioning."""
    history = tuple(_point(r) for r in rows)
    counted = [r for r in rows if r["status"] == "counted"]
    run_id = rows[-1]["run_id"] if rows else ""
    commissioned = com is not None and com.belief_values is not None
    if not counted:
        why = rows[-1]["reason"] if rows else "no window diagnosed"
        return UnitView(
            unit_id,
            run_id,
            "UNKNOWN",
            None,
            f"no counted window: {why}",
            None,
            None,
            None,
            len(rows),
            0,
            commissioned,
            history,
        )
    last = counted[-1]
    summary = last["prognosis"] or {}
    fault: str | None = None
    level = last["level"]
    if level in ("WARN", "ERROR"):
        fault = last["dominant"]
    elif summary.get("level") == "WARN":
        level, fault = "WARN", summary.get("dominant_fault")
    degrading = _faults(summary)
    entry = degrading.get(fault or "")
    return UnitView(
        unit_id,
        run_id,
        level if level in LEVELS else "UNKNOWN",
        fault,
        f"{last['message']}; {summary.get('headline', '')}".strip("; "),
        None if entry is None else _percentiles(entry.get("rul_cycles")),
        None if entry is None else _percentiles(entry.get("rul_hours")),
        int(rows[-1]["cycle"]),
        len(rows),
        len(counted),
        commissioned,
        history,
    )


def read_view(store: Store) -> FleetView:
    """Every unit of `store` (stored windows or a commissioning), ranked by risk."""
    rows = store.unit_rows()
    coms = store.commissioning()
    units = tuple(
        unit_view(u, rows.get(u, []), coms.get(u)) for u in sorted(set(rows) | set(coms))
    )
    created = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    return FleetView(units, store.shown, store.schema_version, created).ranked()
