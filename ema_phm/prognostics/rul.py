"""Remaining useful life (RUL) per fault from a history of per-window k estimates.

Chapter 1 of the thesis defines the aim of prognostics as the RUL: the time left before a
component can no longer do its job.  Here a fault's job ends when its severity
|k_i - nominal_i| reaches its failure threshold (default: the monitor's ERROR threshold,
`ema_phm.domain.faults.DEFAULT_ERROR`, 0.4 for k1..k6).

`History` holds per-window estimates (cycle, k, and a 90 % interval [k_low, k_high] per
entry; without intervals they are zero-width and `intervals_known` is False).
`prognose(history, ...)` fits each fault's trend (`trend.fit_trend`: Bayesian regression
on linear and exponential laws with an unknown onset) and projects it to the threshold,
giving per fault (the growth rate may keep moving over the horizon, by as much as the
history says it has moved: `diffusion.py`, ``rate_walk``, on by default):

- status ``degrading`` with the RUL percentiles 5 / 50 / 95 in cycles and hours and the
  probability of reaching the threshold within ``horizon_cycles`` (RUL a distribution:
  seeded posterior predictive samples given a trend, inf where a sample never reaches the
  threshold);
- ``no_degradation`` ("no degradation detected") while the trend is not significant, or
  rests on one window alone (the trend must survive leaving out the estimate farthest
  from the history's median: an isolation that once misnames a fault is not a trend);
- ``not_applicable`` for the faults the table gives no RUL (`domain.faults.NOT_APPLICABLE`:
  the gain fault, abrupt, and the eccentricity phase, a direction);
- ``insufficient_data`` with fewer than ``min_points`` estimates.

RUL is counted in whole cycles from the last cycle of the history (the time of
prediction) to the first cycle at which the trend is at or above the threshold.

Three pieces of knowledge from outside the history enter, each replaceable per call:
`LAW_PRIORS`, the prior odds of linear against exponential growth from each fault's physics;
`GROWTH_PRIORS`, how fast each fault grew in past lives and by which law (learned by
`prognostics.learn`; with one, the exponential law takes its propagation form and the fit
weighs recent estimates more, `memory_cycles`); and `SEVERITY_SCALE`, how the monitor's
severity estimates err relative to the truth as the robust benchmark measured it on other
units, which sets where the failure threshold lies as the estimates will show it (the
unit's own bias is an unknown of the trajectory: each posterior sample draws one and keeps
it to the threshold; one unit's estimates cannot tell it, being the same curve scaled).
`detection_level` (default 0: off) additionally holds back a RUL until the trend's present
severity is at or above that level with P >= ``p_detect``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from functools import partial
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..domain.faults import (
    DEFAULT_ERROR,
    FAULTS,
    GROWTH_PRIORS,
    LABELS,
    LAW_PRIORS,
    N_K,
    NAMES,
    NOMINAL,
    NOT_APPLICABLE,
    PREDICTED,
    SEVERITY_SCALE,
    Fault,
    per_fault,
)
from ..errors import ConfigError
from ..limits import POSITIVE, Limit, check
from . import diffusion
from .trend import LAWS, Z90, GrowthPrior, TrendFit, fit_trend

#: Statuses a fault's prognosis can have.
STATUSES: tuple[str, ...] = (
    "degrading",
    "no_degradation",
    "not_applicable",
    "insufficient_data",
    "not_seen",  # the recordings cannot show the fault (a channel it needs is not recorded)
)
#: RUL percentiles reported.
PERCENTILES: tuple[float, ...] = (5.0, 50.0, 95.0)


def _matrix(name: str, value: Any, n: int) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ConfigError(f"history {name} must be numbers, got {value!r}") from None
    if a.shape != (n, N_K):
        raise ConfigError(f"history {name} must have shape ({n}, {N_K}), got {a.shape}")
    if not np.all(np.isfinite(a)):
        i, j = np.argwhere(~np.isfinite(a))[0]
        raise ConfigError(f"history {name}[{i}] {LABELS[j]} is {a[i, j]}, must be finite")
    return a


@dataclass(frozen=True)
class History:
    """Per-window estimates: cycle [cycle], k, and its 90 % interval [k_low, k_high]."""

    cycles: np.ndarray  # (n,) strictly increasing
    k: np.ndarray  # (n, N_K)
    k_low: np.ndarray  # (n, N_K)
    k_high: np.ndarray  # (n, N_K)
    intervals_known: bool = True
    #: faults the recordings cannot show (index -> why): no trend is read from their k
    unseen: Mapping[int, str] = field(default_factory=dict)

    @classmethod
    def from_estimates(
        cls,
        cycles: Sequence[float] | np.ndarray,
        k: Sequence[Sequence[float] | np.ndarray] | np.ndarray,
        k_low: Sequence[Sequence[float] | np.ndarray] | np.ndarray | None = None,
        k_high: Sequence[Sequence[float] | np.ndarray] | np.ndarray | None = None,
    ) -> History:
        """Validate and build; without k_low and k_high the intervals are zero-width (unknown).

        ConfigError naming the problem and the value: cycles not finite or not strictly
        increasing, a k outside [0, 1], an interval that does not hold its k.
        """
        try:
            c = np.asarray(cycles, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError):
            raise ConfigError(f"history cycles must be numbers, got {cycles!r}") from None
        n = c.size
        if n == 0:
            raise ConfigError("history is empty: no estimates")
        if not np.all(np.isfinite(c)):
            raise ConfigError(f"history cycles must be finite, got {c[~np.isfinite(c)][0]}")
        steps = np.diff(c)
        if np.any(steps <= 0):
            i = int(np.flatnonzero(steps <= 0)[0])
            raise ConfigError(
                f"history cycles must increase strictly: cycle {c[i + 1]:g} follows {c[i]:g}"
            )
        kk = _matrix("k", k, n)
        if (k_low is None) != (k_high is None):
            raise ConfigError("give both k_low and k_high, or neither (intervals unknown)")
        known = k_low is not None
        lo = kk.copy() if k_low is None else _matrix("k_low", k_low, n)
        hi = kk.copy() if k_high is None else _matrix("k_high", k_high, n)
        for name, a in (("k", kk), ("k_low", lo), ("k_high", hi)):
            bad = (a < 0.0) | (a > 1.0)
            if bad.any():
                i, j = np.argwhere(bad)[0]
                raise ConfigError(
                    f"history {name} at cycle {c[i]:g}: {LABELS[j]} = {a[i, j]:g} is outside "
                    "[0, 1]"
                )
        bad = (lo > kk + 1e-12) | (hi < kk - 1e-12)
        if bad.any():
            i, j = np.argwhere(bad)[0]
            raise ConfigError(
                f"history at cycle {c[i]:g}: {LABELS[j]} = {kk[i, j]:g} is not inside its "
                f"interval [{lo[i, j]:g}, {hi[i, j]:g}]"
            )
        return cls(cycles=c, k=kk, k_low=lo, k_high=hi, intervals_known=known)

    @property
    def n(self) -> int:
        """Number of estimates."""
        return int(self.cycles.size)

    def upto(self, n: int) -> History:
        """The first `n` estimates (the history as it was at its n-th window)."""
        return History(
            self.cycles[:n],
            self.k[:n],
            self.k_low[:n],
            self.k_high[:n],
            self.intervals_known,
            self.unseen,
        )

    def severity(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Severity |k_i - nominal_i| of entry `i` and its stated noise sd from the interval.

        The 90 % interval of the severity is that of k_i mapped the same way; sd =
        half-width / 1.645 (0 for a zero-width interval).
        """
        s = np.abs(self.k[:, i] - NOMINAL[i])
        a = np.abs(self.k_low[:, i] - NOMINAL[i])
        b = np.abs(self.k_high[:, i] - NOMINAL[i])
        straddles = (self.k_low[:, i] <= NOMINAL[i]) & (self.k_high[:, i] >= NOMINAL[i])
        lo = np.where(straddles, 0.0, np.minimum(a, b))
        hi = np.maximum(a, b)
        return s, (hi - lo) / (2.0 * Z90)


