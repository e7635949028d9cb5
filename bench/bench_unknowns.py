#!/usr/bin/env python3
"""A drive described with an unknown speed-loop gain, beside the same drive fully described.

Usage (from the repo root):
    .venv/bin/python -m bench.bench_unknowns [--units 4]
    .venv/bin/python -m bench.bench_unknowns --report-only   # docs/ from the stored rows

Units `Unit.draw(s)`, s = 0 .. units - 1, of the thesis actuator, with the benchmarks' noise
on every channel (`harness.scenarios.NOISE`).  Each is commissioned twice on its two hangar
baselines (`hangar_windows`): with the packaged description ("described"), and with the same
description whose speed-loop gain `controller.speed_kp` is written `{unknown: [0.3, 1.5] x
the datasheet's}` ("kp unknown": the monitor starts from the range's geometric mean, 0.67 x,
and commissioning identifies it).  The drive's true gain is the datasheet's (a drive keeps
the gains it was tuned with).  Then every single fault at the thesis's medium severity and
one healthy window, in the unit's flight environment (`environment`), are isolated with each
commissioned belief (`isolate(..., nuisance=True, intervals=True)`, default preset and
fitness) and judged by `health.assess_isolation`.  Rows: bench/results/bench_unknowns.json;
report: docs/benchmarks_unknowns.md.
"""

from __future__ import annotations

import statistics
import sys
import time

import numpy as np

from bench.harness import (
    OUT_HELP,
    cli,
    command_line,
    git_commit,
    machine,
    out_dirs,
    read_rows,
    write_rows,
)
from bench.harness.scenarios import cases, environment, hangar_windows, sim_kw
from ema_phm.diagnosis import health
from ema_phm.diagnosis.commissioning import commission
from ema_phm.diagnosis.isolation import isolate
from ema_phm.domain.faults import NAMES, NOMINAL
from ema_phm.model.belief import MonitorBelief
from ema_phm.physics.commands import default_specs
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator import real_ema
from ema_phm.simulator.unit import Unit

UNKNOWN = "controller.speed_kp"
#: The range the description gives, in datasheet values (asymmetric: the start is not the truth).
RANGE = (0.3, 1.5)
DESCRIPTIONS = ("described", "kp unknown")


def descriptions() -> dict[str, ActuatorParameters]:
    """The packaged thesis actuator, and the same with `UNKNOWN` known only in `RANGE`."""
    base = ActuatorParameters.default()
    true = base.value(UNKNOWN)
    unknown = ActuatorParameters.from_sections(
        base.as_dict(),
        source=f"the thesis actuator, {UNKNOWN} unknown in {RANGE} x the datasheet",
        controller_kind=base.controller_kind,
        unknowns={UNKNOWN: (RANGE[0] * true, RANGE[1] * true)},
    )
    return {"described": base, "kp unknown": unknown}


def _isolated(window, belief: MonitorBelief, seed: int) -> dict:
    res = isolate(window, belief=belief, seed=seed, nuisance=True, intervals=True)
    a = health.assess_isolation(res)
    adequate = res.adequacy is None or res.adequacy.ok
    return {
        "k": [float(v) for v in res.k],
        "percent_err": float(res.percent_err),
        "level": health.LEVEL_NAMES[a.level],
        "named": NAMES[a.dominant] if a.level >= health.WARN and adequate else "",
        "adequate": bool(adequate),
        "wall_s": float(res.wall_s),
    }


def run_unit(u: int) -> tuple[dict, list[dict]]:
    """One unit's two commissionings and its isolated windows."""
    base = ActuatorParameters.default()
    command, _ = default_specs()
    unit = Unit.draw(u)
    baselines = hangar_windows(u, unit, base, command)
    beliefs, commissioned = {}, {}
    for name, told in descriptions().items():
        res = commission(baselines, belief=MonitorBelief.for_actuator(told))
        beliefs[name] = MonitorBelief.for_actuator(told).commissioned_with(res.values)
        commissioned[name] = {
            "factors": res.factors,
            "unknowns": res.unknowns,
            "unexplained": res.unexplained(),
            "wall_s": res.wall_s,
        }
    env = environment(u)
    kw = sim_kw(unit, base, command, env)
    todo = [c for c in cases() if c[2] is not None and c[3] == "medium"]
    todo.append(("healthy", NOMINAL.copy(), None, None))
    rows = []
    for i, (scenario, k, single, _tag) in enumerate(todo):
        seed = 1000 * u + 500 + i
        window = real_ema.simulate(k, seed=seed, **kw).window
        for name in DESCRIPTIONS:
            row = {"unit": u, "description": name, "scenario": scenario, "seed": seed}
            row |= {"fault": NAMES[single] if single is not None else "", "k_true": list(k)}
            rows.append(row | _isolated(window, beliefs[name], seed))
            print(f"unit {u} {name:10s} {scenario:40s} {rows[-1]['level']:5s} "
                  f"named={rows[-1]['named'] or '-':14s} %err={rows[-1]['percent_err']:.2f}",
                  flush=True)  # fmt: skip
    return {"unit": u, "commissioning": commissioned}, rows


