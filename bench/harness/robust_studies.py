"""What the fit studies on bench_robust's population share: its windows, halves, intervals.

A study (bench/studies/search_budget.py, tracked_polish.py) fits bench_robust's realistic
windows under several settings; the rows carry "unit" and "scenario".  The settings are
chosen on the even units and reported on the odd ones beside them.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from bench.harness import cli, halves, read_rows, stamp, write_rows
from bench.harness.scenarios import cases, environment, hangar_windows, sim_kw, unit_runs
from ema_phm.diagnosis.commissioning import commission
from ema_phm.diagnosis.isolation import isolate
from ema_phm.domain.faults import NOMINAL
from ema_phm.domain.window import Window
from ema_phm.model.belief import MonitorBelief
from ema_phm.physics.commands import default_specs
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator import real_ema
from ema_phm.simulator.unit import Unit

#: Percentile-bootstrap resamples of an interval, and their seed.
BOOT = 2000
BOOT_SEED = 0


def windows(
    units: list[int], offsets: tuple[int, ...] = (0,)
) -> Iterator[tuple[int, str, int, list[Window], MonitorBelief]]:
    """(unit, scenario, run seed, windows, commissioned belief) of bench_robust's population.

    Each unit `Unit.draw(u)` is commissioned from its hangar baselines; then the 16 thesis
    scenarios and one healthy window, in its environment and noise, run seeds
    1000 u + 1, ...: one window per `offsets` entry, run seed + offset (the same k).
    """
    base = ActuatorParameters.default()
    command, _ = default_specs()
    isolate(real_ema.simulate(NOMINAL).window, max_evaluations=100)  # JIT warm-up
    for u in units:
        unit = Unit.draw(u)
        belief = MonitorBelief.default().commissioned_with(
            commission(hangar_windows(u, unit, base, command)).values
        )
        kw = sim_kw(unit, base, command, environment(u))
        for run_seed, (name, k, _single, _tag) in unit_runs(cases(), u, 1):
            ws = [real_ema.simulate(k, seed=run_seed + o, **kw).window for o in offsets]
            yield u, name, run_seed, ws, belief


def bootstrap(values: np.ndarray, stat: Callable[..., Any] = np.median) -> str:
    """`stat` of `values` and its 95 % percentile-bootstrap interval: '+v [+lo, +hi]'."""
    rng = np.random.default_rng(BOOT_SEED)
    boot = [stat(values[rng.integers(0, values.size, values.size)]) for _ in range(BOOT)]
    lo, hi = np.percentile(boot, [2.5, 97.5])
    return f"{stat(values):+.3f} [{lo:+.3f}, {hi:+.3f}]"


def by_half(rows: list[dict]) -> dict[str, tuple[list[dict], list[dict]]]:
    """Per half ('even', 'odd'): (every row, the fault windows' rows)."""
    out = {}
    for half, keep in halves(rows, key="unit").items():
        if half != "all":
            out[half] = (keep, [r for r in keep if not r["scenario"].startswith("healthy")])
    return out


def report(data: dict, head: str, summary: Callable[[list[dict], list[dict]], list[str]]) -> str:
    """The machine, the command and a table per half: `head`, then `summary`'s lines."""
    parts = [f"Machine: {data['machine']}", f"Command: `{data['command']}`", ""]
    labels = {"even": "chosen on (even units)", "odd": "held out (odd units)"}
    for half, (keep, fault) in by_half(data["rows"]).items():
        parts += [f"**{labels[half]}**", "", head, *summary(keep, fault), ""]
    return "\n".join(parts)


def arguments(doc: str | None, units: str) -> argparse.ArgumentParser:
    """The studies' common flags: --units and --report-only."""
    ap = cli(doc)
    ap.add_argument("--units", default=units, help="comma-separated unit seeds")
    ap.add_argument("--report-only", action="store_true", help="print the table of the rows")
    return ap


def run(
    args: argparse.Namespace,
    module: str,
    raw: Path,
    measure: Callable[[list[int]], list[dict]],
    render: Callable[[dict], str],
) -> int:
    """Measure `args.units` into `raw` (unless --report-only), then print `render` of it."""
    if not args.report_only:
        t0 = time.perf_counter()
        rows = measure([int(v) for v in args.units.split(",")])
        command = f".venv/bin/python -m bench.studies.{module} --units {args.units}"
        write_rows(raw, {**stamp(command), "total_s": time.perf_counter() - t0, "rows": rows})
    print(render(read_rows(raw)))
    return 0
