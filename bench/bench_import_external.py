#!/usr/bin/env python3
"""`ema-phm import` on another simulator's drive: motulator's windows in a rig's forms.

Usage (from the repo root; motulator is pinned in requirements.txt's benchmark block):
    .venv/bin/python -m bench.bench_import_external --jobs 2
    .venv/bin/python -m bench.bench_import_external --report-only   # from the saved rows

The drive: `bench_external`'s thesis actuator with an 800 Hz PI current loop in dq,
simulated by motulator (bench/external/motulator_ema.py) with `bench_external`'s noise and
its seeds (its windows cached under build/bench_external/ are reused): 3 healthy windows,
friction k1 = 0.3 and 0.6, position gain k8 = 0.7 and 0.3.  The monitor reads the file its
user writes (`bench_external.described`: PI kind, bandwidth, delay; no high_fidelity
section, no healthy levels), commissioned on motulator's two healthy baselines as
``ema-phm calibrate --baseline`` does (`bench_external.commissioned`).  Every window,
baselines included, is taken as a rig without a load cell records it (`unloaded`): the
rig's forms carry no load.

Each window is fitted as ``ema-phm isolate`` fits it (`bench_import.fit`), with the
commissioned belief, in `bench_import`'s forms (`bench_import.VARIANTS`, written and imported by
`bench_import.imported` with the described actuator): native (seeds 0, 1, 2), bag
(0, 1, 2), csv, parquet and the subsets no_encoder, no_speed, no_temperature, iq_1khz
(seed 0).  Left out: phases_20khz, whose log is the same run acquired at 20 kHz with its
phase currents; `motulator_ema.simulate` gives the 2 kHz acquired window only.  Scored by
`bench_import`'s own scoring.  Rows: bench/results/bench_import_external.json; report:
docs/benchmarks_import_external.md (hand-written analysis below `bench.harness.KEEP_MARKER`
is kept).
"""

from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from bench import bench_external as ext
from bench import bench_import as imp
from bench.external import motulator_ema as mot
from bench.harness import (
    OUT_HELP,
    cli,
    command_line,
    out_dirs,
    pool,
    read_rows,
    stamp,
    write_report,
    write_rows,
)
from ema_phm.domain.faults import NAMES
from ema_phm.domain.window import Window
from ema_phm.model.belief import MonitorBelief

NAME, BANDWIDTH = "thesis_pi", 800.0
#: bench_external's index of this configuration (its seeds are 1000 x index + ...).
CONFIG_INDEX = 0
HEALTHY = 3
FORMS = tuple(f for f in imp.VARIANTS if f != "phases_20khz")
#: The fault each in-k scenario's k names (bench_import's rows name windows by fault).
WINDOW_NAMES = {"friction": "friction", "gain_drift": "gain_drift"}


def scenarios() -> list[tuple[int, ext.Scenario]]:
    """(bench_external's scenario index, scenario): the healthy and in-k ones."""
    actuator = ext.actuator_of(NAME, BANDWIDTH)
    every = ext.scenarios(actuator, HEALTHY)
    return [(i, sc) for i, sc in enumerate(every) if sc.kind in ("healthy", "in_k")]


def unloaded(w: Window) -> Window:
    """`w` as a rig without a load cell records it (its load channel unknown, NaN).

    The rig's forms carry no load (`rig_forms`: ``load: unknown``); motulator's windows
    record their load (0 N*m here), and a native fit that knew it would not be the same
    information as the imported one (with the load known, bag and native differed by
    0.0067 in k, median, against a seed-to-seed 0.0008).
    """
    return dataclasses.replace(w, load=np.full(w.n, np.nan))


def belief() -> MonitorBelief:
    """The described drive's belief, commissioned on motulator's two healthy baselines."""
    actuator = ext.actuator_of(NAME, BANDWIDTH)
    cfg = ext.config_name(NAME, BANDWIDTH)
    base = ext.Scenario("baseline", mot.Faults(), "healthy")
    baselines = [
        ext.window("mot", cfg, actuator, base, 1000 * CONFIG_INDEX + 900 + b)
        for b in range(ext.BASELINES)
    ]
    packaged = MonitorBelief.for_actuator(ext.described(NAME, actuator))
    commissioned, _stored = ext.commissioned([unloaded(w) for w in baselines], packaged, None)
    return commissioned


