"""Every RUL method on the same rows, scored the way PHM papers score it (issue 21).

A method is a `monitor.predictor.Predictor` (anything with ``predict(history, seed=)``).
Each trajectory's windows go through one `monitor.policy.FitPolicy` holding the method (the
live monitor's rule for which windows count: `FitPolicy.count`), and every counted window's
prognosis is reduced to a few numbers per fault (`Point`), so the metrics below are cheap.

Metrics (Saxena et al. 2010; alpha 0.2, beta 0.5; lambda counted from the first counted
window, t_P, so t_lambda is the same for every method):

- prognostic horizon (PH): t_EoL minus the first prediction whose probability inside
  r* +/- alpha t_EoL is at least beta, as a share of the true life (0 when none); "PH
  (stays)" is the stricter reading, from the first prediction after which every one meets
  it (a point method whose estimate swings through the band early scores on PH, not here);
- alpha-lambda at lambda 0.5 and 0.75: the first prediction at or after t_lambda holds
  at least beta of its probability inside (1 -/+ alpha) r*;
- cone share: of the windows from t_0.5 with a true RUL of at least CONE_MIN_RUL cycles, the
  share whose prediction holds at least beta inside the +/-alpha cone (a RUL this small
  leaves the cone under one cycle wide);
- relative accuracy at lambda 0.5 (median RUL; -inf without a RUL);
- coverage: the share of predictions with a 90 % interval (p5-p95) holding r*;
- false alarms: the monitor's RUL WARN (p5 below HORIZON_CYCLES in ALARM_WINDOWS prognoses in
  a row) on a healthy life, and on a fault that does not grow (the other faults of a
  degrading trajectory; every fault of a steady one).
"""

from __future__ import annotations

import math
import statistics
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ema_phm.domain.faults import NAMES
from ema_phm.monitor import replay
from ema_phm.monitor.policy import FitPolicy
from ema_phm.monitor.predictor import Predictor
from ema_phm.monitor.tracker import PrognosticTracker
from ema_phm.prognostics.metrics import mass_within
from ema_phm.prognostics.rul import PREDICTED, Prognosis

#: Saxena's alpha (cone half-width, a fraction; `ema-phm prognose`'s) and beta (probability
#: needed inside).
ALPHA, BETA = replay.ALPHA, 0.5
#: The lambdas alpha-lambda is judged at.
LAMBDAS = (0.5, 0.75)
#: Windows with a smaller true RUL [cycle] are left out of the cone share.
CONE_MIN_RUL = 10
_LIVE = PrognosticTracker()
#: RUL WARN as the live tracker raises it by default: p5 below this many cycles ...
HORIZON_CYCLES = float(_LIVE.horizon_cycles)
#: ... in this many prognoses in a row.
ALARM_WINDOWS = _LIVE.alarm_windows
#: Seed of the methods' sampling.
SEED = 0


@dataclass(frozen=True)
class Point:
    """One fault's prognosis at one counted window, reduced to what the metrics need."""

    cycle: int
    degrading: bool
    p5: float = math.inf
    p50: float = math.inf
    p95: float = math.inf
    cone: float = 0.0  # probability inside (1 -/+ alpha) r* (0 for a fault that does not grow)
    band: float = 0.0  # probability inside r* +/- alpha t_EoL


@dataclass
class Scored:
    """One trajectory under one method: per predicted fault its points, and the update time."""

    index: int
    kind: str
    eol: dict[str, int]
    points: dict[str, list[Point]] = field(default_factory=dict)
    update_s: list[float] = field(default_factory=list)


def _point(prog: Prognosis, name: str, cycle: int, eol: int | None) -> Point:
    f = prog.fault(name)
    if f.status != "degrading" or f.samples is None or f.rul_cycles is None:
        return Point(cycle, False)
    r = f.rul_cycles
    cone = band = 0.0
    if eol is not None and cycle < eol:
        rt = eol - cycle
        cone = mass_within(f.samples, (1 - ALPHA) * rt, (1 + ALPHA) * rt)
        band = mass_within(f.samples, rt - ALPHA * eol, rt + ALPHA * eol)
    return Point(cycle, True, r.p5, r.p50, r.p95, cone, band)


