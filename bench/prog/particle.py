"""A filter baseline: a particle filter on a damage-growth model, progpy's approach.

Per fault, each particle holds the true severity d [1], whether the fault has started to
grow, its growth law (linear: d += rho per cycle; exponential: d *= exp(lam) per cycle), its
rate (rho or lam, a slow random walk: old evidence fades), and the unit's severity bias beta
(the estimates read d (1 + beta); prior `rul.scale_of`).  The rates' priors and the law
split are the fault table's learned growth priors (`rul.growth_priors`), the same knowledge
the project's model is given; a fault without one draws its rates log-uniformly in RHO,
LAM.  Before the onset d stays at its start; the onset comes with a constant hazard per
cycle.  Each counted estimate weighs the
particles by a Gaussian likelihood (sd: q times the estimate's stated sd, at least
NOISE_FLOOR, with q a static state of each particle, as the trend model's noise scale);
systematic resampling when the effective sample size falls below half.  The RUL of a
particle is the whole cycles until its d reaches the threshold (a dormant one first waits
for a drawn onset); the fault is degrading when P(growing) >= P_DETECT.

Why not progpy itself: its ParticleFilter needs a `PrognosticsModel` per fault and steps one
particle set per call; a numpy filter of the same model over the few tens of estimates a
fault has is shorter than the adapter, has no dependency, and runs in milliseconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ema_phm.domain.faults import NAMES
from ema_phm.prognostics.rul import (
    PERCENTILES,
    PREDICTED,
    FaultPrognosis,
    History,
    Percentiles,
    Prognosis,
    failure_thresholds,
    growth_priors,
    law_prior,
    scale_of,
)
from ema_phm.prognostics.trend import GrowthPrior

N_PARTICLES = 2000
NOISE_FLOOR = 0.01
#: Range of the (static, log-uniform) scale q on the estimates' stated sd.
NOISE_SCALE = (0.1, 2.0)
P_DETECT = 0.95
#: Per-cycle onset hazard of a fault that has not started to grow.
ONSET_HAZARD = 0.1
#: Log-uniform prior ranges of the rates: linear [1/cycle of severity], exponential [1/cycle].
RHO = (0.002, 0.08)
LAM = (0.02, 0.4)
#: sd of the rates' log random walk per cycle.
RATE_WALK = 0.03
#: sd of the severity's random walk per cycle (keeps resampled particles apart).
D_WALK = 0.003
#: Severity of a fault that has not started (uniform).
START = (0.0, 0.05)
#: Cycles a RUL is capped at (a particle that would take longer never fails here).
NEVER = 1e6


@dataclass(frozen=True)
class ParticleFilter:
    """The particle-filter baseline as a `monitor.predictor.Predictor`."""

    n: int = N_PARTICLES
    horizon_cycles: float = 10.0
    growth: Any = None  # growth priors (None: the fault table's, `rul.growth_priors`)
    label: str = "particle filter on a damage-growth model (rate and bias as states)"

    def predict(self, history: History, *, seed: int = 0) -> Prognosis:
        """Filter each fault's history from its first estimate; prognose at its last."""
        limits = failure_thresholds(None)
        faults = tuple(
            self._fault(history, i, limits[i], np.random.default_rng([seed, i])) for i in PREDICTED
        )
        return Prognosis(
            cycle=float(history.cycles[-1]),
            cycle_hours=1.0,
            horizon_cycles=self.horizon_cycles,
            intervals_known=history.intervals_known,
            faults=faults,
        )

    def _fault(
        self, history: History, i: int, limit: float, rng: np.random.Generator
    ) -> FaultPrognosis:
        sev, sd = history.severity(i)
        common = {"index": i, "threshold": limit, "severity": float(sev[-1])}
        if sev.size < 5:
            return FaultPrognosis(status="insufficient_data", message="fewer than 5", **common)
        prior = _prior(NAMES[i], growth_priors(self.growth).get(NAMES[i]), self.n, rng)
        p = _filter(history.cycles, sev, sd, prior=prior, rng=rng)
        p_growing = float(np.mean(p["on"]))
        if p_growing < P_DETECT:
            msg = f"P(growing) = {p_growing:.3f} < {P_DETECT}"
            return FaultPrognosis(status="no_degradation", message=msg, **common)
        rul = _rul(p, limit, rng)
        pct = Percentiles(*(float(v) for v in np.percentile(rul, PERCENTILES)))
        return FaultPrognosis(
            status="degrading",
            message=f"particle filter: RUL {pct.p50:.4g} cycles",
            rul_cycles=pct,
            rul_hours=pct,
            p_within_horizon=float(np.mean(rul <= self.horizon_cycles)),
            samples=rul,
            **common,
        )


