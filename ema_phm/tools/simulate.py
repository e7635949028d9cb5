"""`ema-phm simulate`: the HF model for one window, or one window per cycle of a degradation.

One window: `--k` (one fault vector; a bag of one window with its truth).  Faults that grow:
`--windows N --degradation FILE` (ema_phm.simulator.degradation; the bag layout is
ema_phm.telemetry.cycle_bags), read back by `ema-phm prognose`.
"""

# Work is imported where a command runs it, so that `ema-phm --help` and every command start
# without loading scipy, numba, matplotlib or rclpy for the others.
# ruff: noqa: PLC0415

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path
from typing import Any

from ..domain import faults
from ..domain.cycles import DEFAULT_CYCLE_HOURS  # neither --cycle-hours nor the file
from ..errors import ConfigError, EmaPhmError
from .args import (
    actuator_of,
    add_actuator_arg,
    add_command_args,
    add_unit_args,
    command_and_load,
    limited,
    plot_path,
)
from .output import add_json_arg, emit

#: The options that ask for a multi-window run.
CYCLE_OPTIONS = ("windows", "degradation", "cycle_hours")


def add_simulate(subparsers: Any) -> None:
    """The `simulate` subcommand."""
    s = subparsers.add_parser(
        "simulate", help="run the HF model for one window and write it as a rosbag2 MCAP bag"
    )
    s.add_argument(
        "--k",
        help=f"fault vector {faults.LABELS[0]},...,{faults.LABELS[-1]} in [0,1] "
        "(one window; or --windows)",
    )
    s.add_argument("--out", required=True, help="output bag directory (must not exist)")
    s.add_argument("--seed", type=limited("seed"), default=0, help="the sensors' noise")
    s.add_argument(
        "--noise-current",
        type=limited("noise_current"),
        default=0.0,
        help="A RMS of white noise on I_3eq",
    )
    s.add_argument(
        "--noise-position",
        type=limited("noise_position"),
        default=0.0,
        help="rad RMS of white noise on the user position sensor (theta_u)",
    )
    s.add_argument(
        "--noise-speed",
        type=limited("noise_speed"),
        default=0.0,
        help="rad/s RMS of white noise on the motor speed sensor (omega_m)",
    )
    add_actuator_arg(s, what="the actuator simulated")
    add_unit_args(s)
    s.add_argument(
        "--plot", type=plot_path, help="also draw the window to this PNG (or .pdf, .svg, ...)"
    )
    add_command_args(s)
    _add_cycle_args(s)
    add_json_arg(s, what="what was written")
    s.set_defaults(func=_cmd_simulate)


def _add_cycle_args(p: argparse.ArgumentParser) -> None:
    """`simulate`'s multi-window options."""
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


def _run_options(args: argparse.Namespace) -> tuple[dict[str, Any], Any]:
    """The keyword options of `real_ema.simulate` / `simulate_cycles`, and the unit.

    The command and load, this unit of the actuator at --temperature, its sensors with the
    noise options, --seed; ConfigError when the command does not fit the sample rate.
    """
    from ..simulator.unit import select_unit

    cmd, load = command_and_load(args)
    actuator = actuator_of(args)
    cmd.check_sample_rate(actuator["acquisition"]["sample_rate"])
    unit = select_unit(args.unit, args.unit_seed, names=("--unit", "--unit-seed"))
    sensors = unit.sensors(
        noise_current=args.noise_current,
        noise_position=args.noise_position,
        noise_speed=args.noise_speed,
    )
    options = {
        "actuator": unit.actuator(actuator, temperature_c=args.temperature),
        "command": cmd,
        "load": load,
        "sensors": sensors,
        "seed": args.seed,
        "temperature_c": args.temperature,
    }
    return options, unit


