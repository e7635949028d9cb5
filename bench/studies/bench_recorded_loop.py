#!/usr/bin/env python3
"""Recorded-loop settings side by side on a few drawn units (how docs/recorded_loop.md chose).

Each unit `Unit.draw(u)` is commissioned from its 2 hangar windows (bench_robust's
environment: its temperature, unmeasured load, NOISE on every channel); each case is
simulated with run seed 1000 u + s for s in --seeds and isolated once per setting
(`isolate(..., nuisance=True, intervals=True)`, default preset, seed s).  A setting is
"thesis" (the open-loop fitness) or keyword arguments of `RecordedLoop`.  Prints one line per
window: %err of eq. 6.4 and the adequacy statistic per setting.

    .venv/bin/python -m bench.studies.bench_recorded_loop --units 0 --cases "backlash medium"
        --setting open=thesis
        --setting user200='motor_side=False, feedback_hz=200, hunting_feedback_hz=200'
(one command line).
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager

from bench.harness import cli
from bench.harness.scenarios import cases, environment, hangar_windows, sim_kw, unit_runs
from ema_phm.diagnosis import fitness as fitness_mod
from ema_phm.diagnosis.commissioning import commission
from ema_phm.diagnosis.isolation import isolate
from ema_phm.model.belief import MonitorBelief
from ema_phm.model.recorded_loop import RecordedLoop
from ema_phm.physics.commands import default_specs
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator import real_ema
from ema_phm.simulator.unit import Unit


def setting(text: str) -> tuple[str, RecordedLoop | None]:
    """'name=thesis' or 'name=key=value, key=value' (RecordedLoop keywords)."""
    name, _, spec = text.partition("=")
    if spec.strip() == "thesis":
        return name, None
    kw = {}
    for part in filter(None, (p.strip() for p in spec.split(","))):
        key, _, value = part.partition("=")
        kw[key.strip()] = (
            value.strip() == "True" if value.strip() in ("True", "False") else float(value)
        )
    return name, RecordedLoop(**kw)


@contextmanager
def recorded_loop(loop: RecordedLoop | None) -> Iterator[None]:
    """Fitness "recorded" follows `loop` inside the block (None: unchanged), restored after.

    `isolate` takes a fitness name, not a loop, so the setting goes through
    `fitness.LOOPS["recorded"]` for the one isolation and ema_phm's table is put back after:
    nothing else in the process (commissioning's recorded-loop reference included) sees it.
    """
    if loop is None:
        yield
        return
    saved = fitness_mod.LOOPS["recorded"]
    fitness_mod.LOOPS["recorded"] = loop
    try:
        yield
    finally:
        fitness_mod.LOOPS["recorded"] = saved


def main() -> int:
    ap = cli(__doc__)
    ap.add_argument("--units", default="0", help="comma-separated unit seeds")
    ap.add_argument(
        "--seeds",
        default="1,2",
        help="comma-separated run seeds s, or 'bench': each case's bench_robust run seed",
    )
    ap.add_argument("--cases", required=True, help="comma-separated scenario name prefixes")
    ap.add_argument("--setting", action="append", required=True, help="name=thesis|kw=v,...")
    args = ap.parse_args()
    settings = [setting(s) for s in args.setting]
    base = ActuatorParameters.default()
    command, _ = default_specs()
    todo = [c for c in cases() if any(c[0].startswith(p) for p in args.cases.split(","))]
    for u in (int(v) for v in args.units.split(",")):
        unit = Unit.draw(u)
        belief = MonitorBelief.default().commissioned_with(
            commission(hangar_windows(u, unit, base, command)).values
        )
        kw = sim_kw(unit, base, command, environment(u))
        for run_seed, s, (name, k, _single, _tag) in _runs(u, todo, args.seeds):
            w = real_ema.simulate(k, seed=run_seed, **kw).window
            line = f"u{u} s{s} {name[:26]:26s}"
            for label, loop in settings:
                with recorded_loop(loop):
                    r = isolate(
                        w,
                        belief=belief,
                        seed=s,
                        nuisance=True,
                        intervals=True,
                        weights="thesis" if loop is None else "recorded",
                    )
                line += f" | {label} {r.percent_err:5.1f} a{r.adequacy.statistic:5.2f}"
            print(line, flush=True)
    return 0


def _runs(u: int, todo: list, seeds: str) -> list[tuple[int, int, tuple]]:
    """(run seed, fit seed, case) of unit u: --seeds s (1000 u + s, s) or bench_robust's."""
    names = {c[0] for c in todo}
    if seeds == "bench":  # bench_robust's windows: its run seeds, fit seed = run seed
        return [(rs, rs, c) for rs, c in unit_runs(cases(), u, 0) if c[0] in names]
    return [(1000 * u + int(v), int(v), c) for v in seeds.split(",") for c in todo]


if __name__ == "__main__":
    sys.exit(main())
