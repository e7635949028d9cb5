"""The CLI's prognostics parts: `simulate --windows N --degradation FILE` and `prognose BAG`.

`cli.py` registers these with one line each; the work is in `ema_phm.physics.degradation`
(faults that grow), `ema_phm.telemetry.cycle_bags` (the bag layout) and
`ema_phm.prognostics` (trend, RUL, metrics, replay).
"""

from __future__ import annotations

import argparse
import math
import warnings
from pathlib import Path
from typing import Any

from ..errors import ConfigError, EmaPhmError
from ..physics.degradation import DEFAULT_CYCLE_HOURS  # neither --cycle-hours nor the file


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
    hours = deg.hours_per_cycle(args.cycle_hours)
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


def _thresholds_arg(text: str) -> tuple[float, ...]:
    """Argparse `type=` for --thresholds: 8 comma-separated failure thresholds."""
    fields = [f.strip() for f in text.split(",")]
    try:
        values = tuple(float(f) for f in fields)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"--thresholds must be 8 comma-separated numbers, got {text!r}"
        ) from None
    if len(values) != 8:
        raise argparse.ArgumentTypeError(
            f"--thresholds must have 8 entries (one per k), got {len(values)} in {text!r}"
        )
    return values


def _number_in(flag: str, what: str, high: float, high_text: str):
    """Argparse `type=` for `flag`: a finite number in (0, high]; the error names both."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and 0.0 < value <= high):
            raise argparse.ArgumentTypeError(
                f"{flag} must be {what} in (0, {high_text}], got {text!r}"
            )
        return value

    return parse


#: --horizon: cycles; --noise-floor: an sd of severity.
_horizon_arg = _number_in("--horizon", "a number of cycles", 1e9, "1e9")
_noise_floor_arg = _number_in("--noise-floor", "a number", 0.5, "0.5")


def add_prognose(subparsers: Any) -> None:
    """The `prognose` subcommand."""
    from .cli import _limited, _plot_path

    p = subparsers.add_parser(
        "prognose",
        help="replay a multi-window bag: isolate each window, RUL per fault from the history",
    )
    p.add_argument("bag", help="bag written by `ema-phm simulate --windows N --degradation F`")
    p.add_argument("--preset", default=None, help="optimizer preset (default: the measured best)")
    p.add_argument("--seed", type=_limited("seed"), default=0, help="isolation and RUL sampling")
    p.add_argument(
        "--max-evaluations",
        type=_limited("max_evaluations"),
        default=None,
        help="cap on LF evaluations per window (0: the preset's own budget)",
    )
    p.add_argument(
        "--cycle-hours",
        type=_limited("cycle_hours", label="--cycle-hours"),
        metavar="H",
        help=f"operating hours per cycle (default: the bag's, else {DEFAULT_CYCLE_HOURS:g})",
    )
    p.add_argument(
        "--horizon",
        type=_horizon_arg,
        default=10.0,
        metavar="CYCLES",
        help="horizon of the probability of reaching the threshold, in cycles (default 10)",
    )
    p.add_argument(
        "--thresholds",
        type=_thresholds_arg,
        default=None,
        metavar="T1,...,T8",
        help="failure threshold of each fault's severity (default: the monitor's ERROR "
        "thresholds; entries 7 and 8 are ignored: no RUL for the phase and the gain)",
    )
    p.add_argument(
        "--noise-floor",
        type=_noise_floor_arg,
        default=0.01,
        metavar="SD",
        help="smallest noise sd the trend fit assumes for a k estimate (default 0.01; larger: "
        "wider RUL intervals, later detection; docs/prognostics.md)",
    )
    p.add_argument(
        "--unit",
        default=None,
        metavar="UNIT.yaml",
        help="a commissioned unit, as for `ema-phm isolate --unit`",
    )
    p.add_argument(
        "--count-unexplained",
        action="store_true",
        help="also count windows whose fit the monitor model does not explain (the live "
        "monitor does not)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument(
        "--plot", type=_plot_path, help="draw k with intervals over cycles and the RUL cone"
    )
    p.set_defaults(func=_cmd_prognose)


def _json_safe(obj: Any) -> Any:
    """`obj` with non-finite floats as None (JSON has no inf or NaN)."""
    if isinstance(obj, dict):
        return {k: _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json_safe(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def _fmt_rul(p: Any) -> str:
    def f(v: float) -> str:
        return "never" if not math.isfinite(v) else f"{v:.4g}"

    return f"{f(p.p50)} [{f(p.p5)}, {f(p.p95)}]"


def _window_lines(r: Any) -> list[str]:
    if r.skipped:  # the reason says what happened (monitor.window_rule)
        return [f"cycle {r.cycle:>4}: skipped: {' '.join(r.skipped.split())}"]
    ks = "  ".join(
        f"k{i + 1} {r.k[i]:.3f}"
        + (f" [{r.k_low[i]:.3f},{r.k_high[i]:.3f}]" if r.interval_source == "isolate" else "")
        for i in range(8)
    )
    lines = [f"cycle {r.cycle:>4}: {ks}"]
    quiet = []
    for f in r.prognosis.faults:
        if f.status == "degrading":
            lines.append(
                f"    {f.name}: RUL {_fmt_rul(f.rul_cycles)} cycles = {_fmt_rul(f.rul_hours)} h "
                f"(5-50-95 %), P(threshold {f.threshold:g} within {r.prognosis.horizon_cycles:g} "
                f"cycles) {f.p_within_horizon:.2f}"
            )
        elif f.status in ("no_degradation", "insufficient_data"):
            quiet.append(f.name)
    if quiet:
        status = {f.status for f in r.prognosis.faults if f.name in quiet}
        why = (
            "no degradation detected"
            if status == {"no_degradation"}
            else "not enough estimates yet"
            if status == {"insufficient_data"}
            else "no degradation detected or not enough estimates"
        )
        lines.append(f"    {why}: {', '.join(quiet)}")
    return lines


def _relative_accuracy_text(ra: float | None, na: str) -> str:
    """RA is -inf when the prognosis at lambda had no finite median RUL: say that instead."""
    if ra is None:
        return na
    if not math.isfinite(ra):
        return "n/a (no finite median RUL predicted at lambda 0.5)"
    return f"{ra:.3f}"


def _cmd_prognose(args: argparse.Namespace) -> int:
    import json
    import sys

    from ..diagnosis.isolation import DEFAULT_PRESET, PRESETS
    from ..monitor.replay import replay, score, true_end_of_life
    from ..prognostics.rul import failure_thresholds
    from ..telemetry.cycle_bags import read_cycle_windows

    preset = args.preset or DEFAULT_PRESET
    if preset not in PRESETS:
        raise EmaPhmError(f"unknown preset {preset!r}; choose from {', '.join(sorted(PRESETS))}")
    thresholds = failure_thresholds(args.thresholds)
    belief = None
    if args.unit is not None:
        from ..diagnosis.commissioning import unit_warnings
        from ..physics.parameters import MonitorBelief

        belief = MonitorBelief.default().with_unit(args.unit)
        for text in unit_warnings(args.unit):
            warnings.warn(text, stacklevel=1)
    windows = read_cycle_windows(args.bag)
    meta_hours = windows[0].meta.get("cycle_hours")
    if args.cycle_hours is not None:
        hours, hours_from = float(args.cycle_hours), "--cycle-hours"
    elif meta_hours is not None:
        from ..physics.degradation import check_cycle_hours

        hours, hours_from = check_cycle_hours(meta_hours, label="bag run_info cycle_hours"), "bag"
    else:
        hours, hours_from = DEFAULT_CYCLE_HOURS, "default"

    def show(r: Any) -> None:
        if not args.json:
            print("\n".join(_window_lines(r)), flush=True)

    if not args.json:
        print(
            f"{args.bag}: {len(windows)} windows, {hours:g} h per cycle ({hours_from}); "
            f"isolation as `ema-phm isolate` (preset {preset}, seed {args.seed}, nuisances "
            f"searched, unit {args.unit or 'none: the packaged belief'})"
        )
    replayed = replay(
        windows,
        seed=args.seed,
        preset=preset,
        max_evaluations=args.max_evaluations or None,
        cycle_hours=hours,
        horizon_cycles=args.horizon,
        thresholds=thresholds,
        noise_floor=args.noise_floor,
        belief=belief,
        nuisance=True,  # as `ema-phm isolate`: the unmeasured-load nuisances are searched
        count_unexplained=args.count_unexplained,
        on_window=show,
    )
    assessed = [r for r in replayed if not r.skipped]
    intervals = (
        "no window assessed"
        if not assessed
        else "isolate's 90 % intervals"
        if all(r.interval_source == "isolate" for r in assessed)
        else "unavailable: isolate gave no k_interval, zero-width intervals used (noise learned "
        "from the scatter)"
        if all(r.interval_source == "unavailable" for r in assessed)
        else "isolate's 90 % intervals where given, zero-width elsewhere"
    )
    eol = true_end_of_life(windows, thresholds)
    scores = score(replayed, eol)
    final = assessed[-1].prognosis if assessed else None
    if args.plot:
        from .prognose_plot import plot_prognosis

        plot_prognosis(replayed, eol, args.plot, alpha=0.2)
    if args.json:
        out = {
            "bag": str(args.bag),
            "cycle_hours": hours,
            "cycle_hours_source": hours_from,
            "horizon_cycles": args.horizon,
            "noise_floor": args.noise_floor,
            "thresholds": list(thresholds),
            "preset": preset,
            "seed": args.seed,
            "unit": args.unit,
            "intervals": intervals,
            "windows": [r.as_dict() for r in replayed],
            "summary": {
                "assessed_windows": len(assessed),
                "skipped_windows": len(replayed) - len(assessed),
                "skipped": [
                    {"cycle": r.cycle, "reason": r.skipped} for r in replayed if r.skipped
                ],
                "final": None if final is None else final.as_dict(),
                "true_eol_cycles": eol,
                "scores": scores,
            },
        }
        if args.plot:
            out["plot"] = str(args.plot)
        print(json.dumps(_json_safe(out)))
        return 0
    print(f"intervals: {intervals}")
    print(
        f"summary after {len(assessed)} counted (assessed and explained) of "
        f"{len(replayed)} windows:"
    )
    for r in replayed:
        if r.skipped:
            print(f"  skipped cycle {r.cycle}: {' '.join(r.skipped.split())}")
    if final is None:
        print("  no window could be assessed: no prognosis")
    else:
        for f in final.faults:
            print(f"  {f.name:<20} {f.status:<17} {' '.join(f.message.split())}")
    for name, s in scores.items():
        if not s.get("predictions"):
            print(f"  truth: {name} reaches its threshold at cycle {s['true_eol_cycle']}")
            continue
        ra = s["relative_accuracy_at_lambda"]
        na = "n/a (no window at or after lambda)"
        print(
            f"  truth: {name} reaches its threshold at cycle {s['true_eol_cycle']}: prognostic "
            f"horizon {s['prognostic_horizon_cycles']:g} cycles (alpha 0.2); alpha-lambda "
            f"(alpha 0.2) at lambda 0.5: {na if s['alpha_lambda'] is None else s['alpha_lambda']}"
            f", at every window from lambda 0.5 on: "
            f"{na if s['alpha_lambda_from_lambda'] is None else s['alpha_lambda_from_lambda']}; "
            f"relative accuracy at lambda 0.5: {_relative_accuracy_text(ra, na)}; 90 % "
            f"interval coverage {s['interval_coverage_90']:.2f} over the "
            f"{s['windows_with_rul']} of {s['predictions']} windows before the end of life that "
            "gave a RUL"
        )
    if args.plot:
        print(f"plot: {args.plot}")
    sys.stdout.flush()
    return 0
