"""Replaying a multi-window recording: isolate each window, prognose from the history so far.

`replay(windows)` runs the live monitor's policy (`policy.FitPolicy`) on every window in
turn: `ema_phm.diagnosis.isolation.isolate` with 90 % intervals, tracked from the last
explained fit or searched globally, and `rul.prognose` on the history up to it (the windows
`window_rule.WindowRule` counts; see `replay`);
scoring against the truth (`ema_phm.evaluation.truth`) is not the monitor's: it reads what
a real actuator never records.  `ema-phm prognose` (`ema_phm/tools/prognose.py`) prints and
draws the result.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from ..diagnosis.isolation import isolate
from ..diagnosis.isolation_settings import FitSettings
from ..domain.window import Window
from ..prognostics.rul import Prognosis
from .estimator import IsolationEstimator
from .policy import FitPolicy, Step
from .predictor import RulPredictor
from .window_rule import run_identity, run_sample_rate

#: alpha of the alpha-lambda cone and of the prognostic-horizon bounds (issue 11: 0.2).
ALPHA = 0.2
#: lambda at which the summary scores alpha-lambda and relative accuracy.
LAMBDA = 0.5


@dataclass(frozen=True)
class ReplayedWindow:
    """One window of a replay: its isolation (or why it was skipped) and the prognosis after it."""

    cycle: int
    k: np.ndarray | None = None
    k_low: np.ndarray | None = None
    k_high: np.ndarray | None = None
    interval_source: str = ""  # "isolate" (90 %) or "unavailable"
    k_true: np.ndarray | None = None
    evaluations: int = 0
    wall_s: float = math.nan
    skipped: str = ""  # reason the window was not assessed
    prognosis: Prognosis | None = None
    fit_mode: str = ""  # `policy.MODES` ('' when not fitted)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready values."""

        def vec(a: np.ndarray | None) -> list[float] | None:
            return None if a is None else [float(v) for v in a]

        out: dict[str, Any] = {"cycle": self.cycle, "k_true": vec(self.k_true)}
        if self.fit_mode:
            out["fit_mode"] = self.fit_mode
        if self.skipped:
            out["skipped"] = self.skipped
            return out
        out.update(
            k=vec(self.k),
            k_low=vec(self.k_low),
            k_high=vec(self.k_high),
            interval_source=self.interval_source,
            evaluations=self.evaluations,
            wall_s=self.wall_s,
            prognosis=None if self.prognosis is None else self.prognosis.as_dict(),
        )
        return out


def replay(
    windows: Sequence[Window],
    *,
    fit: FitSettings | None = None,
    cycle_hours: float = 1.0,
    horizon_cycles: float = 10.0,
    thresholds: Sequence[float] | None = None,
    noise_floor: float = 0.01,
    growth_priors: Any = None,
    belief: Any = None,
    count_unexplained: bool = False,
    tracking: bool = True,
    on_window: Callable[[ReplayedWindow], None] | None = None,
) -> list[ReplayedWindow]:
    """Isolate every window in turn and prognose from the history so far: `policy.FitPolicy`.

    The windows are fitted as the live monitor fits them: tracked from the last explained
    fit, searched globally again when the tracked fit is not explained (`tracking` False:
    every window searched globally).  Each window's k interval is the isolation's
    `k_interval` (90 %) when it has one; otherwise the interval is zero-width and the window
    says "unavailable" (nothing is invented).  A k outside its stated interval widens the
    interval to hold it.  Which windows count is the live monitor's rule (`window_rule`): a
    window that cannot be fitted (a non-finite sample, another sample rate than the run's),
    a duplicated or stepped-back cycle, one that does not excite the actuator enough or
    whose isolation fails, and one whose fit the monitor model does not explain
    (`count_unexplained`: counted anyway) is skipped with its reason and adds nothing to the
    history; a window of a new run (`window_rule.run_identity` of its meta) starts a new
    history.  `fit` (default `FitSettings()`, as the live monitor) says how isolate() fits,
    with `belief` (a `MonitorBelief`, e.g. with a commissioned unit); its seed seeds every
    isolation and prognosis; `growth_priors` goes to `rul.prognose` (None: the fault table's).
    """
    fit = fit or FitSettings()
    options = fit.isolate_options(belief)
    estimator = IsolationEstimator(options, isolate)  # looked up here: tests replace it
    predictor = RulPredictor(thresholds, cycle_hours, horizon_cycles, noise_floor, growth_priors)
    policy = FitPolicy(predictor, tracking=tracking, count_unexplained=count_unexplained)
    out: list[ReplayedWindow] = []
    for w in windows:
        cycle = _cycle(w, len(out))
        step = policy.step(
            w,
            estimator,
            cycle=cycle,
            run=run_identity(w.meta),
            sample_rate=run_sample_rate(w.meta),
            seed=fit.seed,
        )
        out.append(_replayed(w, cycle, step))
        if on_window is not None:
            on_window(out[-1])
    return out


def _replayed(w: Window, cycle: int, step: Step) -> ReplayedWindow:
    """What `step` of window `w` reports; a restart's cost includes its tracked attempt."""
    if step.fit is None:
        return ReplayedWindow(cycle=cycle, k_true=w.k_true, skipped=step.skipped)
    fit, attempt = step.fit, step.fit.tracked_attempt
    spent = [fit.result] if attempt is None else [attempt, fit.result]
    evaluations = sum(int(r.evaluations) for r in spent)
    wall_s = sum(float(r.wall_s) for r in spent)
    estimate = None if step.counted is None else step.counted.estimate
    if estimate is None or step.counted is None:
        return ReplayedWindow(
            cycle=cycle,
            k_true=w.k_true,
            skipped=step.skipped,
            evaluations=evaluations,
            wall_s=wall_s,
            fit_mode=fit.mode,
        )
    return ReplayedWindow(
        cycle=cycle,
        k=fit.result.k,
        k_low=estimate.low,
        k_high=estimate.high,
        interval_source="isolate" if estimate.known else "unavailable",
        k_true=w.k_true,
        prognosis=step.counted.prognosis,
        evaluations=evaluations,
        wall_s=wall_s,
        fit_mode=fit.mode,
    )


def _cycle(w: Window, index: int) -> int:
    """The window's cycle from its meta (its position when it has none)."""
    try:
        return int(w.meta.get("cycle", index))
    except (TypeError, ValueError, OverflowError):
        return index
