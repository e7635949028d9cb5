"""The prognostics benchmark's scoring: histories of the stored rows, prognoses, metrics.

As the live monitor (`monitor.tracker`): a window whose fit the model explains (adequacy
ok) enters the history and is a prediction time; a window it does not explain adds nothing.
"""

from __future__ import annotations

import inspect
import math
import statistics
from typing import Any, Callable

import numpy as np

from ema_phm.domain.faults import N_K, NAMES, NOMINAL
from ema_phm.monitor import replay as replay_mod
from ema_phm.monitor.tracker import PrognosticTracker
from ema_phm.prognostics import metrics
from ema_phm.prognostics.rul import PREDICTED, History, Prognosis, prognose

#: What makes a prognosis from a history: `rul.prognose`, or a baseline (prog.baseline).
Predict = Callable[..., Prognosis]


def _tracker_alarm_windows() -> int:
    p = inspect.signature(PrognosticTracker.__init__).parameters.get("alarm_windows")
    return 1 if p is None or p.default is inspect.Parameter.empty else int(p.default)


#: Seed of rul.prognose's posterior-predictive sampling.
SCORE_SEED = 0
#: RUL WARN: the RUL's 5th percentile below this many cycles (rul.prognose's horizon).
HORIZON_CYCLES = 10.0
#: True RULs this small [cycle] leave the +/-20 % alpha-lambda cone around one whole cycle
#: at most (4 +/- 0.8: only 4 itself), reported apart.
SMALL_RUL = 4
#: The monitor's WARN: the RUL p5 below the horizon in this many consecutive prognoses
#: (`monitor.tracker.PrognosticTracker`'s default, read from it; 1 when it has none).
ALARM_WINDOWS = _tracker_alarm_windows()


def counts(w: dict, every_window: bool = False) -> bool:
    """Whether a window enters the prognostic history.

    As the live monitor (`monitor.tracker`): an isolated window whose fit the model
    explains (adequacy ok); with `every_window` every isolated window (as `replay` and
    `ema-phm prognose` do).
    """
    return "k" in w and (every_window or bool(w.get("adequacy_ok", True)))


def history_of(
    windows: list[dict], *, oracle: bool = False, every_window: bool = False
) -> tuple[History, list[dict]]:
    """The History of a trajectory's counted windows (`counts`, in cycle order), those windows.

    Intervals as replay.replay builds them: the isolation's 90 % k_interval, widened to
    hold k when k lies outside it.  With `oracle` the estimates are the true k and each
    interval the isolation's, moved to sit around the truth as it sat around the estimate
    (clipped to [0, 1]): the RUL model's own error, without the isolation's.
    """
    ws = sorted((w for w in windows if counts(w, every_window)), key=lambda w: w["cycle"])
    k = np.array([w["k"] for w in ws], dtype=np.float64).reshape(-1, N_K)
    iv = np.array([w["k_interval"] for w in ws], dtype=np.float64).reshape(-1, N_K, 2)
    lo, hi = np.minimum(iv[..., 0], k), np.maximum(iv[..., 1], k)
    if oracle:
        kt = np.array([w["k_true"] for w in ws], dtype=np.float64).reshape(-1, N_K)
        lo, hi = np.clip(kt - (k - lo), 0.0, 1.0), np.clip(kt + (hi - k), 0.0, 1.0)
        k = kt
    return History.from_estimates([w["cycle"] for w in ws], k, lo, hi), ws


def _replayed(
    hist: History, ws: list[dict], kw: dict, predict: Predict = prognose
) -> list[replay_mod.ReplayedWindow]:
    """A prognosis at every counted window, from the history up to it (by `predict`)."""
    replayed = []
    for n, w in enumerate(ws, start=1):
        prog = predict(hist.upto(n), **kw)
        replayed.append(
            replay_mod.ReplayedWindow(
                cycle=int(w["cycle"]),
                k=hist.k[n - 1],
                k_low=hist.k_low[n - 1],
                k_high=hist.k_high[n - 1],
                interval_source="isolate",
                k_true=np.array(w["k_true"]),
                prognosis=prog,
            )
        )
    return replayed


def _alarms(replayed: list[replay_mod.ReplayedWindow]) -> dict[str, dict[str, list[int]]]:
    """Per predicted fault, the cycles it was degrading, below the horizon, and WARN."""
    out = {}
    for i in PREDICTED:
        name = NAMES[i]
        deg, below, warn, streak = [], [], [], 0
        for r in replayed:
            f = r.prognosis.fault(name)
            low = f.status == "degrading" and f.rul_cycles.p5 < HORIZON_CYCLES
            streak = streak + 1 if low else 0
            if f.status == "degrading":
                deg.append(r.cycle)
            if low:
                below.append(r.cycle)
            if streak >= ALARM_WINDOWS:
                warn.append(r.cycle)
        # degrading: a RUL given; below: its p5 under the horizon at that prognosis; warn:
        # the monitor's WARN (below in ALARM_WINDOWS consecutive prognoses, as the tracker)
        out[name] = {"degrading": deg, "below": below, "warn": warn}
    return out


