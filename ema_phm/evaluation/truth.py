"""Scoring a replay against the truth a simulated or test-rig recording carries.

`true_end_of_life` reads each fault's true end of life from the recording's ground truth (the
degradation description of its run_info, or the true k of each window); `score` computes the
metrics of `prognostics.metrics` per fault against it.  None of this feeds the monitor.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from ..domain.faults import NAMES, NOMINAL, PREDICTED
from ..domain.window import Window
from ..monitor.replay import ALPHA, LAMBDA, ReplayedWindow
from ..prognostics import metrics
from ..simulator.degradation import Degradation


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