@dataclass(frozen=True)
class Percentiles:
    """RUL percentiles 5 / 50 / 95 (inf: beyond every sampled crossing: never reached)."""

    p5: float
    p50: float
    p95: float

    def scaled(self, factor: float) -> Percentiles:
        """Each percentile times `factor` (cycles -> hours)."""
        return Percentiles(self.p5 * factor, self.p50 * factor, self.p95 * factor)

    def as_dict(self) -> dict[str, float | None]:
        """JSON-ready: inf as None."""
        return {
            f"p{int(p)}": (v if math.isfinite(v) else None)
            for p, v in zip(PERCENTILES, (self.p5, self.p50, self.p95), strict=True)
        }


@dataclass(frozen=True)
class FaultPrognosis:
    """The prognosis of one k entry at the last cycle of a history."""

    index: int  # 0-based entry of k
    status: str  # one of STATUSES
    message: str
    threshold: float  # failure threshold on the severity [1]
    severity: float  # the last estimate's severity [1]
    p_trend: float = math.nan  # P(a trend | data)
    p_growth: float = math.nan  # P(growing | trend, data)
    law_probabilities: dict[str, float] | None = None
    onset: float = math.nan  # most probable onset [cycle]
    rul_cycles: Percentiles | None = None
    rul_hours: Percentiles | None = None
    p_within_horizon: float = math.nan  # P(threshold reached within the horizon)
    samples: np.ndarray | None = None  # RUL samples [cycle] (inf = never)
    estimates_needed: int = 0  # insufficient_data: how many more estimates a trend needs
    # posterior mean diffusion of the log growth rate [1/sqrt(cycle)] (diffusion.py; NaN:
    # not learned, the rate held constant)
    rate_diffusion: float = math.nan

    @property
    def name(self) -> str:
        """The fault's name (domain.faults.NAMES)."""
        return NAMES[self.index]

    @property
    def rul(self) -> tuple[Percentiles, Percentiles]:
        """The RUL in cycles and in hours; ConfigError for a fault without one (not degrading)."""
        if self.rul_cycles is None or self.rul_hours is None:
            raise ConfigError(f"{self.name} has no RUL: its status is {self.status}")
        return self.rul_cycles, self.rul_hours

    @property
    def law(self) -> str | None:
        """The most probable growth law among linear and exponential (None: no fit)."""
        laws = self.law_probabilities
        if laws is None:
            return None
        return max(("linear", "exponential"), key=lambda k: laws[k])

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready values (no samples; NaN and inf as None)."""

        def num(v: float) -> float | None:
            return float(v) if math.isfinite(v) else None

        return {
            "fault": self.name,
            "status": self.status,
            "message": self.message,
            "threshold": self.threshold,
            "severity": num(self.severity),
            "p_trend": num(self.p_trend),
            "p_growth": num(self.p_growth),
            "law": self.law if self.status == "degrading" else None,
            "law_probabilities": self.law_probabilities,
            "onset_cycle": num(self.onset) if self.status == "degrading" else None,
            "rul_cycles": None if self.rul_cycles is None else self.rul_cycles.as_dict(),
            "rul_hours": None if self.rul_hours is None else self.rul_hours.as_dict(),
            "p_within_horizon": num(self.p_within_horizon),
            "estimates_needed": self.estimates_needed,
            "rate_diffusion": num(self.rate_diffusion),
        }


@dataclass(frozen=True)
class Prognosis:
    """Every fault's prognosis at the last cycle of a history."""

    cycle: float  # time of prediction [cycle]
    cycle_hours: float  # [h / cycle]
    horizon_cycles: float  # horizon of p_within_horizon [cycle]
    intervals_known: bool
    faults: tuple[FaultPrognosis, ...]

    def fault(self, name: str) -> FaultPrognosis:
        """The prognosis of fault `name`."""
        for f in self.faults:
            if f.name == name:
                return f
        raise ConfigError(f"unknown fault {name!r}; choose from {', '.join(NAMES)}")

    @property
    def degrading(self) -> tuple[FaultPrognosis, ...]:
        """The faults with a RUL."""
        return tuple(f for f in self.faults if f.status == "degrading")

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready values."""
        return {
            "cycle": self.cycle,
            "cycle_hours": self.cycle_hours,
            "horizon_cycles": self.horizon_cycles,
            "horizon_hours": self.horizon_cycles * self.cycle_hours,
            "intervals_known": self.intervals_known,
            "faults": [f.as_dict() for f in self.faults],
        }


def failure_thresholds(thresholds: Sequence[float] | None) -> tuple[float, ...]:
    """N_K failure thresholds (default `domain.faults.DEFAULT_ERROR`).

    ConfigError naming a bad one; those of faults without a RUL are not checked.
    """
    if thresholds is None:
        return tuple(float(v) for v in DEFAULT_ERROR)
    th = per_fault("failure thresholds", thresholds)
    for i in PREDICTED:
        if not (math.isfinite(th[i]) and 0.0 < th[i] <= 1.0):
            raise ConfigError(
                f"failure threshold of {LABELS[i]} ({NAMES[i]}) must be in (0, 1], got {th[i]!r}"
            )
    return th


def law_prior(
    name: str, priors: Mapping[str, Mapping[str, float]] | None = None
) -> dict[str, float]:
    """The growth-law prior of fault `name`: from `priors` if it names it, else `LAW_PRIORS`.

    ConfigError naming the fault and value unless it gives every law of `LAWS` a positive
    probability and they sum to 1.
    """
    table = LAW_PRIORS if priors is None or name not in priors else priors
    raw = table.get(name, {"none": 0.5, "linear": 0.25, "exponential": 0.25})
    try:
        prior = {law: float(raw[law]) for law in LAWS}
    except (KeyError, TypeError, ValueError):
        raise ConfigError(
            f"law prior of {name} must give a probability to each of {', '.join(LAWS)}, "
            f"got {raw!r}"
        ) from None
    if not all(math.isfinite(v) and v > 0 for v in prior.values()) or not math.isclose(
        sum(prior.values()), 1.0, abs_tol=1e-9
    ):
        raise ConfigError(
            f"law prior of {name} must be positive probabilities summing to 1, got {raw!r}"
        )
    return prior


def scale_of(
    name: str, table: Mapping[str, tuple[float, float]] | None = None
) -> tuple[float, float]:
    """(median, sd) relative error of fault `name`'s severity estimates.

    From `table` if it names the fault, else `SEVERITY_SCALE`; (0, 0) for one in neither.
    ConfigError naming the fault and value unless the median is in (-1, 1) and the sd in
    [0, 1).
    """
    src = SEVERITY_SCALE if table is None or name not in table else table
    raw = src.get(name, (0.0, 0.0))
    try:
        med, sd = (float(v) for v in raw)
    except (TypeError, ValueError):
        raise ConfigError(f"severity scale of {name} must be (median, sd), got {raw!r}") from None
    if not (-1.0 < med < 1.0 and 0.0 <= sd < 1.0):
        raise ConfigError(
            f"severity scale of {name} must have a median in (-1, 1) and an sd in [0, 1), "
            f"got {raw!r}"
        )
    return med, sd


#: Whole numbers of samples and estimates (min_points: a trend needs two points).
_COUNT = Limit(0, math.inf, integer=True, low_open=True)
_MIN_POINTS = Limit(2, math.inf, integer=True, low_open=True)
_DETECTION_LEVEL = Limit(0.0, 1.0, high_open=True)
_P_DETECT = Limit(0.5, 1.0, high_open=True)


@dataclass(frozen=True)
class _Options:
    """`prognose`'s options, checked."""

    thresholds: tuple[float, ...]
    hours: float
    horizon: float
    seed: int
    n_samples: int
    p_detect: float
    min_points: int
    floor: float
    detection: float
    law_priors: Mapping[str, Mapping[str, float]] | None
    severity_scale: Mapping[str, tuple[float, float]] | None
    growth: Mapping[str, GrowthPrior]
    memory: float | None
    rate_walk: bool


