"""The monitor's policy: when to track or restart a fit, which windows count, and the prognosis.

`FitPolicy` is used by the live monitor (`health_monitor.HealthMonitor` fits through the one
in its `MonitorState`; its `tracker.PrognosticTracker` counts through its own), by the
offline replay (`replay.replay`, `ema-phm prognose`: one policy fits and counts) and by the
prognostics benchmark (fits); the estimator and the predictor behind
it are any `estimator.Estimator` and `predictor.Predictor`.

Track, then restart: a window is fitted from the last explained fit's row (`start`: the
global stage skipped) when tracking is on and there is one; a tracked fit that the model does
not explain (a fault jumped, or the last fit was off) is done again with the global search on
the same window.  Only an explained fit (adequacy ok, or not tested) is tracked from; a fit
that raised leaves nothing to track from.

Which windows count: `window_rule.WindowRule` (see there); a counted window's estimate joins
the history (`estimates.Estimates`) and the predictor prognoses from it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..diagnosis.isolation import IsolationResult
from ..domain.window import Window
from ..errors import EmaPhmError
from ..prognostics.rul import Prognosis
from .estimates import Estimate, Estimates
from .estimator import Estimator
from .predictor import Predictor, RulPredictor
from .window_rule import Verdict, WindowRule

#: How a fit was reached: searched globally, tracked, or tracked, unexplained and searched again.
MODES: tuple[str, ...] = ("global", "tracked", "restarted")


@dataclass(frozen=True)
class Fit:
    """One window's fit under the policy: the result, its mode (`MODES`), a failed tracked fit."""

    result: IsolationResult
    mode: str
    tracked_attempt: IsolationResult | None = None  # the tracked fit a restart replaced


@dataclass(frozen=True)
class Counted:
    """A fitted window judged: whether it counts, its estimate and the prognosis after it."""

    verdict: Verdict
    estimate: Estimate | None = None  # None: not counted
    prognosis: Prognosis | None = None  # None: not counted, or no predictor


@dataclass(frozen=True)
class Step:
    """One window under the policy: skipped before a fit, or fitted and judged."""

    cycle: float
    skipped: str = ""  # why it was not fitted, not assessed or not counted ('' if counted)
    fit: Fit | None = None
    counted: Counted | None = None


def explained(result: Any) -> bool:
    """True when the model explains the fit (its adequacy is ok, or was not tested)."""
    adequacy = getattr(result, "adequacy", None)
    return adequacy is None or bool(adequacy.ok)


def not_assessed(exc: Exception) -> str:
    """A fit's failure (not excited, failed) as one line."""
    text = " ".join(str(exc).split())
    return text if text.startswith("not enough excitation") else f"not assessed: {text}"


class FitPolicy:
    """When to track or restart (`fit`), which windows count and the prognosis (`count`)."""

    def __init__(
        self,
        predictor: Predictor | None = None,
        *,
        tracking: bool = True,
        count_unexplained: bool = False,
        max_windows: int | None = None,
    ) -> None:
        """`predictor` (default `RulPredictor()`) prognoses after each counted window.

        `tracking` False: every window is searched globally.  `count_unexplained`: a fit the
        model does not explain counts anyway.  `max_windows`: estimates kept (None: all).
        """
        self.predictor: Predictor = RulPredictor() if predictor is None else predictor
        self.tracking = tracking
        self.count_unexplained = count_unexplained
        self.rule = WindowRule()
        self.estimates = Estimates(max_windows)
        self._start: np.ndarray | None = None  # the last explained fit's row

    # ------------------------------------------------------ track, then restart
    def track_from(self, row: np.ndarray | None) -> None:
        """Track the next window from `row` (a previous explained fit's; None: search)."""
        self._start = row

    @property
    def tracking_row(self) -> np.ndarray | None:
        """The row the next window is tracked from (None: it is searched globally)."""
        return self._start

    def forget_track(self) -> None:
        """Search the next window globally (e.g. a new baseline changed what k means)."""
        self._start = None

    def fit(self, window: Window, estimator: Estimator, *, tracking: bool | None = None) -> Fit:
        """Fit `window`: tracked from the last explained fit, searched again if unexplained.

        `tracking` overrides the policy's own for this window.  An exception of the
        estimator propagates and leaves nothing to track from.
        """
        track = self.tracking if tracking is None else tracking
        start = self._start if track else None
        self._start = None  # kept only if this fit is explained (below)
        result, attempt = estimator.fit(window, start), None
        if start is not None and not explained(result):
            attempt, result = result, estimator.fit(window, None)
        if explained(result):
            self._start = getattr(result, "row", None)
        mode = "global" if start is None else "tracked" if attempt is None else "restarted"
        return Fit(result, mode, attempt)

    # ----------------------------------------------------- which windows count
    def screen(
        self,
        window: Window,
        cycle: float,
        run: tuple[str, ...] | None = None,
        sample_rate: float | None = None,
    ) -> str:
        """Why `window` of `cycle` would not be fitted ('' when it would): `window_rule`."""
        return self.rule.fit_problem(window, sample_rate) or self.rule.order_problem(cycle, run)

    def count(
        self,
        cycle: float,
        fitted: Any,
        run: tuple[str, ...] | None = None,
        *,
        seed: int = 0,
        prognose: bool = True,
    ) -> Counted:
        """Judge a fitted window (an `IsolationResult` or a `health.Assessment`) and prognose.

        A window of a new run starts a new history; a counted one joins it and the
        predictor prognoses from it with `seed` (`prognose` False: the history only).
        """
        adequacy = None if self.count_unexplained else getattr(fitted, "adequacy", None)
        verdict = self.rule.judge(cycle, adequacy, run)
        if verdict.new_run:
            self.estimates.clear()
        if not verdict.counts:
            return Counted(verdict)
        estimate = Estimate.of(
            cycle,
            fitted.k,
            getattr(fitted, "k_interval", None),
            getattr(fitted, "unseen", None),
        )
        self.estimates.add(estimate)
        if not prognose:
            return Counted(verdict, estimate)
        prognosis = self.predictor.predict(self.estimates.history(), seed=seed)
        return Counted(verdict, estimate, prognosis)

    # ------------------------------------------------------------- one window
    def step(
        self,
        window: Window,
        estimator: Estimator,
        *,
        cycle: float,
        run: tuple[str, ...] | None = None,
        sample_rate: float | None = None,
        seed: int = 0,
    ) -> Step:
        """Screen, fit and count one window (offline: a window that is skipped is not fitted).

        A fit that raises an `EmaPhmError` (not excited, failed) is not assessed: skipped.
        """
        why = self.screen(window, cycle, run, sample_rate)
        if why:
            return Step(cycle, why)
        try:
            fit = self.fit(window, estimator)
        except EmaPhmError as exc:
            return Step(cycle, not_assessed(exc))
        counted = self.count(cycle, fit.result, run, seed=seed)
        return Step(cycle, counted.verdict.reason, fit, counted)
