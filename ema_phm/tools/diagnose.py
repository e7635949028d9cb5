"""`ema-phm isolate` (fit the monitor to a bag) and `ema-phm calibrate` (ke, gt; or a unit)."""

# Work is imported where a command runs it, so that `ema-phm --help` and every command start
# without loading scipy, numba, matplotlib or rclpy for the others.
# ruff: noqa: PLC0415

from __future__ import annotations

import argparse
import dataclasses
import math
import warnings
from pathlib import Path
from typing import Any

from ..errors import ConfigError, EmaPhmError
from ..physics.parameters import QUANTITIES
from .args import ProgressBar, actuator_of, add_actuator_arg, belief_of, limited, plot_path
from .output import add_json_arg, emit

#: The weightings of diagnosis.fitness.WEIGHTINGS, named here so that building the parser
#: does not import scipy (a test keeps the two equal).
FITNESS_WEIGHTINGS = ("default", "recorded", "thesis", "position", "current", "all")


def add_isolate(subparsers: Any) -> None:
    """The `isolate` subcommand."""
    i = subparsers.add_parser(
        "isolate",
        help="fit the monitor model to a bag and report k (and %%err if the bag has truth)",
    )
    i.add_argument(
        "bag", help="rosbag2 bag written by `ema-phm simulate` or recorded by the nodes"
    )
    i.add_argument("--preset", default=None, help="optimizer preset (default: the measured best)")
    i.add_argument("--seed", type=limited("seed"), default=0, help="the optimizer's random start")
    i.add_argument(
        "--fitness",
        default="default",
        help=f"fitness: {' | '.join(FITNESS_WEIGHTINGS)}; 'recorded' "
        "follows the recorded loop, 'thesis' replays the command open-loop "
        "(docs/recorded_loop.md)",
    )
    i.add_argument(
        "--max-evaluations",
        type=limited("max_evaluations"),
        default=None,
        help="cap on LF evaluations (global search only; 0: the preset's own budget)",
    )
    add_actuator_arg(i, what="the monitor believes it is watching this actuator")
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
    add_json_arg(i, what="k, its intervals, the verdict and the fit")
    i.add_argument(
        "--plot", type=plot_path, help="draw HF vs fitted LF, k bars and convergence to this PNG"
    )
    i.set_defaults(func=_cmd_isolate)


def _cmd_isolate(args: argparse.Namespace) -> int:
    from ..diagnosis import health
    from ..diagnosis.isolation import DEFAULT_PRESET, PRESETS, isolate, preset_budget
    from ..diagnosis.isolation_settings import FitSettings
    from ..telemetry import bags

    if args.preset is None:
        args.preset = DEFAULT_PRESET
    if args.preset not in PRESETS:
        raise EmaPhmError(
            f"unknown preset {args.preset!r}; choose from {', '.join(sorted(PRESETS))}"
        )
    belief = belief_of(args, calibration=args.calibration, unit=args.unit)
    window = bags.read_window(args.bag).validated()
    bar = ProgressBar(args.max_evaluations or preset_budget(args.preset))
    try:
        fit = FitSettings(
            preset=args.preset,
            seed=args.seed,
            fitness=args.fitness,
            max_evaluations=args.max_evaluations or 0,
        )  # as the live monitor: nuisances searched, 90 % intervals
        res = isolate(window, **fit.isolate_options(belief, on_progress=bar))
    finally:
        bar.close()
    verdict = health.assess_isolation(res)
    out = health.isolation_report(res, verdict)
    out["calibration"] = belief.calibration_file
    out["unit"] = args.unit
    if args.actuator is not None:
        out["actuator"] = args.actuator
    if args.plot:
        from .plotting import plot_isolation

        out["plot"] = str(plot_isolation(window, res, args.plot, belief=belief))
    emit(args, out, _isolation_lines(args, res, verdict.message, belief.calibration_file))
    return 0