def _fault_score(
    name: str,
    s: dict,
    replayed: list[replay_mod.ReplayedWindow],
    t_eol: int,
    warn: list[int],
) -> dict[str, Any]:
    """`replay.score`'s metrics `s` of one fault, with its RULs and alpha-lambda checks."""
    t_first = float(replayed[0].cycle)
    t_lam = t_first + replay_mod.LAMBDA * (t_eol - t_first)
    rul, al_met, al_n, al_checks = [], 0, 0, []
    for r in replayed:
        if r.cycle >= t_eol:
            continue
        f = r.prognosis.fault(name)
        r_true = t_eol - r.cycle
        degrading = f.status == "degrading" and f.samples is not None
        if degrading:
            rul.append((r.cycle, f.rul_cycles.p5, f.rul_cycles.p50, f.rul_cycles.p95))
        if r.cycle >= t_lam:  # the alpha-lambda check of metrics.alpha_lambda_from
            al_n += 1
            a = replay_mod.ALPHA
            ok = bool(
                degrading
                and metrics.mass_within(f.samples, (1 - a) * r_true, (1 + a) * r_true) >= 0.5
            )
            al_met += ok
            # (true RUL, median RUL or inf without a RUL, met)
            al_checks.append((r_true, f.rul_cycles.p50 if degrading else math.inf, ok))
    s = dict(s)
    s["rul"] = rul  # (cycle, p5, p50, p95) where degrading, before the end of life
    s["first_rul_cycle"] = rul[0][0] if rul else None
    s["first_warn_cycle"] = next((c for c in warn if c < t_eol), None)
    s["al_windows"] = (al_met, al_n)  # windows from t_lambda meeting alpha-lambda, all
    s["al_checks"] = al_checks
    return s


def score_trajectory(
    tr: dict,
    windows: list[dict],
    *,
    prognose_kw: dict | None = None,
    oracle: bool = False,
    every_window: bool = False,
    predict: Predict = prognose,
) -> dict[str, Any]:
    """Prognoses at every window of one trajectory and their scores (by `predict`).

    Returns per fault with a true end of life `replay.score`'s metrics plus the first
    cycle with a RUL, and for every predicted fault the windows at which it was
    ``degrading`` and at which the RUL 5th percentile was below HORIZON_CYCLES ("WARN").
    `prognose_kw` goes to rul.prognose (default: its defaults, seed SCORE_SEED); `oracle`
    prognoses from the true k instead of the estimates (`history_of`).  A prediction is
    made at each counted window (`counts`): a window the model does not explain adds no
    estimate and makes no new prediction, as in the live monitor.
    """
    kw = {"seed": SCORE_SEED, "horizon_cycles": HORIZON_CYCLES, **(prognose_kw or {})}
    out: dict[str, Any] = {"index": tr["index"], "type": tr["type"], "faults": {}, "alarms": {}}
    if not any(counts(w, every_window) for w in windows):
        return out
    hist, ws = history_of(windows, oracle=oracle, every_window=every_window)
    replayed = _replayed(hist, ws, kw, predict)
    out["alarms"] = _alarms(replayed)
    eol = {name: c for name, c in tr["true_eol"].items() if c is not None}
    for name, s in replay_mod.score(replayed, eol).items():
        out["faults"][name] = _fault_score(
            name, s, replayed, eol[name], out["alarms"][name]["warn"]
        )
    return out


def score_all(
    data: dict,
    prognose_kw: dict | None = None,
    oracle: bool = False,
    every_window: bool = False,
    predict: Predict = prognose,
) -> list[dict]:
    by_t: dict[int, list[dict]] = {}
    for w in data["windows"]:
        by_t.setdefault(w["trajectory"], []).append(w)
    return [
        score_trajectory(
            tr,
            by_t.get(tr["index"], []),
            prognose_kw=prognose_kw,
            oracle=oracle,
            every_window=every_window,
            predict=predict,
        )
        for tr in data["plan"]
        if tr["index"] in by_t
    ]


def _median(v: list[float]) -> float:
    return float(statistics.median(v)) if v else math.nan


def _pct(v: list[float], q: float) -> float:
    return float(np.percentile(v, q)) if v else math.nan


