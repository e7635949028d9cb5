"""A growth rate that keeps moving: its diffusion learned from one fault's own history.

`trend.fit_trend` fits one rate per law over the history; its predictive spread is that of
the rate's posterior.  A fault whose rate wanders (wear that speeds up and slows down with
the duty, a rate that steps when a second mechanism starts) makes that posterior confident
about a rate the future does not keep.  This module lets the rate keep moving over the
horizon, by as much as the unit's own history says it has moved.

The model (progpy's vocabulary):

- states: the severity s [1] and the rate factor beta [1], the fault's present growth rate
  relative to the trend's: over a step from cycle c to c', s gains b beta (g(c') - g(c)),
  where g is the law's normalized shape (`trend._shape`) and b its rise;
- process: log beta takes a random walk, sd ``diffusion`` per sqrt(cycle) (0: the constant
  rate of `trend`), so beta stays positive;
- output: the estimates y_j = s(c_j) + e_j, e_j ~ N(0, max(q sigma_j, floor)^2), q the
  noise scale on `trend.NOISE_SCALES`.

Learning the diffusion.  For the most probable model of the trend's most probable law
(law, onset, rate, rise), a Kalman filter on (s, beta), the walk of log beta linearized
around the filtered beta (beta's variance grows by (diffusion beta)^2 per cycle: an
extended Kalman filter), gives the evidence of every diffusion on DIFFUSIONS and every noise
scale (exact for the linearized model, its severity prior centred on the first estimate);
the posterior on the diffusion uses the prior DIFFUSION_PRIOR and marginalizes the noise
scale, and the filters' (s, beta) at the last cycle are the present severity and rate
factor at each diffusion (a trend through a history whose rate has moved misplaces both).

Forecast (`walk`): each posterior sample of the trend (model, a, b) draws a diffusion; with
0 it keeps the trend's closed-form crossing.  A walking sample keeps its own rise and level,
which carry the constant rate's uncertainty, and takes on what the walk adds (`_relative`):
its rate factor moved by E[beta | d] / E[beta | 0] with the relative variance beyond the
constant rate's (log-normal), its level moved by the filters' difference with the variance
beyond d = 0's (the two drawn independently; the filter's correlation between them is not
kept); then it is stepped cycle by cycle, each step the trend's own rise times the factor
times e^W, W the walk, until it reaches the threshold (inf when it has not within WALK_CAP
cycles or twice the largest constant-rate RUL, whichever is more).  At d -> 0 a walking
sample is the constant-rate one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr, ndtri

from ..errors import ConfigError
from .trend import LAWS, NOISE_SCALES, TrendFit

#: The diffusions considered [1/sqrt(cycle)]: sd of the log rate's change over one cycle.
#: 0.4 doubles or halves the rate within ~3 cycles, 0.025 within ~770.
DIFFUSIONS = np.array([0.0, 0.025, 0.05, 0.1, 0.2, 0.4])
#: Prior probability of a constant rate (the rest is spread over the walking diffusions).
P_CONSTANT = 0.5
#: Rate [sqrt(cycle)] of the exponential (penalized-complexity) prior on a walking diffusion
#: d: weights ~ e^(-15 d) on the grid (mean 0.052, P(d >= 0.2 | walking) 3.6 %): the
#: simpler model is preferred and a large diffusion needs the history's evidence, without
#: being ruled out.  Chosen on the prognostics benchmark's tuning half (even trajectories,
#: constant rates) among the rates 0 (log-uniform), 7.5, 15 and 30 and P_CONSTANT 0.25 /
#: 0.5, by the rule "the largest prior on walking that keeps alpha-lambda at 0.5 within one
#: trajectory and PH (stays) within 1.5 points of the constant rate's" (first filter: 21
#: against 22 of 36, 0.595 against 0.606).  With the filter as reviewed (log walk, what the
#: walk adds) no walking prior meets the PH clause: 15 gives 21 of 36 and 0.571, 30 gives
#: 22 and 0.586, log-uniform 17 and 0.560, against 22 and 0.606; 15 was kept, its cost on
#: constant rates stated in docs/benchmarks_prognostics.md.  The foreign lives were scored
#: with the log-uniform prior during the design (before this choice), never to choose it.
WALK_PRIOR_RATE = 15.0
_walking = np.exp(-WALK_PRIOR_RATE * DIFFUSIONS[1:])
DIFFUSION_PRIOR = np.concatenate([[P_CONSTANT], (1.0 - P_CONSTANT) * _walking / _walking.sum()])
#: Prior sd of the rate factor at the first estimate (the trend's rise sets its scale).
PRIOR_SD_FACTOR = 1.0
#: Prior sd of the severity at the first estimate [1].
PRIOR_SD_SEVERITY = 1.0
#: Most cycles a walking sample is stepped before it is counted as never reaching the
#: threshold.
WALK_CAP = 2000
#: Cycles stepped at a time.
WALK_BLOCK = 64


@dataclass(frozen=True)
class Diffusion:
    """The posterior of one history's rate diffusion, and the present rate factor."""

    weights: np.ndarray  # (len(DIFFUSIONS),) posterior probability of each diffusion
    factor_mean: np.ndarray  # (len(DIFFUSIONS),) E[beta at the last cycle | diffusion]
    factor_sd: np.ndarray  # (len(DIFFUSIONS),) its sd
    level_mean: np.ndarray  # (len(DIFFUSIONS),) E[severity at the last cycle | diffusion]
    level_sd: np.ndarray  # (len(DIFFUSIONS),) its sd

    @property
    def mean(self) -> float:
        """Posterior mean diffusion [1/sqrt(cycle)]."""
        return float(np.sum(self.weights * DIFFUSIONS))

    @property
    def p_constant(self) -> float:
        """Posterior probability of a constant rate."""
        return float(self.weights[0])