def _isolation_lines(
    args: argparse.Namespace, res: Any, message: str, calibration: Any
) -> list[str]:
    """The text report of `isolate`: one line per fault, the nuisances, fitness and adequacy."""
    from ..domain.faults import FAULTS

    lines = [
        f"{args.bag}: {res.evaluations} evaluations in {res.wall_s:.2f} s (preset "
        f"{res.preset}, seed {res.seed}, "
        f"calibration {calibration}, unit {args.unit}"
        + ("" if args.actuator is None else f", actuator {args.actuator}")
        + ")",
        f"  {message}",
    ]
    for f in FAULTS:
        i = f.index
        truth = "" if res.k_true is None else f"   true {res.k_true[i]:.4f}"
        lo, hi = res.k_interval[i]
        ok, why = res.identifiable[i]
        flag = "" if ok else f"   not identifiable: {why}"
        lines.append(
            f"  {f.label} {f.name:<20} {res.k[i]:.4f}  90 % [{lo:.4f}, {hi:.4f}]{truth}{flag}"
        )
    lines.extend(f"  {name:<24} {value:.6g}" for name, value in res.nuisance.items())
    ad = res.adequacy
    lines.append(
        f"  fitness {res.fitness:.6g}   adequacy {ad.statistic:.3g} "
        f"({'ok' if ad.ok else 'NOT ok'}, threshold {ad.threshold:g})"
        + ("" if res.percent_err is None else f"   %err {res.percent_err:.3f}")
    )
    if getattr(args, "plot", None):
        lines.append(f"  plot: {args.plot}")
    return lines


class _RemovedWrite(argparse.Action):
    """`calibrate --write` used to rewrite the packaged file: refuse it, naming --out."""

    def __call__(self, parser: argparse.ArgumentParser, *_: object, **__: object) -> None:
        parser.error(
            "--write was removed: the calibration is written to --out FILE "
            "(default ${XDG_CONFIG_HOME:-~/.config}/ema_phm/calibration.yaml), never into the "
            "package"
        )


def add_calibrate(subparsers: Any) -> None:
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
        "excited or disagree, or when the commissioned fit does not explain the unit (the "
        "unit file then carries the warnings, shown on every use)",
    )
    add_actuator_arg(
        c,
        what="ke and gt are fitted to this actuator's HF model; with --baseline the monitor "
        "starts from its belief of this actuator (isolate the unit with the same --actuator)",
    )
    c.add_argument("--write", nargs=0, action=_RemovedWrite, help=argparse.SUPPRESS)
    add_json_arg(c, what="the fitted values and the file written")
    c.set_defaults(func=_cmd_calibrate)


def _cmd_calibrate(args: argparse.Namespace) -> int:
    from ..diagnosis.calibration import calibrate, user_calibration_file, write_calibration

    if args.baseline:
        return _cmd_commission(args)
    out = Path(args.out) if args.out is not None else user_calibration_file()
    if out.is_dir():
        raise ConfigError(
            f"--out {out} is a folder; name a file (e.g. {out / 'calibration.yaml'})"
        )
    from ..model.belief import belief_for
    from ..simulator.real_ema import calibration_window  # the HF plays the actuator here

    actuator = actuator_of(args)
    belief = belief_for(args.actuator, uncalibrated=True)
    res = calibrate(calibration_window(actuator), belief=belief)
    line: dict[str, Any] = {
        "ke": res.ke,
        "gt": res.gt,
        "mse_before_a2": res.mse_before,
        "mse_after_a2": res.mse_after,
        "ke_before": res.ke_before,
        "gt_before": res.gt_before,
        "evaluations": res.evaluations,
    }
    line["written"] = str(write_calibration(res, out))
    emit(args, line, _calibration_lines(line))
    return 0


def _calibration_lines(line: dict[str, Any]) -> list[str]:
    """The text of `calibrate`: ke and gt before and after, the current error, the file."""
    return [
        f"calibrated the monitor to the HF in {line['evaluations']} evaluations: "
        f"ke {line['ke_before']:.6g} -> {line['ke']:.6g}, gt {line['gt_before']:.6g} -> "
        f"{line['gt']:.6g}; current MSE {line['mse_before_a2']:.4g} -> "
        f"{line['mse_after_a2']:.4g} A^2",
        f"wrote {line['written']} (use it with `ema-phm isolate --calibration FILE`)",
    ]