def _prior(
    name: str, growth: GrowthPrior | None, n: int, rng: np.random.Generator
) -> dict[str, np.ndarray]:
    laws = law_prior(name) if growth is None else growth.law_prior(law_prior(name))
    p_exp = laws["exponential"] / (laws["linear"] + laws["exponential"])
    exp = rng.random(n) < p_exp
    if growth is None:
        rho = np.exp(rng.uniform(*np.log(RHO), n))
        lam = np.exp(rng.uniform(*np.log(LAM), n))
    else:
        rho = growth.linear[0] * np.exp(growth.linear[1] * rng.standard_normal(n))
        lam = growth.exponential[0] * np.exp(growth.exponential[1] * rng.standard_normal(n))
    med, bsd = scale_of(name)
    return {
        "d": rng.uniform(*START, n),
        "on": np.zeros(n, dtype=bool),
        "exp": exp,
        "rate": np.where(exp, lam, rho),
        "beta": med + bsd * rng.standard_normal(n),
        "q": np.exp(rng.uniform(*np.log(NOISE_SCALE), n)),
    }


def _step(p: dict[str, np.ndarray], dc: float, rng: np.random.Generator) -> None:
    """Advance every particle by `dc` cycles (onsets, growth, the rates' random walk)."""
    n = p["d"].size
    start = (~p["on"]) & (rng.random(n) < 1.0 - (1.0 - ONSET_HAZARD) ** dc)
    p["on"] = p["on"] | start
    p["rate"] = p["rate"] * np.exp(RATE_WALK * math.sqrt(dc) * rng.standard_normal(n))
    grow_lin = p["on"] & ~p["exp"]
    grow_exp = p["on"] & p["exp"]
    p["d"] = np.where(grow_lin, p["d"] + p["rate"] * dc, p["d"])
    p["d"] = np.where(grow_exp, np.maximum(p["d"], 1e-3) * np.exp(p["rate"] * dc), p["d"])
    # only a growing fault wanders: a dormant one stays at its start, or it would track
    # a growth by selection alone
    walk = np.where(p["on"], D_WALK * math.sqrt(dc) * rng.standard_normal(n), 0.0)
    p["d"] = np.maximum(p["d"] + walk, 0.0)


def _filter(
    cycles: np.ndarray,
    y: np.ndarray,
    sd: np.ndarray,
    *,
    prior: dict[str, np.ndarray],
    rng: np.random.Generator,
) -> dict[str, np.ndarray]:
    p = prior
    n = p["d"].size
    for j, c in enumerate(cycles):
        if j:
            _step(p, float(c - cycles[j - 1]), rng)
        s = np.maximum(p["q"] * sd[j], NOISE_FLOOR)
        logw = -0.5 * ((y[j] - p["d"] * (1.0 + p["beta"])) / s) ** 2 - np.log(s)
        w = np.exp(logw - logw.max())
        w /= w.sum()
        if 1.0 / np.sum(w**2) < n / 2 or j == len(cycles) - 1:
            idx = _systematic(w, rng)
            p = {k: v[idx] for k, v in p.items()}
    return p


def _systematic(w: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    n = w.size
    u = (rng.random() + np.arange(n)) / n
    return np.minimum(np.searchsorted(np.cumsum(w), u), n - 1)


def _rul(p: dict[str, np.ndarray], limit: float, rng: np.random.Generator) -> np.ndarray:
    """Whole cycles until each particle's d reaches `limit` (a dormant one waits for onset)."""
    d = np.maximum(p["d"], 1e-3)
    grow = np.where(
        p["exp"],
        np.log(np.maximum(limit / d, 1.0)) / p["rate"],
        np.maximum(limit - d, 0) / p["rate"],
    )
    wait = np.where(p["on"], 0.0, rng.geometric(ONSET_HAZARD, d.size).astype(float))
    return np.minimum(np.ceil(wait + grow - 1e-9), NEVER)