#: A history that says nothing: the prior, and the trend's own rate.
def prior_only(prior: np.ndarray | tuple[float, ...] | None = None) -> Diffusion:
    """The prior (used when there is no growing trend to measure the rate against).

    `prior`: weights over DIFFUSIONS (None: DIFFUSION_PRIOR).
    """
    n = DIFFUSIONS.size
    w = check_prior(DIFFUSION_PRIOR if prior is None else prior)
    return Diffusion(w, np.ones(n), np.zeros(n), np.zeros(n), np.zeros(n))


def check_prior(prior: object) -> np.ndarray:
    """`prior` as normalized weights over DIFFUSIONS; ConfigError naming the value otherwise."""
    try:
        w = np.asarray(prior, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise ConfigError(
            f"a diffusion prior must be {DIFFUSIONS.size} numbers, got {prior!r}"
        ) from None
    if w.size != DIFFUSIONS.size or not np.all(np.isfinite(w)) or np.any(w < 0) or not w.sum() > 0:
        raise ConfigError(
            f"a diffusion prior must be {DIFFUSIONS.size} weights >= 0 (not all 0) over the "
            f"diffusions {DIFFUSIONS.tolist()}, got {prior!r}"
        )
    return w / w.sum()


def learn(
    cycles: np.ndarray,
    y: np.ndarray,
    sigma: np.ndarray,
    *,
    shape: np.ndarray,
    rise: float,
    floor: float,
    noise_scales: np.ndarray,
    prior: np.ndarray | tuple[float, ...] | None = None,
) -> Diffusion:
    """The posterior of the diffusion of one history (see the module docstring).

    `shape` g(c_j) of the trend's most probable model at the observed cycles, `rise` its b
    (> 0), `sigma` the stated sd of each estimate (before any memory), `floor` the smallest
    sd, `noise_scales` the grid of q (uniform prior), `prior` weights over DIFFUSIONS (None:
    DIFFUSION_PRIOR).
    """
    r = np.maximum(np.asarray(sigma)[:, None] * noise_scales[None, :], floor) ** 2  # (n, Q)
    log_ev, (s, beta), (pss, pbb) = _filter(
        np.asarray(cycles, dtype=np.float64), np.asarray(y, dtype=np.float64), r, shape, rise
    )
    with np.errstate(divide="ignore"):  # a prior may rule a diffusion out
        log_prior = np.log(check_prior(DIFFUSION_PRIOR if prior is None else prior))
    log_post = log_ev + log_prior[:, None]
    log_post -= log_post.max()
    w = np.exp(log_post)
    w /= w.sum()
    per_d = w.sum(axis=1)
    # the noise scale's weights given each diffusion, each row from its own evidence: from
    # the joint posterior they underflow to 0 for a diffusion the history all but rules out
    # (a constant rate under a walking truth), and its state would read as 0
    given_d = np.exp(log_ev - log_ev.max(axis=1, keepdims=True))
    given_d /= given_d.sum(axis=1, keepdims=True)

    def moments(x: np.ndarray, var: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mean and sd per diffusion of a Gaussian mixture over the noise scales."""
        mean = (given_d * x).sum(axis=1)
        second = (given_d * (np.maximum(var, 0.0) + x**2)).sum(axis=1)
        return mean, np.sqrt(np.maximum(second - mean**2, 0.0))

    return Diffusion(per_d, *moments(beta, pbb), *moments(s, pss))


def _filter(
    c: np.ndarray, y: np.ndarray, r: np.ndarray, shape: np.ndarray, rise: float
) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """The filter over every (diffusion, noise scale) at once (`r`: (n, Q) noise variances).

    Returns the log evidence, the last (severity, factor) means and their variances, each
    (len(DIFFUSIONS), Q).
    """
    d2 = (DIFFUSIONS**2)[:, None]  # (D, 1)
    shp = (DIFFUSIONS.size, r.shape[1])
    s, beta = np.full(shp, y[0]), np.ones(shp)
    pss, psb = np.full(shp, PRIOR_SD_SEVERITY**2), np.zeros(shp)
    pbb = np.full(shp, PRIOR_SD_FACTOR**2)
    log_ev = np.zeros(shp)
    for j in range(c.size):
        if j > 0:
            # predict: s += rise * beta * dg, beta walks
            h = rise * (shape[j] - shape[j - 1])
            s = s + h * beta
            pss, psb = pss + 2 * h * psb + h * h * pbb, psb + h * pbb
            # log beta walks: beta's variance grows by (d beta)^2 dc (linearized, EKF)
            pbb = pbb + d2 * (c[j] - c[j - 1]) * beta * beta
        # update with y_j (observes s)
        v = pss + r[j][None, :]
        e = y[j] - s
        log_ev += -0.5 * (np.log(2 * np.pi * v) + e * e / v)
        ks, kb = pss / v, psb / v
        s, beta = s + ks * e, beta + kb * e
        pss, psb, pbb = pss - ks * pss, psb - ks * psb, pbb - kb * psb
    return log_ev, (s, beta), (pss, pbb)


def of_trend(
    fit: TrendFit,
    sigma: np.ndarray,
    *,
    floor: float,
    prior: np.ndarray | tuple[float, ...] | None = None,
) -> Diffusion:
    """`learn` on the most probable growing model of `fit` (the prior if none grows).

    `sigma`: the stated sd of each estimate, before any memory; `prior`: weights over
    DIFFUSIONS (None: DIFFUSION_PRIOR).
    """
    w = fit._trend_weight_array
    per_model = w.sum(axis=1)
    laws = fit.law_probabilities
    best = LAWS.index(max(("linear", "exponential"), key=lambda k: laws[k]))
    j = int(np.argmax(np.where(fit.law == best, per_model, -1.0)))
    q = int(np.argmax(w[j]))
    rise = float(fit.mean[j, q, 1])
    if not (per_model[j] > 0 and rise > 0):
        return prior_only(prior)
    one = np.array([j])
    shape = fit.severity(fit.cycles, one, np.zeros(1), np.ones(1))
    return learn(
        fit.cycles,
        fit.y,
        sigma,
        shape=shape,
        rise=rise,
        floor=floor,
        noise_scales=NOISE_SCALES,
        prior=prior,
    )


def walk(
    fit: TrendFit,
    sampled: tuple[np.ndarray, np.ndarray, np.ndarray],
    threshold: np.ndarray,
    constant: np.ndarray,
    *,
    now: float,
    diffusion: Diffusion,
    rng: np.random.Generator,
) -> np.ndarray:
    """Whole cycles from `now` until each sampled trend reaches its `threshold` (inf: never).

    `constant`: each sample's RUL at the trend's constant rate (whole cycles, as
    `rul.prognose` counts them).  Each sample draws a diffusion from `diffusion`; a constant
    rate keeps that RUL, a walking one is stepped from its trend's present state moved as
    the walk moves it (`_relative`; see the module docstring).
    """
    m, a, b = sampled
    d = rng.choice(DIFFUSIONS.size, size=m.size, p=diffusion.weights)
    z = rng.standard_normal((2, m.size))
    out = np.array(constant, dtype=np.float64)
    moving = np.flatnonzero((d > 0) & (out > 0) & np.isfinite(out))
    if moving.size == 0:
        return out
    factor, shift = _relative(diffusion, d[moving], z[:, moving], rng)
    out[moving] = _stepped(
        fit,
        (m[moving], a[moving], b[moving]),
        threshold[moving],
        now=now,
        factor=factor,
        shift=shift,
        sd=DIFFUSIONS[d[moving]],
        rng=rng,
        cap=max(WALK_CAP, int(2 * out[moving].max())),
    )
    return out


def _relative(
    diffusion: Diffusion, d: np.ndarray, z: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """What a walk of diffusion `d` adds to a sample of the constant-rate trend.

    The sample's rise and level already carry the constant rate's uncertainty; the filter
    at diffusion d moves the present rate factor by E[beta | d] / E[beta | 0] and spreads
    it by the relative variance beyond the constant rate's (log-normal, so the factor stays
    positive, as a walk of log beta does), and moves the present severity by the filters'
    difference, spread by the variance beyond d = 0's.  At d -> 0 both vanish: the walking
    sample is the constant-rate one.  A present factor the filter puts at or below 0 is
    drawn from its Gaussian restricted to beta > 0.
    """
    m0, s0 = diffusion.factor_mean[0], diffusion.factor_sd[0]
    md, sdd = diffusion.factor_mean[d], diffusion.factor_sd[d]
    base = m0 if m0 > 0 else 1.0
    rel0 = (s0 / base) ** 2 if m0 > 0 else 0.0
    pos = md > 0
    extra = np.maximum(sdd**2 / np.where(pos, md, 1.0) ** 2 - rel0, 0.0)
    s_log = np.sqrt(np.log1p(extra))
    factor = np.where(pos, md / base, 1.0) * np.exp(s_log * z[0] - 0.5 * s_log**2)
    if not pos.all():  # the positive part of the filter's Gaussian
        lo = ndtr(-md[~pos] / np.maximum(sdd[~pos], 1e-300))
        u = lo + (1.0 - lo) * rng.uniform(size=int((~pos).sum()))
        factor[~pos] = np.maximum(md[~pos] + sdd[~pos] * ndtri(u), 0.0) / base
    l0, ls0 = diffusion.level_mean[0], diffusion.level_sd[0]
    spread = np.sqrt(np.maximum(diffusion.level_sd[d] ** 2 - ls0**2, 0.0))
    return factor, diffusion.level_mean[d] - l0 + spread * z[1]


def _stepped(
    fit: TrendFit,
    sampled: tuple[np.ndarray, np.ndarray, np.ndarray],
    threshold: np.ndarray,
    *,
    now: float,
    factor: np.ndarray,
    sd: np.ndarray,
    rng: np.random.Generator,
    shift: np.ndarray | None = None,
    cap: int = WALK_CAP,
) -> np.ndarray:
    """Cycles until each walking sample's severity reaches `threshold` (inf after `cap`).

    Each starts at its trend's severity now plus `shift` (None: 0); each step adds the
    trend's own rise times `factor` e^W, W the walk of sd `sd` per cycle.
    """
    m, a, b = (v[:, None] for v in sampled)
    last = fit.severity(np.array([[now]]), m, a, b)[:, 0]  # the trend's, at the last step
    level = last + (0.0 if shift is None else shift)
    out = np.full(level.size, np.inf)
    # the closed form's tolerance: a crossing that lands on a whole cycle counts there
    th = threshold - 1e-9 * np.maximum(np.abs(threshold), 1.0)
    out[level >= th] = 0.0
    walked = np.zeros(level.size)  # W, the log rate's walk so far
    live = np.flatnonzero((out > 0) & (factor > 0))
    for start in range(0, cap, WALK_BLOCK):
        steps = np.arange(start + 1, start + WALK_BLOCK + 1, dtype=np.float64)
        with np.errstate(over="ignore", invalid="ignore"):
            trend = fit.severity(now + steps[None, :], m[live], a[live], b[live])
            gain = np.diff(np.concatenate([last[live, None], trend], axis=1), axis=1)
        gain = np.where(np.isnan(gain), np.inf, gain)
        w = walked[live, None] + np.cumsum(
            sd[live, None] * rng.standard_normal((live.size, WALK_BLOCK)), axis=1
        )
        with np.errstate(over="ignore", invalid="ignore"):
            path = level[live, None] + np.cumsum(factor[live, None] * np.exp(w) * gain, axis=1)
        reached = (path >= th[live, None]) & (steps[None, :] <= cap)
        hit = reached.any(axis=1)
        out[live[hit]] = steps[np.argmax(reached[hit], axis=1)]
        level[live], last[live], walked[live] = path[:, -1], trend[:, -1], w[:, -1]
        live = live[~hit]
        if live.size == 0:
            break
    return out
