"""Sizing on paper: arithmetic on the measured per-window costs for larger fleets.

Nothing here is measured: each figure is a measured input (named in `inputs`) times a
count.  A window's fit runs on one core (one numba and one BLAS thread), so its measured
wall time on an otherwise idle worker is taken as its CPU seconds.
"""

from __future__ import annotations

import math
from typing import Any

#: Fleets sized, in actuators, and pre-flight windows per actuator per day.
FLEETS = (1_000, 10_000, 100_000)
WINDOWS_PER_DAY = 4
#: Dask distributed's documented overhead per task ("about 1 ms", distributed.dask.org,
#: Motivation: low latency) -- an order of magnitude, not a measurement of this machine.
DASK_TASK_S = 1e-3
DAY_S = 86_400.0
CORES_PER_MACHINE = 2
UTILISATION = 0.5


def inputs(data: dict[str, Any]) -> dict[str, Any] | None:
    """The measured figures the sizing rests on, and where each comes from (None: none yet)."""
    scaling, fleet = data.get("scaling"), data.get("fleet")
    if scaling is None and fleet is None:
        return None
    src = scaling["runs"]["1"] if scaling else fleet
    where = "scaling, 1 worker" if scaling else "fleet, 2 workers"
    t = src["timing"]
    store = fleet or scaling["runs"]["2"]
    rows = fleet["db_rows"] if fleet else store["windows"]
    rss = (scaling["runs"]["2"] if scaling else fleet)["rss"]
    coms = [c for c in src.get("commission_s", []) if c is not None and math.isfinite(c)]
    return {
        "timing_from": where,
        "first_s": t["first"]["mean"],
        "later_s": t["later"]["mean"],
        "tracked_s": t["by_mode"].get("tracked", {}).get("mean", math.nan),
        "later_n": t["later"]["n"],
        "later_modes": {m: v["n"] for m, v in t["by_mode"].items()},
        "commission_s": sum(coms) / len(coms) if coms else math.nan,
        "bytes_from": "fleet store" if fleet else "scaling store, 2 workers",
        "bytes_per_window": store["db_bytes"] / rows if rows else math.nan,
        "worker_rss_mb": rss["worker_peak_mb"],
        "main_rss_mb": rss["main_peak_mb"],
    }


def table(data: dict[str, Any]) -> list[dict[str, Any]]:
    """One row per fleet size: windows, CPU, cores, machines, store, scheduler load, RAM."""
    src = inputs(data)
    if src is None:
        return []
    out = []
    for n in FLEETS:
        windows = n * WINDOWS_PER_DAY
        cpu = windows * src["later_s"]
        cores = cpu / DAY_S
        machines = math.ceil(cores / UTILISATION / CORES_PER_MACHINE)
        tasks_s = windows / DAY_S
        worker = src["worker_rss_mb"] or math.nan
        out.append(
            {
                "actuators": n,
                "windows_per_day": windows,
                "cpu_s_per_day": cpu,
                "cpu_s_per_day_all_first": windows * src["first_s"],
                "cores_100": cores,
                "cores_50": cores / UTILISATION,
                "machines": machines,
                "rows_per_day": windows,
                "bytes_per_day": windows * src["bytes_per_window"],
                "tasks_per_s": tasks_s,
                "scheduler_busy": tasks_s * DASK_TASK_S,
                "ram_mb": machines * CORES_PER_MACHINE * worker + src["main_rss_mb"],
                "commission_cpu_s": n * src["commission_s"],
            }
        )
    return out
