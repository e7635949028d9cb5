#!/usr/bin/env python3
"""Realistic isolation benchmark: drawn units, temperatures, noisy sensors, unmeasured loads.

Usage (from the repo root):
    nohup .venv/bin/python -m bench.bench_realistic > /tmp/bench_realistic.log 2>&1 &
    .venv/bin/python -m bench.bench_realistic --units 2      # a quick look
    .venv/bin/python -m bench.bench_realistic --report-only  # table from the saved JSON

Population: units with `Unit.draw(s)` for s = seed .. seed + units - 1 (manufacturing
tolerances of config/unit_tolerances.yaml).  Each unit gets, from
numpy.random.default_rng((s, 7)), an operating temperature (uniform in TEMPERATURE_C),
an unmeasured constant hinge load (uniform in LOAD_NM) and a hinge spring (uniform in
SPRING_NM_PER_RAD), with `LoadSpec(measured=False)`: the load acts, the telemetry's load
channel is NaN.  Every channel is noisy (NOISE, RMS, with the reason beside each).
Each unit runs the thesis's 16 fault scenarios (`harness.scenarios.scenarios()`)
and HEALTHY_PER_UNIT healthy windows, isolated without commissioning, nuisance search or
intervals (packaged MonitorBelief, default preset, one seed per run): the issue-9 baseline
set-up (docs/benchmarks_realistic.md holds its figures, measured at 7488fd3; the robust
monitor is measured by bench/bench_robust.py).  The same 16 scenarios and one healthy
window also run on the ideal twin: the datasheet unit (`Unit()`), 20 degC, no noise, zero
measured load.  Deterministic for a given --seed and --units.

Raw rows go to bench/results/bench_realistic.json, the report to docs/benchmarks_realistic.md.
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np

from bench.harness import (
    OUT_HELP,
    cli,
    command_line,
    machine,
    out_dirs,
    read_rows,
    stamp,
    write_rows,
)
from bench.harness.scenarios import (
    IDEAL_ENV,
    IDEAL_LABEL,
    LOAD_NM,
    NOISE,
    PHASE_AMOUNT,
    PHASE_INDEX,
    SPRING_NM_PER_RAD,
    TEMPERATURE_C,
    case_fields,
    cases,
    environment,
    ideal_kw,
    ideal_runs,
    sim_kw,
    unit_runs,
)
from ema_phm.diagnosis import health
from ema_phm.diagnosis.isolation import DEFAULT_PRESET, isolate
from ema_phm.domain.faults import NAMES, NOMINAL, WARN_SEVERITY, fault
from ema_phm.errors import ExcitationError
from ema_phm.physics.commands import default_specs
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator import real_ema
from ema_phm.simulator.unit import Unit

HEALTHY_PER_UNIT = 1


def one(case: tuple, run_seed: int, *, kind, unit_seed, env, unit, kw) -> dict:
    """The row of one case (name, true k, single fault, tag: `harness.scenarios.cases`)."""
    name, k, _single, _tag = case
    window = real_ema.simulate(k, seed=run_seed, **kw).window
    row = {
        "population": kind,
        "unit_seed": unit_seed,
        "unit": unit.as_dict(),
        **env,
        **case_fields(case, run_seed),
        "preset": DEFAULT_PRESET,
    }
    try:
        res = isolate(window, preset=DEFAULT_PRESET, seed=run_seed)
    except ExcitationError as exc:
        row.update(error=str(exc))
        print(f"{kind} unit {unit_seed} {name}: not excited ({exc})", flush=True)
        return row
    a = health.assess(res.k, k_true=k)
    row.update(
        k=[float(v) for v in res.k],
        percent_err=float(res.percent_err),
        level=health.LEVEL_NAMES[a.level],
        dominant=NAMES[a.dominant],
        fitness=float(res.fitness),
        evaluations=int(res.evaluations),
        wall_s=float(res.wall_s),
    )
    print(
        f"{kind:9s} unit {unit_seed!s:>4} {name:34s} %err={res.percent_err:7.2f} "
        f"{row['level']:5s} {row['dominant']:18s} wall={res.wall_s:5.2f}s",
        flush=True,
    )
    return row


def run(units: int, seed: int, raw: Path, mach: dict, cmdline: str) -> list[dict]:
    base = ActuatorParameters.default()
    command, _ = default_specs()
    isolate(real_ema.simulate(NOMINAL).window, max_evaluations=100)  # JIT warm-up, not timed
    rows: list[dict] = []
    todo = cases()
    # the ideal twin: datasheet unit, 20 degC, ideal sensors, zero measured load
    ideal = ideal_kw(base, command)
    for run_seed, case in ideal_runs(todo):
        rows.append(
            one(case, run_seed, kind="ideal", unit_seed=None, env=IDEAL_ENV, unit=Unit(), kw=ideal)
        )
    for u in range(seed, seed + units):
        unit = Unit.draw(u)
        env = environment(u)
        kw = sim_kw(unit, base, command, env)
        for run_seed, case in unit_runs(todo, u, HEALTHY_PER_UNIT):
            rows.append(
                one(case, run_seed, kind="realistic", unit_seed=u, env=env, unit=unit, kw=kw)
            )
        write_rows(raw, {"machine": mach, "command": cmdline, "rows": rows})
    return rows


# ----------------------------------------------------------------------------- report


def _pct(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else float("nan")


def summary(rows: list[dict]) -> dict:
    """The headline figures of one population."""
    fault = [r for r in rows if not r["scenario"].startswith("healthy")]
    healthy = [r for r in rows if r["scenario"].startswith("healthy")]
    ok = [r for r in fault if "percent_err" in r]
    e = [r["percent_err"] for r in ok]
    low = [r for r in ok if r["severity_tag"] == "low"]
    det_low = [r for r in low if r["level"] != "OK" and r["dominant"] == NAMES[r["single_fault"]]]
    h_ok = [r for r in healthy if "percent_err" in r]
    alarms = [r for r in h_ok if r["level"] != "OK"]
    walls = [r["wall_s"] for r in rows if "wall_s" in r]
    return {
        "fault_runs": len(fault),
        "not_excited": len(fault) - len(ok) + len(healthy) - len(h_ok),
        "median": statistics.median(e) if e else float("nan"),
        "p90": _pct(e, 90),
        "worst": max(e) if e else float("nan"),
        "mean": statistics.mean(e) if e else float("nan"),
        "low_runs": len(low),
        "low_detected": len(det_low),
        "healthy_runs": len(h_ok),
        "false_alarms": len(alarms),
        "false_alarm_faults": sorted({r["dominant"] for r in alarms}),
        "wall_median": statistics.median(walls) if walls else float("nan"),
    }


def _rate(n: int, d: int) -> str:
    return f"{n}/{d} ({100.0 * n / d:.0f} %)" if d else "-"


def report(data: dict) -> str:
    rows = data["rows"]
    mach = data["machine"]
    real = [r for r in rows if r["population"] == "realistic"]
    ideal = [r for r in rows if r["population"] == "ideal"]
    sr, si = summary(real), summary(ideal)
    units = sorted({r["unit_seed"] for r in real})
    lines = [
        "# Realistic isolation benchmark",
        "",
        "The monitor as it is today (packaged `MonitorBelief`, default preset "
        f"`{DEFAULT_PRESET}`, default fitness, full budget, one seed per run) isolating "
        f"windows of the HF model played by {len(units)} manufactured units "
        f"(`Unit.draw(s)`, s = {units[0] if units else '-'}..{units[-1] if units else '-'}), "
        "each at its own temperature, with noise on every channel and an unmeasured load. "
        "Nothing about the unit, its temperature or its load is given to the monitor. "
        "The figures are bad on purpose: they are the baseline the next issue must beat.",
        "",
        f"Machine: {mach['cpu']}, {mach['cores']} cores ({mach['numba_threads']} numba "
        f"threads), Python {mach['python']}, numba {mach['numba']}.  Command: "
        f"`{data['command']}`; the report alone: `.venv/bin/python -m bench.bench_realistic "
        "--report-only`.",
        "",
        "## Set-up",
        "",
        "- Units: `Unit.draw(seed)`, every key of config/unit_tolerances.yaml drawn normal "
        "(band = 3 sigma, truncated), e.g. torque constant +/-10 %, resistance +/-10 %, "
        "friction +/-30 %, current-sensor gain +/-2 %, position offset +/-1e-3 rad.",
        f"- Temperature: uniform in {TEMPERATURE_C[0]:g}..{TEMPERATURE_C[1]:+g} degC per unit "
        "(`numpy.random.default_rng((seed, 7))`); R follows copper (+0.393 %/K), the back-EMF "
        "constant the NdFeB magnet (-0.12 %/K) from 20 degC.  The telemetry carries the "
        "measured temperature; the monitor today does not use it.",
        f"- Load, not measured (`LoadSpec(measured=False)`, load channel NaN): a constant "
        f"uniform in {LOAD_NM[0]:g}..{LOAD_NM[1]:+g} N*m plus a hinge spring uniform in "
        f"{SPRING_NM_PER_RAD[0]:g}..{SPRING_NM_PER_RAD[1]:g} N*m/rad, per unit.  The monitor "
        "assumes no load.",
        f"- Noise, white, RMS: current {NOISE['noise_current']:g} A (1 % of the 22.5 A range), "
        f"user position {NOISE['noise_position']:g} rad (about 3 LSB of the 1.5e-5 rad "
        "resolution, 0.17 % of the 0.03 rad chirp), motor speed "
        f"{NOISE['noise_speed']:g} rad/s (about 2.5 resolver LSB differentiated over 0.5 ms, "
        "0.12 % of the 420 rad/s chirp peak).  Position and speed noise enter the loops too.",
        "- Window: the default 2 s chirp, 0.03 rad, 0.5 -> 4.5 Hz (config/commands.yaml).",
        "- Runs per unit: the thesis's 16 fault scenarios (`scenarios()` of "
        f"bench/bench_isolation.py) and {HEALTHY_PER_UNIT} healthy window(s); run seed "
        "(noise and optimizer) = 1000*unit + 1 + scenario index.",
        f"- {IDEAL_LABEL[0].upper() + IDEAL_LABEL[1:]}: the same 16 scenarios and one healthy "
        "window, `Unit()` at 20 degC, ideal sensors, zero load, measured.",
        "",
        "%err is eq. 6.4 of the thesis.  False alarm: a healthy window whose isolated k has "
        "any fault at or above its WARN threshold (`health.assess`, default thresholds: "
        f"{WARN_SEVERITY:g} severity, {fault('gain_drift').warn:g} for gain drift).  "
        'Detection at the thesis\'s "low" severities '
        "(k1 = 0.25, k2 = 0.2, k3 = 0.2, k6 = 0.2, k8 = 0.2): level >= WARN *and* "
        "`dominant` names the injected fault.",
        "",
        "## Headline",
        "",
        "| population | fault runs | median %err | 90th pct %err | worst %err | false alarms "
        "(healthy) | low-severity detection, right fault | median wall s / isolation |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for label, s in (
        (f"realistic: {len(units)} drawn units, -20..+70 degC, noisy, unmeasured load", sr),
        (IDEAL_LABEL, si),
    ):
        lines.append(
            f"| {label} | {s['fault_runs']} | {s['median']:.2f} | {s['p90']:.2f} | "
            f"{s['worst']:.2f} | {_rate(s['false_alarms'], s['healthy_runs'])} | "
            f"{_rate(s['low_detected'], s['low_runs'])} | {s['wall_median']:.2f} |"
        )
    lines += [""]
    if sr["not_excited"] or si["not_excited"]:
        lines += [
            f"Windows refused as not excited (no %err): realistic {sr['not_excited']}, "
            f"ideal {si['not_excited']}.",
            "",
        ]
    if sr["false_alarm_faults"]:
        lines += [
            "Faults named by the false alarms (dominant): "
            + ", ".join(f"`{n}`" for n in sr["false_alarm_faults"])
            + ".",
            "",
        ]
    # per scenario
    lines += [
        "## Per scenario",
        "",
        "%err over the units (realistic) and the single ideal run; detection = level >= WARN "
        "with the injected fault dominant (single faults), or level >= WARN (multi-fault).",
        "",
        "| scenario | realistic median %err | 90th pct | worst | realistic detected | "
        "dominant (most often) | ideal %err |",
        "|---|---:|---:|---:|---:|---|---:|",
    ]
    for name, _k, single, _tag in cases():
        rr = [r for r in real if r["scenario"] == name and "percent_err" in r]
        ii = [r for r in ideal if r["scenario"] == name and "percent_err" in r]
        e = [r["percent_err"] for r in rr]
        det = [
            r
            for r in rr
            if r["level"] != "OK" and (single is None or r["dominant"] == NAMES[single])
        ]
        doms = [r["dominant"] for r in rr]
        dom = max(set(doms), key=doms.count) if doms else "-"
        lines.append(
            f"| {name} | {statistics.median(e) if e else float('nan'):.2f} | {_pct(e, 90):.2f} | "
            f"{max(e) if e else float('nan'):.2f} | {_rate(len(det), len(rr))} | {dom} | "
            f"{ii[0]['percent_err'] if ii else float('nan'):.2f} |"
        )
    # per entry
    lines += [
        "",
        "## Per fault entry",
        "",
        "Mean |k_i - true k_i| over all fault-scenario runs (k7, the eccentricity phase, only "
        "where the true k6 > 0).",
        "",
        "| entry | realistic | ideal |",
        "|---|---:|---:|",
    ]
    for i, n in enumerate(NAMES):
        cells = []
        for pop in (real, ideal):
            rr = [
                r
                for r in pop
                if "k" in r
                and not r["scenario"].startswith("healthy")
                and (i != PHASE_INDEX or r["k_true"][PHASE_AMOUNT] > 0)
            ]
            d = [abs(r["k"][i] - r["k_true"][i]) for r in rr]
            cells.append(f"{statistics.mean(d):.3f}" if d else "-")
        lines.append(f"| k{i + 1} {n} | {cells[0]} | {cells[1]} |")
    # healthy windows
    hh = [r for r in real if r["scenario"].startswith("healthy") and "k" in r]
    lines += [
        "",
        "## Healthy windows (realistic)",
        "",
        "| unit | temperature degC | load N*m | spring N*m/rad | level | dominant | "
        "isolated k1..k8 |",
        "|---:|---:|---:|---:|---|---|---|",
    ]
    for r in hh:
        lines.append(
            f"| {r['unit_seed']} | {r['temperature_c']:.1f} | {r['load_nm']:.1f} | "
            f"{r['spring_nm_per_rad']:.0f} | {r['level']} | {r['dominant']} | "
            + ", ".join(f"{v:.3f}" for v in r["k"])
            + " |"
        )
    return "\n".join(lines) + "\n"


def main() -> int:
    ap = cli(
        __doc__,
        seed=(0, "first unit seed (default 0)"),
        out=(None, OUT_HELP),
    )
    ap.add_argument("--units", type=int, default=20, help="number of drawn units (default 20)")
    ap.add_argument(
        "--report-only", action="store_true", help="rewrite the report from the saved JSON"
    )
    args = ap.parse_args()
    rows_dir, report_dir = out_dirs(args.out)
    raw, md = rows_dir / "bench_realistic.json", report_dir / "benchmarks_realistic.md"
    if not args.report_only:
        cmdline = command_line(
            "bench_realistic", flags=[("--units", args.units, 20), ("--seed", args.seed, 0)]
        )
        t0 = time.perf_counter()
        rows = run(args.units, args.seed, raw, machine(), cmdline)
        data = {**stamp(cmdline), "total_s": time.perf_counter() - t0, "rows": rows}
        write_rows(raw, data)
    data = read_rows(raw)
    md.write_text(report(data))
    print(f"wrote {raw} and {md}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
