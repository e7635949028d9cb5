#!/usr/bin/env python3
"""How a baseline's fit before commissioning tells a healthy unit from a faulty one.

Usage (from the repo root):
    .venv/bin/python -m bench.bench_commissioning_guard [--units 10] [--out FILE.json]

For drawn units (`Unit.draw(s)`, s = 0 .. units - 1) in the benchmarks' hangar
(`harness.scenarios.hangar`: two baselines per unit, own temperature and small unmeasured
load) at three noise levels (none, current only at 1 % of 22.5 A, `harness.scenarios.NOISE`
on every channel), healthy and with a
friction (k1 = 0.3) or short-circuit (k4 = 0.3) fault, print each baseline's starting fit
(`commissioning.starting_check`: the packaged belief, every factor 1, the window's load fitted),
its noise part, and the statistic the guard compares with `adequacy.THRESHOLD`.
Chooses nothing by itself: commissioning.UNIT_SPREAD_FITNESS quotes its healthy maximum.
"""

from __future__ import annotations

import json
from pathlib import Path

from bench.harness import cli
from bench.harness.scenarios import NOISE, hangar_windows
from ema_phm.diagnosis.commissioning import starting_check
from ema_phm.domain.faults import NOMINAL, fault
from ema_phm.physics.commands import default_specs
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator.unit import Unit

LEVELS = {"none": {}, "current": {"noise_current": NOISE["noise_current"]}, "all": NOISE}
CASES = {
    "healthy": (None, 0.0),
    "k1=0.3": (fault("friction").index, 0.3),
    "k4=0.3": (fault("short_circuit_b").index, 0.3),
}


def main() -> None:
    ap = cli(None, raw_description=False)
    ap.add_argument("--units", type=int, default=10)
    ap.add_argument("--first", type=int, default=0, help="first unit seed")
    ap.add_argument("--levels", default=",".join(LEVELS), help="noise levels to run")
    ap.add_argument("--cases", default=",".join(CASES), help="cases to run")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    base = ActuatorParameters.default()
    command, _ = default_specs()
    rows = []
    levels, cases = args.levels.split(","), args.cases.split(",")
    for level in levels:
        for u in range(args.first, args.first + args.units):
            unit = Unit.draw(u)
            for case in cases:
                i, value = CASES[case]
                k = NOMINAL.copy()
                if i is not None:
                    k[i] = value
                windows = hangar_windows(u, unit, base, command, k=k, noise=LEVELS[level])
                for b, c in enumerate(starting_check(windows)):
                    row = {"level": level, "unit": u, "case": case, "baseline": b, **c.as_dict()}
                    rows.append(row)
                    print(json.dumps(row), flush=True)
    for level in levels:
        for case in cases:
            sel = [r for r in rows if r["level"] == level and r["case"] == case]
            stats = [r["statistic"] for r in sel]
            refused = sum(not r["ok"] for r in sel)
            print(
                f"noise {level:8s} {case:8s} statistic min {min(stats):.3g} max "
                f"{max(stats):.3g}  model part max {max(r['model_part'] for r in sel):.3g}  "
                f"refused {refused}/{len(sel)}"
            )
    if args.out:
        args.out.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
