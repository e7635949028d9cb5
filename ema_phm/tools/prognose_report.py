"""What `ema-phm prognose` prints: a line block per window, then a summary (or one JSON object)."""

# Work is imported where a command runs it, so that `ema-phm --help` and every command start
# without loading scipy, numba, matplotlib or rclpy for the others.
# ruff: noqa: PLC0415

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

from ..domain.faults import FAULTS


@dataclass(frozen=True)
class Outcome:
    """A replayed bag: every window, the true ends of life, the scores and how it was run."""

    replayed: Sequence[Any]
    eol: Mapping[str, int | None]
    scores: Mapping[str, Mapping[str, Any]]
    hours: float
    hours_from: str
    preset: str
    thresholds: Sequence[float]
    assessed: list[Any] = field(init=False)

    def __post_init__(self) -> None:
        """The windows assessed (not skipped), in order."""
        object.__setattr__(self, "assessed", [r for r in self.replayed if not r.skipped])

    @property
    def final(self) -> Any:
        """The prognosis after the last assessed window (None: none was)."""
        return self.assessed[-1].prognosis if self.assessed else None

    @property
    def intervals(self) -> str:
        """Where the k intervals of the assessed windows came from, in words."""
        sources = {r.interval_source for r in self.assessed}
        if not self.assessed:
            return "no window assessed"
        if sources == {"isolate"}:
            return "isolate's 90 % intervals"
        if sources == {"unavailable"}:
            return (
                "unavailable: isolate gave no k_interval, zero-width intervals used (noise "
                "learned from the scatter)"
            )
        return "isolate's 90 % intervals where given, zero-width elsewhere"


