"""A fleet that learns from its own lives: growth priors learned leave-one-out on the rows.

For each trajectory, `prognostics.learn.learn_growth_priors` learns the growth priors (rates,
law split, how much the rate moves) from every other trajectory's lives in the same rows,
as the monitor's estimates kept them up to each failure (`prog.lives.counted_history`), and
`rul.prognose` runs on that trajectory with them: what a fleet whose past lives grew like
these would get from its own history.  The scored trajectory never enters its own prior.
A fault with too few other lives keeps the shipped prior.
"""

from __future__ import annotations

from typing import Any

from bench.prog import compare
from bench.prog.lives import MIN_ESTIMATES, counted_history
from bench.prog.rescore import Prognose
from ema_phm.domain.faults import GROWTH_PRIORS, NAMES
from ema_phm.errors import ConfigError
from ema_phm.prognostics.learn import learn_growth_priors
from ema_phm.prognostics.rul import History

LABEL = "ema_phm, growth priors learned from the other lives (leave one out)"


def _lives(data: dict, by_t: dict[int, list[dict]]) -> dict[int, list[tuple[str, History, int]]]:
    """Per trajectory, its faults' estimate histories up to their true end of life."""
    out: dict[int, list[tuple[str, History, int]]] = {}
    for tr in data["plan"]:
        for name, eol in tr["true_eol"].items():
            if eol is None or tr["index"] not in by_t:
                continue
            hist = counted_history([w for w in by_t[tr["index"]] if w["cycle"] < eol])
            if hist is not None and hist.n >= MIN_ESTIMATES:
                out.setdefault(tr["index"], []).append((name, hist, NAMES.index(name)))
    return out


def priors_without(lives: dict[int, list], index: int) -> dict[str, Any]:
    """The shipped priors, with those the other trajectories' lives teach over them."""
    others = [life for t, ls in lives.items() if t != index for life in ls]
    try:
        return {**GROWTH_PRIORS, **learn_growth_priors(others)}
    except ConfigError:  # no fault has enough other lives: the shipped priors
        return dict(GROWTH_PRIORS)


def score(data: dict, seed: int = compare.SEED) -> list[compare.Scored]:
    """Every trajectory with stored rows, prognosed with priors learned without it."""
    by_t: dict[int, list[dict]] = {}
    for w in data["windows"]:
        by_t.setdefault(int(w["trajectory"]), []).append(w)
    lives = _lives(data, by_t)
    out = []
    for tr in data["plan"]:
        if tr["index"] not in by_t:
            continue
        predictor = Prognose("own fleet", {"growth_priors": priors_without(lives, tr["index"])})
        out.append(compare.score_trajectory(tr, by_t[tr["index"]], predictor, seed=seed))
    return out
