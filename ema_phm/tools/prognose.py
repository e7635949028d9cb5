"""`ema-phm prognose BAG`: replay a multi-window bag, isolate each window, RUL from the history.

The work is in `ema_phm.monitor.replay` (the live monitor's policy on a recording) and
`ema_phm.telemetry.cycle_bags` (the bag layout); `prognose_report` prints the result and
`prognose_plot` draws it.
"""

# Work is imported where a command runs it, so that `ema-phm --help` and every command start
# without loading scipy, numba, matplotlib or rclpy for the others.
# ruff: noqa: PLC0415

from __future__ import annotations

import argparse
from typing import Any

from ..domain.cycles import DEFAULT_CYCLE_HOURS  # neither --cycle-hours nor the bag
from ..domain.faults import FAULTS, LABELS, N_K, NOT_APPLICABLE
from ..errors import EmaPhmError
from ..limits import Limit
from .args import (
    add_actuator_arg,
    add_fit_args,
    belief_of,
    growth_priors_arg,
    limited,
    plot_path,
    thresholds_arg,
)
from .output import add_json_arg, emit
from .prognose_report import Outcome, as_json, outcome_lines, print_window

#: --horizon: cycles; --noise-floor: an sd of severity.
_horizon_arg = limited(
    "horizon", label="--horizon", limit=Limit(0.0, 1e9, "cycles", low_open=True)
)
_noise_floor_arg = limited(
    "noise_floor", label="--noise-floor", limit=Limit(0.0, 0.5, low_open=True)
)


def _thresholds_help() -> str:
    ignored = " and ".join(LABELS[i] for i in NOT_APPLICABLE)
    without = ", ".join(FAULTS[i].title for i in NOT_APPLICABLE)
    return (
        "failure threshold of each fault's severity (default: the monitor's ERROR "
        f"thresholds; {ignored} are ignored: no RUL for {without})"
    )


def add_prognose(subparsers: Any) -> None:
    """The `prognose` subcommand."""
    p = subparsers.add_parser(
        "prognose",
        help="replay a multi-window bag: isolate each window, RUL per fault from the history",
    )
    p.add_argument(
        "bag",
        help="one unit's life: a bag of `ema-phm simulate --windows N --degradation F`, or a "
        "folder of one-window recordings (`ema-phm import`)",
    )
    add_fit_args(p)
    p.add_argument(
        "--cycle-hours",
        type=limited("cycle_hours", label="--cycle-hours"),
        metavar="H",
        help=f"operating hours per cycle (default: the bag's, else {DEFAULT_CYCLE_HOURS:g})",
    )
    _add_prognosis_args(p)
    add_actuator_arg(p, what="the monitor believes it is watching this actuator")
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
    add_json_arg(p, what="every window and the summary")
    p.add_argument(
        "--plot", type=plot_path, help="draw k with intervals over cycles and the RUL cone"
    )
    p.set_defaults(func=_cmd_prognose)


def _add_prognosis_args(p: argparse.ArgumentParser) -> None:
    """--horizon, --thresholds and --noise-floor: how the RUL is predicted from the history."""
    p.add_argument(
        "--horizon",
        type=_horizon_arg,
        default=10.0,
        metavar="CYCLES",
        help="horizon of the probability of reaching the threshold, in cycles",
    )
    p.add_argument(
        "--thresholds",
        type=thresholds_arg,
        default=None,
        metavar=f"T1,...,T{N_K}",
        help=_thresholds_help(),
    )
    p.add_argument(
        "--noise-floor",
        type=_noise_floor_arg,
        default=0.01,
        metavar="SD",
        help="smallest noise sd the trend fit assumes for a k estimate (larger: wider RUL "
        "intervals, later detection; docs/prognostics.md)",
    )
    p.add_argument(
        "--growth-priors",
        type=growth_priors_arg,
        default=None,
        metavar="FILE.yaml|none",
        help="how fast each fault grew in your fleet's past lives (YAML: fault: {linear: "
        "[median, log sd], exponential: [median, log sd], p_exponential: P}); 'none': no "
        "growth prior; default: the packaged ones (docs/prognostics.md)",
    )


def _belief_words(args: argparse.Namespace) -> str:
    """Which belief the windows are fitted with, in words (the actuator only when named)."""
    if args.actuator is None:
        return f"unit {args.unit or 'none: the packaged belief'}"
    return f"actuator {args.actuator}, unit {args.unit or 'none'}"


def _cycle_hours(args: argparse.Namespace, meta: dict[str, Any]) -> tuple[float, str]:
    """Hours per cycle and where they came from: --cycle-hours, the bag, or the default."""
    meta_hours = meta.get("cycle_hours")
    if args.cycle_hours is not None:
        return float(args.cycle_hours), "--cycle-hours"
    if meta_hours is not None:
        from ..domain.cycles import check_cycle_hours

        return check_cycle_hours(meta_hours, label="bag run_info cycle_hours"), "bag"
    return DEFAULT_CYCLE_HOURS, "default"


def _cmd_prognose(args: argparse.Namespace) -> int:
    from ..diagnosis.isolation import DEFAULT_PRESET, PRESETS
    from ..diagnosis.isolation_settings import FitSettings
    from ..evaluation.truth import score, true_end_of_life
    from ..fleet.catalog import read_life
    from ..monitor.replay import ALPHA, replay
    from ..prognostics.rul import failure_thresholds

    preset = args.preset or DEFAULT_PRESET
    if preset not in PRESETS:
        raise EmaPhmError(f"unknown preset {preset!r}; choose from {', '.join(sorted(PRESETS))}")
    thresholds = failure_thresholds(args.thresholds)
    belief = belief_of(args, unit=args.unit)
    windows = read_life(args.bag)
    hours, hours_from = _cycle_hours(args, windows[0].meta)
    if not args.json:
        print(
            f"{args.bag}: {len(windows)} windows, {hours:g} h per cycle ({hours_from}); "
            f"isolation as `ema-phm isolate` (preset {preset}, seed {args.seed}, nuisances "
            f"searched, {_belief_words(args)})"
        )
    # as `ema-phm isolate`: the unmeasured-load nuisances are searched
    fit = FitSettings(preset=preset, seed=args.seed, max_evaluations=args.max_evaluations or 0)
    replayed = replay(
        windows,
        fit=fit,
        cycle_hours=hours,
        horizon_cycles=args.horizon,
        thresholds=thresholds,
        noise_floor=args.noise_floor,
        growth_priors=args.growth_priors,
        belief=belief,
        count_unexplained=args.count_unexplained,
        on_window=None if args.json else print_window,
    )
    eol = true_end_of_life(windows, thresholds)
    outcome = Outcome(replayed, eol, score(replayed, eol), hours, hours_from, preset, thresholds)
    if args.plot:
        from .prognose_plot import plot_prognosis

        plot_prognosis(replayed, eol, args.plot, alpha=ALPHA)
    emit(args, as_json(args, outcome), outcome_lines(args, outcome))
    return 0
