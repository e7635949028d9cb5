"""A store read back as a fleet: each unit's level, the fault it names, its RUL, its history.

A unit's level and the fault it names come from its last fitted window (counted or not),
as monitor_node's status reports its last fit: the window's health level and the fault it
claims past its WARN severity (`health.assess_isolation`; a window the model does not
explain is WARN and claims none); else a fault whose RUL alarm stands after that window
(`tracker.PrognosticSummary`: imminent).  The RUL shown is the named fault's, from the
tracker's prognosis after that window (a new run starts without one).  A unit with no
fitted window is UNKNOWN.  Each fitted window keeps the entry its verdict names and, per
fault without a RUL, why (`no_rul_reasons`: from the tracker's summary, nothing guessed).
"""

from __future__ import annotations

import datetime
import math
from collections.abc import Mapping, Sequence
from typing import Any

from ..domain.faults import NAMES, PREDICTED
from .store import Store
from .unit_job import Commissioned
from .view import LEVELS, NOT_SEEN, FleetView, Percentiles, UnitView, WindowPoint

#: The faults a RUL is predicted for (`rul.prognose`; the others are not applicable).
PREDICTED_NAMES = tuple(NAMES[i] for i in PREDICTED)


def _percentiles(d: Mapping[str, Any] | None) -> Percentiles | None:
    if not d:
        return None
    vals = [d.get(p) for p in ("p5", "p50", "p95")]
    return Percentiles(*(math.inf if v is None else float(v) for v in vals))


def _faults(prognosis: Mapping[str, Any] | None) -> dict[str, Mapping[str, Any]]:
    """Each degrading fault's entry of a tracker summary's prognosis."""
    inner = (prognosis or {}).get("prognosis") or {}
    return {f["fault"]: f for f in inner.get("faults", []) if f.get("status") == "degrading"}


def _plural(n: int, word: str) -> str:
    return f"{n} {word}" if n == 1 else f"{n} {word}s"


def no_rul_reasons(summary: Mapping[str, Any] | None) -> dict[str, str]:
    """Why each fault has no RUL after a window, from the tracker's summary after it.

    What the prognosis said of each fault that is not degrading (`rul.prognose`): too few
    explained windows counted yet (and how many more a trend needs), no growing trend
    detected (the test that failed), or no RUL for that fault at all; with no window
    counted yet, that for every fault.  Empty when the window left no summary.
    """
    if not summary:
        return {}
    prognosis = summary.get("prognosis")
    if not prognosis:
        skipped = summary.get("last_skipped") or ""
        why = "no RUL yet: no explained window counted yet" + (
            f" (the last left out: {skipped})" if skipped else ""
        )
        return dict.fromkeys(PREDICTED_NAMES, why)
    out = {}
    for f in prognosis.get("faults", []):
        status, message = f.get("status"), " ".join(str(f.get("message", "")).split())
        if status == "insufficient_data" and int(f.get("estimates_needed") or 0) > 0:
            more = _plural(int(f["estimates_needed"]), "more explained window")
            out[f["fault"]] = f"no RUL yet: needs {more} for a trend ({message})"
        elif status in ("insufficient_data", "no_degradation"):
            out[f["fault"]] = f"no RUL yet: {message}"
        elif status == "not_applicable":
            out[f["fault"]] = f"no RUL for this fault: {message}"
        elif status == "not_seen":
            out[f["fault"]] = f"{NOT_SEEN}{message}"
    return out


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
        dominant=r["dominant"] if r["status"] != "skipped" else "",
        no_rul=no_rul_reasons(r["prognosis"]) if r["status"] != "skipped" else {},
    )


def unit_view(
    unit_id: str, rows: Sequence[Mapping[str, Any]], com: Commissioned | None
) -> UnitView:
    """One unit from its stored windows (in the order diagnosed) and its commissioning."""
    history = tuple(_point(r) for r in rows)
    fitted = [r for r in rows if r["status"] != "skipped"]
    counted = sum(r["status"] == "counted" for r in rows)
    run_id = rows[-1]["run_id"] if rows else ""
    commissioned = com is not None and com.belief_values is not None
    if not fitted:
        why = rows[-1]["reason"] if rows else "no window diagnosed"
        return UnitView(
            unit_id, run_id, "UNKNOWN", None, f"no window fitted: {why}", None, None,
            None if not rows else int(rows[-1]["cycle"]), len(rows), 0, commissioned, history,
        )  # fmt: skip
    last = fitted[-1]
    summary = last["prognosis"] or {}
    explained = last["adequacy"] is None or bool(last["adequacy"].get("ok", True))
    fault: str | None = None
    level = last["level"]
    if level in ("WARN", "ERROR") and explained:
        fault = last["dominant"]
    elif summary.get("level") == "WARN":
        level, fault = "WARN", summary.get("dominant_fault")
    entry = _faults(summary).get(fault or "")
    words = last["message"] if last["status"] == "counted" else last["reason"]
    return UnitView(
        unit_id,
        run_id,
        level if level in LEVELS else "UNKNOWN",
        fault,
        f"{words}; {summary.get('headline', '')}".strip("; "),
        None if entry is None else _percentiles(entry.get("rul_cycles")),
        None if entry is None else _percentiles(entry.get("rul_hours")),
        int(rows[-1]["cycle"]),
        len(rows),
        counted,
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