def _records(args: argparse.Namespace, unit: Any) -> dict[str, Any]:
    """What the bag records of the unit, and of the actuator file when one was named."""
    from ..simulator.unit import unit_record

    out: dict[str, Any] = {"unit": unit_record(unit, spec=args.unit, seed=args.unit_seed)}
    if args.actuator is not None:
        out["actuator_file"] = str(args.actuator)
    return out


def _refuse_existing(out: Path) -> None:
    if out.exists() or out.is_symlink():
        raise EmaPhmError(f"refusing to overwrite {out}: it already exists")


def _cmd_simulate(args: argparse.Namespace) -> int:
    from ..simulator import real_ema
    from ..telemetry import bags

    if any(getattr(args, name, None) is not None for name in CYCLE_OPTIONS):
        return _cmd_simulate_cycles(args)
    if args.k is None:
        raise ConfigError(
            f"simulate needs --k {faults.LABELS[0].upper()},...,{faults.LABELS[-1].upper()} "
            "(one window) or --windows N --degradation FILE"
        )
    k = faults.parse(args.k)
    out = Path(args.out)
    if out.exists():
        raise EmaPhmError(f"refusing to overwrite {out}: it already exists")
    options, unit = _run_options(args)
    res = real_ema.simulate(k, **options)
    meta = dict(res.window.meta, **_records(args, unit))
    w = replace(res.window, meta=meta)
    bags.write_window(out, w)
    assert w.k_true is not None  # a simulated window carries its truth
    if args.plot:
        from .plotting import plot_window

        plot_window(w, args.plot)
    k_true = [float(v) for v in w.k_true]
    data = {
        "bag": str(out),
        "samples": w.n,
        "duration_s": w.duration,
        "sample_rate_hz": 1 / w.dt,
        "k_true": k_true,
    }
    if args.plot:
        data["plot"] = str(args.plot)
    emit(
        args,
        data,
        f"wrote {out}: {w.n} samples over {w.duration:g} s at {1 / w.dt:g} Hz, k={k_true}",
    )
    return 0


def _check_cycle_args(args: argparse.Namespace) -> None:
    """ConfigError for a multi-window run asked for with a missing or clashing option."""
    if args.k is not None:
        raise ConfigError(
            "--k sets one fault vector for one window; with --windows/--degradation the "
            "degradation file gives k per cycle (leave --k out)"
        )
    if args.windows is None or args.degradation is None:
        raise ConfigError("a multi-window run needs both --windows N and --degradation FILE")
    if args.plot:
        raise ConfigError("--plot draws one window; it is not available with --windows")
    _refuse_existing(Path(args.out))


def _cmd_simulate_cycles(args: argparse.Namespace) -> int:
    """`ema-phm simulate --windows N --degradation FILE [--cycle-hours H] --out BAG`."""
    from ..simulator.degradation import Degradation, simulate_cycles
    from ..telemetry.cycle_bags import write_cycle_bag

    _check_cycle_args(args)
    out = Path(args.out)
    deg = Degradation.load(args.degradation)
    deg.check_cycles(args.windows)  # every cycle's k checked before anything is simulated
    hours = deg.hours_per_cycle(args.cycle_hours)
    options, unit = _run_options(args)
    cmd = options["command"]
    fs = options["actuator"]["acquisition"]["sample_rate"]
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
        "load": options["load"].as_dict(),
        "seed": args.seed,
        "sensors": options["sensors"].as_dict(),
        **_records(args, unit),
        "temperature_c": args.temperature,
    }
    cycles = simulate_cycles(deg, args.windows, **options)
    written = write_cycle_bag(out, cycles, run_info)
    last = [round(float(v), 6) for v in deg.k(written - 1)]
    emit(
        args,
        {
            "bag": str(out),
            "windows": written,
            "cycle_hours": hours,
            "window_duration_s": n / fs,
            "sample_rate_hz": fs,
            "k_last": last,
        },
        f"wrote {out}: {written} windows (cycles 0..{written - 1}, {hours:g} h each) of "
        f"{n / fs:g} s at {fs:g} Hz; k at the last cycle = {last}",
    )
    return 0