def _cmd_commission(args: argparse.Namespace) -> int:
    from ..diagnosis.commissioning import commission, review, write_unit
    from ..telemetry import bags

    if args.out is None:
        raise ConfigError("calibrate --baseline needs --out UNIT.yaml (the unit file to write)")
    out = Path(args.out)
    if out.is_dir():
        raise ConfigError(f"--out {out} is a folder; name a file (e.g. {out / 'unit.yaml'})")
    belief = belief_of(args)
    windows = [bags.read_window(b).validated() for b in args.baseline]
    checks, problems = review(windows, [str(b) for b in args.baseline], belief=belief)
    _refuse_unless_forced(args, problems)
    res = commission(windows, belief=belief, checks=checks)
    problems += res.unexplained()
    _refuse_unless_forced(args, problems)
    res = dataclasses.replace(res, forced=bool(problems))
    res.sources.extend(str(b) for b in args.baseline)
    for warning in res.warnings:  # factors at a search bound: a warning, never a refusal
        warnings.warn(warning, stacklevel=1)
    res.warnings.extend(problems)
    for problem in problems:
        warnings.warn(f"commissioned with --force despite: {problem}", stacklevel=1)
    line = {
        "warnings": res.warnings,
        "baseline_checks": [c.as_dict() for c in checks],
        "factors": res.factors,
        "interval90": res.intervals,
        "identifiable": res.identifiable,
        "at_bound": res.at_bound,
        "unknowns": res.unknowns,
        "healthy_references": [ref.as_dict() for ref in res.references],
        "fitness_before": res.fitness_before,
        "fitness_after": res.fitness_after,
        "temperature_c": res.temperature_c,
        "wall_s": res.wall_s,
        "written": str(write_unit(res, out)),
    }
    emit(args, line, _commission_lines(line))
    return 0


def _finite(v: Any) -> bool:
    return isinstance(v, (int, float)) and math.isfinite(v)


def _commission_lines(line: dict[str, Any]) -> list[str]:
    """The text of `calibrate --baseline`: each factor with its interval, the fits, the file."""
    checks = line["baseline_checks"]
    temperature = line["temperature_c"]
    lines = [
        f"commissioned one unit from {len(checks)} baseline(s) in {line['wall_s']:.1f} s"
        + (f" at {temperature:g} degC" if _finite(temperature) else "")
        + ": fitness "
        + ", ".join(
            f"{a:.4g} -> {b:.4g}"
            for a, b in zip(line["fitness_before"], line["fitness_after"], strict=False)
        ),
    ]
    for name, factor in line["factors"].items():
        if name in line["unknowns"]:
            continue  # said in its own units below
        lo, hi = line["interval90"].get(name, (float("nan"), float("nan")))
        notes = [] if line["identifiable"].get(name, True) else ["not identifiable"]
        if name in line["at_bound"]:
            notes.append("at a search bound")
        interval = (
            f"90 % [{lo:.4f}, {hi:.4f}]" if _finite(lo) and _finite(hi) else "no 90 % interval"
        )
        lines.append(
            f"  {name:<16} x {factor:.4f}  {interval}"
            + (f"  ({', '.join(notes)})" if notes else "")
        )
    lines.extend(_unknown_lines(line["unknowns"]))
    for ref in line["healthy_references"]:
        head = (
            f"  healthy reference {ref['name']} ({ref['fit']} fit): model error "
            f"{ref['model_error']:.3g}"
        )
        if ref["ratio"] is None:
            lines.append(
                f"{head}, measured on these baselines (the actuator description gives no "
                "level to judge it by; later windows are judged against it)"
            )
            continue
        lines.append(
            f"{head}, {ref['ratio']:.3g} x expected "
            f"({'ok' if ref['ok'] else 'NOT ok'}, limit {ref['limit']:g})"
        )
    lines.extend(f"  warning: {w}" for w in line["warnings"])
    lines.append(f"wrote {line['written']} (use it with `ema-phm isolate --unit FILE`)")
    return lines


def _unknown_lines(unknowns: dict[str, Any]) -> list[str]:
    """One line per quantity the actuator file left unknown: its value and 90 % interval."""
    out = []
    for name, u in unknowns.items():
        unit = QUANTITIES[name].split(" (")[0]
        said = (
            f"90 % [{u['interval90'][0]:.4g}, {u['interval90'][1]:.4g}]"
            if u["identified"]
            else f"not identified ({u['warning']})"
        )
        out.append(
            f"  {name} = {u['value']:.4g} {unit}  {said}  (unknown in the actuator file: "
            f"[{u['range'][0]:.4g}, {u['range'][1]:.4g}])"
        )
    return out


def _refuse_unless_forced(args: argparse.Namespace, problems: list[str]) -> None:
    """ConfigError (exit 2, one line) naming the first problem, unless --force."""
    if problems and not args.force:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise ConfigError(f"not commissioned: {problems[0]}{more}; --force commissions anyway")
