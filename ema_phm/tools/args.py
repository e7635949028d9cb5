"""What the `ema-phm` subcommands share: checked argparse types, option groups, the parser.

The subcommand modules (simulate, diagnose, prognose, demo) import from here (play has
its own two argument types) and `cli.py` assembles them; no subcommand module imports
another or `cli.py`.
"""

# Work is imported where a command runs it, so that `ema-phm --help` and every command start
# without loading scipy, numba, matplotlib or rclpy for the others.
# ruff: noqa: PLC0415

from __future__ import annotations

import argparse
import sys
import warnings
from dataclasses import replace
from pathlib import Path
from typing import Any, Callable

from ..domain.faults import N_K
from ..errors import ConfigError, EmaPhmError
from ..limits import LIMITS, Limit, check
from ..model.belief import MonitorBelief, belief_for
from ..model.unit_file import read_warnings
from ..physics.parameters import ActuatorParameters


def limited(
    name: str, *, label: str | None = None, limit: Limit | None = None
) -> Callable[[str], float | int]:
    """Argparse `type=` for an option bounded by `limit` (default LIMITS[name]), named `label`.

    Every failure (not a number, not an integer, too many digits, inf/nan, out of
    range) becomes argparse's one-line usage error naming the option and the value
    as typed, never an OverflowError/ValueError traceback.
    """
    lim = limit or LIMITS[name]
    shown = label or name

    def convert(text: str) -> float | int:
        try:
            if lim.integer:
                int(text)  # "1.5" and "1e3" are not seeds or counts
            return check(name, text, limit=lim, label=shown)
        except (ValueError, OverflowError):  # ConfigError is a ValueError
            shortened = text if len(text) <= 40 else f"{text[:20]}...({len(text)} characters)"
            raise argparse.ArgumentTypeError(
                f"{shown} must be {lim.describe()}, got {shortened!r}"
            ) from None

    convert.__name__ = shown
    return convert


def plot_path(text: str) -> Path:
    """Argparse `type=` for --plot: a file matplotlib can write, checked before any work."""
    from .plotting import check_plot_path

    try:
        return check_plot_path(Path(text), label="plot file")
    except ConfigError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Every `ema-phm` help: an option's default shown, unless it has none worth showing.

    "(default: X)" is added to an option whose default is not None, False or SUPPRESS and
    whose help does not name it already (``%(default)s``); descriptions keep their own
    line breaks.
    """

    def _get_help_string(self, action: argparse.Action) -> str | None:
        """The help, with its default when `shows_default(action)`."""
        text = action.help or ""
        if shows_default(action) and "%(default)" not in text:
            return f"{text} (default: %(default)s)".lstrip()
        return action.help


def shows_default(action: argparse.Action) -> bool:
    """True for an option whose default the help shows (not None, False or SUPPRESS)."""
    default = action.default
    if default is None or default is False or default is argparse.SUPPRESS:
        return False
    if action.help is argparse.SUPPRESS:
        return False
    return bool(action.option_strings) or action.nargs in (
        argparse.OPTIONAL,
        argparse.ZERO_OR_MORE,
    )


class OneLineParser(argparse.ArgumentParser):
    """argparse that reports a bad argument as one line and exit code 2.

    Its help is `HelpFormatter`'s, as is that of every subparser made with
    ``parser_class=OneLineParser``.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> None:  # type: ignore[override]
        """Exit 2 with `prog: error: message` on one line (no usage block)."""
        self.exit(2, f"{self.prog}: error: {message}\n")


def add_actuator_arg(p: argparse.ArgumentParser, *, what: str) -> None:
    """--actuator FILE.yaml: the actuator `what` (default: the packaged thesis actuator)."""
    p.add_argument(
        "--actuator",
        default=None,
        metavar="FILE.yaml",
        help=f"actuator file (ema_phm/physics/actuator_file.py): {what} (default: the "
        "packaged thesis actuator, config/actuators/thesis_ema.yaml)",
    )


def actuator_of(args: argparse.Namespace) -> ActuatorParameters:
    """The actuator --actuator describes (absent: the packaged thesis actuator)."""
    if args.actuator is None:
        return ActuatorParameters.default()
    from ..physics.actuator_file import load_actuator

    return load_actuator(args.actuator)


