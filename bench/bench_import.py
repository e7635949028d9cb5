#!/usr/bin/env python3
"""`ema-phm import` measured: imported windows against native ones, channel subsets, speed.

Usage (from the repo root):
    .venv/bin/python -m bench.bench_import --jobs 2          # simulate, import, fit, report
    .venv/bin/python -m bench.bench_import --report-only     # report from the saved rows
    .venv/bin/python -m bench.bench_import --quick           # 3 units

Population: `--units` drawn units (`Unit.draw`, seeds 0..N-1 after `--seed`), each with a
healthy window and one single-fault window (friction 0.4, backlash 0.6, short circuit B 0.4,
eccentricity 0.4 in turn), in the unit's drawn flight environment (temperature, unmeasured
load) with the realistic sensors (`scenarios.NOISE`): the HF model, never the monitor's.

Each window is fitted as `ema-phm isolate` fits it (packaged belief, uncommissioned) in
these forms (`VARIANTS`):
- ``native``: the window as ema_phm records it (seeds 0, 1, 2);
- ``bag``: written as a ros2_control rig's bag (`rig_forms.joint_states_bag`: JointState,
  Float64 current and command received 20 us late, Temperature) and imported (seeds 0, 1, 2);
- ``csv``, ``parquet``: a drive's table (`rig_forms.table`), imported (seed 0);
- subsets of the CSV (seed 0): ``no_encoder`` (the motor angle through the gear, the speed
  derived), ``no_speed`` (the speed derived from the motor angle), ``no_temperature``,
  ``iq_1khz`` (the current on every other row only: logged at 1 kHz, interpolated);
- ``phases_20khz``: the same run (unit, environment, k, seed) simulated with the acquisition at
  20 kHz, logged as a CSV at that rate with the three phase currents (each with the current
  sensor's noise) instead of I_3eq, which the import derives (``park_q``: Park transform at
  the motor angle, the acquisition filter, low-pass and resampling to 2 kHz).

Scored: the largest k difference between the bag and the native window at the same seed
beside the native fits' own seed-to-seed difference; per form, %err (eq. 6.4, over all
entries and over the entries the recording shows), healthy windows claimed faulty (false
alarms), faulty windows whose fault is named, windows withheld (model not adequate), and
claims on a fault the recording cannot show; the import's speed (recordings and source MB
per second, one process).  Rows: bench/results/bench_import.json; report:
docs/benchmarks_import.md (hand-written analysis below `bench.harness.KEEP_MARKER` is kept).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from bench.harness import (
    OUT_HELP,
    cli,
    command_line,
    out_dirs,
    read_rows,
    scenarios,
    write_report,
    write_rows,
)
from bench.harness.import_forms import (
    PHASE_RATE,
    SEEDS,
    VARIANTS,
    Fast,
    equivalence,
    equivalence_lines,
    fit,
    form_lines,
    imported,
    per_form,
    run_jobs,
    speed_lines,
)
from ema_phm.diagnosis.isolation import isolate
from ema_phm.domain.faults import NOMINAL, k_with
from ema_phm.domain.window import Window
from ema_phm.physics.commands import CommandSpec
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator import real_ema
from ema_phm.simulator.unit import Unit

#: The faults the faulty windows carry, in turn.
FAULTS = (("friction", 0.4), ("backlash", 0.6), ("short_circuit_b", 0.4), ("eccentricity", 0.4))


def windows_of(index: int, seed: int) -> list[tuple[str, np.ndarray, Window, Fast]]:
    """(name, true k, window, the same run logged at PHASE_RATE) of unit `index`.

    The healthy window, then its single fault.  The fast run is the same unit, environment,
    k and seed with the acquisition at PHASE_RATE; its phase currents get the current
    sensor's noise (`scenarios.NOISE`) per phase.
    """
    unit_seed = seed + index
    unit = Unit.draw(unit_seed)
    env = scenarios.environment(unit_seed)
    base, command = ActuatorParameters.default(), CommandSpec()
    fast_base = base.with_values({"acquisition.sample_rate": PHASE_RATE})
    name, level = FAULTS[index % len(FAULTS)]
    out = []
    for j, (label, k) in enumerate((("healthy", NOMINAL.copy()), (name, k_with(**{name: level})))):
        run_seed = 5000 + 10 * unit_seed + j
        w = real_ema.simulate(k, seed=run_seed, **scenarios.sim_kw(unit, base, command, env))
        fast = real_ema.simulate(
            k, seed=run_seed, **scenarios.sim_kw(unit, fast_base, command, env)
        )
        assert fast.phase_currents is not None
        rng = np.random.default_rng((unit_seed, j, 20))
        noisy = fast.phase_currents + scenarios.NOISE_RMS * rng.standard_normal(
            fast.phase_currents.shape
        )
        out.append((label, k, w.window, (fast.window, noisy)))
    return out


def run_unit(job: tuple[int, int]) -> list[dict[str, Any]]:
    """Every form and fit of unit `index`'s windows (a pool job)."""
    index, seed = job
    rows = []
    for label, k, w, fast in windows_of(index, seed):
        base = {"index": index, "window": label, "k_true": [float(v) for v in k]}
        forms: list[tuple[str, Window, dict[str, float], tuple[int, ...]]] = [
            ("native", w, {}, SEEDS)
        ]
        for form, (kind, cmap) in VARIANTS.items():
            got, cost = imported(kind, cmap, w, fast)
            forms.append((form, got, cost, SEEDS if form == "bag" else SEEDS[:1]))
        for form, window, cost, seeds in forms:
            for s in seeds:
                row = {**base, "form": form, "seed": s, **cost, **fit(window, s)}
                rows.append(row)
                print(
                    f"unit {index:2d} {label:16s} {form:15s} seed {s} "
                    f"%err {row.get('percent_err', math.nan):6.2f}",
                    flush=True,
                )
    return rows