def score_trajectory(
    tr: dict, windows: list[dict], predictor: Predictor, *, oracle: bool = False, seed: int = SEED
) -> Scored:
    """Count each stored window by the live monitor's policy and reduce every prognosis.

    `oracle`: the true k replaces the estimate, the isolation's interval moved onto it.
    `seed`: the method's sampling seed (the RUL samples; the rows are the same).
    """
    eol = {n: int(c) for n, c in tr["true_eol"].items() if c is not None}
    out = Scored(tr["index"], tr["type"], eol, {NAMES[i]: [] for i in PREDICTED})
    policy = FitPolicy(predictor)
    for w in sorted(windows, key=lambda w: w["cycle"]):
        if "k" not in w:
            continue  # not isolated (no excitation): nothing to count
        t0 = time.perf_counter()
        counted = policy.count(int(w["cycle"]), fitted_row(w, oracle), seed=seed)
        if counted.prognosis is None:
            continue
        out.update_s.append(time.perf_counter() - t0)
        for name, pts in out.points.items():
            pts.append(_point(counted.prognosis, name, int(w["cycle"]), eol.get(name)))
    return out


@dataclass(frozen=True)
class _Fitted:
    """A stored row as the policy sees a fit: k, its interval and its adequacy."""

    k: np.ndarray
    k_interval: np.ndarray
    adequacy: dict[str, Any]  # as `window_rule` reads a mapping: ok, statistic


def fitted_row(w: dict, oracle: bool = False) -> _Fitted:
    """A stored window's row as the policy sees a fit (`oracle`: the true k, see below).

    The oracle's estimate is the true k and its interval the isolation's, moved to sit
    around the truth as it sat around the estimate (clipped to [0, 1]).
    """
    k = np.asarray(w["k"], dtype=np.float64)
    iv = np.asarray(w["k_interval"], dtype=np.float64)
    lo, hi = np.minimum(iv[:, 0], k), np.maximum(iv[:, 1], k)
    if oracle:
        kt = np.asarray(w["k_true"], dtype=np.float64)
        lo, hi, k = np.clip(kt - (k - lo), 0, 1), np.clip(kt + (hi - k), 0, 1), kt
    ok = bool(w.get("adequacy_ok", True))
    adequacy = {"ok": ok, "statistic": float(w["adequacy_statistic"])}
    return _Fitted(k, np.stack([lo, hi], axis=1), adequacy)


def windows_by_trajectory(data: dict) -> dict[int, list[dict]]:
    """The stored window rows of each trajectory index."""
    by_t: dict[int, list[dict]] = {}
    for w in data["windows"]:
        by_t.setdefault(int(w["trajectory"]), []).append(w)
    return by_t


def score_all(
    data: dict, predictor: Predictor, *, oracle: bool = False, seed: int = SEED
) -> list[Scored]:
    """Every planned trajectory with stored rows, under `predictor` (sampling `seed`)."""
    by_t = windows_by_trajectory(data)
    return [
        score_trajectory(tr, by_t[tr["index"]], predictor, oracle=oracle, seed=seed)
        for tr in data["plan"]
        if tr["index"] in by_t
    ]


