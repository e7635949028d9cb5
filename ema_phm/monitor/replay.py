"""Replaying a multi-window recording: isolate each window, prognose from the history so far.

`replay(windows)` runs the live monitor's policy (`policy.FitPolicy`) on every window in
turn: `ema_phm.diagnosis.isolation.isolate` with 90 % intervals, tracked from the last
explained fit or searched globally, and `rul.prognose` on the history up to it (the windows
`window_rule.WindowRule` counts; see `replay`);
`true_end_of_life` reads each fault's true end of life from the bag's ground truth;
`score` computes the metrics of `metrics.py` per fault against it.  `ema-phm prognose`
(`ema_phm/tools/prognose.py`) prints and draws the result.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from ..diagnosis.isolation import DEFAULT_PRESET, isolate
from ..domain.faults import NAMES, NOMINAL, PREDICTED
from ..domain.window import Window
from ..physics.degradation import Degradation
from ..prognostics import metrics
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
    seed: int = 0,
    preset: str | None = None,
    max_evaluations: int | None = None,
    cycle_hours: float = 1.0,
    horizon_cycles: float = 10.0,
    thresholds: Sequence[float] | None = None,
    noise_floor: float = 0.01,
    growth_priors: Any = None,
    belief: Any = None,
    nuisance: bool = False,
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
    history.  `belief` (a `MonitorBelief`, e.g. with a commissioned unit) and `nuisance` go
    to isolate() as they are; `seed` seeds every isolation and prognosis; `growth_priors`
    goes to `rul.prognose` (None: the fault table's).
    """
    options = {
        "seed": seed,
        "preset": preset or DEFAULT_PRESET,
        "max_evaluations": max_evaluations,
        "belief": belief,
        "nuisance": nuisance,
        "intervals": True,
    }
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
            seed=seed,
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


def true_end_of_life(
    windows: Sequence[Window], thresholds: Sequence[float]
) -> dict[str, int | None]:
    """Per predicted fault, the true end of life [cycle], when the bag tells it.

    From the run_info's degradation description when there is one (the end may lie beyond
    the recording), else the first window whose true severity reaches the threshold; None
    when neither tells.  Empty without any ground truth.
    """
    meta = windows[0].meta if windows else {}
    out: dict[str, int | None] = {}
    if isinstance(meta.get("degradation"), dict):
        deg = Degradation.from_mapping(meta["degradation"], source="(bag run_info)")
        for i in PREDICTED:
            out[NAMES[i]] = deg.first_cycle_at(NAMES[i], thresholds[i])
        return out
    truths = [(int(w.meta.get("cycle", j)), w.k_true) for j, w in enumerate(windows)]
    known = [(c, k) for c, k in truths if k is not None]
    if len(known) < len(truths):
        return {}
    for i in PREDICTED:
        hit = [c for c, k in known if abs(k[i] - NOMINAL[i]) >= thresholds[i]]
        out[NAMES[i]] = hit[0] if hit else None
    return out


def score(
    replayed: Sequence[ReplayedWindow], eol: dict[str, int | None]
) -> dict[str, dict[str, Any]]:
    """Metrics per fault with a known true end of life, over the windows before it.

    Prognostic horizon and alpha-lambda: a window whose prognosis of the fault is not
    ``degrading`` counts as a prediction of RUL inf (it meets no bound); t_P (where lambda
    counts from) is the first counted window, so lambda is a fraction of the life monitored.  The
    90 % interval coverage is over the windows that gave a RUL (``windows_with_rul``).
    """
    out: dict[str, dict[str, Any]] = {}
    for name, t_eol in eol.items():
        if t_eol is None:
            continue
        times, samples, lows, highs = [], [], [], []
        for r in replayed:
            if r.prognosis is None or r.cycle >= t_eol:
                continue
            f = r.prognosis.fault(name)
            times.append(float(r.cycle))
            if f.status == "degrading" and f.samples is not None and f.rul_cycles is not None:
                samples.append(f.samples)
                lows.append(f.rul_cycles.p5)
                highs.append(f.rul_cycles.p95)
            else:
                samples.append(np.array([np.inf]))
                lows.append(np.inf)
                highs.append(np.inf)
        if not times:
            out[name] = {"true_eol_cycle": t_eol, "predictions": 0}
            continue
        t_lam = times[0] + LAMBDA * (t_eol - times[0])
        at_lam = next((j for j, t in enumerate(times) if t >= t_lam), None)
        out[name] = {
            "true_eol_cycle": t_eol,
            "predictions": len(times),
            "prognostic_horizon_cycles": metrics.prognostic_horizon(
                times, samples, t_eol, alpha=ALPHA
            ),
            "alpha_lambda": metrics.alpha_lambda(times, samples, t_eol, alpha=ALPHA, lam=LAMBDA),
            "alpha_lambda_from_lambda": metrics.alpha_lambda_from(
                times, samples, t_eol, alpha=ALPHA, lam=LAMBDA
            ),
            "relative_accuracy_at_lambda": None
            if at_lam is None
            else metrics.relative_accuracy(samples[at_lam], times[at_lam], t_eol),
            "windows_with_rul": int(np.isfinite(lows).sum()),
            "interval_coverage_90": metrics.interval_coverage(
                np.asarray(times)[np.isfinite(lows)],
                np.asarray(lows)[np.isfinite(lows)],
                np.asarray(highs)[np.isfinite(lows)],
                t_eol,
            ),
        }
    return out
