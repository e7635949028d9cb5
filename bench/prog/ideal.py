"""What any predictor could reach on the foreign lives: a forecaster that knows all but the future.

The ideal forecaster of a foreign life (`prog.foreign_lives.severity_path`) at cycle t
knows the true severity at t, the law, the rate scale, the rate multiplier of the last
cycle, the walk's sd, and whether and when a rate change is still to come (not its factor,
drawn log-uniform as the plan draws it).  It simulates the plan's own future (the walk, the
change) IDEAL_SAMPLES times; the RUL is the first whole cycle at or above the threshold.
What it cannot know is the future's randomness, so its alpha-lambda and coverage are the
ceiling the walk and the change leave to every method: a target above it is unattainable.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from bench.prog import compare, foreign_lives

#: Futures per forecast.
IDEAL_SAMPLES = 4000
#: Cycles simulated ahead (beyond: never reached).
IDEAL_HORIZON = 400


def _path(tr: dict) -> tuple[list[float], dict]:
    """The trajectory's severity path and its drawing, regenerated from the plan's stream."""
    rng = np.random.default_rng((int(tr["unit_seed"]), foreign_lives.LAW_STREAM))
    changes = "change_cycle" in tr["growth"]
    path, info = foreign_lives.severity_path(rng, tr["law"], changes)
    if info["life"] != tr["growth"]["life"]:
        raise ValueError(f"trajectory {tr['index']}: the plan's path does not regenerate")
    return path, info


def forecast(tr: dict, t: int, rng: np.random.Generator) -> np.ndarray:
    """IDEAL_SAMPLES RUL samples [cycle] of the ideal forecaster at cycle `t` (> onset)."""
    path, info = _path(tr)
    rate, law = info["mean_rate"], info["law"]
    step = path[t] - path[t - 1] if law == "linear" else math.log(path[t]) - math.log(path[t - 1])
    walk = rng.normal(0.0, foreign_lives.RATE_WALK_SD, (IDEAL_SAMPLES, IDEAL_HORIZON))
    m = step / rate * np.exp(np.cumsum(walk, axis=1))
    at = info.get("change_cycle")
    if at is not None and at > t:
        lo, hi = (math.log(v) for v in foreign_lives.RATE_CHANGE)
        m[:, at - t - 1 :] *= np.exp(rng.uniform(lo, hi, IDEAL_SAMPLES))[:, None]
    cum = np.cumsum(m, axis=1)
    with np.errstate(over="ignore"):
        s = path[t] + rate * cum if law == "linear" else path[t] * np.exp(rate * cum)
    reached = s >= foreign_lives.THRESHOLD
    return np.where(reached.any(axis=1), np.argmax(reached, axis=1) + 1.0, np.inf)


def ceiling(data: dict, scored: list[compare.Scored], seed: int = 0) -> dict[str, Any]:
    """The ideal forecaster's figures on the cycles `scored` predicted at (one method's).

    alpha-lambda at each of compare.LAMBDAS (lambda counted from each life's first counted
    window, as `compare.history_metrics`), and the coverage of its 90 % interval and the
    share of windows with BETA inside the cone, over every counted window from lambda 0.5.
    """
    rng = np.random.default_rng(seed)
    plan = {tr["index"]: tr for tr in data["plan"]}
    al = {lam: [] for lam in compare.LAMBDAS}
    covered, cone = [], []
    for s in scored:
        tr = plan[s.index]
        for name, eol in s.eol.items():
            cycles = [p.cycle for p in s.points[name] if p.cycle < eol]
            onset = tr["growth"]["onset"]
            if not cycles:
                continue
            for lam in compare.LAMBDAS:
                t_lam = cycles[0] + lam * (eol - cycles[0])
                at = next((c for c in cycles if c >= t_lam), None)
                if at is not None and at > onset:
                    al[lam].append(_in_cone(forecast(tr, at, rng), eol - at) >= compare.BETA)
            for c in (c for c in cycles if c >= cycles[0] + 0.5 * (eol - cycles[0])):
                if c <= onset:
                    continue
                rul = forecast(tr, c, rng)
                p5, p95 = np.percentile(rul, [5, 95], method="inverted_cdf")
                covered.append(bool(p5 <= eol - c <= p95))
                cone.append(_in_cone(rul, eol - c) >= compare.BETA)
    return {
        **{f"al{int(lam * 100)}": (sum(v), len(v)) for lam, v in al.items()},
        "coverage_late": (sum(covered), len(covered)),
        "cone_late": (sum(cone), len(cone)),
    }


def _in_cone(rul: np.ndarray, truth: float) -> float:
    """Share of RUL samples inside truth x (1 -/+ ALPHA)."""
    a = compare.ALPHA
    return float(np.mean((rul >= (1 - a) * truth) & (rul <= (1 + a) * truth)))