# ---------------------------------------------------------------- per fault history
def history_metrics(pts: list[Point], eol: int) -> dict[str, Any]:
    """The metrics of one growing fault's predictions (see the module docstring)."""
    before = [p for p in pts if p.cycle < eol]
    out: dict[str, Any] = {"eol": eol, "predictions": len(before)}
    if not before:
        return out
    t_p = before[0].cycle
    first = next((p for p in before if p.band >= BETA), None)
    out["ph"] = 0.0 if first is None else (eol - first.cycle) / eol
    # the stricter reading: from the first prediction on which every later one meets it too
    stays = None
    for p in reversed(before):
        if p.band < BETA:
            break
        stays = p
    out["ph_stays"] = 0.0 if stays is None else (eol - stays.cycle) / eol
    for lam in LAMBDAS:
        t_lam = t_p + lam * (eol - t_p)
        at = next((p for p in before if p.cycle >= t_lam), None)
        out[f"al{int(lam * 100)}"] = None if at is None else at.cone >= BETA
        if lam == 0.5:
            out["ra50"] = None if at is None else _ra(at, eol)
            cone = [p for p in before if p.cycle >= t_lam and eol - p.cycle >= CONE_MIN_RUL]
            out["cone"] = (sum(p.cone >= BETA for p in cone), len(cone))
    with_rul = [p for p in before if p.degrading]
    out["covered"] = (sum(p.p5 <= eol - p.cycle <= p.p95 for p in with_rul), len(with_rul))
    out["first_rul"] = with_rul[0].cycle if with_rul else None
    return out


def _ra(p: Point, eol: int) -> float:
    rt = eol - p.cycle
    return -math.inf if not p.degrading else 1.0 - abs(rt - p.p50) / rt


def warned(pts: list[Point]) -> list[int]:
    """Cycles at which the monitor would show the RUL WARN (ALARM_WINDOWS low p5s in a row)."""
    out, streak = [], 0
    for p in pts:
        streak = streak + 1 if p.degrading and p.p5 < HORIZON_CYCLES else 0
        if streak >= ALARM_WINDOWS:
            out.append(p.cycle)
    return out


# ------------------------------------------------------------------- a population
def summary(scored: list[Scored]) -> dict[str, Any]:
    """Every figure of the comparison table over `scored` trajectories."""
    hist = [
        history_metrics(s.points[name], eol)
        for s in scored
        for name, eol in s.eol.items()
        if s.kind not in ("healthy", "steady")
    ]
    ph = [h["ph"] for h in hist if "ph" in h]
    stays = [h["ph_stays"] for h in hist if "ph_stays" in h]
    cone = [h["cone"] for h in hist if "cone" in h]
    cov = [h["covered"] for h in hist if "covered" in h]
    ra = [h["ra50"] for h in hist if h.get("ra50") is not None]
    healthy = [s for s in scored if s.kind == "healthy"]
    still = [
        s.points[name]
        for s in scored
        if s.kind != "healthy"
        for name in s.points
        if name not in s.eol
    ]
    upd = [u for s in scored for u in s.update_s]
    return {
        "histories": len(hist),
        "ph_median": statistics.median(ph) if ph else math.nan,
        "ph_p10": float(np.percentile(ph, 10)) if ph else math.nan,
        "ph_stays_median": statistics.median(stays) if stays else math.nan,
        "al50": (sum(h.get("al50") is True for h in hist), len(hist)),
        "al75": (sum(h.get("al75") is True for h in hist), len(hist)),
        "cone": (sum(c[0] for c in cone), sum(c[1] for c in cone)),
        "ra50_median": statistics.median(ra) if ra else math.nan,
        "coverage": (sum(c[0] for c in cov), sum(c[1] for c in cov)),
        "healthy_warn": (
            sum(any(warned(p) for p in s.points.values()) for s in healthy),
            len(healthy),
        ),
        "healthy_rul": (
            sum(any(q.degrading for p in s.points.values() for q in p) for s in healthy),
            len(healthy),
        ),
        "still_warn": (sum(bool(warned(p)) for p in still), len(still)),
        "still_rul": (sum(any(q.degrading for q in p) for p in still), len(still)),
        "update_ms_median": 1e3 * statistics.median(upd) if upd else math.nan,
        "update_ms_p99": 1e3 * float(np.percentile(upd, 99)) if upd else math.nan,
    }
