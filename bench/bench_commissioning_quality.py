#!/usr/bin/env python3
"""How well a commissioned unit is explained: healthy drawn units against mis-described drives.

Usage (from the repo root):
    .venv/bin/python -m bench.bench_commissioning_quality [--units 8] [--levels none,all]
        [--cases healthy,...] [--out FILE.json]

For drawn units (`Unit.draw(s)`, s = first .. first + units - 1) in the benchmarks' hangar
(`harness.scenarios.hangar`: two baselines per unit, own temperature and small unmeasured
load), noise-free ("none") or with `harness.scenarios.NOISE` on every channel ("all"), the
unit is simulated healthy on the packaged actuator ("healthy") or on a drive the packaged
description gets wrong (`CASES`), and commissioned against the packaged belief.  Prints,
per unit, the factors, those that ran to a search bound, and each healthy reference's model
error in expected healthy levels (`commissioning.HealthyReference.ratio`: the open-loop
"thesis" fit against monitor.healthy_fitness, the recorded-loop fit against
monitor.healthy_fitness_followed), then the largest and smallest ratio per case and level.
Chooses nothing by itself: commissioning.UNEXPLAINED_RATIO quotes its figures.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from bench.harness import cli
from bench.harness.scenarios import NOISE, hangar_windows
from ema_phm.diagnosis.commissioning import commission
from ema_phm.physics.actuator import PI_DQ_CURRENT
from ema_phm.physics.commands import CommandSpec, default_specs
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator.unit import Unit

LEVELS = {"none": {}, "all": NOISE}


def _scaled(base: ActuatorParameters, factor: float, *names: str) -> ActuatorParameters:
    return base.with_values({n: factor * base.value(n) for n in names})


def _pi_loop(base: ActuatorParameters, hz: float) -> ActuatorParameters:
    """The drive with a PI current loop in dq of `hz` bandwidth (the belief: hysteresis)."""
    return dataclasses.replace(
        base.with_values({"current_loop.bandwidth_hz": hz}), controller_kind=PI_DQ_CURRENT
    )


def cases(base: ActuatorParameters) -> dict[str, ActuatorParameters]:
    """The actuator each case simulates (every one commissioned with the packaged belief)."""
    gear, inertia = "mechanics.gear_ratio", ("mechanics.j_motor", "mechanics.j_user")
    return {
        "healthy": base,
        "gear x0.95": _scaled(base, 0.95, gear),
        "gear x1.05": _scaled(base, 1.05, gear),
        "gear x0.8": _scaled(base, 0.8, gear),
        "gear x1.2": _scaled(base, 1.2, gear),
        "inertia x2": _scaled(base, 2.0, *inertia),
        "current loop 200 Hz": _pi_loop(base, 200.0),
        "current loop 1000 Hz": _pi_loop(base, 1000.0),
    }


def _row(
    case: str, level: str, u: int, actuator: ActuatorParameters, command: CommandSpec
) -> dict:
    windows = hangar_windows(u, Unit.draw(u), actuator, command, noise=LEVELS[level])
    res = commission(windows)
    return {
        "case": case,
        "level": level,
        "unit": u,
        "factors": res.factors,
        "at_bound": res.at_bound,
        "references": [r.as_dict() for r in res.references],
        "unexplained": bool(res.unexplained()),
        "wall_s": res.wall_s,
    }


def main() -> None:
    ap = cli(None, raw_description=False)
    ap.add_argument("--units", type=int, default=8)
    ap.add_argument("--first", type=int, default=0, help="first unit seed")
    ap.add_argument("--levels", default=",".join(LEVELS), help="noise levels to run")
    ap.add_argument("--cases", default=None, help="cases to run (default: all)")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    base = ActuatorParameters.default()
    command, _ = default_specs()
    table = cases(base)
    names = args.cases.split(",") if args.cases else list(table)
    rows = []
    for level in args.levels.split(","):
        for case in names:
            for u in range(args.first, args.first + args.units):
                rows.append(_row(case, level, u, table[case], command))
                print(json.dumps(rows[-1]), flush=True)
    for level in args.levels.split(","):
        for case in names:
            sel = [r for r in rows if r["level"] == level and r["case"] == case]
            ratios = [[r["references"][i]["ratio"] for r in sel] for i in (0, 1)]
            bound = sum(bool(r["at_bound"]) for r in sel)
            print(
                f"noise {level:5s} {case:22s} thesis ratio {min(ratios[0]):8.3g}..."
                f"{max(ratios[0]):<8.3g} recorded ratio {min(ratios[1]):8.3g}..."
                f"{max(ratios[1]):<8.3g} unexplained {sum(r['unexplained'] for r in sel)}/"
                f"{len(sel)}  a factor at a bound {bound}/{len(sel)}"
            )
    if args.out:
        args.out.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
