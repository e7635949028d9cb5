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

import copy
import dataclasses
import math
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from bench.harness import (
    OUT_HELP,
    cli,
    command_line,
    out_dirs,
    pool,
    read_rows,
    rig_forms,
    scenarios,
    stamp,
    write_report,
    write_rows,
)
from ema_phm.diagnosis import health
from ema_phm.diagnosis.isolation import isolate
from ema_phm.diagnosis.isolation_settings import FitSettings
from ema_phm.domain.faults import NAMES, NOMINAL, k_with, percent_err
from ema_phm.domain.window import Window
from ema_phm.errors import ExcitationError
from ema_phm.importing.channel_map import parse_channel_map
from ema_phm.importing.importer import import_recordings
from ema_phm.model.belief import MonitorBelief
from ema_phm.physics.commands import CommandSpec
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator import real_ema
from ema_phm.simulator.unit import Unit
from ema_phm.telemetry.bags import read_window

#: The faults the faulty windows carry, in turn.
FAULTS = (("friction", 0.4), ("backlash", 0.6), ("short_circuit_b", 0.4), ("eccentricity", 0.4))
#: Seeds of the native and bag fits (the seed-to-seed spread); the other forms use the first.
SEEDS = (0, 1, 2)
PHASE = NAMES.index("eccentricity_phase")


def _csv_map(change: dict[str, Any]) -> dict[str, Any]:
    m = copy.deepcopy(rig_forms.TABLE_MAP)
    m["windows"] = {"by": "length", "seconds": 2.0}
    m["channels"].update(change)
    return m


BAG_MAP = {**copy.deepcopy(rig_forms.JOINT_STATES_MAP), "windows": {"by": "length"}}
#: form -> (how the source is written, the map that reads it)
VARIANTS: dict[str, tuple[str, dict[str, Any]]] = {
    "bag": ("bag", BAG_MAP),
    "csv": ("csv", _csv_map({})),
    "parquet": ("parquet", _csv_map({})),
    "no_encoder": (
        "csv",
        _csv_map(
            {"theta_m": {"derive": "through_gear"}, "omega_m": {"derive": "rate_of_theta_m"}}
        ),
    ),
    "no_speed": ("csv", _csv_map({"omega_m": {"derive": "rate_of_theta_m"}})),
    "no_temperature": ("csv", _csv_map({"temperature": "unknown"})),
    "iq_1khz": ("csv_iq_1khz", _csv_map({})),
    "phases_20khz": (
        "csv_phases",
        _csv_map(
            {"i3eq": {"derive": "park_q", "phases": [{"column": c} for c in ("ia", "ib", "ic")]}}
        ),
    ),
}
#: The rate a rig logs its phase currents at (the `phases_20khz` form's own HF run).
PHASE_RATE = 20_000.0

Fast = tuple[Window, np.ndarray]  # a window simulated at PHASE_RATE, and its phase currents


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


def _write_source(folder: Path, form: str, w: Window, fast: Fast | None) -> Path:
    """The window as a rig logs it in `form` (`csv_phases`: the fast run, phases for I_3eq)."""
    if form == "csv_phases":
        assert fast is not None
        window, phases = fast
        cols = {name: phases[:, i] for i, name in enumerate(("ia", "ib", "ic"))}
        return rig_forms.table(folder / "log.csv", window.without_truth(), cols)
    if form == "bag":
        return rig_forms.joint_states_bag(folder / "log", w)
    if form == "csv_iq_1khz":
        thinned = w.i3eq.copy()
        thinned[1::2] = np.nan  # a 1 kHz current beside 2 kHz positions: empty cells
        return rig_forms.table(folder / "log.csv", dataclasses.replace(w, i3eq=thinned))
    return rig_forms.table(folder / f"log.{form}", w)


def imported(
    form: str,
    cmap_data: dict[str, Any],
    w: Window,
    fast: Fast | None,
    actuator: ActuatorParameters | None = None,
) -> tuple[Window, dict[str, float]]:
    """The window written in `form`, imported back; and the import's time and source size.

    `actuator`: whose acquisition the import puts the log on (default: the thesis actuator).
    """
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        src = _write_source(folder, form, w.without_truth(), fast)
        size = sum(p.stat().st_size for p in [src, *src.rglob("*")] if p.is_file())
        cmap = parse_channel_map(cmap_data, where=form)
        t0 = time.perf_counter()
        act = actuator or ActuatorParameters.default()
        report = import_recordings([src], cmap, act, folder / "out")
        wall = time.perf_counter() - t0
        (path,) = report.written
        got = read_window(path)
    return dataclasses.replace(got, k_true=w.k_true), {"import_s": wall, "bytes": size}


def fit(w: Window, seed: int, belief: MonitorBelief | None = None) -> dict[str, Any]:
    """`ema-phm isolate` of `w` (`belief`; None: the packaged one): the row's fields."""
    try:
        res = isolate(w, **FitSettings(seed=seed).isolate_options(belief))
    except ExcitationError as exc:
        return {"error": str(exc)}
    verdict = health.assess_isolation(res)
    return {
        "k": [float(v) for v in res.k],
        "percent_err": float(res.percent_err),
        "explained": bool(res.adequacy.ok),
        "level": int(verdict.level),
        "dominant": int(verdict.dominant),
        "unseen": sorted(int(i) for i in res.unseen),
        "wall_s": float(res.wall_s),
    }


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
    rows: list[dict[str, Any]] = []
    partial = {"command": cmdline, "seed": seed, "units": units}
    t0 = time.perf_counter()
    with pool(max(1, jobs), _warm) as p:
        for got in p.imap_unordered(run_unit, todo):
            rows.extend(got)
            write_rows(raw, {**partial, "rows": rows})
    return {**partial, **stamp(cmdline), "total_s": time.perf_counter() - t0, "rows": rows}