def _options(
    thresholds: Sequence[float] | None,
    seed: int,
    law_priors: Any,
    severity_scale: Any,
    growth: Any,
    **numbers: Any,
) -> _Options:
    """Check `prognose`'s options; ConfigError naming the first bad one."""
    th = failure_thresholds(thresholds)
    hours = float(check("cycle_hours", numbers["cycle_hours"], limit=POSITIVE))
    horizon = float(check("horizon_cycles", numbers["horizon_cycles"], limit=POSITIVE))
    n_samples = int(check("samples", numbers["samples"], limit=_COUNT))
    min_pts = int(check("min_points", numbers["min_points"], limit=_MIN_POINTS))
    floor = float(check("noise_floor", numbers["noise_floor"], limit=POSITIVE))
    detection = float(check("detection_level", numbers["detection_level"], limit=_DETECTION_LEVEL))
    p_detect = float(check("p_detect", numbers["p_detect"], limit=_P_DETECT))
    memory = numbers["memory_cycles"]
    if memory is not None and not (isinstance(memory, (int, float)) and memory == math.inf):
        memory = float(check("memory_cycles", memory, limit=POSITIVE))
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ConfigError(f"seed must be a whole number >= 0, got {seed!r}")
    return _Options(
        thresholds=th,
        hours=hours,
        horizon=horizon,
        seed=int(seed),
        n_samples=n_samples,
        p_detect=p_detect,
        min_points=min_pts,
        floor=floor,
        detection=detection,
        law_priors=law_priors,
        severity_scale=severity_scale,
        growth=growth_priors(growth),
        memory=memory,
        rate_walk=bool(numbers["rate_walk"]),
    )


