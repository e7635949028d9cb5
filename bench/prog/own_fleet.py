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
from bench.prog.lives import lives_by_trajectory
from bench.prog.rescore import Prognose
from ema_phm.domain.faults import GROWTH_PRIORS
from ema_phm.errors import ConfigError
from ema_phm.prognostics.learn import learn_growth_priors

LABEL = "ema_phm, growth priors learned from the other lives (leave one out)"


def priors_without(lives: dict[int, list], index: int) -> dict[str, Any]:
    """The shipped priors, with those the other trajectories' lives teach over them."""
    others = [life for t, ls in lives.items() if t != index for life in ls]
    try:
        return {**GROWTH_PRIORS, **learn_growth_priors(others)}
    except ConfigError:  # no fault has enough other lives: the shipped priors
        return dict(GROWTH_PRIORS)


def score(data: dict, seed: int = compare.SEED) -> list[compare.Scored]:
    """Every trajectory with stored rows, prognosed with priors learned without it."""
    by_t = compare.windows_by_trajectory(data)
    lives = lives_by_trajectory(data)
    out = []
    for tr in data["plan"]:
        if tr["index"] not in by_t:
            continue
        predictor = Prognose("own fleet", {"growth_priors": priors_without(lives, tr["index"])})
        out.append(compare.score_trajectory(tr, by_t[tr["index"]], predictor, seed=seed))
    return out
