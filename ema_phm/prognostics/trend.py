"""Degradation-trend model of one fault: Bayesian regression on linear and exponential laws.

The model (progpy's vocabulary; every quantity is a severity |k - nominal| of one k entry,
dimensionless, a fraction of that fault's range):

- state: the fault's true severity s(c) at cycle c [1];
- input: the operating cycle c [cycle];
- output: the monitor's estimate y_j of s(c_j) at cycle c_j, with a stated 90 % interval
  [lo_j, hi_j] [1];
- parameters: ``level`` a [1] (severity before the onset), ``rise`` b [1] (severity gained
  from the onset to the last observed cycle), ``onset`` c0 [cycle], ``curvature`` kappa [1]
  (exponential only: rate lambda = kappa / (c_last - c0) [1/cycle]; with a growth prior
  lambda itself is on the prior's nodes), ``noise_scale`` q [1].

Laws, with G = c_last - c0 and u = max(0, c - c0)::

    none         s(c) = a                                            (no degradation)
    linear       s(c) = a + b u / G
    exponential  s(c) = a + b (exp(lambda u) - 1) / (exp(lambda G) - 1)

With a learned `GrowthPrior` (how fast the fault grew in past lives) the rates come from
it instead: the linear rate b / G and lambda each on RATE_NODES Gauss-Hermite nodes of
their log-normal priors (weighted), the linear rise held near rate x G, and
the exponential law in its propagation form (the damage feeds its own growth,
ds/dc = lambda s)::

    exponential  s(c) = a + b exp(lambda (u - G))     a ~ N(0, PRIOR_SD_OFFSET^2)

where a + b is the severity at the last cycle and a only an offset of the estimates.
No fleet rules out what it has not seen: each law keeps at least LAW_FLOOR of the trend's
prior, and UNLIKE_FLEET of each law's rate prior is a wide component -- the linear law's
free rise (N(0, 0.5^2)), the exponential rate on a log-normal of log sd >= WIDE_LOG_SD --
so a unit whose fault grows unlike the fleet's lives, or by a law they never showed, is
still followed.

Measurement: y_j = s(c_j) + e_j, e_j ~ N(0, max(q sigma_j, f)^2), sigma_j = max(half-width
of the 90 % interval / 1.645, f), f = ``noise_floor`` (0.01: below it an estimate's scatter
is not trusted to describe its error, which also holds a bias the scatter does not show).
q says how far the stated intervals are off: it is learned from the residuals
(log-uniform prior on a grid from 0.1 to 100), so a zero-width interval (intervals
unavailable) gives sigma_j = f and q takes the whole noise level from the data.

Why this model.  Given (law, onset, rate, q) it is linear in (a, b): with Gaussian
priors (without a growth prior a ~ N(0, 0.5^2), b ~ N(0, 0.5^2)) the posterior of (a, b)
and the marginal likelihood (evidence) are exact and closed-form.  The four nonlinear
quantities are put on grids (onset: the observed cycles followed by at least 3 more,
thinned to at most MAX_ONSETS; curvature: 12 values from 0.3 to 8, or the growth prior's
rate nodes; q: 16 values) and
marginalized exactly over the grid, so the law is chosen by Bayesian model averaging on
the evidence, which penalizes the extra freedom of a trend (the Occam factor BIC
approximates) -- no tuning of a significance level per law.  Prior model probabilities:
the caller's `law_prior` (`rul.LAW_PRIORS` gives one per fault, from its physics), default
none 1/2, linear 1/4, exponential 1/4; uniform over each law's grid.  `TrendFit` gives
P(trend | data) and P(b > 0 | trend, data); `rul.prognose` decides from them whether the
fault is degrading.  A particle filter would also do, but
with a few tens of noisy points per fault an exact posterior is cheaper, deterministic
and has no degeneracy to tune.

Forecast.  Posterior predictive samples (seeded) of (law, onset, curvature, q, a, b),
conditional on a trend, each projected to the failure threshold: the cycle c* where the
noise-free s(c*) reaches it (`crossing_cycles`; `rul.prognose` turns it into whole cycles
after the last one); a sample that does not grow (b <= 0) never reaches it (inf), one at or
above the threshold from the start has reached it (-inf).

Recent evidence: `fit_trend(memory=M)` lets an estimate M cycles older than the last count
e^-1 as much (its sd times e^(age / 2M)); inf (the default) weighs every estimate alike.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property, lru_cache
from typing import Any

import numpy as np
from numpy.polynomial.hermite import hermgauss
from scipy.special import ndtr

from ..errors import ConfigError

#: The model's named quantities and their units, in progpy's terms (see the module docstring).
STATES: dict[str, str] = {"severity": "1 (fraction of the fault's k range)"}
INPUTS: dict[str, str] = {"cycle": "cycle"}
OUTPUTS: dict[str, str] = {
    "severity_estimate": "1",
    "severity_low_90": "1",
    "severity_high_90": "1",
}
PARAMETERS: dict[str, str] = {
    "law": "none | linear | exponential",
    "level": "1",
    "rise": "1",
    "onset": "cycle",
    "curvature": "1 (exponential: rate = curvature / (last cycle - onset) [1/cycle])",
    "noise_scale": "1",
}
#: z of a central 90 % interval: its half-width is 1.645 standard deviations.
Z90 = 1.6448536269514722
#: Prior standard deviations of the level a and the rise b [severity].
PRIOR_SD_LEVEL = 0.5
PRIOR_SD_RISE = 0.5
#: Prior sd of the offset a of the exponential law's propagation form [severity].
PRIOR_SD_OFFSET = 0.02
#: Grid of the exponential curvature kappa = lambda * (c_last - c0).
CURVATURES = np.geomspace(0.3, 8.0, 12)
#: Grid of the noise scale q (stated sigma times q), log-uniform prior.
NOISE_SCALES = np.geomspace(0.1, 100.0, 16)
#: Most onset candidates kept (evenly thinned from the observed cycles).
MAX_ONSETS = 20
#: Prior probability of each law family.
LAW_PRIOR = {"none": 0.5, "linear": 0.25, "exponential": 0.25}
LAWS = ("none", "linear", "exponential")


@dataclass(frozen=True)
class TrendFit:
    """The posterior over the trend models of one fault's history."""

    cycles: np.ndarray  # (n,) observed cycles
    y: np.ndarray  # (n,) severity estimates
    sigma: np.ndarray  # (n,) stated noise sd (from the intervals, floored; x the memory's)
    law: np.ndarray  # (M,) index into LAWS of each model
    onset: np.ndarray  # (M,) c0 [cycle]
    rate: np.ndarray  # (M,) lambda [1/cycle] (0 for none / linear)
    span: np.ndarray  # (M,) G = c_last - c0 [cycle]
    log_w: np.ndarray  # (M, Q) normalized log posterior of (model, noise scale)
    mean: np.ndarray  # (M, Q, 2) posterior mean of (a, b)
    cov: np.ndarray  # (M, Q, 2, 2) posterior covariance of (a, b)
    propagating: bool = False  # exponential models in the propagation form (GrowthPrior)

    @cached_property
    def law_probabilities(self) -> dict[str, float]:
        """Posterior probability of each law (none, linear, exponential)."""
        w = np.exp(self.log_w).sum(axis=1)
        per_law = np.bincount(self.law, weights=w, minlength=len(LAWS))
        return {name: float(per_law[i]) for i, name in enumerate(LAWS)}

    @property
    def p_trend(self) -> float:
        """Posterior probability that the severity follows a trend (not constant)."""
        return 1.0 - self.law_probabilities["none"]

    @cached_property
    def _trend_weight_array(self) -> np.ndarray:
        """Posterior weights (M, Q) given a trend (the no-trend model's set to 0); read-only."""
        w = np.exp(self.log_w)
        w[self.law == 0] = 0.0
        total = w.sum()
        out = w / total if total > 0 else w
        out.setflags(write=False)
        return out

    @cached_property
    def p_growth(self) -> float:
        """P(b > 0 | a trend, data): the trend makes the fault worse."""
        w = self._trend_weight_array
        sd = np.sqrt(np.maximum(self.cov[..., 1, 1], 1e-300))
        return float(np.sum(w * ndtr(self.mean[..., 1] / sd)))

    @property
    def onset_mode(self) -> float:
        """The most probable onset cycle among the trend models."""
        w = self._trend_weight_array.sum(axis=1)
        return float(self.onset[int(np.argmax(w))])

    @property
    def noise_scale_mean(self) -> float:
        """Posterior mean of q (how far the stated intervals are off)."""
        w = np.exp(self.log_w).sum(axis=0)
        return float(np.sum(w * NOISE_SCALES))

    def severity(
        self, c: np.ndarray, model: np.ndarray, a: np.ndarray, b: np.ndarray
    ) -> np.ndarray:
        """Noise-free severity at cycles `c` of sampled (model, a, b) (arrays broadcast)."""
        g = _shape(
            c,
            self.onset[model],
            self.rate[model],
            self.span[model],
            self.law[model],
            propagating=self.propagating,
        )
        return a + b * g

    def sample(self, n: int, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
        """`n` posterior samples conditional on a trend: (model index, a, b)."""
        w = self._trend_weight_array.ravel()
        if not w.sum() > 0:
            raise ConfigError("no trend model has posterior weight; nothing to sample")
        idx = rng.choice(w.size, size=n, p=w / w.sum())
        m, q = np.divmod(idx, self.log_w.shape[1])
        mu = self.mean[m, q]
        chol = np.linalg.cholesky(self.cov[m, q] + 1e-15 * np.eye(2))
        z = rng.standard_normal((n, 2))
        theta = mu + np.einsum("nij,nj->ni", chol, z)
        return m, theta[:, 0], theta[:, 1]

    def crossing_cycles(
        self, threshold: float | np.ndarray, m: np.ndarray, a: np.ndarray, b: np.ndarray
    ) -> np.ndarray:
        """Cycle at which each sampled trend (model m, a, b) reaches `threshold`.

        `threshold`: one value, or one per sample.

        -inf when it is at or above the threshold from the start (its level before the
        onset), inf when it never gets there (b <= 0); otherwise the solved crossing,
        possibly in the past.
        """
        law, c0 = self.law[m], self.onset[m]
        lam, span = self.rate[m], self.span[m]
        th = np.broadcast_to(np.asarray(threshold, dtype=np.float64), m.shape)
        out = np.full(m.shape, np.inf)
        # the trend's level before its onset: at or above the threshold there, it has reached
        # it from the start (a falling trend only moves away from it)
        start = a + np.where(self.propagating & (law == 2), b * np.exp(-lam * span), 0.0)
        above = start >= th
        out[above] = -np.inf
        grow = (~above) & (b > 0) & (law > 0)
        g_star = (th[grow] - a[grow]) / b[grow]
        lin = law[grow] == 1
        idx = np.flatnonzero(grow)
        li, ei = idx[lin], idx[~lin]
        out[li] = c0[li] + g_star[lin] * span[li]
        if self.propagating:
            out[ei] = c0[ei] + span[ei] + np.log(g_star[~lin]) / lam[ei]
        else:
            scale = np.expm1(lam[ei] * span[ei])
            out[ei] = c0[ei] + np.log1p(g_star[~lin] * scale) / lam[ei]
        return out


def _shape(
    c: np.ndarray,
    c0: np.ndarray,
    lam: np.ndarray,
    span: np.ndarray,
    law: np.ndarray,
    *,
    propagating: bool = False,
) -> np.ndarray:
    """The normalized law g(c) over the history (0 for the no-trend model).

    Linear u / G and exponential (e^(lam u) - 1) / (e^(lam G) - 1) rise from 0 at the onset
    to 1 at the last cycle; the propagation form e^(lam (u - G)) of the exponential law
    (`propagating`) is the damage itself, e^(-lam G) before the onset and 1 at the last cycle.
    """
    u = np.maximum(np.asarray(c, dtype=np.float64) - c0, 0.0)
    safe_span = np.where(span > 0, span, 1.0)
    lin = u / safe_span
    with np.errstate(over="ignore", invalid="ignore"):
        if propagating:
            ex = np.exp(lam * (u - safe_span))
        else:
            ex = np.expm1(lam * u) / np.expm1(np.where(lam > 0, lam, 1.0) * safe_span)
    return np.where(law == 0, 0.0, np.where(law == 1, lin, ex))


@dataclass(frozen=True)
class GrowthPrior:
    """A learned prior on how fast a fault grows once it has started.

    Log-normal rates: ``linear`` the severity gained per cycle [1/cycle], ``exponential``
    the rate lambda [1/cycle]; each (median, sd of the natural log).  With one, each law's
    rate is put on RATE_NODES Gauss-Hermite nodes of its prior, weighted (a linear model's
    rise b is then held near rate x span), with UNLIKE_FLEET of the linear law's weight
    left to the flat prior on b (a unit unlike the fleet).
    """

    linear: tuple[float, float]
    exponential: tuple[float, float]
    #: P(exponential | a trend) the lives showed (None: the fault table's law prior).
    p_exponential: float | None = None
    #: Prior weights of the rate's diffusion over `diffusion.DIFFUSIONS`, as the lives
    #: showed it (None: `diffusion.DIFFUSION_PRIOR`).
    diffusion: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        if self.diffusion is not None:
            from .diffusion import check_prior  # noqa: PLC0415  (diffusion.py imports this)

            object.__setattr__(
                self, "diffusion", tuple(float(v) for v in check_prior(self.diffusion))
            )
        p = self.p_exponential
        if p is not None and not (math.isfinite(p) and 0.0 < p < 1.0):
            raise ConfigError(f"growth prior p_exponential must be in (0, 1), got {p!r}")
        for law in ("linear", "exponential"):
            med, sd = getattr(self, law)
            if not (math.isfinite(med) and med > 0 and math.isfinite(sd) and 0 < sd < 5):
                raise ConfigError(
                    f"growth prior of the {law} law must be (median > 0, log sd in (0, 5)), "
                    f"got {getattr(self, law)!r}"
                )

    def nodes(self, law: str, *, wide: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """RATE_NODES rates and their log prior weights (Gauss-Hermite on the log rate).

        The nodes reach +/-5.5 sd of the log rate (their weights fall to ~1e-7 there), so
        a unit far in the tail of its fleet is still a model, only an unlikely one.
        `wide`: the nodes of the wide component (log sd at least WIDE_LOG_SD, same median).
        """
        med, sd = getattr(self, law)
        if wide:
            sd = max(sd, WIDE_LOG_SD)
        x, log_w = _hermite()
        return med * np.exp(math.sqrt(2.0) * sd * x), log_w

    def law_prior(self, base: dict[str, float]) -> dict[str, float]:
        """`base` (none / linear / exponential) with the trend split as the lives showed.

        A `p_exponential` replaces the caller's own linear / exponential split (P(none) is
        kept); without one `base` is returned as it is.
        """
        if self.p_exponential is None:
            return base
        trend = 1.0 - base["none"]
        p = self.p_exponential
        return {"none": base["none"], "linear": trend * (1 - p), "exponential": trend * p}

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return {
            "linear": list(self.linear),
            "exponential": list(self.exponential),
            "p_exponential": self.p_exponential,
            "diffusion": None if self.diffusion is None else list(self.diffusion),
        }


#: Gauss-Hermite nodes per law of a `GrowthPrior`.
RATE_NODES = 12


@lru_cache(maxsize=1)
def _hermite() -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Hermite nodes and log weights of N(0, 1/2) (computed once)."""
    x, w = hermgauss(RATE_NODES)
    return x, np.log(w / math.sqrt(math.pi))


#: sd of a linear model's rise around rate x span, per log sd of the rate prior: about half
#: the gap between neighbouring central nodes (0.89 log sd), so the nodes' bumps join up.
RATE_SPREAD = 0.45
#: Smallest such sd, as a fraction of the rise.
MIN_RATE_SPREAD = 0.05
# What no prior may rule out, however confident the fleet it was learned from (the one
# place these are set).  A fleet's lives show the laws and rates its units happened to
# follow, not every law a unit can follow: friction that grew linearly in every past life
# can still start small and accelerate in the next unit.  So the priors are kept open:
#: Smallest prior share of each growth law given a trend (P(linear | trend) and
#: P(exponential | trend) both at least this).  0.2 puts the prior odds against a law the
#: fleet never showed at 4 : 1, so a Bayes factor of 4 from the unit's own history -- the
#: "positive evidence" of Kass & Raftery (1995) -- makes it the more probable law.
LAW_FLOOR = 0.2
#: Share of each law's rate prior in its wide component, a unit unlike the fleet's lives:
#: the linear law's free rise (the flat prior's linear models) and the exponential law's
#: rate on a log-normal of log sd at least WIDE_LOG_SD around the fleet's median.  Without
#: the linear one a friction growing 3-4x faster than the lives got no RUL at all.
UNLIKE_FLEET = 0.1
#: Smallest log sd of that wide component: a rate 10x (or 1/10) the fleet's median is 1.5
#: sd out, at e^-1.1 = 1/3 of the component's peak density, where the fleet's own log sd
#: (0.25-0.4 for the law its lives grew by) puts it 6-9 sd out: ruled out.  The mixture
#: (1 - UNLIKE_FLEET) fleet + UNLIKE_FLEET wide has the heavy tails of a log-Student-t
#: while keeping the Gauss-Hermite nodes exact for each component.  Chosen on the tuning
#: half (even trajectories) of the prognostics benchmark among three wide exponential
#: components, all with LAW_FLOOR: centred on the fleet's median, log sd 1.5 (RUL WARN on
#: 4 of 168 faults that do not grow, alpha-lambda at 0.5 22/36); centred on the fleet's
#: time scale (ln(threshold / 0.02) x median linear rate / threshold), log sd 1.5 (7/168,
#: 22/36) or 1.0 (5/168, 22/36).  LAW_FLOOR alone gave 2/168 and 24/36, the priors
#: before both 2/168 and 25/36: a heavy tail on the exponential rate costs that much where
#: the fleet's priors are right.
WIDE_LOG_SD = 1.5


def open_law_prior(prior: dict[str, float]) -> dict[str, float]:
    """`prior` with each growth law's share of the trend kept within [LAW_FLOOR, 1 - LAW_FLOOR].

    P(none) is kept; a split already within the bounds is returned unchanged.
    """
    trend = prior["linear"] + prior["exponential"]
    if not trend > 0:
        return prior
    p_exp = min(max(prior["exponential"] / trend, LAW_FLOOR), 1.0 - LAW_FLOOR)
    return {"none": prior["none"], "linear": trend * (1.0 - p_exp), "exponential": trend * p_exp}


def _onsets(cycles: np.ndarray, min_after: int) -> np.ndarray:
    """Onset candidates: observed cycles followed by >= `min_after` more (at most MAX_ONSETS).

    "Before the first point" (a trend over the whole history) is the first cycle.
    """
    candidates = np.unique(cycles[: max(len(cycles) - min_after, 1)])
    if candidates.size > MAX_ONSETS:
        candidates = candidates[
            np.unique(np.linspace(0, candidates.size - 1, MAX_ONSETS).round().astype(int))
        ]
    return candidates[candidates < float(cycles[-1])].astype(np.float64)


def _block(
    c0: np.ndarray,
    g: np.ndarray,
    law: int,
    *,
    rate: np.ndarray,
    rise: tuple[np.ndarray, np.ndarray],
    log_w: np.ndarray,
) -> tuple[np.ndarray, ...]:
    """Models of one law at every onset: rate and rise prior (mean, sd) are (onsets, k)."""
    k = log_w.size
    return (
        np.full(c0.size * k, law),
        np.repeat(c0, k),
        rate.ravel(),
        np.repeat(g, k),
        rise[0].ravel(),
        rise[1].ravel(),
        np.tile(log_w, c0.size) - math.log(max(c0.size, 1)),
    )


def _flat_blocks(c0: np.ndarray, g: np.ndarray, log_share: float) -> list[tuple[np.ndarray, ...]]:
    """The flat prior's models: a free rise, exponentials on the curvature grid."""
    free = np.full((c0.size, 1), PRIOR_SD_RISE)
    exp_free = np.full((c0.size, CURVATURES.size), PRIOR_SD_RISE)
    w_exp = np.full(CURVATURES.size, log_share - math.log(CURVATURES.size))
    return [
        _block(
            c0,
            g,
            1,
            rate=np.zeros((c0.size, 1)),
            rise=(np.zeros_like(free), free),
            log_w=np.array([log_share]),
        ),
        _block(
            c0,
            g,
            2,
            rate=CURVATURES[None, :] / g[:, None],
            rise=(np.zeros_like(exp_free), exp_free),
            log_w=w_exp,
        ),
    ]


def _models(
    cycles: np.ndarray, min_after: int, growth: GrowthPrior | None = None
) -> tuple[np.ndarray, ...]:
    """Every model on the grids: its law, onset, rate, span, b prior and weight in its law.

    Returns (law, onset, rate, span, prior mean of b, prior sd of b, log prior weight within
    its law); onsets weigh alike.  With a growth prior, its nodes carry 1 - UNLIKE_FLEET of
    each law's weight (by their Gauss-Hermite weights) and the flat prior's linear models
    (a free rise) UNLIKE_FLEET of the linear law's: a unit whose fault grows unlike the
    fleet's lives is still followed.
    """
    c0 = _onsets(cycles, min_after)
    g = float(cycles[-1]) - c0
    if growth is None:
        blocks = _flat_blocks(c0, g, 0.0)
    else:
        lin_rate, lin_w = growth.nodes("linear")
        rise = lin_rate[None, :] * g[:, None]
        spread = max(RATE_SPREAD * growth.linear[1], MIN_RATE_SPREAD)
        exp_free = np.full((c0.size, RATE_NODES), PRIOR_SD_RISE)
        keep, unlike = math.log(1.0 - UNLIKE_FLEET), math.log(UNLIKE_FLEET)
        blocks = [
            _block(
                c0, g, 1, rate=np.zeros_like(rise), rise=(rise, spread * rise), log_w=lin_w + keep
            ),
            # a unit unlike the fleet, linear: the flat linear models (a free rise)
            _flat_blocks(c0, g, unlike)[0],
        ]
        # exponential: the fleet's rates, and a unit unlike the fleet on the wide log-normal
        # (in the propagation form; the flat prior's exponentials, rising from 0 at the onset
        # on a free curvature, let one late window read as an explosive growth: on the tuning
        # half they took the non-growing faults' RUL WARN from 2 to 6 of 168)
        for wide, share in ((False, keep), (True, unlike)):
            exp_rate, exp_w = growth.nodes("exponential", wide=wide)
            blocks.append(
                _block(
                    c0,
                    g,
                    2,
                    rate=np.broadcast_to(exp_rate, (c0.size, RATE_NODES)),
                    rise=(np.zeros_like(exp_free), exp_free),
                    log_w=exp_w + share,
                )
            )
    span0 = max(float(cycles[-1] - cycles[0]), 1.0)
    head = (0, float(cycles[0]), 0.0, span0, 0.0, PRIOR_SD_RISE, 0.0)  # the no-trend model
    columns = [np.concatenate([[h], *(b[j] for b in blocks)]) for j, h in enumerate(head)]
    law, onset, rate, span, b_mean, b_sd, weight = columns
    return law.astype(int), onset, rate, span, b_mean, b_sd, weight


def fit_trend(
    cycles: np.ndarray,
    y: np.ndarray,
    sigma: np.ndarray,
    *,
    floor: float = 0.0,
    min_after: int = 3,
    law_prior: dict[str, float] | None = None,
    growth: GrowthPrior | None = None,
    memory: float = math.inf,
) -> TrendFit:
    """Posterior over (law, onset, rate, noise scale, a, b) of one fault's history.

    `cycles` strictly increasing, `y` the severity estimates, `sigma` > 0 the stated
    noise sd of each; the sd used with noise scale q is max(q sigma_j, `floor`) (see the
    module docstring).  `law_prior`: prior probability of each law (keys `LAWS`, positive,
    summing to 1), default `LAW_PRIOR`.  `growth`: a learned prior on the rates (None: the
    flat rise and the curvature grid).  `memory` [cycle]: an estimate that many cycles older
    than the last counts e^-1 as much (its sd grows by e^(age / (2 memory))); inf: all alike.
    """
    prior = open_law_prior(LAW_PRIOR if law_prior is None else law_prior)
    c = np.asarray(cycles, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    s = np.asarray(sigma, dtype=np.float64)
    # a memory discounts after the floor, so an old estimate counts less at any noise scale
    age = np.exp((c[-1] - c) / (2.0 * memory)) if math.isfinite(memory) else np.ones(c.size)
    models = _models(c, min_after, growth)
    law, weight = models[0], models[6]
    sd = np.maximum(s[:, None] * NOISE_SCALES[None, :], floor) * age[:, None]  # (n, Q)
    mean, cov, log_ev = _evidence(c, y, sd, models, propagating=growth is not None)
    per_law = np.array([math.log(prior[name]) for name in LAWS])
    log_post = log_ev + (per_law[law] + weight)[:, None] - math.log(NOISE_SCALES.size)
    top = log_post.max()
    log_post -= top + math.log(np.exp(log_post - top).sum())
    # the no-trend model has no b: its b is the prior's (never sampled, never counted)
    return TrendFit(
        cycles=c,
        y=y,
        sigma=s * age,
        law=law,
        onset=models[1],
        rate=models[2],
        span=models[3],
        log_w=log_post,
        mean=mean,
        cov=cov,
        propagating=growth is not None,
    )


def _evidence(
    c: np.ndarray,
    y: np.ndarray,
    sd: np.ndarray,
    models: tuple[np.ndarray, ...],
    *,
    propagating: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Posterior of (a, b) and log evidence of every model and noise scale (`_regression`)."""
    law, onset, rate, span, b_mean, b_sd, _ = models
    # models that differ only in their b prior (a linear law's rate nodes) share a shape
    _, first, shared = np.unique(
        np.stack([law, onset, rate]), axis=1, return_index=True, return_inverse=True
    )
    g = _shape(
        c[None, :],
        onset[first, None],
        rate[first, None],
        span[first, None],
        law[first, None],
        propagating=propagating,
    )  # (unique shapes, n)
    # the propagation form's a is an offset of the estimates (their floor), not a level
    a_sd = np.where(propagating & (law == 2), PRIOR_SD_OFFSET, PRIOR_SD_LEVEL)[:, None]
    return _regression(
        g, y, sd, shared=shared.ravel(), a_sd=a_sd, b_mean=b_mean[:, None], b_sd=b_sd[:, None]
    )


def _regression(
    g: np.ndarray,
    y: np.ndarray,
    sd: np.ndarray,
    *,
    shared: np.ndarray,
    a_sd: np.ndarray,
    b_mean: np.ndarray,
    b_sd: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bayesian regression y = a + b g(c) + noise for every model and noise scale.

    `g` (S, n) the distinct laws at the observed cycles and `shared` (M,) the one of each
    model, `sd` (n, Q) the noise sd per noise scale;
    priors a ~ N(0, `a_sd`^2), b ~ N(`b_mean`, `b_sd`^2) ((M, 1) each).
    Returns the posterior mean (M, Q, 2) and covariance (M, Q, 2, 2) of (a, b), and the
    log evidence (M, Q) of each (model, noise scale).
    """
    w = 1.0 / sd**2
    s11 = w.sum(axis=0)[None, :]  # (1, Q)
    s12 = (g @ w)[shared]  # (M, Q)
    s22 = ((g**2) @ w)[shared]
    r1 = (w * y[:, None]).sum(axis=0)[None, :]
    r2 = (g @ (w * y[:, None]))[shared]
    yy = (w * y[:, None] ** 2).sum(axis=0)[None, :]
    logdet_noise = np.log(sd**2).sum(axis=0)[None, :]
    p0a, p0b = 1.0 / a_sd**2, 1.0 / b_sd**2
    # posterior precision P = P0 + Phi' W Phi and h = Phi' W y + P0 mu0, per (model, q)
    pa = np.broadcast_to(p0a + s11, s12.shape)
    pab = s12
    pb = p0b + s22
    h1 = np.broadcast_to(r1, s12.shape)
    h2 = r2 + p0b * b_mean
    det = pa * pb - pab**2
    ma = (pb * h1 - pab * h2) / det
    mb = (pa * h2 - pab * h1) / det
    n = y.size
    log_ev = (
        -0.5 * n * np.log(2 * np.pi)
        - 0.5 * logdet_noise
        - 0.5 * yy
        - 0.5 * p0b * b_mean**2
        + 0.5 * (h1 * ma + h2 * mb)
        - 0.5 * np.log(det)
        + 0.5 * np.log(p0a * p0b)
    )
    cov = np.empty(ma.shape + (2, 2))
    cov[..., 0, 0] = pb / det
    cov[..., 1, 1] = pa / det
    cov[..., 0, 1] = cov[..., 1, 0] = -pab / det
    return np.stack([ma, mb], axis=-1), cov, log_ev
