"""`ema-phm` command line.  Never imports rclpy.

Exit codes: 0 ok, 2 bad input (one line on stderr naming the problem), 1 other failures.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path
from typing import Any, Callable, Sequence

from ..errors import ConfigError, EmaPhmError
from ..limits import LIMITS, check
from .play import add_play
from .prognose import add_cycle_args, add_prognose


def _limited(name: str, *, label: str | None = None) -> Callable[[str], float | int]:
    """Argparse `type=` for an option bounded by limits.LIMITS[name] (reported as `label`).

    Every failure (not a number, not an integer, too many digits, inf/nan, out of
    range) becomes argparse's one-line usage error naming the option and the value
    as typed, never an OverflowError/ValueError traceback.
    """
    lim = LIMITS[name]
    shown = label or name

    def convert(text: str) -> float | int:
        try:
            if lim.integer:
                int(text)  # "1.5" and "1e3" are not seeds or counts
            return check(name, text, label=shown)
        except (ValueError, OverflowError):  # ConfigError is a ValueError
            shortened = text if len(text) <= 40 else f"{text[:20]}...({len(text)} characters)"
            raise argparse.ArgumentTypeError(
                f"{shown} must be {lim.describe()}, got {shortened!r}"
            ) from None

    convert.__name__ = shown
    return convert


def _plot_path(text: str) -> Path:
    """Argparse `type=` for --plot: a file matplotlib can write, checked before any work."""
    from .plotting import check_plot_path

    try:
        return check_plot_path(Path(text), label="plot file")
    except ConfigError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


class _Parser(argparse.ArgumentParser):
    """argparse that reports a bad argument as one line and exit code 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message}\n")