def belief_of(
    args: argparse.Namespace, *, calibration: str | None = None, unit: str | None = None
) -> MonitorBelief:
    """The monitor's belief of the --actuator (`belief_for`), with a unit's warnings issued.

    `calibration`: a calibration file's ke and gt instead of the packaged ones.  `unit`: a
    unit file (`ema-phm calibrate --baseline`), whose warnings are issued.
    """
    belief = belief_for(args.actuator, calibration=calibration, unit_file=unit)
    said = read_warnings(unit) if unit else []
    for text in said:
        warnings.warn(text, stacklevel=1)
    for name, (low, high) in belief.unknowns.items():
        # a unit file that leaves it unknown (and does not already say so)
        if unit and not any(name in text for text in said):
            warnings.warn(
                f"{name} is unknown in [{low:.4g}, {high:.4g}] (the actuator file) and not "
                f"identified by unit file {unit}: the monitor uses {belief.value(name):.4g}",
                stacklevel=1,
            )
    return belief


def add_command_args(p: argparse.ArgumentParser) -> None:
    """The command and load options of a simulated window (defaults: config/commands.yaml)."""
    g = p.add_argument_group("command and load (defaults: config/commands.yaml)")
    g.add_argument("--command", dest="kind", choices=("chirp", "step", "ramp", "sine"))
    g.add_argument(
        "--amplitude", type=limited("amplitude"), help="rad at the user shaft (ramp: rad/s)"
    )
    g.add_argument(
        "--f0",
        type=limited("frequency", label="f0"),
        help="Hz, chirp start / sine frequency (below half the telemetry sample rate)",
    )
    g.add_argument(
        "--f1",
        type=limited("frequency", label="f1"),
        help="Hz, chirp end frequency (below half the telemetry sample rate)",
    )
    g.add_argument("--duration", type=limited("duration"), help="s, window length")
    g.add_argument("--load", type=limited("load"), help="N*m at the user shaft (constant)")


def add_unit_args(p: argparse.ArgumentParser) -> None:
    """Which unit of the actuator is simulated, and its temperature and load environment."""
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
        type=limited("seed", label="--unit-seed"),
        metavar="S",
        help="draw the unit from config/unit_tolerances.yaml with this seed",
    )
    g.add_argument(
        "--temperature",
        type=limited("temperature", label="--temperature"),
        metavar="C",
        help="winding and magnet temperature [degC]: R and the back-EMF constant follow it; "
        "the telemetry's temperature channel reads it (default: unknown, the datasheet values)",
    )
    g.add_argument(
        "--load-spring",
        type=limited("load_spring", label="--load-spring"),
        metavar="NM_PER_RAD",
        help="hinge-moment load -NM_PER_RAD * theta_u on top of --load",
    )
    g.add_argument(
        "--load-unmeasured",
        action="store_true",
        help="the load acts but the telemetry's load channel is NaN (not measured)",
    )


def command_and_load(args: argparse.Namespace) -> tuple[Any, Any]:
    """The CommandSpec and LoadSpec the options of `add_command_args`/`add_unit_args` give."""
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


class ProgressBar:
    """A one-line progress bar on stderr (only when stderr is a terminal)."""

    def __init__(self, total: int) -> None:
        self.total = max(total, 1)
        self.on = sys.stderr.isatty()

    def __call__(self, p: Any) -> None:
        """Draw the bar for progress `p` (evaluations, best_fitness, stage)."""
        if not self.on:
            return
        frac = min(p.evaluations / self.total, 1.0)
        bar = "#" * int(30 * frac)
        sys.stderr.write(
            f"\r[{bar:<30}] {p.evaluations:>6} evals  best {p.best_fitness:.4g}  ({p.stage})"
        )
        sys.stderr.flush()

    def close(self) -> None:
        """End the bar's line."""
        if self.on:
            sys.stderr.write("\n")


def thresholds_arg(text: str) -> tuple[float, ...]:
    """Argparse `type=` for --thresholds: N_K comma-separated failure thresholds."""
    fields = [f.strip() for f in text.split(",")]
    try:
        values = tuple(float(f) for f in fields)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"--thresholds must be {N_K} comma-separated numbers, got {text!r}"
        ) from None
    if len(values) != N_K:
        raise argparse.ArgumentTypeError(
            f"--thresholds must have {N_K} entries (one per k), got {len(values)} in {text!r}"
        )
    return values


def growth_priors_arg(text: str) -> dict[str, Any] | None:
    """--growth-priors: 'none' ({}) or a YAML file of growth priors, checked."""
    from ..prognostics.learn import load_growth_priors  # noqa: PLC0415

    try:
        return load_growth_priors(text)
    except EmaPhmError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_fit_args(p: argparse.ArgumentParser) -> None:
    """--preset, --seed and --max-evaluations: how each window of a history is fitted."""
    p.add_argument("--preset", default=None, help="optimizer preset (default: the measured best)")
    p.add_argument("--seed", type=limited("seed"), default=0, help="isolation and RUL sampling")
    p.add_argument(
        "--max-evaluations",
        type=limited("max_evaluations"),
        default=None,
        help="cap on LF evaluations per window (0: the preset's own budget)",
    )