def _median(values: list[float]) -> str:
    return f"{statistics.median(values):.2f}" if values else "-"


def report(data: dict) -> str:
    """docs/benchmarks_unknowns.md from the stored rows."""
    m, rows, true = data["machine"], data["rows"], data["true"]
    start = true * (RANGE[0] * RANGE[1]) ** 0.5
    lines = [
        "# An unknown speed-loop gain, identified at commissioning",
        "",
        f"Measured with `{data['command']}` (bench/bench_unknowns.py; raw rows "
        f"`bench/results/bench_unknowns.json`) on {m['cpu']}, {m['cores']} cores, Python "
        f"{m['python']}, numba {m['numba']}, at commit {data['commit']}; "
        f"{data['wall_s'] / 60:.0f} min.  How the units, windows and descriptions are made: "
        "the script's docstring.",
        "",
        f"## {UNKNOWN}: identified at commissioning (truth {true:.4g}, range "
        f"[{RANGE[0] * true:.4g}, {RANGE[1] * true:.4g}], start {start:.4g})",
        "",
        "| unit | identified | value | 90 % interval | holds the truth "
        "| other factors (kp unknown) | other factors (described) |",
        "|---:|---|---:|---|---|---|---|",
    ]
    for c in data["units"]:
        got = c["commissioning"]["kp unknown"]["unknowns"][UNKNOWN]
        lo, hi = got["interval90"]
        others = {
            d: ", ".join(
                f"{k} {v:.3f}" for k, v in c["commissioning"][d]["factors"].items() if k != UNKNOWN
            )
            for d in DESCRIPTIONS
        }
        lines.append(
            f"| {c['unit']} | {'yes' if got['identified'] else 'no'} | {got['value']:.4g} | "
            f"[{lo:.4g}, {hi:.4g}] | {'yes' if lo <= true <= hi else 'no'} | "
            f"{others['kp unknown']} | {others['described']} |"
        )
    lines += [
        "",
        "## Isolation, side by side (the same windows)",
        "",
        "| description | healthy OK | right fault named | withheld (not explained) "
        "| median %err | 90th pct %err |",
        "|---|---|---|---|---:|---:|",
    ]
    for d in DESCRIPTIONS:
        mine = [r for r in rows if r["description"] == d]
        healthy = [r for r in mine if not r["fault"]]
        faulty = [r for r in mine if r["fault"]]
        errs = [r["percent_err"] for r in faulty]
        lines.append(
            f"| {d} | {sum(r['level'] == 'OK' for r in healthy)}/{len(healthy)} | "
            f"{sum(r['named'] == r['fault'] for r in faulty)}/{len(faulty)} | "
            f"{sum(not r['adequate'] for r in faulty)}/{len(faulty)} | {_median(errs)} | "
            f"{np.percentile(errs, 90):.2f} |"
        )
    lines += ["", *data.get("reading", []), ""]
    return "\n".join(lines)


def main() -> int:
    ap = cli(__doc__, out=(None, OUT_HELP))
    ap.add_argument("--units", type=int, default=4, help="drawn units 0 .. N-1")
    ap.add_argument("--report-only", action="store_true", help="render the stored rows")
    args = ap.parse_args()
    rows_dir, report_dir = out_dirs(args.out)
    raw, md = rows_dir / "bench_unknowns.json", report_dir / "benchmarks_unknowns.md"
    if args.report_only:
        md.write_text(report(read_rows(raw)))
        return 0
    data = {
        "machine": machine(),
        "command": command_line("bench_unknowns", flags=[("--units", args.units, 4)]),
        **git_commit(),
        "true": ActuatorParameters.default().value(UNKNOWN),
        "units": [],
        "rows": [],
    }
    t0 = time.perf_counter()
    for u in range(args.units):
        unit, rows = run_unit(u)
        data["units"].append(unit)
        data["rows"] += rows
        data["wall_s"] = time.perf_counter() - t0
        write_rows(raw, data)
    md.write_text(report(data))
    print(f"wrote {md}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