def _add_command_args(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("command and load (defaults: config/commands.yaml)")
    g.add_argument("--command", dest="kind", choices=("chirp", "step", "ramp", "sine"))
    g.add_argument(
        "--amplitude", type=_limited("amplitude"), help="rad at the user shaft (ramp: rad/s)"
    )
    g.add_argument(
        "--f0",
        type=_limited("frequency", label="f0"),
        help="Hz, chirp start / sine frequency (below half the telemetry sample rate)",
    )
    g.add_argument(
        "--f1",
        type=_limited("frequency", label="f1"),
        help="Hz, chirp end frequency (below half the telemetry sample rate)",
    )
    g.add_argument("--duration", type=_limited("duration"), help="s, window length")
    g.add_argument("--load", type=_limited("load"), help="N*m at the user shaft (constant)")


def _add_unit_args(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("the unit and its environment (default: the datasheet unit)")
    which = g.add_mutually_exclusive_group()
    which.add_argument(
        "--unit",
        metavar="SPEC",
        help="KEY=VALUE[,KEY=VALUE...] or a YAML file: how this unit differs from its datasheet "
        "(keys: inertia, torque_constant, resistance, inductance, friction, damping, stiffness, "
        "current_gain, current_offset [A], position_offset [rad], speed_gain, mesh_damping)",
    )
    which.add_argument(
        "--unit-seed",
        type=_limited("seed", label="--unit-seed"),
        metavar="S",
        help="draw the unit from config/unit_tolerances.yaml with this seed",
    )
    g.add_argument(
        "--temperature",
        type=_limited("temperature", label="--temperature"),
        metavar="C",
        help="winding and magnet temperature [degC]: R and the back-EMF constant follow it; "
        "the telemetry's temperature channel reads it (default: unknown, the datasheet values)",
    )
    g.add_argument(
        "--load-spring",
        type=_limited("load_spring", label="--load-spring"),
        metavar="NM_PER_RAD",
        help="hinge-moment load -NM_PER_RAD * theta_u on top of --load",
    )
    g.add_argument(
        "--load-unmeasured",
        action="store_true",
        help="the load acts but the telemetry's load channel is NaN (not measured)",
    )


def _specs(args: argparse.Namespace):
    from dataclasses import replace

    from ..physics.commands import default_specs

    cmd, load = default_specs()
    changes = {
        name: getattr(args, name)
        for name in ("kind", "amplitude", "f0", "f1", "duration")
        if getattr(args, name) is not None
    }
    cmd = replace(cmd, **changes)
    if args.load is not None:
        load = replace(load, kind="constant", value=args.load, amplitude=0.0, frequency=0.0)
    spring = getattr(args, "load_spring", None)
    if spring is not None:
        load = replace(load, spring=spring)
    if getattr(args, "load_unmeasured", False):
        load = replace(load, measured=False)
    return cmd, load


def _cmd_simulate(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from ..domain import faults as fault_vector
    from ..physics import real_ema
    from ..physics.parameters import ActuatorParameters
    from ..physics.unit import select_unit, unit_record
    from ..telemetry import bags
    from .prognose import simulate_cycles_cmd, wants_cycles

    if wants_cycles(args):
        return simulate_cycles_cmd(args)
    if args.k is None:
        raise ConfigError(
            "simulate needs --k K1,...,K8 (one window) or --windows N --degradation FILE"
        )
    k = fault_vector.parse(args.k)
    out = Path(args.out)
    if out.exists():
        raise EmaPhmError(f"refusing to overwrite {out}: it already exists")
    cmd, load = _specs(args)
    cmd.check_sample_rate(ActuatorParameters.default()["acquisition"]["sample_rate"])
    unit = select_unit(args.unit, args.unit_seed, names=("--unit", "--unit-seed"))
    res = real_ema.simulate(
        k,
        actuator=unit.actuator(ActuatorParameters.default(), temperature_c=args.temperature),
        command=cmd,
        load=load,
        sensors=unit.sensors(
            noise_current=args.noise_current,
            noise_position=args.noise_position,
            noise_speed=args.noise_speed,
        ),
        seed=args.seed,
        temperature_c=args.temperature,
    )
    meta = dict(res.window.meta, unit=unit_record(unit, spec=args.unit, seed=args.unit_seed))
    w = replace(res.window, meta=meta)
    bags.write_window(out, w)
    if args.plot:
        from .plotting import plot_window

        plot_window(w, args.plot)
    print(
        f"wrote {out}: {w.n} samples over {w.duration:g} s at {1 / w.dt:g} Hz, "
        f"k={list(map(float, w.k_true))}"
    )
    return 0


class _ProgressBar:
    """A one-line progress bar on stderr (only when stderr is a terminal)."""

    def __init__(self, total: int) -> None:
        self.total = max(total, 1)
        self.on = sys.stderr.isatty()

    def __call__(self, p) -> None:
        if not self.on:
            return
        frac = min(p.evaluations / self.total, 1.0)
        bar = "#" * int(30 * frac)
        sys.stderr.write(
            f"\r[{bar:<30}] {p.evaluations:>6} evals  best {p.best_fitness:.4g}  ({p.stage})"
        )
        sys.stderr.flush()

    def close(self) -> None:
        if self.on:
            sys.stderr.write("\n")


def _cmd_isolate(args: argparse.Namespace) -> int:
    from ..diagnosis.isolation import PRESETS, isolate, preset_budget
    from ..physics.parameters import MonitorBelief
    from ..telemetry import bags

    if args.preset not in PRESETS:
        raise EmaPhmError(
            f"unknown preset {args.preset!r}; choose from {', '.join(sorted(PRESETS))}"
        )
    # an explicit calibration replaces the packaged one; nothing is picked up silently
    belief = (
        MonitorBelief.default()
        if args.calibration is None
        else MonitorBelief.packaged_uncalibrated().with_calibration(args.calibration)
    )
    if args.unit is not None:
        from ..diagnosis.commissioning import unit_warnings

        belief = belief.with_unit(args.unit)
        for text in unit_warnings(args.unit):
            warnings.warn(text, stacklevel=1)
    window = bags.read_window(args.bag).validated()
    bar = _ProgressBar(args.max_evaluations or preset_budget(args.preset))
    try:
        res = isolate(
            window,
            belief=belief,
            preset=args.preset,
            seed=args.seed,
            weights=args.fitness,
            on_progress=bar,
            max_evaluations=args.max_evaluations or None,
            nuisance=True,
            intervals=True,
        )
    finally:
        bar.close()
    from ..diagnosis import health

    verdict = health.assess_isolation(res)
    out = res.as_dict()
    out["level"] = health.LEVEL_NAMES[verdict.level]
    out["message"] = verdict.message
    out["calibration"] = belief.calibration_file
    out["unit"] = args.unit
    if args.plot:
        from .plotting import plot_isolation

        out["plot"] = str(plot_isolation(window, res, args.plot, belief=belief))
    if args.json:
        print(json.dumps(out))
    else:
        from ..domain.faults import NAMES

        print(
            f"{args.bag}: {res.evaluations} evaluations in {res.wall_s:.2f} s (preset "
            f"{res.preset}, seed {res.seed}, "
            f"calibration {belief.calibration_file}, unit {args.unit})"
        )
        print(f"  {verdict.message}")
        for i, name in enumerate(NAMES):
            truth = "" if res.k_true is None else f"   true {res.k_true[i]:.4f}"
            lo, hi = res.k_interval[i]
            ok, why = res.identifiable[i]
            flag = "" if ok else f"   not identifiable: {why}"
            print(f"  k{i + 1} {name:<20} {res.k[i]:.4f}  90 % [{lo:.4f}, {hi:.4f}]{truth}{flag}")
        for name, value in res.nuisance.items():
            print(f"  {name:<24} {value:.6g}")
        ad = res.adequacy
        print(
            f"  fitness {res.fitness:.6g}   adequacy {ad.statistic:.3g} "
            f"({'ok' if ad.ok else 'NOT ok'}, threshold {ad.threshold:g})"
            + ("" if res.percent_err is None else f"   %err {res.percent_err:.3f}")
        )
    return 0


def _cmd_recover(args: argparse.Namespace) -> int:
    from ..telemetry.bags import recover_bag

    print(recover_bag(args.bag, out=args.out).summary())
    return 0


def _cmd_commission(args: argparse.Namespace) -> int:
    from ..diagnosis.commissioning import commission, review, write_unit
    from ..telemetry import bags

    if args.out is None:
        raise ConfigError("calibrate --baseline needs --out UNIT.yaml (the unit file to write)")
    out = Path(args.out)
    if out.is_dir():
        raise ConfigError(f"--out {out} is a folder; name a file (e.g. {out / 'unit.yaml'})")
    windows = [bags.read_window(b).validated() for b in args.baseline]
    checks, problems = review(windows, [str(b) for b in args.baseline])
    if problems and not args.force:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise ConfigError(f"not commissioned: {problems[0]}{more}; --force commissions anyway")
    res = commission(windows, checks=checks)
    res.sources.extend(str(b) for b in args.baseline)
    res.warnings.extend(problems)
    for problem in problems:
        warnings.warn(f"commissioned with --force despite: {problem}", stacklevel=1)
    line = {
        "warnings": res.warnings,
        "baseline_checks": [c.as_dict() for c in checks],
        "factors": res.factors,
        "interval90": res.intervals,
        "identifiable": res.identifiable,
        "fitness_before": res.fitness_before,
        "fitness_after": res.fitness_after,
        "temperature_c": res.temperature_c,
        "wall_s": res.wall_s,
        "written": str(write_unit(res, out)),
    }
    print(json.dumps(line, indent=None if args.json else 2))
    return 0


def _cmd_calibrate(args: argparse.Namespace) -> int:
    from ..diagnosis.calibration import calibrate, user_calibration_file, write_calibration

    if args.baseline:
        return _cmd_commission(args)
    out = Path(args.out) if args.out is not None else user_calibration_file()
    if out.is_dir():
        raise ConfigError(
            f"--out {out} is a folder; name a file (e.g. {out / 'calibration.yaml'})"
        )
    res = calibrate()
    line = {
        "ke": res.ke,
        "gt": res.gt,
        "mse_before_a2": res.mse_before,
        "mse_after_a2": res.mse_after,
        "ke_before": res.ke_before,
        "gt_before": res.gt_before,
        "evaluations": res.evaluations,
    }
    line["written"] = str(write_calibration(res, out))
    print(json.dumps(line, indent=None if args.json else 2))
    return 0


class _RemovedWrite(argparse.Action):
    """`calibrate --write` used to rewrite the packaged file: refuse it, naming --out."""

    def __call__(self, parser: argparse.ArgumentParser, *_: object, **__: object) -> None:
        parser.error(
            "--write was removed: the calibration is written to --out FILE "
            "(default ${XDG_CONFIG_HOME:-~/.config}/ema_phm/calibration.yaml), never into the "
            "package"
        )


def _cmd_bench(args: argparse.Namespace) -> int:
    from .benchmark import measure_models

    res = measure_models(cold_start=not args.no_cold_start)
    if args.json:
        print(json.dumps(res))
    else:
        for key, val in res.items():
            print(f"{key:>22}: {val}")
    return 0


#: What the demo's %err is printed next to: the thesis measured a twin monitor, noise-free.
THESIS_FIGURE = "thesis, twin monitor, no noise: 1-7 % in ~12 min; this HF is not a twin"


def _cmd_demo(args: argparse.Namespace) -> int:
    """Main job on bundled defaults.

    ema_node plays the faulty EMA for one window, monitor_node isolates it, the health result is
    printed (--offline: no ROS 2).
    """
    import numpy as np

    from ..diagnosis.isolation import DEFAULT_PRESET, isolate, preset_budget
    from ..domain import faults as fault_vector
    from ..physics import real_ema

    k = fault_vector.parse(args.k)
    if not args.offline:
        from ..ros.demo import run_demo  # the only path of the CLI that loads rclpy

        print(
            f"starting ema_node (true k = {np.round(k, 4).tolist()}, current noise "
            f"{args.noise_current:g} A RMS) and monitor_node in one process, localhost only ...",
            flush=True,
        )
        h = run_demo(k=k, seed=args.seed, ema_params={"noise_current": args.noise_current})
        print(
            f"/ema/health after one {h['window_t1'] - h['window_t0']:g} s window: level "
            f"{h['level']}: {h['message']}"
        )
        print(f"  fitted k = {np.round(h['k'], 4).tolist()}")
        if h.get("k_interval") is not None:
            print(f"  90 % intervals = {np.round(h['k_interval'], 3).tolist()}")
        print(f"  true   k = {np.round(h['k_true'], 4).tolist()}")
        if h.get("nuisance"):
            print(f"  nuisances = { {n: round(v, 3) for n, v in h['nuisance'].items()} }")
        print(
            f"  %err (eq. 6.4) = {h['percent_err']:.3f}   {h['evaluations']} evaluations in "
            f"{h['elapsed_s']:.2f} s "
            f"(preset {h['preset']}; {THESIS_FIGURE})"
        )
        return 0
    w = real_ema.simulate(k, seed=args.seed, noise_current=args.noise_current).window
    print(
        f"real EMA (HF model): {w.duration:g} s chirp "
        f"{w.meta['command']['f0']:g}->{w.meta['command']['f1']:g} Hz, "
        f"{w.n} samples at {1 / w.dt:g} Hz, current noise {args.noise_current:g} A RMS"
    )
    print(f"  true k = {np.round(k, 4).tolist()}")
    bar = _ProgressBar(preset_budget(DEFAULT_PRESET))
    try:
        res = isolate(w, seed=args.seed, on_progress=bar, nuisance=True, intervals=True)
    finally:
        bar.close()
    from ..diagnosis import health

    print(
        f"monitor (LF model + {res.preset}): {res.evaluations} evaluations in {res.wall_s:.2f} s"
    )
    print(f"  {health.assess_isolation(res).message}")
    print(f"  fitted k = {np.round(res.k, 4).tolist()}")
    print(f"  90 % intervals = {np.round(res.k_interval, 3).tolist()}")
    print(f"  %err (eq. 6.4) = {res.percent_err:.3f}   ({THESIS_FIGURE})")
    if args.plot:
        from .plotting import plot_isolation

        print(f"  plot: {plot_isolation(w, res, args.plot)}")
    return 0


def _add_simulate(subparsers: Any) -> None:
    """The `simulate` subcommand."""
    s = subparsers.add_parser(
        "simulate", help="run the HF model for one window and write it as a rosbag2 MCAP bag"
    )
    s.add_argument("--k", help="fault vector k1,...,k8 in [0,1] (one window; or --windows)")
    s.add_argument("--out", required=True, help="output bag directory (must not exist)")
    s.add_argument("--seed", type=_limited("seed"), default=0)
    s.add_argument(
        "--noise-current",
        type=_limited("noise_current"),
        default=0.0,
        help="A RMS of white noise on I_3eq",
    )
    s.add_argument(
        "--noise-position",
        type=_limited("noise_position"),
        default=0.0,
        help="rad RMS of white noise on the user position sensor (theta_u)",
    )
    s.add_argument(
        "--noise-speed",
        type=_limited("noise_speed"),
        default=0.0,
        help="rad/s RMS of white noise on the motor speed sensor (omega_m)",
    )
    _add_unit_args(s)
    s.add_argument(
        "--plot", type=_plot_path, help="also draw the window to this PNG (or .pdf, .svg, ...)"
    )
    _add_command_args(s)
    add_cycle_args(s, _limited)
    s.set_defaults(func=_cmd_simulate)


def _add_isolate(subparsers: Any) -> None:
    """The `isolate` subcommand."""
    i = subparsers.add_parser(
        "isolate",
        help="fit the monitor model to a bag and report k (and %%err if the bag has truth)",
    )
    i.add_argument(
        "bag", help="rosbag2 bag written by `ema-phm simulate` or recorded by the nodes"
    )
    i.add_argument("--preset", default=None, help="optimizer preset (default: the measured best)")
    i.add_argument("--seed", type=_limited("seed"), default=0)
    i.add_argument(
        "--fitness", default="default", help="residual weighting: current | default | all"
    )
    i.add_argument(
        "--max-evaluations",
        type=_limited("max_evaluations"),
        default=None,
        help="cap on LF evaluations (global search only; 0: the preset's own budget)",
    )
    i.add_argument(
        "--calibration",
        default=None,
        metavar="FILE",
        help="monitor calibration (ke, gt) to use instead of the packaged config/calibration.yaml",
    )
    i.add_argument(
        "--unit",
        default=None,
        metavar="UNIT.yaml",
        help="a commissioned unit (`ema-phm calibrate --baseline BAG --out UNIT.yaml`): "
        "faults are judged against that unit's healthy state",
    )
    i.add_argument("--json", action="store_true", help="print one JSON object")
    i.add_argument(
        "--plot", type=_plot_path, help="draw HF vs fitted LF, k bars and convergence to this PNG"
    )
    i.set_defaults(func=_cmd_isolate)


def _add_recover(subparsers: Any) -> None:
    """The `recover` subcommand."""
    r = subparsers.add_parser(
        "recover",
        help="rebuild a recording whose writer was killed (no metadata.yaml or no MCAP "
        "footer) from its complete chunks, as a finished bag",
    )
    r.add_argument(
        "bag", help="bag folder or .mcap file of the unfinished recording (left untouched)"
    )
    r.add_argument(
        "--out", default=None, help="new bag folder to write (default: BAG_recovered beside it)"
    )
    r.set_defaults(func=_cmd_recover)


def _add_calibrate(subparsers: Any) -> None:
    """The `calibrate` subcommand."""
    c = subparsers.add_parser(
        "calibrate",
        help="fit the LF ke and gt to the nominal HF (section 6.2), or with --baseline "
        "commission one unit from its healthy recordings",
    )
    c.add_argument(
        "--baseline",
        nargs="+",
        default=None,
        metavar="BAG",
        help="healthy recordings of one unit: fit the monitor to that unit and write a unit "
        "file to --out (use it with `isolate --unit FILE`)",
    )
    c.add_argument(
        "--out",
        default=None,
        metavar="FILE",
        help="calibration file to write "
        "(default: ${XDG_CONFIG_HOME:-~/.config}/ema_phm/calibration.yaml; "
        "use it with `isolate --calibration FILE`)",
    )
    c.add_argument(
        "--force",
        action="store_true",
        help="with --baseline: commission even from baselines that look faulty, are not "
        "excited or disagree (the unit file then carries the warnings, shown on every use)",
    )
    c.add_argument("--write", nargs=0, action=_RemovedWrite, help=argparse.SUPPRESS)
    c.add_argument("--json", action="store_true")
    c.set_defaults(func=_cmd_calibrate)


def _add_bench(subparsers: Any) -> None:
    """The `bench` subcommand."""
    b = subparsers.add_parser("bench", help="measure speed/accuracy")
    b.add_argument("what", choices=("models",))
    b.add_argument("--json", action="store_true")
    b.add_argument(
        "--no-cold-start", action="store_true", help="skip the cold-start subprocess measurement"
    )
    b.set_defaults(func=_cmd_bench)


def _add_demo(subparsers: Any) -> None:
    """The `demo` subcommand."""
    d = subparsers.add_parser("demo", help="the main job on bundled defaults")
    d.add_argument(
        "--k",
        default="0.3,0.2,0,0.25,0,0.3,0.3,0.6",
        help="true fault vector of the simulated EMA",
    )
    d.add_argument("--seed", type=_limited("seed"), default=0)
    d.add_argument(
        "--noise-current",
        type=_limited("noise_current"),
        default=0.225,
        help="A RMS (default 1 %% of 22.5 A)",
    )
    d.add_argument("--plot", type=_plot_path, default=None, help="PNG to draw (with --offline)")
    d.add_argument(
        "--offline",
        action="store_true",
        help="library only: simulate and isolate without ROS 2 nodes",
    )
    d.set_defaults(func=_cmd_demo)


#: Every subcommand, and the function that adds it to the parser.
SUBCOMMANDS: dict[str, Callable[[Any], None]] = {
    "simulate": _add_simulate,
    "isolate": _add_isolate,
    "recover": _add_recover,
    "calibrate": _add_calibrate,
    "bench": _add_bench,
    "demo": _add_demo,
    "prognose": add_prognose,
    "play": add_play,
}


def build_parser() -> argparse.ArgumentParser:
    """The `ema-phm` argument parser with every subcommand of `SUBCOMMANDS`."""
    p = _Parser(
        prog="ema-phm",
        description="Model-based fault isolation for EMAs (HF 'real EMA' + LF monitor).",
    )
    subparsers = p.add_subparsers(dest="cmd", required=True, parser_class=_Parser)
    for add in SUBCOMMANDS.values():
        add(subparsers)
    return p


def _one_line_warning(
    message: Warning | str, category: type[Warning], *_: object, **__: object
) -> None:
    """Warnings the package emits on purpose (a recovered bag) as one stderr line each."""
    print(f"ema-phm: warning: {' '.join(str(message).split())}", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """The `ema-phm` command line; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "cmd", None) == "isolate" and args.preset is None:
        from ..diagnosis.isolation import DEFAULT_PRESET

        args.preset = DEFAULT_PRESET
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _one_line_warning
            return int(args.func(args))
    except EmaPhmError as exc:
        print(f"ema-phm: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("ema-phm: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
