"""The fleet benchmark's --fleet phase: the whole fleet ingested, reported and scored.

The whole generated fleet is ingested with the default embedded cluster (one worker per
core) into a fresh SQLite store, timed end to end (cluster start-up and close included),
read back (`summary.read_view`), written as the HTML report, and scored against the
fleet's truth: each unit with a growing fault should be named with that fault, each
healthy one with none.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from typing import Any

from bench.fleet.common import (
    ROW_COLUMNS,
    Progress,
    Run,
    check_fleet,
    compact_rows,
    settings,
    timing,
)
from bench.fleet.memory import RssSampler, spawned_workers
from ema_phm.domain.faults import fault
from ema_phm.fleet.ingest import ingest
from ema_phm.fleet.report import write_report
from ema_phm.fleet.store import Store
from ema_phm.fleet.summary import read_view
from ema_phm.fleet.view import FleetView
from ema_phm.simulator.degradation import Degradation


def _last_counted(rows: Sequence[Mapping[str, Any]]) -> Mapping[str, Any] | None:
    return next((r for r in reversed(rows) if r["status"] == "counted"), None)


def _entry(values: Sequence[float] | None, index: int) -> float | None:
    return None if values is None else float(values[index])


def _true_rul(t: Mapping[str, Any], last_cycle: int | None) -> int | None:
    """Cycles from the unit's last window to its fault's failure severity (None: not reached)."""
    if last_cycle is None:
        return None
    deg = Degradation.from_mapping(t["degradation"], source="fleet truth")
    eol = deg.first_cycle_at(t["fault"], fault(t["fault"]).error)
    return None if eol is None else eol - last_cycle


def _degrading(uid: str, t: Mapping[str, Any], view: Any, rows: Sequence[Any]) -> dict[str, Any]:
    """One degrading unit: what it is named, its last counted k of the true fault, its RUL."""
    idx = fault(t["fault"]).index
    last = _last_counted(rows)
    rul = None if view is None else view.rul_cycles
    return {
        "unit": uid,
        "truth": t["fault"],
        "final_severity": t["final_severity"],
        "named": None if view is None else view.fault,
        "level": "absent" if view is None else view.level,
        "right": view is not None and view.fault == t["fault"],
        "k": None if last is None else _entry(last["k"], idx),
        "k_true": None if last is None else _entry(last["k_true"], idx),
        "rul_p50": None if rul is None else (rul.p50 if math.isfinite(rul.p50) else "inf"),
        "true_rul": _true_rul(t, None if view is None else view.last_cycle),
    }


def score(view: FleetView, rows: Mapping[str, Sequence[Any]], truth: Mapping) -> dict[str, Any]:
    """Named right, misses, false alarms on healthy units, RULs, against the fleet's truth."""
    units = {u.unit_id: u for u in view.units}
    degrading = [
        _degrading(uid, t, units.get(uid), rows.get(uid, []))
        for uid, t in sorted(truth["units"].items())
        if t["fault"] is not None
    ]
    healthy = [uid for uid, t in sorted(truth["units"].items()) if t["fault"] is None]
    alarms = [
        {"unit": uid, "named": units[uid].fault, "level": units[uid].level}
        for uid in healthy
        if uid in units and units[uid].fault is not None
    ]
    right = sum(d["right"] for d in degrading)
    with_rul = [d for d in degrading if d["rul_p50"] is not None]
    return {
        "degrading": len(degrading),
        "right": right,
        "share_right": right / len(degrading) if degrading else None,
        "misses": [d for d in degrading if not d["right"]],
        "healthy": len(healthy),
        "false_alarms": alarms,
        "with_rul": len(with_rul),
        "units": degrading,
        "levels": {lv: sum(u.level == lv for u in view.units) for lv in ("ERROR", "WARN", "OK")},
    }


def run_fleet(run: Run) -> dict[str, Any]:
    """Ingest, view, report and score the whole fleet."""
    assert run.fleet_dir is not None
    truth = check_fleet(run.fleet_dir, run.quick, run.seed)
    db, html = run.work / "fleet.sqlite", run.work / "fleet_report.html"
    db.unlink(missing_ok=True)  # a fresh store (--work may hold an earlier run's)
    sampler = RssSampler(spawned_workers).start()
    with Store(db) as store:
        t0 = time.perf_counter()
        rep = ingest([run.fleet_dir], store, settings(run.quick), progress=Progress("fleet"))
        wall = time.perf_counter() - t0
        rss = sampler.stop()
        t1 = time.perf_counter()
        view = read_view(store)
        rows = store.unit_rows()
        read_s = time.perf_counter() - t1
    t2 = time.perf_counter()
    write_report(view, html)
    report_s = time.perf_counter() - t2
    n_rows = sum(len(r) for r in rows.values())
    result = score(view, rows, truth)
    print(
        f"[fleet] {rep.windows_diagnosed} windows in {wall:.0f} s; named right "
        f"{result['right']}/{result['degrading']}, false alarms {len(result['false_alarms'])}"
    )
    return {
        "settings": settings(run.quick).as_dict(),
        "wall_s": wall,
        "report": rep.as_dict(),
        "rss": rss,
        "read_view_s": read_s,
        "write_report_s": report_s,
        "html_bytes": html.stat().st_size,
        "db_bytes": db.stat().st_size,
        "db_rows": n_rows,
        "timing": timing(rows),
        "score": result,
        "view": view.as_dict(),
        "row_columns": ROW_COLUMNS,
        "rows": compact_rows(rows),
        "command": run.command("--fleet", f"--dir {run.fleet_dir}"),
    }