def _pair(v: Any) -> tuple[float, float]:
    a, b = v
    return float(a), float(b)


def growth_priors(table: Any) -> dict[str, GrowthPrior]:
    """The growth priors by fault name: `table`, or the fault table's (`GROWTH_PRIORS`).

    A mapping of a fault name to a `GrowthPrior` or to {"linear": (median, log sd),
    "exponential": (...)}; ConfigError naming the fault and the value otherwise.  An empty
    mapping: no growth prior (the flat prior on the rise).
    """
    src = GROWTH_PRIORS if table is None else table
    if not isinstance(src, Mapping):
        raise ConfigError(f"growth priors must map fault names to priors, got {src!r}")
    out = {}
    for name, v in src.items():
        if name not in NAMES:
            raise ConfigError(
                f"growth prior of unknown fault {name!r}; choose from {', '.join(NAMES)}"
            )
        if isinstance(v, GrowthPrior):
            out[name] = v
            continue
        try:
            pe, diff = v.get("p_exponential"), v.get("diffusion")
            out[name] = GrowthPrior(
                _pair(v["linear"]),
                _pair(v["exponential"]),
                None if pe is None else float(pe),
                None if diff is None else tuple(diff),
            )
        except ConfigError as exc:  # a value out of range: say which fault's
            raise ConfigError(f"{name}: {exc}") from None
        except (KeyError, TypeError, ValueError, AttributeError):
            raise ConfigError(
                f"growth prior of {name} must give linear and exponential (median, log sd), "
                f"got {v!r}"
            ) from None
    return out