def _json_safe(obj: Any) -> Any:
    """`obj` with non-finite floats as None (JSON has no inf or NaN)."""
    if isinstance(obj, dict):
        return {k: _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json_safe(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def as_json(args: argparse.Namespace, o: Outcome) -> dict[str, Any]:
    """The one JSON object of `prognose --json` (non-finite numbers as null)."""
    out = {
        "bag": str(args.bag),
        "cycle_hours": o.hours,
        "cycle_hours_source": o.hours_from,
        "horizon_cycles": args.horizon,
        "noise_floor": args.noise_floor,
        "growth_priors": "packaged" if args.growth_priors is None else args.growth_priors,
        "thresholds": list(o.thresholds),
        "preset": o.preset,
        "seed": args.seed,
        "unit": args.unit,
        "intervals": o.intervals,
        "windows": [r.as_dict() for r in o.replayed],
        "summary": {
            "assessed_windows": len(o.assessed),
            "skipped_windows": len(o.replayed) - len(o.assessed),
            "skipped": [{"cycle": r.cycle, "reason": r.skipped} for r in o.replayed if r.skipped],
            "final": None if o.final is None else o.final.as_dict(),
            "true_eol_cycles": o.eol,
            "scores": o.scores,
        },
    }
    if args.actuator is not None:
        out["actuator"] = args.actuator
    if args.plot:
        out["plot"] = str(args.plot)
    return dict(_json_safe(out))


def _fmt_rul(p: Any) -> str:
    def f(v: float) -> str:
        return "never" if not math.isfinite(v) else f"{v:.4g}"

    return f"{f(p.p50)} [{f(p.p5)}, {f(p.p95)}]"


def _quiet_line(r: Any) -> list[str]:
    """One line naming the faults with no RUL yet, and why (empty if every fault has one)."""
    quiet = [
        f.name for f in r.prognosis.faults if f.status in ("no_degradation", "insufficient_data")
    ]
    if not quiet:
        return _unseen_line(r)
    status = {f.status for f in r.prognosis.faults if f.name in quiet}
    why = (
        "no degradation detected"
        if status == {"no_degradation"}
        else "not enough estimates yet"
        if status == {"insufficient_data"}
        else "no degradation detected or not enough estimates"
    )
    return [f"    {why}: {', '.join(quiet)}", *_unseen_line(r)]


def _unseen_line(r: Any) -> list[str]:
    """One line naming the faults the recordings cannot show (empty if none)."""
    unseen = [f.name for f in r.prognosis.faults if f.status == "not_seen"]
    return [f"    not seen in these recordings: {', '.join(unseen)}"] if unseen else []


def _window_lines(r: Any) -> list[str]:
    if r.skipped:  # the reason says what happened (monitor.window_rule)
        return [f"cycle {r.cycle:>4}: skipped: {' '.join(r.skipped.split())}"]
    ks = "  ".join(
        f"{f.label} {r.k[f.index]:.3f}"
        + (
            f" [{r.k_low[f.index]:.3f},{r.k_high[f.index]:.3f}]"
            if r.interval_source == "isolate"
            else ""
        )
        for f in FAULTS
    )
    lines = [f"cycle {r.cycle:>4}: {ks}"]
    for f in r.prognosis.faults:
        if f.status == "degrading":
            lines.append(
                f"    {f.name}: RUL {_fmt_rul(f.rul_cycles)} cycles = {_fmt_rul(f.rul_hours)} h "
                f"(5-50-95 %), P(threshold {f.threshold:g} within {r.prognosis.horizon_cycles:g} "
                f"cycles) {f.p_within_horizon:.2f}"
            )
    return lines + _quiet_line(r)


def print_window(r: Any) -> None:
    """Print one replayed window as it is done (replay's `on_window`)."""
    print("\n".join(_window_lines(r)), flush=True)


def _relative_accuracy_text(ra: float | None, na: str, lam: float) -> str:
    """RA is -inf when the prognosis at lambda had no finite median RUL: say that instead."""
    if ra is None:
        return na
    if not math.isfinite(ra):
        return f"n/a (no finite median RUL predicted at lambda {lam:g})"
    return f"{ra:.3f}"


def _score_line(name: str, s: Mapping[str, Any]) -> str:
    """One fault's scores against its true end of life (alpha and lambda: monitor.replay's)."""
    from ..monitor.replay import ALPHA, LAMBDA

    if not s.get("predictions"):
        return f"  truth: {name} reaches its threshold at cycle {s['true_eol_cycle']}"
    ra = s["relative_accuracy_at_lambda"]
    na = "n/a (no window at or after lambda)"
    return (
        f"  truth: {name} reaches its threshold at cycle {s['true_eol_cycle']}: prognostic "
        f"horizon {s['prognostic_horizon_cycles']:g} cycles (alpha {ALPHA:g}); alpha-lambda "
        f"(alpha {ALPHA:g}) at lambda {LAMBDA:g}: "
        f"{na if s['alpha_lambda'] is None else s['alpha_lambda']}"
        f", at every window from lambda {LAMBDA:g} on: "
        f"{na if s['alpha_lambda_from_lambda'] is None else s['alpha_lambda_from_lambda']}; "
        f"relative accuracy at lambda {LAMBDA:g}: {_relative_accuracy_text(ra, na, LAMBDA)}; 90 % "
        f"interval coverage {s['interval_coverage_90']:.2f} over the "
        f"{s['windows_with_rul']} of {s['predictions']} windows before the end of life that "
        "gave a RUL"
    )


def outcome_lines(args: argparse.Namespace, o: Outcome) -> list[str]:
    """The text summary after the windows: intervals, skipped windows, final state, scores."""
    lines = [
        f"intervals: {o.intervals}",
        f"summary after {len(o.assessed)} counted (assessed and explained) of "
        f"{len(o.replayed)} windows:",
    ]
    for r in o.replayed:
        if r.skipped:
            lines.append(f"  skipped cycle {r.cycle}: {' '.join(r.skipped.split())}")
    if o.final is None:
        lines.append("  no window could be assessed: no prognosis")
    else:
        for f in o.final.faults:
            lines.append(f"  {f.name:<20} {f.status:<17} {' '.join(f.message.split())}")
    lines.extend(_score_line(name, s) for name, s in o.scores.items())
    if args.plot:
        lines.append(f"plot: {args.plot}")
    return lines
