"""The fleet benchmark's --scaling phase: the same units ingested three ways, compared.

The first `subset` units of the fleet (a manifest listing their folders) are ingested into
three fresh SQLite stores: (a) ``workers=0``, a plain loop in this process, no Dask; (b) an
embedded cluster of 1 worker; (c) of 2 workers.  For (b) and (c) the cluster is started
here (`ingest.start_cluster`, a Client, all workers up: the start-up, timed) and the ingest
is pointed at it (``scheduler=``), so that the ingest's wall time and the cluster's
start-up and close are measured apart, and a thread samples the workers' RSS meanwhile.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

from bench.fleet.common import (
    ROW_COLUMNS,
    Progress,
    Run,
    check_fleet,
    compact_rows,
    flat,
    settings,
    sizes,
    timing,
    unit_folders,
)
from bench.fleet.memory import RssSampler
from ema_phm.fleet.ingest import IngestReport, ingest, start_cluster
from ema_phm.fleet.store import Store, results_equal

#: Labels of the three runs, in the order they run.
RUNS = ("plain", "1", "2")
LABELS = {"plain": "plain loop (no Dask)", "1": "Dask, 1 worker", "2": "Dask, 2 workers"}


def subset_manifest(run: Run, n: int) -> tuple[Path, list[str]]:
    """A manifest (.txt) of the fleet's first `n` unit folders, and their names."""
    assert run.fleet_dir is not None
    folders = unit_folders(run.fleet_dir)[:n]
    path = run.work / f"subset_{n}_units.txt"
    path.write_text("".join(f"{p}\n" for p in folders))
    return path, [p.name for p in folders]


def _outcome(label: str, rep: IngestReport, wall: float, store: Store) -> tuple[dict, Any]:
    """A run's entry for the JSON, and what its store holds (rows, commissioning)."""
    rows = store.unit_rows()
    coms = store.commissioning()
    entry = {
        "label": LABELS[label],
        "workers": 0 if label == "plain" else int(label),
        "wall_s": wall,
        "report": rep.as_dict(),
        "windows": rep.windows_diagnosed,
        "commissioned": rep.commissioned,
        "timing": timing(rows),
        "commission_s": sorted(c.wall_s for c in coms.values()),
        "rows": compact_rows(rows),
    }
    return entry, (rows, {u: (c.belief_values, c.problem) for u, c in coms.items()})


def run_plain(run: Run, manifest: Path) -> tuple[dict, Any]:
    """(a) the plain loop in this process."""
    db = run.work / "scaling_plain.sqlite"
    db.unlink(missing_ok=True)  # a fresh store (--work may hold an earlier run's)
    sampler = RssSampler(list).start()
    with Store(db) as store:
        t0 = time.perf_counter()
        rep = ingest(
            [manifest], store, settings(run.quick), workers=0, progress=Progress("plain loop")
        )
        wall = time.perf_counter() - t0
        entry, results = _outcome("plain", rep, wall, store)
    entry.update(
        rss=sampler.stop(),
        db_bytes=db.stat().st_size,
        startup_s=0.0,
        close_s=0.0,
        wall_total_s=wall,
    )
    return entry, results


def run_cluster(run: Run, manifest: Path, workers: int) -> tuple[dict, Any]:
    """(b), (c): an embedded cluster of `workers`, started here, the ingest pointed at it."""
    from distributed import Client  # noqa: PLC0415

    db = run.work / f"scaling_{workers}w.sqlite"
    db.unlink(missing_ok=True)
    t0 = time.perf_counter()
    cluster = start_cluster(workers)
    client = Client(cluster, timeout=30)
    client.wait_for_workers(workers)
    startup = time.perf_counter() - t0
    try:
        pids = sorted(client.run(os.getpid).values())
        sampler = RssSampler(lambda: pids).start()
        with Store(db) as store:
            t1 = time.perf_counter()
            rep = ingest(
                [manifest],
                store,
                settings(run.quick),
                scheduler=cluster.scheduler_address,
                progress=Progress(LABELS[str(workers)]),
            )
            wall = time.perf_counter() - t1
            entry, results = _outcome(str(workers), rep, wall, store)
        entry["rss"] = sampler.stop()
    finally:
        t2 = time.perf_counter()
        client.close()
        cluster.close()
        close = time.perf_counter() - t2
    entry.update(
        db_bytes=db.stat().st_size,
        startup_s=startup,
        close_s=close,
        wall_total_s=startup + wall + close,
    )
    return entry, results


def _ratio(a: float, b: float) -> float | None:
    return a / b if b else None


def summarize(runs: dict[str, dict], results: dict[str, Any]) -> dict[str, Any]:
    """Windows/s, the 2-vs-1-worker ratio, Dask's overhead per window, identical results."""
    for r in runs.values():
        r["windows_per_s"] = _ratio(r["windows"], r["wall_total_s"])
        r["windows_per_s_ingest"] = _ratio(r["windows"], r["wall_s"])
    plain, one = runs["plain"], runs["1"]
    n = plain["windows"]
    iso = plain["timing"]["all"]["mean"]
    with_startup = (one["wall_total_s"] - plain["wall_s"]) / n if n else None
    without = (one["wall_s"] - plain["wall_s"]) / n if n else None
    base_rows, base_coms = results["plain"]
    return {
        "ratio": _ratio(runs["2"]["windows_per_s"], one["windows_per_s"]),
        "ratio_ingest": _ratio(runs["2"]["windows_per_s_ingest"], one["windows_per_s_ingest"]),
        "mean_isolation_s": iso,
        "overhead_s_per_window": with_startup,
        "overhead_pct": None if with_startup is None else 100 * with_startup / iso,
        "overhead_no_startup_s_per_window": without,
        "overhead_no_startup_pct": None if without is None else 100 * without / iso,
        "identical": all(results_equal(flat(base_rows), flat(results[k][0])) for k in ("1", "2")),
        "commissioning_identical": all(base_coms == results[k][1] for k in ("1", "2")),
    }


def run_scaling(run: Run, subset: int) -> dict[str, Any]:
    """The three ingests of the first `subset` units and what they show."""
    assert run.fleet_dir is not None
    check_fleet(run.fleet_dir, run.quick, run.seed)
    manifest, units = subset_manifest(run, subset)
    print(f"[scaling] {len(units)} units: {', '.join(units)}", flush=True)
    runs: dict[str, dict] = {}
    results: dict[str, Any] = {}
    runs["plain"], results["plain"] = run_plain(run, manifest)
    for w in (1, 2):
        runs[str(w)], results[str(w)] = run_cluster(run, manifest, w)
    for key in RUNS:
        r = runs[key]
        print(f"[scaling] {r['label']}: {r['windows']} windows, {r['wall_total_s']:.1f} s")
    return {
        "units": units,
        "settings": settings(run.quick).as_dict(),
        "row_columns": ROW_COLUMNS,
        "runs": runs,
        "summary": summarize(runs, results),
        "command": run.command("--scaling", f"--dir {run.fleet_dir}")
        + ("" if subset == sizes(run.quick)["subset"] else f" --units-subset {subset}"),
    }