def prognose(
    history: History,
    *,
    thresholds: Sequence[float] | None = None,
    cycle_hours: float = 1.0,
    horizon_cycles: float = 10.0,
    seed: int = 0,
    samples: int = 4000,
    p_detect: float = 0.95,
    min_points: int = 5,
    noise_floor: float = 0.01,
    law_priors: Mapping[str, Mapping[str, float]] | None = None,
    detection_level: float = 0.0,
    severity_scale: Mapping[str, tuple[float, float]] | None = None,
    growth_priors: Mapping[str, Any] | None = None,
    memory_cycles: float | None = None,
    rate_walk: bool = True,
) -> Prognosis:
    """Prognosis of every fault at the last cycle of `history` (see the module docstring).

    `thresholds`: failure threshold of each k entry's severity (N_K numbers; those of the
    faults without a RUL are ignored), default `domain.faults.DEFAULT_ERROR`.
    `horizon_cycles`: the horizon of ``p_within_horizon``.  `seed`: the posterior predictive
    sampling (each fault draws from its own stream, so one fault's result does not depend on
    the others).  `noise_floor`: smallest stated noise sd of an estimate [severity].
    `growth_priors`: how fast each fault grew in past lives (None: the fault table's
    `GROWTH_PRIORS`; {}: none, the flat prior on the rise).  `memory_cycles`: an estimate
    that many cycles older than the last counts e^-1 as much; None (default): MEMORY_SHARE
    of the lives' typical span (threshold / the growth prior's median linear rate) for a
    fault with a growth prior, inf (every estimate alike) for one without.  `rate_walk`:
    let the log growth rate diffuse over the horizon by the diffusion the history shows
    (`diffusion.py`); False: the trend's constant rate.
    """
    opts = _options(
        thresholds,
        seed,
        law_priors,
        severity_scale,
        growth_priors,
        cycle_hours=cycle_hours,
        horizon_cycles=horizon_cycles,
        samples=samples,
        min_points=min_points,
        noise_floor=noise_floor,
        detection_level=detection_level,
        p_detect=p_detect,
        memory_cycles=memory_cycles,
        rate_walk=rate_walk,
    )
    return Prognosis(
        cycle=float(history.cycles[-1]),
        cycle_hours=opts.hours,
        horizon_cycles=opts.horizon,
        intervals_known=history.intervals_known,
        faults=tuple(_prognose_fault(history, f, opts) for f in FAULTS),
    )


