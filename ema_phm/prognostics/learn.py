"""Growth priors learned from past lives: how fast each fault grew in a fleet's own units.

`learn_growth_priors(lives)` takes the estimate histories of faults that grew until they
failed (a fleet's removed units, or a benchmark's tuning half), fits each one's trend
(`trend.fit_trend`, flat prior) on the whole life, and reads the law it more probably grew
by and its rate under that law: linear, the severity gained per cycle (b / span);
exponential, lambda.  The population prior of a fault is log-normal per law: the median of
its lives' rates and the sd of their logarithms (at least MIN_LOG_SD, so a few alike lives
do not make a prior sharper than the lives can tell).  How much each life's rate moved
(`diffusion.py`): each life's likelihood over the diffusions (its posterior under a flat
prior), averaged over the fault's lives, every diffusion kept at MIN_DIFFUSION_SHARE or
more.  The result is what `rul.prognose(growth_priors=)` takes.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ..errors import ConfigError
from . import diffusion
from .rul import History, growth_priors, law_prior
from .trend import TrendFit, fit_trend

#: Smallest log sd of a learned rate prior.
MIN_LOG_SD = 0.25
#: Fewest lives of a fault to learn its prior from.
MIN_LIVES = 2
#: Noise floor of the severity estimates (as `rul.prognose`'s default).
FLOOR = 0.01


#: Smallest log sd of a law's prior learned from lives that did not grow by it.
VAGUE_LOG_SD = 1.0
#: Largest log sd of a learned rate prior: wider says nothing more (its Gauss-Hermite nodes
#: already span e^(+/-16) of the median), and `trend.GrowthPrior` refuses 5 and above.
MAX_LOG_SD = 3.0
#: Smallest share of either law in a learned law split.
MIN_LAW_SHARE = 0.05
#: Smallest weight of any diffusion in a learned diffusion prior (none is ruled out).
MIN_DIFFUSION_SHARE = 0.02


def life_rates(history: History, index: int, name: str) -> tuple[float, ...]:
    """A whole-life history's rates, law split and how much its rate moved.

    (linear rate, exponential rate, P(exponential | trend), then the likelihood of each of
    `diffusion.DIFFUSIONS`, normalized).
    """
    sev, sd = history.severity(index)
    sigma = np.maximum(sd, FLOOR)
    fit = fit_trend(history.cycles, sev, sigma, floor=FLOOR, law_prior=law_prior(name))
    laws = fit.law_probabilities
    p_exp = laws["exponential"] / max(laws["linear"] + laws["exponential"], 1e-300)
    flat = np.full(diffusion.DIFFUSIONS.size, 1.0)
    moved = diffusion.of_trend(fit, sigma, floor=FLOOR, prior=flat).weights
    return (_rate(fit, 1), _rate(fit, 2), p_exp, *moved)


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


def _log_normal(rates: np.ndarray, grew_so: np.ndarray) -> tuple[float, float]:
    """(median, log sd) of the rates of the lives that grew by this law.

    With fewer than MIN_LIVES such lives, the rates every life reads under it (a linear
    life's "exponential rate" is only the gentlest curve that mimics its line) with a log
    sd of at least VAGUE_LOG_SD: a prior that knows little.
    """
    logs = np.log(rates[np.isfinite(rates) & (rates > 0)])
    own = np.log(rates[grew_so & np.isfinite(rates) & (rates > 0)])
    if own.size >= MIN_LIVES:
        sd = float(np.std(own, ddof=1))
        least = MIN_LOG_SD
        median = float(math.exp(np.median(own)))
    else:
        sd = float(np.std(logs, ddof=1)) if logs.size > 1 else 0.0
        least = VAGUE_LOG_SD
        median = float(math.exp(np.median(logs)))
    return median, min(max(sd if math.isfinite(sd) else 0.0, least), MAX_LOG_SD)


def learn_growth_priors(
    lives: Iterable[tuple[str, History, int]],
) -> dict[str, dict[str, Any]]:
    """Per fault name, the growth prior its lives show (what `rul.prognose` takes).

    {"linear": (median, log sd), "exponential": (...), "p_exponential": p, "diffusion":
    [weight per diffusion.DIFFUSIONS]}.

    Each life counts for the law it more probably grew by (P(exponential | trend) > 1/2):
    a law's log-normal prior is learned from its own lives (`_log_normal`), and
    p_exponential is the share of exponential lives, kept within [MIN_LAW_SHARE,
    1 - MIN_LAW_SHARE]; diffusion the lives' mean likelihood of each diffusion, each at
    least MIN_DIFFUSION_SHARE.

    `lives`: (fault name, its estimate history up to failure, its k index).  A fault with
    fewer than MIN_LIVES lives gets no prior (ConfigError if none has enough).
    """
    rates: dict[str, list[tuple[float, ...]]] = {}
    for name, history, index in lives:
        rates.setdefault(name, []).append(life_rates(history, index, name))
    out = {}
    for name, rs in sorted(rates.items()):
        if len(rs) < MIN_LIVES:
            continue
        r = np.array(rs, dtype=np.float64)
        exponential = r[:, 2] > 0.5  # each life read under the law it more probably grew by
        prior: dict[str, Any] = {
            "linear": _log_normal(r[:, 0], ~exponential),
            "exponential": _log_normal(r[:, 1], exponential),
        }
        share = float(np.mean(exponential))
        prior["p_exponential"] = min(max(share, MIN_LAW_SHARE), 1.0 - MIN_LAW_SHARE)
        moved = r[:, 3:].mean(axis=0)
        floor = MIN_DIFFUSION_SHARE  # every diffusion keeps at least this weight
        moved = floor + (1.0 - floor * moved.size) * moved / moved.sum()
        prior["diffusion"] = [float(v) for v in moved]
        out[name] = prior
    if not out:
        raise ConfigError(f"no fault has {MIN_LIVES} or more lives to learn a growth prior from")
    return out


def load_growth_priors(spec: str | Path) -> dict[str, Any] | None:
    """Growth priors named by `spec`, as `rul.prognose(growth_priors=)` takes them.

    '' the packaged ones (None), 'none' no priors ({}), or a YAML file (fault: {linear:
    [median, log sd], exponential: [...], p_exponential: P, diffusion: [6 weights],
    optional}).  ConfigError naming the file
    and the problem (unreadable, not YAML, a bad prior).
    """
    text = str(spec)
    if text == "":
        return None
    if text == "none":
        return {}
    try:
        raw = yaml.safe_load(Path(text).read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError) as exc:
        raise ConfigError(f"cannot read growth priors {text}: {exc}") from None
    try:
        growth_priors(raw)
    except ConfigError as exc:
        raise ConfigError(f"{text}: {exc}") from None
    return raw
