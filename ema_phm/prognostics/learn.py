"""Growth priors learned from past lives: how fast each fault grew in a fleet's own units.

`learn_growth_priors(lives)` takes the estimate histories of faults that grew until they
failed (a fleet's removed units, or a benchmark's tuning half), fits each one's trend
(`trend.fit_trend`, flat prior) on the whole life, and reads, per law, the rate the life
grew at given that law: linear, the severity gained per cycle (b / span); exponential,
lambda.  The population prior of a fault is log-normal: the median of those rates and the
sd of their logarithms (at least MIN_LOG_SD, so a few alike lives do not make a prior
sharper than the lives can tell).  The result is what `rul.prognose(growth_priors=)` takes.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import numpy as np

from ..errors import ConfigError
from .rul import History, law_prior
from .trend import TrendFit, fit_trend

#: Smallest log sd of a learned rate prior.
MIN_LOG_SD = 0.25
#: Fewest lives of a fault to learn its prior from.
MIN_LIVES = 2
#: Noise floor of the severity estimates (as `rul.prognose`'s default).
FLOOR = 0.01


#: Smallest share of either law in a learned law split.
MIN_LAW_SHARE = 0.05


def life_rates(history: History, index: int, name: str) -> tuple[float, float, float]:
    """(linear rate, exponential rate, P(exponential | trend)) of a whole-life history."""
    sev, sd = history.severity(index)
    fit = fit_trend(
        history.cycles, sev, np.maximum(sd, FLOOR), floor=FLOOR, law_prior=law_prior(name)
    )
    laws = fit.law_probabilities
    p_exp = laws["exponential"] / max(laws["linear"] + laws["exponential"], 1e-300)
    return _rate(fit, 1), _rate(fit, 2), p_exp


def _rate(fit: TrendFit, law: int) -> float:
    """Posterior-mean log rate of `law` (1 linear, 2 exponential), as a rate."""
    w = np.exp(fit.log_w)
    w[fit.law != law] = 0.0
    if not w.sum() > 0:
        return math.nan
    w /= w.sum()
    if law == 1:
        per_cycle = fit.mean[..., 1] / fit.span[:, None]
    else:
        per_cycle = np.broadcast_to(fit.rate[:, None], w.shape)
    logs = np.log(np.maximum(per_cycle, 1e-6))
    return float(math.exp(np.sum(w * logs)))


def learn_growth_priors(
    lives: Iterable[tuple[str, History, int]],
) -> dict[str, dict[str, Any]]:
    """Per fault name, {"linear": (median, log sd), "exponential": (...), "p_exponential": p}.

    The rates' log-normal priors and the share of the lives that grew exponentially (the
    mean P(exponential | trend), kept within [MIN_LAW_SHARE, 1 - MIN_LAW_SHARE]).

    `lives`: (fault name, its estimate history up to failure, its k index).  A fault with
    fewer than MIN_LIVES lives gets no prior (ConfigError if none has enough).
    """
    rates: dict[str, list[tuple[float, float, float]]] = {}
    for name, history, index in lives:
        rates.setdefault(name, []).append(life_rates(history, index, name))
    out = {}
    for name, rs in sorted(rates.items()):
        if len(rs) < MIN_LIVES:
            continue
        r = np.array(rs, dtype=np.float64)
        a = np.log(r[:, :2])
        prior: dict[str, Any] = {
            law: (
                float(math.exp(np.nanmedian(a[:, j]))),
                max(float(np.nanstd(a[:, j], ddof=1)), MIN_LOG_SD),
            )
            for j, law in enumerate(("linear", "exponential"))
        }
        share = float(np.mean(r[:, 2]))
        prior["p_exponential"] = min(max(share, MIN_LAW_SHARE), 1.0 - MIN_LAW_SHARE)
        out[name] = prior
    if not out:
        raise ConfigError(f"no fault has {MIN_LIVES} or more lives to learn a growth prior from")
    return out