def _prognose_fault(history: History, f: Fault, opts: _Options) -> FaultPrognosis:
    """The prognosis of fault `f` at the last cycle of `history`."""
    i = f.index
    sev, sd = history.severity(i)
    last = float(sev[-1])
    threshold = opts.thresholds[i]
    if not f.has_rul:
        return FaultPrognosis(i, "not_applicable", NOT_APPLICABLE[i], threshold, last)
    if i in history.unseen:
        return FaultPrognosis(i, "not_seen", history.unseen[i], threshold, last)
    if history.n < opts.min_points:
        return FaultPrognosis(
            i,
            "insufficient_data",
            f"{history.n} estimates; a trend needs at least {opts.min_points}",
            threshold,
            last,
            estimates_needed=opts.min_points - history.n,
        )
    sigma = np.maximum(sd, opts.floor)
    growth = opts.growth.get(f.name)
    laws = law_prior(f.name, opts.law_priors)
    fit_history = partial(
        fit_trend,
        floor=opts.floor,
        law_prior=laws if growth is None else growth.law_prior(laws),
        growth=growth,
        memory=_memory(opts.memory, growth, threshold=opts.thresholds[i]),
    )
    fit = fit_history(history.cycles, sev, sigma)
    return _fault_prognosis(
        i,
        fit,
        one_out=_one_out(history.cycles, sev, sigma, fit_history),
        walk=partial(
            diffusion.of_trend,
            sigma=sigma,
            floor=opts.floor,
            prior=None if growth is None else growth.diffusion,
        )
        if opts.rate_walk
        else None,
        detection_level=opts.detection,
        scale=scale_of(f.name, opts.severity_scale),
        threshold=threshold,
        now=float(history.cycles[-1]),
        hours=opts.hours,
        horizon=opts.horizon,
        rng=np.random.default_rng([opts.seed, i]),
        n_samples=opts.n_samples,
        p_detect=opts.p_detect,
    )


#: Default memory, as a share of the lives' typical span (threshold / median linear rate).
MEMORY_SHARE = 0.4


def _memory(memory: float | None, growth: GrowthPrior | None, *, threshold: float) -> float:
    """The memory [cycle] a fit weighs its estimates with (see `prognose`)."""
    if memory is not None:
        return memory
    if growth is None:
        return math.inf
    return MEMORY_SHARE * threshold / growth.linear[0]


def _one_out(
    cycles: np.ndarray,
    y: np.ndarray,
    sigma: np.ndarray,
    fit_history: Callable[[np.ndarray, np.ndarray, np.ndarray], TrendFit],
) -> Callable[[], tuple[float, TrendFit]]:
    """The check behind "a trend carried by one window is not a trend".

    Returns a function giving the cycle of the estimate farthest from the history's median
    (in its stated sd) and the fit without it.
    """

    def refit() -> tuple[float, TrendFit]:
        j = int(np.argmax(np.abs(y - np.median(y)) / sigma))
        keep = np.arange(y.size) != j
        return float(cycles[j]), fit_history(cycles[keep], y[keep], sigma[keep])

    return refit