_BELIEF: MonitorBelief | None = None


def _warm() -> None:
    """Each worker commissions once (the same baselines: the same belief)."""
    global _BELIEF  # noqa: PLW0603 - one belief per worker process
    _BELIEF = belief()


def run_window(job: tuple[int, str]) -> list[dict[str, Any]]:
    """Every form and fit of one scenario's window (a pool job)."""
    si, name = job
    assert _BELIEF is not None
    actuator = ext.actuator_of(NAME, BANDWIDTH)
    sc = dict(scenarios())[si]
    seed = 1000 * CONFIG_INDEX + 10 * si + 1
    w = unloaded(ext.window("mot", ext.config_name(NAME, BANDWIDTH), actuator, sc, seed))
    label = "healthy" if sc.kind == "healthy" else WINDOW_NAMES[sc.fault]
    base = {"index": si, "scenario": name, "window": label}
    assert w.k_true is not None
    base["k_true"] = [float(v) for v in w.k_true]
    forms: list[tuple[str, Window, dict[str, float], tuple[int, ...]]] = [
        ("native", w, {}, imp.SEEDS)
    ]
    described = ext.described(NAME, actuator)
    for form in FORMS:
        kind, cmap = imp.VARIANTS[form]
        got, cost = imp.imported(kind, cmap, w, None, described)
        forms.append((form, got, cost, imp.SEEDS if form == "bag" else imp.SEEDS[:1]))
    rows = []
    for form, window, cost, seeds in forms:
        for s in seeds:
            row = {**base, "form": form, "seed": s, **cost, **imp.fit(window, s, _BELIEF)}
            rows.append(row)
            print(
                f"{name:18s} {form:15s} seed {s} %err {row.get('percent_err', math.nan):6.2f} "
                f"{NAMES[row['dominant']] if 'dominant' in row else '-'}",
                flush=True,
            )
    return rows


def run(jobs: int, raw: Path, cmdline: str) -> dict[str, Any]:
    """Every window's rows, written after each window."""
    todo = [(i, sc.name) for i, sc in scenarios()]
    rows: list[dict[str, Any]] = []
    partial = {"command": cmdline, "drive": ext.config_name(NAME, BANDWIDTH)}
    t0 = time.perf_counter()
    with pool(max(1, jobs), _warm) as p:
        for got in p.imap_unordered(run_window, todo):
            rows.extend(got)
            write_rows(raw, {**partial, "rows": rows})
    return {**partial, **stamp(cmdline), "total_s": time.perf_counter() - t0, "rows": rows}


def report(data: dict[str, Any]) -> str:
    """The Markdown report of the saved rows."""
    rows = data["rows"]
    m = data.get("machine", {})
    return "\n".join(
        [
            "# `ema-phm import` on another simulator's drive (motulator)",
            "",
            f"Command: `{data['command']}`; the drive: {data['drive']} (motulator), "
            f"{len({r['index'] for r in rows})} windows; "
            f"{data.get('total_s', math.nan) / 60:.1f} min on {m.get('cpu', '?')}, "
            f"{m.get('cores', '?')} cores, Python {m.get('python', '?')}. What is measured "
            "and how: `bench/bench_import_external.py`'s docstring; the same scoring as "
            "[benchmarks_import](benchmarks_import.md).",
            "",
            *imp.equivalence_lines(imp.equivalence(rows)),
            *imp.form_lines(imp.per_form(rows, ("native", *FORMS))),
            "## Import speed (one process, the write of the source not counted)",
            "",
            "| form | recordings / s | source MB / s |",
            "|---|---:|---:|",
            *(f"| {f} | {r:.1f} | {mb:.2f} |" for f, (r, mb) in imp.speed(rows, FORMS).items()),
            "",
        ]
    )


def main() -> int:
    ap = cli(__doc__, jobs=(2, "worker processes"), out=(None, OUT_HELP))
    ap.add_argument("--report-only", action="store_true", help="report from the saved rows")
    args = ap.parse_args()
    rows_dir, docs_dir = out_dirs(args.out)
    raw = rows_dir / "bench_import_external.json"
    if not args.report_only:
        cmdline = command_line("bench_import_external", flags=[("--jobs", str(args.jobs), "2")])
        write_rows(raw, run(args.jobs, raw, cmdline))
    text = report(read_rows(raw))
    write_report(docs_dir / "benchmarks_import_external.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
