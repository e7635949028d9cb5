"""Which windows a prognosis counts, and why one is skipped: one rule, live and offline.

The live monitor's `tracker.PrognosticTracker` and the offline replay (`replay.replay`,
`ema-phm prognose`) both ask a `WindowRule`; a window is skipped, with its reason, when:

- it cannot be fitted (`fit_problem`: a non-finite sample, an uneven time base, too few
  samples, or a sample rate other than the run's).  Live, the monitor's window intake
  already refuses such windows before they are fitted; offline the replay asks first;
- its cycle is not after the last fitted window's cycle of the same run (`order_problem`:
  a duplicated cycle, or a step back).  The first one fitted is kept; nothing is cleared;
- its fit is not explained by the monitor model (adequacy not ok): its k describes a misfit,
  not the actuator, and one such k would tilt a trend.

A window of a new run starts a new history (a new life): the run is the stream's identity,
``hardware_id`` and ``run_id`` of its run_info (`run_identity`).  A stream that carries
neither is one run; a restart of it steps back and is skipped until its cycles pass the last
one.  Windows not assessed (not excited, failed) are not fitted: they move nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

from ..domain.window import Window
from ..errors import WindowError

#: run_info keys that identify a stream (a unit and one run of it).
RUN_KEYS: tuple[str, ...] = ("hardware_id", "run_id")
#: Relative difference of sample rate tolerated between a window and its run.
RATE_TOLERANCE = 1e-6


def run_identity(info: Mapping[str, Any] | None) -> tuple[str, ...] | None:
    """The stream's identity from a run_info mapping; None when it carries none."""
    if not info:
        return None
    ident = tuple(str(info.get(key, "")) for key in RUN_KEYS)
    return ident if any(ident) else None


def run_sample_rate(info: Mapping[str, Any] | None) -> float | None:
    """The run's sample rate [Hz] from its run_info, None when it does not say."""
    try:
        rate = float((info or {}).get("sample_rate"))  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None
    return rate if math.isfinite(rate) and rate > 0 else None


@dataclass(frozen=True)
class Verdict:
    """Whether a fitted window counts, why not, and whether it starts a new history."""

    counts: bool
    reason: str = ""
    new_run: bool = False


class WindowRule:
    """Remembers the last fitted window's cycle and run; decides what counts."""

    def __init__(self) -> None:
        self.last_cycle: float | None = None
        self.run: tuple[str, ...] | None = None

    @staticmethod
    def fit_problem(window: Window, sample_rate: float | None = None) -> str:
        """Why `window` cannot be fitted ('' when it can); `sample_rate` is the run's [Hz]."""
        try:
            window.validated()
        except WindowError as exc:
            return f"bad window: {exc}"
        if sample_rate is not None and sample_rate > 0:
            rate = 1.0 / window.dt
            if abs(rate - sample_rate) > RATE_TOLERANCE * sample_rate:
                return (
                    f"bad window: sampled at {rate:.6g} Hz, the run at {sample_rate:.6g} Hz "
                    "(not a window of this run)"
                )
        return ""

    def _is_new_run(self, run: tuple[str, ...] | None) -> bool:
        return self.last_cycle is not None and run is not None and run != self.run

    def order_problem(self, cycle: float, run: tuple[str, ...] | None = None) -> str:
        """Why a window of `cycle` (of `run`) would not count for its order ('' if it would)."""
        if not math.isfinite(cycle):
            return f"cycle {cycle!r} is not a number"
        if self.last_cycle is None or self._is_new_run(run):
            return ""
        if cycle == self.last_cycle:
            return f"cycle {cycle:g} again (duplicate): the first one is kept, not counted"
        if cycle < self.last_cycle:
            return (
                f"cycle {cycle:g} steps back from cycle {self.last_cycle:g} of the same run: "
                "not counted"
            )
        return ""

    def judge(
        self,
        cycle: float,
        adequacy: Mapping[str, Any] | Any | None = None,
        run: tuple[str, ...] | None = None,
    ) -> Verdict:
        """Judge a fitted window (its adequacy a mapping, an `Adequacy` or None: untested).

        A window in order becomes the last fitted one, counted or not.
        """
        why = self.order_problem(cycle, run)
        if why:
            return Verdict(False, why)
        new_run = self._is_new_run(run)
        self.last_cycle, self.run = float(cycle), run if run is not None else self.run
        ok, stat, threshold = _adequacy(adequacy)
        if not ok:
            return Verdict(
                False,
                f"the monitor model does not explain this window (adequacy {stat:.3g} > "
                f"{threshold:.3g}): not counted",
                new_run,
            )
        return Verdict(True, "", new_run)


def _adequacy(a: Mapping[str, Any] | Any | None) -> tuple[bool, float, float]:
    if a is None:
        return True, math.nan, math.nan
    if isinstance(a, Mapping):
        return (
            bool(a.get("ok", True)),
            float(a.get("statistic", math.nan)),
            float(a.get("threshold", math.nan)),
        )
    return bool(a.ok), float(a.statistic), float(a.threshold)
