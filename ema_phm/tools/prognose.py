"""The CLI's prognostics parts: `simulate --windows N --degradation FILE` (multi-window bags).

`cli.py` registers these with one line each; the work is in `ema_phm.physics.degradation`
(faults that grow), `ema_phm.telemetry.cycle_bags` (the bag layout).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ..errors import ConfigError, EmaPhmError

#: Default operating hours per cycle when neither --cycle-hours nor the file gives one.
DEFAULT_CYCLE_HOURS = 1.0


def add_cycle_args(p: argparse.ArgumentParser, limited: Any) -> None:
    """`simulate`'s multi-window options; `limited` is cli._limited (limits-checked types)."""
    g = p.add_argument_group("faults that grow: one window per operating cycle (instead of --k)")
    g.add_argument(
        "--windows",
        type=limited("windows", label="--windows"),
        metavar="N",
        help="simulate N consecutive windows, one per cycle, k held constant in each",
    )
    g.add_argument(
        "--degradation",
        metavar="FILE",
        help="YAML description of how each fault grows over cycles "
        "(config/degradation_example.yaml)",
    )
    g.add_argument(
        "--cycle-hours",
        type=limited("cycle_hours", label="--cycle-hours"),
        metavar="H",
        help=f"operating hours per cycle (default: the file's cycle_hours, else "
        f"{DEFAULT_CYCLE_HOURS:g})",
    )


def wants_cycles(args: argparse.Namespace) -> bool:
    """True when `simulate` was asked for a multi-window run (any of its options given)."""
    return any(
        getattr(args, name, None) is not None for name in ("windows", "degradation", "cycle_hours")
    )


def simulate_cycles_cmd(args: argparse.Namespace) -> int:
    """`ema-phm simulate --windows N --degradation FILE [--cycle-hours H] --out BAG`."""
    from ..physics.degradation import Degradation, simulate_cycles
    from ..physics.parameters import ActuatorParameters
    from ..physics.unit import select_unit, unit_record
    from ..telemetry.cycle_bags import write_cycle_bag
    from .cli import _specs

    if args.k is not None:
        raise ConfigError(
            "--k sets one fault vector for one window; with --windows/--degradation the "
            "degradation file gives k per cycle (leave --k out)"
        )
    if args.windows is None or args.degradation is None:
        raise ConfigError("a multi-window run needs both --windows N and --degradation FILE")
    if args.plot:
        raise ConfigError("--plot draws one window; it is not available with --windows")
    out = Path(args.out)
    if out.exists() or out.is_symlink():
        raise EmaPhmError(f"refusing to overwrite {out}: it already exists")
    deg = Degradation.load(args.degradation)
    deg.check_cycles(args.windows)  # every cycle's k checked before anything is simulated
    hours = (
        args.cycle_hours
        if args.cycle_hours is not None
        else (deg.cycle_hours if deg.cycle_hours is not None else DEFAULT_CYCLE_HOURS)
    )
    cmd, load = _specs(args)
    fs = ActuatorParameters.default()["acquisition"]["sample_rate"]
    cmd.check_sample_rate(fs)
    unit = select_unit(args.unit, args.unit_seed, names=("--unit", "--unit-seed"))
    sensors = unit.sensors(
        noise_current=args.noise_current,
        noise_position=args.noise_position,
        noise_speed=args.noise_speed,
    )
    actuator = unit.actuator(ActuatorParameters.default(), temperature_c=args.temperature)
    n = int(round(cmd.duration * fs))
    run_info = {
        "source": "ema-phm simulate --windows",
        "sample_rate": fs,
        "samples_per_window": n,
        "window_duration": n / fs,
        "windows": args.windows,
        "cycle_hours": hours,
        "degradation": deg.as_dict(),
        "degradation_file": str(args.degradation),
        "command": cmd.as_dict(),
        "load": load.as_dict(),
        "seed": args.seed,
        "sensors": sensors.as_dict(),
        "unit": unit_record(unit, spec=args.unit, seed=args.unit_seed),
        "temperature_c": args.temperature,
    }
    cycles = simulate_cycles(
        deg,
        args.windows,
        actuator=actuator,
        command=cmd,
        load=load,
        sensors=sensors,
        seed=args.seed,
        temperature_c=args.temperature,
    )
    written = write_cycle_bag(out, cycles, run_info)
    last = deg.k(written - 1)
    print(
        f"wrote {out}: {written} windows (cycles 0..{written - 1}, {hours:g} h each) of "
        f"{n / fs:g} s at {fs:g} Hz; k at the last cycle = {[round(float(v), 6) for v in last]}"
    )
    return 0