def _fault_prognosis(
    i: int,
    fit: TrendFit,
    *,
    one_out: Callable[[], tuple[float, TrendFit]],
    threshold: float,
    now: float,
    hours: float,
    horizon: float,
    rng: np.random.Generator,
    n_samples: int,
    p_detect: float,
    detection_level: float = 0.0,
    scale: tuple[float, float] = (0.0, 0.0),
    walk: Callable[[TrendFit], diffusion.Diffusion] | None = None,
) -> FaultPrognosis:
    held = FaultPrognosis(
        i,
        "no_degradation",
        "",
        threshold=threshold,
        severity=float(fit.y[-1]),
        p_trend=fit.p_trend,
        p_growth=fit.p_growth,
        law_probabilities=fit.law_probabilities,
    )
    why = _not_a_trend(fit, one_out, p_detect)
    if why:
        return dataclasses.replace(held, message=f"no degradation detected ({why})")
    m, a, b = fit.sample(n_samples, rng)
    why = _not_present(fit, (m, a, b), now, detection_level, p_detect)
    if why:
        return dataclasses.replace(held, message=f"no degradation detected ({why})")
    moving = None if walk is None else walk(fit)
    rul = _rul_samples(fit, (m, a, b), threshold, scale=scale, now=now, rng=rng, moving=moving)
    pct = np.percentile(rul, PERCENTILES, method="inverted_cdf")
    rc = Percentiles(*(float(v) for v in pct))
    p_h = float(np.mean(rul <= horizon))
    laws = fit.law_probabilities
    best = max(("linear", "exponential"), key=lambda k: laws[k])
    message = (
        f"{NAMES[i]} degrading ({best}, P = {laws[best] / max(fit.p_trend, 1e-300):.2f} given a "
        f"trend): RUL {rc.p50:.4g} cycles [{rc.p5:.4g}, {rc.p95:.4g}] to severity "
        f"{threshold:g}; P(reached within {horizon:g} cycles) = {p_h:.2f}"
    )
    return dataclasses.replace(
        held,
        status="degrading",
        message=message,
        onset=fit.onset_mode,
        rul_cycles=rc,
        rul_hours=rc.scaled(hours),
        p_within_horizon=p_h,
        samples=rul,
        rate_diffusion=math.nan if moving is None else moving.mean,
    )


def _not_present(
    fit: TrendFit,
    sampled: tuple[np.ndarray, np.ndarray, np.ndarray],
    now: float,
    detection_level: float,
    p_detect: float,
) -> str:
    """Why the trend is not yet at `detection_level` now ("" when it is, or with no level)."""
    if not detection_level > 0.0:
        return ""
    p_present = float(np.mean(fit.severity(np.array(now), *sampled) >= detection_level))
    if p_present >= p_detect:
        return ""
    return (
        f"the trend is at severity {detection_level:g} or above now with P = "
        f"{p_present:.3f} < {p_detect:g}"
    )


def _rul_samples(
    fit: TrendFit,
    sampled: tuple[np.ndarray, np.ndarray, np.ndarray],
    threshold: float,
    *,
    scale: tuple[float, float],
    now: float,
    rng: np.random.Generator,
    moving: diffusion.Diffusion | None = None,
) -> np.ndarray:
    """Whole cycles from `now` until each sampled trend (model, a, b) reaches the threshold.

    `moving`: the rate's diffusion (`diffusion.walk` moves the walking samples); None: the
    trend's constant rate.
    """
    m, a, b = sampled
    # the estimates' own scale error moves the threshold as the trend sees it
    th = threshold * np.maximum(1.0 + scale[0] + scale[1] * rng.standard_normal(m.size), 0.05)
    # whole cycles until the first cycle at or above the threshold (-inf, above from the
    # start, and crossings in the past -> 0)
    constant = np.maximum(np.ceil(fit.crossing_cycles(th, m, a, b) - now - 1e-9), 0.0)
    if moving is None:
        return constant
    return diffusion.walk(fit, sampled, th, constant, now=now, diffusion=moving, rng=rng)


def _not_a_trend(
    fit: TrendFit, one_out: Callable[[], tuple[float, TrendFit]], p_detect: float
) -> str:
    """Why `fit` shows no degradation ("" when it does): too weak, or one window's alone."""
    if fit.p_trend < p_detect:
        return f"P(trend) = {fit.p_trend:.3f} < {p_detect:g}"
    if fit.p_growth < p_detect:
        return f"P(growing) = {fit.p_growth:.3f} < {p_detect:g}"
    dropped, fit_without = one_out()
    if fit_without.p_trend < p_detect or fit_without.p_growth < p_detect:
        return (
            f"the trend rests on the estimate at cycle {dropped:g} alone: without it P(trend) = "
            f"{fit_without.p_trend:.3f}, P(growing) = {fit_without.p_growth:.3f}"
        )
    return ""


__all__ = [
    "History",
    "Percentiles",
    "FaultPrognosis",
    "Prognosis",
    "prognose",
    "LAWS",
    "STATUSES",
    "PREDICTED",
]