def _alarm_counts(traj: list[dict], healthy: list[dict]) -> dict[str, int]:
    """RUL alarms on healthy trajectories, and on faults that do not grow in degrading ones."""
    h_deg = [s for s in healthy if any(a["degrading"] for a in s["alarms"].values())]
    h_warn = [s for s in healthy if any(a["warn"] for a in s["alarms"].values())]
    h_below = [s for s in healthy if any(a["below"] for a in s["alarms"].values())]
    # faults that do not grow in a degrading trajectory: a RUL there is spurious
    spurious_deg, spurious_warn, spurious_below, others = 0, 0, 0, 0
    for s in traj:
        for name, a in s["alarms"].items():
            if name in s["faults"]:
                continue
            others += 1
            spurious_deg += bool(a["degrading"])
            spurious_warn += bool(a["warn"])
            spurious_below += bool(a["below"])
    return {
        "healthy": len(healthy),
        "healthy_degrading": len(h_deg),
        "healthy_warn": len(h_warn),
        "healthy_below": len(h_below),
        "others": others,
        "spurious_degrading": spurious_deg,
        "spurious_warn": spurious_warn,
        "spurious_below": spurious_below,
    }


def _misses(fault_scores: list[tuple[int, str, dict]]) -> dict[str, int]:
    """The alpha-lambda misses from lambda 0.5, by cause."""
    missed = [(r, p) for _, _, f in fault_scores for r, p, ok in f["al_checks"] if not ok]
    return {
        "al_missed_small": sum(1 for r, _ in missed if r <= SMALL_RUL),
        "al_missed_none": sum(1 for _, p in missed if math.isinf(p)),
        "al_missed_long": sum(1 for r, p in missed if math.isfinite(p) and p > 1.2 * r),
        "al_missed_short": sum(1 for r, p in missed if p < 0.8 * r),
        "al_missed_wide": sum(1 for r, p in missed if 0.8 * r <= p <= 1.2 * r),
    }


def headline(scored: list[dict], plan_by_t: dict[int, dict]) -> dict[str, Any]:
    """The four target figures over `scored` trajectories."""
    fault_scores = [
        (s["index"], name, f)
        for s in scored
        if s["type"] != "healthy"
        for name, f in s["faults"].items()
    ]
    traj = [s for s in scored if s["type"] != "healthy" and s["faults"]]
    al_traj = [
        all(f.get("alpha_lambda_from_lambda") is True for f in s["faults"].values()) for s in traj
    ]
    ph = [f["prognostic_horizon_cycles"] / f["true_eol_cycle"] for _, _, f in fault_scores]
    n_cov = sum(f.get("windows_with_rul", 0) for _, _, f in fault_scores)
    hit = sum(
        f["interval_coverage_90"] * f["windows_with_rul"]
        for _, _, f in fault_scores
        if f.get("windows_with_rul")
    )
    return {
        "trajectories": len(traj),
        "fault_histories": len(fault_scores),
        "al_traj_met": sum(al_traj),
        "al_fault_met": sum(f.get("alpha_lambda_from_lambda") is True for _, _, f in fault_scores),
        "al_at_lambda_met": sum(f.get("alpha_lambda") is True for _, _, f in fault_scores),
        "ph_share_median": _median(ph),
        "ph_share_min": min(ph) if ph else math.nan,
        "al_windows_met": sum(f["al_windows"][0] for _, _, f in fault_scores),
        "al_windows": sum(f["al_windows"][1] for _, _, f in fault_scores),
        **_misses(fault_scores),
        "coverage": hit / n_cov if n_cov else math.nan,
        "coverage_windows": n_cov,
        **_alarm_counts(traj, [s for s in scored if s["type"] == "healthy"]),
    }


def _severity_errors(windows: list[dict], tr: dict, name: str) -> dict[str, list[float]]:
    """Estimate - truth of a fault's severity, interval half-width, covered, per life half."""
    i = NAMES.index(name)
    eol = tr["true_eol"][name]
    out: dict[str, list[float]] = {
        "err_early": [],
        "err_late": [],
        "half": [],
        "covered": [],
        "true_early": [],
    }
    for w in windows:
        if not counts(w) or w["cycle"] >= eol:
            continue
        e = abs(w["k"][i] - NOMINAL[i]) - abs(w["k_true"][i] - NOMINAL[i])
        late = w["cycle"] >= 0.5 * eol
        out["err_late" if late else "err_early"].append(e)
        lo, hi = w["k_interval"][i]
        lo, hi = min(lo, w["k"][i]), max(hi, w["k"][i])
        out["half"].append((hi - lo) / 2)
        out["covered"].append(float(lo - 1e-12 <= w["k_true"][i] <= hi + 1e-12))
    return out


def _rul_errors(f: dict, eol: int) -> dict[str, list[float]]:
    """RUL errors of one fault history.

    From lambda 0.5 on: relative error of the median and the 5-95 % width over the true RUL;
    over every window with a RUL: misses of the 90 % interval (too long, too short).
    """
    out: dict[str, list[float]] = {"rel": [], "width": [], "long": [], "short": [], "all": []}
    for c, p5, p50, p95 in f["rul"]:
        r = eol - c
        if c >= 0.5 * eol:
            out["rel"].append((p50 - r) / r)
            out["width"].append((p95 - p5) / r)
        out["all"].append(1.0)
        out["long"].append(float(p5 > r))
        out["short"].append(float(p95 < r))
    return out