# ----------------------------------------------------------------------------- scoring


def _gap(a: list[float], b: list[float]) -> float:
    """Largest |a - b| over the entries that are amounts (the phase left out)."""
    d = np.abs(np.asarray(a) - np.asarray(b))
    d[PHASE] = 0.0
    return float(d.max())


def equivalence(rows: list[dict[str, Any]]) -> dict[str, list[float]]:
    """Per window and seed: bag vs native at that seed; native seed s vs seed s'."""
    fits: dict[tuple[int, str, str, int], list[float]] = {
        (r["index"], r["window"], r["form"], r["seed"]): r["k"] for r in rows if "k" in r
    }
    imp, spread = [], []
    for idx, win, form, s in fits:
        if form != "native":
            continue
        if (idx, win, "bag", s) in fits:
            imp.append(_gap(fits[idx, win, "bag", s], fits[idx, win, "native", s]))
        for s2 in SEEDS:
            if s2 > s and (idx, win, "native", s2) in fits:
                spread.append(_gap(fits[idx, win, "native", s2], fits[idx, win, "native", s]))
    return {"import": imp, "seed": spread}


def _seen_err(r: dict[str, Any]) -> float:
    """%err (eq. 6.4) over the entries the recording shows."""
    k, kt = np.array(r["k"]), np.array(r["k_true"])
    k[r["unseen"]] = kt[r["unseen"]]  # an entry held unseen adds no error
    return float(percent_err(k, kt))


def per_form(
    rows: list[dict[str, Any]], forms: tuple[str, ...] = ("native", *VARIANTS)
) -> dict[str, dict[str, Any]]:
    """Per form (seed 0): %err, false alarms, named, withheld, claims on unseen faults."""
    out = {}
    for form in forms:
        rs = [r for r in rows if r["form"] == form and r["seed"] == 0 and "k" in r]
        healthy = [r for r in rs if r["window"] == "healthy"]
        faulty = [r for r in rs if r["window"] != "healthy"]
        claimed = [r for r in rs if r["explained"] and r["level"] >= health.WARN]
        out[form] = {
            "n": len(rs),
            "err": [r["percent_err"] for r in rs],
            "seen_err": [_seen_err(r) for r in rs],
            "false_alarms": (sum(r in claimed for r in healthy), len(healthy)),
            "named": (
                sum(r in claimed and NAMES[r["dominant"]] == r["window"] for r in faulty),
                len(faulty),
            ),
            "withheld": (sum(not r["explained"] for r in rs), len(rs)),
            "unseen_claims": sum(r["dominant"] in r["unseen"] for r in claimed),
            "errors": sum(1 for r in rows if r["form"] == form and "error" in r),
        }
    return out


def speed(
    rows: list[dict[str, Any]], forms: tuple[str, ...] = tuple(VARIANTS)
) -> dict[str, tuple[float, float]]:
    """Per form: (recordings per second, source MB per second) of the imports."""
    out = {}
    for form in forms:
        rs = [r for r in rows if r["form"] == form and r["seed"] == 0 and "bytes" in r]
        wall = sum(r["import_s"] for r in rs) if rs else 0.0
        if wall > 0:
            out[form] = (len(rs) / wall, sum(r["bytes"] for r in rs) / 1e6 / wall)
    return out


# ----------------------------------------------------------------------------- report


def _pct(values: list[float], q: float) -> float:
    v = [x for x in values if math.isfinite(x)]
    return float(np.percentile(v, q)) if v else math.nan


def _share(pair: tuple[int, int]) -> str:
    n, d = pair
    return "-" if d == 0 else f"{n}/{d}"


def equivalence_lines(eq: dict[str, list[float]]) -> list[str]:
    imp, seed = eq["import"], eq["seed"]
    within = sum(d <= _pct(seed, 90) for d in imp)
    return [
        "## Imported against native",
        "",
        "The largest k difference (amounts; the phase left out) between a window fitted as",
        "ema_phm recorded it and the same window written as a rig's bag and imported, at the",
        "same seed, beside the difference between two seeds of the native fit:",
        "",
        "| | windows x seeds | median | 90th percentile | largest |",
        "|---|---:|---:|---:|---:|",
        f"| bag vs native, same seed | {len(imp)} | {_pct(imp, 50):.4f} | {_pct(imp, 90):.4f} "
        f"| {max(imp, default=math.nan):.4f} |",
        f"| native seed vs native seed | {len(seed)} | {_pct(seed, 50):.4f} | "
        f"{_pct(seed, 90):.4f} | {max(seed, default=math.nan):.4f} |",
        "",
        f"{within} of {len(imp)} imported fits are within the native fits' 90th-percentile "
        "seed-to-seed difference.",
        "",
    ]


def form_lines(forms: dict[str, dict[str, Any]]) -> list[str]:
    lines = [
        "## Forms and channel subsets (seed 0)",
        "",
        "| form | fits | median %err | median %err, entries shown | false alarms (healthy) "
        "| fault named | withheld | claims on an unseen fault | fit errors |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for form, f in forms.items():
        lines.append(
            f"| {form} | {f['n']} | {_pct(f['err'], 50):.2f} | {_pct(f['seen_err'], 50):.2f} | "
            f"{_share(f['false_alarms'])} | {_share(f['named'])} | {_share(f['withheld'])} | "
            f"{f['unseen_claims']} | {f['errors']} |"
        )
    return [*lines, ""]


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
        "## Import speed (one process, the write of the source not counted)",
        "",
        "| form | recordings / s | source MB / s |",
        "|---|---:|---:|",
        *(f"| {f} | {r:.1f} | {mb:.2f} |" for f, (r, mb) in speed(rows).items()),
        "",
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