def _warm() -> None:
    isolate(real_ema.simulate(NOMINAL).window, max_evaluations=100)


def run(units: int, seed: int, *, jobs: int, raw: Path, cmdline: str) -> dict[str, Any]:
    """Every unit's rows, written after each unit."""
    todo = [(i, seed) for i in range(units)]
    partial = {"command": cmdline, "seed": seed, "units": units}
    return run_jobs(todo, run_unit, _warm, jobs=jobs, raw=raw, partial=partial)


# ----------------------------------------------------------------------------- scoring


def report(data: dict[str, Any]) -> str:
    rows = data["rows"]
    m = data.get("machine", {})
    lines = [
        "# `ema-phm import`: imported windows, channel subsets, speed",
        "",
        f"Command: `{data['command']}`; {data['units']} units (seed {data['seed']}); "
        f"{data.get('total_s', math.nan) / 60:.1f} min on {m.get('cpu', '?')}, "
        f"{m.get('cores', '?')} cores, Python {m.get('python', '?')}. What is measured and "
        "how: `bench/bench_import.py`'s docstring.",
        "",
        *equivalence_lines(equivalence(rows)),
        *form_lines(per_form(rows)),
        *speed_lines(rows),
    ]
    return "\n".join(lines)


def main() -> int:
    ap = cli(
        __doc__,
        quick="3 units",
        seed=(0, "first unit seed"),
        jobs=(2, "worker processes"),
        out=(None, OUT_HELP),
    )
    ap.add_argument("--units", type=int, default=None, help="units (default 12; --quick 3)")
    ap.add_argument("--report-only", action="store_true", help="report from the saved rows")
    args = ap.parse_args()
    rows_dir, docs_dir = out_dirs(args.out)
    raw = rows_dir / "bench_import.json"
    units = args.units or (3 if args.quick else 12)
    if not args.report_only:
        cmdline = command_line(
            "bench_import",
            flags=[
                ("--units", args.units, None),
                ("--seed", args.seed, 0),
                ("--quick", args.quick, False),
                ("--jobs", args.jobs, 2),
            ],
        )
        write_rows(raw, run(units, args.seed, jobs=args.jobs, raw=raw, cmdline=cmdline))
    data = read_rows(raw)
    write_report(docs_dir / "benchmarks_import.md", report(data))
    print(report(data))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
