"""Prognostic performance metrics: alpha-lambda, prognostic horizon, relative accuracy, coverage.

Definitions from A. Saxena, J. Celaya, B. Saha, S. Saha, K. Goebel, "Metrics for Offline
Evaluation of Prognostic Performance", International Journal of Prognostics and Health
Management 1(1), 2010 (below: Saxena 2010), the same as NASA progpy's
``progpy.metrics`` (``alpha_lambda``, ``prognostic_horizon``,
``cumulative_relative_accuracy``).  progpy itself is not used: it installs cleanly but
pulls pandas, filterpy, fastdtw and requests into this environment for four formulas.

Notation (times in cycles here; any unit works):

- t_j: the times at which RUL predictions were made (increasing); t_P the first one;
- t_EoL: the true end of life (the first cycle at which the fault's true severity reaches
  its failure threshold);
- r*(t) = t_EoL - t: the true RUL at t;
- r(t_j): the predicted RUL distribution at t_j, given here as samples (an array; one
  value is a point prediction; ``[inf]`` is "no prediction": it meets no bound);
- pi[r(t)](lo, hi): the fraction of that distribution inside [lo, hi] (bounds included).

Only predictions made before the end of life (t_j < t_EoL, so r* > 0) are scored.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from ..errors import ConfigError
from ..limits import FINITE, Limit, check

ArrayLike = Sequence[float] | np.ndarray


def _profile(
    times: ArrayLike, samples: Sequence[ArrayLike], t_eol: float
) -> tuple[np.ndarray, list[np.ndarray]]:
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    if len(samples) != t.size:
        raise ConfigError(f"{t.size} prediction times but {len(samples)} RUL predictions")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ConfigError(f"prediction times must be finite and increasing, got {t.tolist()}")
    check("true end of life", t_eol, limit=FINITE)
    out = []
    for j, s in enumerate(samples):
        a = np.asarray(s, dtype=np.float64).reshape(-1)
        if a.size == 0 or np.any(np.isnan(a)):
            raise ConfigError(f"RUL prediction {j} (t = {t[j]:g}) must be numbers, got {s!r}")
        out.append(a)
    return t, out


#: alpha and beta of the alpha-lambda and prognostic-horizon metrics; lambda.
_FRACTION = Limit(0.0, 1.0, low_open=True)
_LAMBDA = Limit(0.0, 1.0)


def _fraction(alpha: float, name: str = "alpha") -> float:
    return float(check(name, alpha, limit=_FRACTION))


def _lambda(lam: float) -> float:
    return float(check("lambda", lam, limit=_LAMBDA))


def mass_within(samples: ArrayLike, low: float, high: float) -> float:
    """pi[r](low, high): the fraction of the samples inside [low, high]."""
    a = np.asarray(samples, dtype=np.float64).reshape(-1)
    return float(np.mean((a >= low) & (a <= high)))


def _cone_checks(
    times: ArrayLike,
    samples: Sequence[ArrayLike],
    t_eol: float,
    *,
    alpha: float,
    lam: float,
    beta: float,
    t_p: float | None,
) -> list[bool]:
    """The alpha-lambda criterion at each prediction t_j in [t_lambda, t_EoL), in order."""
    t, s = _profile(times, samples, t_eol)
    a, b, lam = _fraction(alpha), _fraction(beta, "beta"), _lambda(lam)
    tp = float(t[0]) if t_p is None else float(t_p)
    t_lam = tp + lam * (t_eol - tp)
    return [
        mass_within(sj, (1 - a) * (t_eol - tj), (1 + a) * (t_eol - tj)) >= b
        for tj, sj in zip(t, s, strict=True)
        if t_lam <= tj < t_eol
    ]


def alpha_lambda(
    times: ArrayLike,
    samples: Sequence[ArrayLike],
    t_eol: float,
    *,
    alpha: float = 0.2,
    lam: float = 0.5,
    beta: float = 0.5,
    t_p: float | None = None,
) -> bool | None:
    """alpha-lambda accuracy (Saxena 2010, sec. "alpha-lambda Performance").

    At t_lambda = t_P + lambda (t_EoL - t_P) the prediction must hold at least `beta` of
    its probability within (1 - alpha) r*(t_lambda) .. (1 + alpha) r*(t_lambda).  As in
    progpy, the prediction evaluated is the first one made at or after t_lambda.  `t_p`
    defaults to the first prediction time.  None when no prediction is made in
    [t_lambda, t_EoL).
    """
    checks = _cone_checks(times, samples, t_eol, alpha=alpha, lam=lam, beta=beta, t_p=t_p)
    return checks[0] if checks else None


def alpha_lambda_from(
    times: ArrayLike,
    samples: Sequence[ArrayLike],
    t_eol: float,
    *,
    alpha: float = 0.2,
    lam: float = 0.5,
    beta: float = 0.5,
    t_p: float | None = None,
) -> bool | None:
    """Whether alpha-lambda holds at every prediction from t_lambda on (before t_EoL).

    The form of the issue's target ("met from lambda = 0.5 of life onward"): the criterion
    of `alpha_lambda` at each prediction t_j in [t_lambda, t_EoL).  None when there is none.
    """
    checks = _cone_checks(times, samples, t_eol, alpha=alpha, lam=lam, beta=beta, t_p=t_p)
    return None if not checks else all(checks)


def prognostic_horizon(
    times: ArrayLike,
    samples: Sequence[ArrayLike],
    t_eol: float,
    *,
    alpha: float = 0.2,
    beta: float = 0.5,
) -> float:
    """Prognostic horizon PH = t_EoL - t_i_alpha (Saxena 2010, sec. "Prognostic Horizon").

    t_i_alpha is the first prediction time whose prediction holds at least `beta` of its
    probability within the alpha-bounds r*(t_i) +/- alpha t_EoL (bounds a fixed fraction of
    the true end of life).  0.0 when no prediction before t_EoL meets them.
    """
    t, s = _profile(times, samples, t_eol)
    a, b = _fraction(alpha), _fraction(beta, "beta")
    for tj, sj in zip(t, s, strict=True):
        if tj >= t_eol:
            break
        r_true = t_eol - tj
        if mass_within(sj, r_true - a * t_eol, r_true + a * t_eol) >= b:
            return float(t_eol - tj)
    return 0.0


def relative_accuracy(samples: ArrayLike, t: float, t_eol: float) -> float:
    """RA = 1 - |r*(t) - median r(t)| / r*(t) (Saxena 2010, sec. "Relative Accuracy").

    The central tendency is the median (Saxena 2010 leaves mean or median to the user;
    the median exists for a distribution with samples at inf).  Can be negative (an error
    larger than the true RUL) or -inf (a median at inf).
    """
    r_true = float(t_eol) - float(t)
    if not r_true > 0:
        raise ConfigError(f"relative accuracy needs t < t_EoL, got t = {t!r}, t_EoL = {t_eol!r}")
    med = float(np.median(np.asarray(samples, dtype=np.float64)))
    return 1.0 - abs(r_true - med) / r_true


def cumulative_relative_accuracy(
    times: ArrayLike, samples: Sequence[ArrayLike], t_eol: float
) -> float:
    """CRA: the mean RA over the predictions made before t_EoL (Saxena 2010, equal weights).

    NaN when there is none.
    """
    t, s = _profile(times, samples, t_eol)
    ra = [relative_accuracy(sj, tj, t_eol) for tj, sj in zip(t, s, strict=True) if tj < t_eol]
    return float(np.mean(ra)) if ra else math.nan


def interval_coverage(times: ArrayLike, low: ArrayLike, high: ArrayLike, t_eol: float) -> float:
    """Fraction of predictions before t_EoL whose [low, high] RUL interval holds r*(t_j).

    The empirical coverage of a prediction interval (90 % nominal for the 5th-95th
    percentiles): a calibrated predictor covers about its nominal fraction.  NaN when
    there is no prediction before t_EoL.
    """
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    lo = np.asarray(low, dtype=np.float64).reshape(-1)
    hi = np.asarray(high, dtype=np.float64).reshape(-1)
    if not (t.size == lo.size == hi.size):
        raise ConfigError(f"{t.size} times, {lo.size} lows and {hi.size} highs differ in number")
    if np.any(lo > hi):
        j = int(np.flatnonzero(lo > hi)[0])
        raise ConfigError(f"interval {j} has low {lo[j]:g} > high {hi[j]:g}")
    before = t < t_eol
    if not before.any():
        return math.nan
    r_true = t_eol - t[before]
    return float(np.mean((lo[before] <= r_true) & (r_true <= hi[before])))
