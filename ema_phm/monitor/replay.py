"""Replaying a multi-window recording: isolate each window, prognose from the history so far.

`replay(windows)` runs `ema_phm.diagnosis.isolation.isolate` on every window in turn (with
90 % intervals when that isolate offers them) and `rul.prognose` on the history up to it
(the windows `window_rule.WindowRule` counts, the live monitor's rule; see `replay`);
`true_end_of_life` reads each fault's true end of life from the bag's ground truth;
`score` computes the metrics of `metrics.py` per fault against it.  `ema-phm prognose`
(`ema_phm/tools/prognose.py`) prints and draws the result.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Callable, Sequence

import numpy as np

from ..domain.faults import NAMES, NOMINAL
from ..domain.window import Window
from ..prognostics import metrics
from ..prognostics.rul import PREDICTED, History, Prognosis, prognose
from .window_rule import WindowRule, run_identity

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

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready values."""

        def vec(a: np.ndarray | None) -> list[float] | None:
            return None if a is None else [float(v) for v in a]

        out: dict[str, Any] = {"cycle": self.cycle, "k_true": vec(self.k_true)}
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


def _isolate_window(
    window: Window,
    *,
    seed: int,
    preset: str,
    max_evaluations: int | None,
    belief: Any = None,
    nuisance: bool = False,
):
    """isolate() with 90 % intervals when this isolate() offers them (`intervals=`)."""
    import inspect

    from ..diagnosis.isolation import isolate

    kwargs: dict[str, Any] = {"seed": seed, "preset": preset, "max_evaluations": max_evaluations}
    if belief is not None:
        kwargs["belief"] = belief
    params = inspect.signature(isolate).parameters
    if "intervals" in params:
        kwargs["intervals"] = True
    if nuisance:
        kwargs["nuisance"] = True
    return isolate(window, **kwargs)


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
    belief: Any = None,
    nuisance: bool = False,
    count_unexplained: bool = False,
    on_window: Callable[[ReplayedWindow], None] | None = None,
) -> list[ReplayedWindow]:
    """Isolate every window in turn and prognose from the history so far.

    Each window's k interval is the isolation's `k_interval` (90 %) when it has one;
    otherwise the interval is zero-width and the window says "unavailable" (nothing is
    invented).  A k outside its stated interval widens the interval to hold it.  Which
    windows count is the live monitor's rule (`window_rule`): a window that cannot be
    fitted (a non-finite sample, another sample rate than the run's), a duplicated or
    stepped-back cycle, one that does not excite the actuator enough or whose isolation
    fails, and one whose fit the monitor model does not explain (`count_unexplained`:
    counted anyway) is skipped with its reason and adds nothing to the history; a window of
    a new run (`window_rule.run_identity` of its meta) starts a new history.  `belief` (a
    `MonitorBelief`, e.g. with a commissioned unit) and `nuisance` go to isolate() as they are.
    """
    from ..diagnosis.isolation import DEFAULT_PRESET
    from ..errors import EmaPhmError

    preset = preset or DEFAULT_PRESET
    cycles: list[float] = []
    ks: list[np.ndarray] = []
    lows: list[np.ndarray] = []
    highs: list[np.ndarray] = []
    all_known = True
    out: list[ReplayedWindow] = []
    rule = WindowRule()

    def skip(item: ReplayedWindow) -> None:
        out.append(item)
        if on_window is not None:
            on_window(item)

    for w in windows:
        cycle = _cycle(w, len(out))
        run = run_identity(w.meta)
        why = rule.fit_problem(w, _rate(w.meta)) or rule.order_problem(cycle, run)
        if why:
            skip(ReplayedWindow(cycle=cycle, k_true=w.k_true, skipped=why))
            continue
        try:
            res = _isolate_window(
                w,
                seed=seed,
                preset=preset,
                max_evaluations=max_evaluations,
                belief=belief,
                nuisance=nuisance,
            )
        except EmaPhmError as exc:  # not excited, or the fit failed (live: not assessed)
            skip(ReplayedWindow(cycle=cycle, k_true=w.k_true, skipped=_one_line(exc)))
            continue
        adequacy = None if count_unexplained else getattr(res, "adequacy", None)
        verdict = rule.judge(cycle, adequacy, run)
        if verdict.new_run:
            cycles, ks, lows, highs, all_known = [], [], [], [], True
        if not verdict.counts:
            skip(
                ReplayedWindow(
                    cycle=cycle,
                    k_true=w.k_true,
                    evaluations=int(res.evaluations),
                    wall_s=float(res.wall_s),
                    skipped=verdict.reason,
                )
            )
            continue
        interval = getattr(res, "k_interval", None)
        if interval is not None:
            iv = np.asarray(interval, dtype=np.float64).reshape(8, 2)
            lo, hi = np.minimum(iv[:, 0], res.k), np.maximum(iv[:, 1], res.k)
            source = "isolate"
        else:
            lo, hi, source = res.k.copy(), res.k.copy(), "unavailable"
            all_known = False
        cycles.append(float(cycle))
        ks.append(res.k)
        lows.append(lo)
        highs.append(hi)
        history = History.from_estimates(cycles, ks, lows, highs)
        if not all_known:
            history = replace(history, intervals_known=False)
        prog = prognose(
            history,
            thresholds=thresholds,
            cycle_hours=cycle_hours,
            horizon_cycles=horizon_cycles,
            seed=seed,
            noise_floor=noise_floor,
        )
        item = ReplayedWindow(
            cycle=cycle,
            k=res.k,
            k_low=lo,
            k_high=hi,
            interval_source=source,
            k_true=w.k_true,
            evaluations=int(res.evaluations),
            wall_s=float(res.wall_s),
            prognosis=prog,
        )
        out.append(item)
        if on_window is not None:
            on_window(item)
    return out


def _cycle(w: Window, index: int) -> int:
    """The window's cycle from its meta (its position when it has none)."""
    try:
        return int(w.meta.get("cycle", index))
    except (TypeError, ValueError, OverflowError):
        return index


def _rate(meta: dict[str, Any]) -> float | None:
    """The run's sample rate [Hz] from its run_info, None when it does not say."""
    try:
        rate = float(meta.get("sample_rate"))  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None
    return rate if math.isfinite(rate) and rate > 0 else None


def _one_line(exc: Exception) -> str:
    text = " ".join(str(exc).split())
    return text if text.startswith("not enough excitation") else f"not assessed: {text}"


def true_end_of_life(
    windows: Sequence[Window], thresholds: Sequence[float]
) -> dict[str, int | None]:
    """Per predicted fault, the true end of life [cycle], when the bag tells it.

    From the run_info's degradation description when there is one (the end may lie beyond
    the recording), else the first window whose true severity reaches the threshold; None
    when neither tells.  Empty without any ground truth.
    """
    from ..physics.degradation import Degradation

    meta = windows[0].meta if windows else {}
    out: dict[str, int | None] = {}
    if isinstance(meta.get("degradation"), dict):
        deg = Degradation.from_mapping(meta["degradation"], source="(bag run_info)")
        for i in PREDICTED:
            out[NAMES[i]] = deg.first_cycle_at(NAMES[i], thresholds[i])
        return out
    truths = [(int(w.meta.get("cycle", j)), w.k_true) for j, w in enumerate(windows)]
    if any(k is None for _, k in truths):
        return {}
    for i in PREDICTED:
        hit = [c for c, k in truths if abs(k[i] - NOMINAL[i]) >= thresholds[i]]
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
