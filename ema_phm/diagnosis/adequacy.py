"""Model adequacy: whether the monitor explains a window at all.

Statistic: the fitted window's fitness divided by what a healthy window of this unit with
this window's noise would score, ``F / (F_noise + F_fed + F_healthy)``.  F_noise is the
fitness the telemetry's own white noise adds (`Fitness.noise_fitness`, from the noise
measured in the window itself); F_fed, for a model that follows the recorded loop, what
the noise of the channels it reads adds through the loop (`Fitness.fed_noise_fitness`,
measured on the window: a fine position sensor's healthy windows, whose deflection goes in
unfiltered, scored 1.5-1.9 before it was counted, 0.86-0.88 since); F_healthy is the
belief's monitor.healthy_fitness, the model-error part of a healthy fit (the packaged value
for the datasheet belief, a commissioned unit's own from its baselines;
monitor.healthy_fitness_followed for a fit that follows the recorded loop).  An actuator
description that gives no level is judged against the packaged actuator's as a stand-in
until a commissioning measures the unit's (`Adequacy.stand_in`; the verdict of a window held
back as not explained says so).  A window the
monitor explains as well as a healthy one scores about 1 whatever k it needed; an
unmodelled effect, a sensor fault or a bad recording leaves
residuals no k removes and scores high.  Where the loop hunts and the open-loop "thesis"
fitness compares its envelope (fitness.py), F leaves that term out
(`Fitness.adequacy_fitness`).  The thresholds are chosen by measurement on healthy realistic
windows: `THRESHOLD` for the open-loop fitnesses (docs/benchmarks_robust.md),
`FOLLOWED_THRESHOLD` for "recorded" (docs/benchmarks_robust_recorded.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from ..model.belief import HEALTHY_LEVELS, MonitorBelief

#: Statistic above which the model "does not explain this window": the largest healthy
#: statistic of the realistic benchmark's even units (0.955) x 1.5 (docs/benchmarks_robust.md:
#: no healthy window of the 60 above it, every hunting backlash window but 8 of 60 above it).
THRESHOLD = 1.43
#: The same choice for a fit that follows the recorded loop (fitness "recorded"): the largest
#: healthy statistic of the even units (0.957) x 1.5, rounded (docs/benchmarks_robust_recorded.md,
#: which uses the unrounded 1.435: no healthy window of the 60 above it; 15 of 320 fault
#: windows above 1.44, 13 of them backlash, 2 multi-fault).
FOLLOWED_THRESHOLD = 1.44


@dataclass(frozen=True)
class Adequacy:
    """Goodness of fit of one window: statistic, threshold, ok."""

    statistic: float
    threshold: float
    ok: bool
    #: the healthy level judged against is a stand-in (`MonitorBelief.own_levels`): the
    #: actuator description gives none and no commissioning has measured the unit's
    stand_in: bool = False

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready values."""
        out = {"statistic": self.statistic, "threshold": self.threshold, "ok": self.ok}
        return out | ({"stand_in_level": True} if self.stand_in else {})


def judge(
    fitness: float,
    *,
    belief: MonitorBelief,
    noise_fitness: float = 0.0,
    threshold: float | None = None,
    followed: bool = False,
    fed_noise_fitness: float = 0.0,
) -> Adequacy:
    """Adequacy of a fitted window whose best fitness is `fitness` (see the module doc).

    `followed`: the fit followed the recorded loop; its healthy reference is the belief's
    monitor.healthy_fitness_followed and its default threshold FOLLOWED_THRESHOLD (else
    THRESHOLD).  `fed_noise_fitness`: what the followed channels' noise adds (F_fed).
    """
    if threshold is None:
        threshold = FOLLOWED_THRESHOLD if followed else THRESHOLD
    healthy = HEALTHY_LEVELS[1] if followed else HEALTHY_LEVELS[0]
    noise = max(0.0, float(noise_fitness)) + max(0.0, float(fed_noise_fitness))
    ref = belief.value(healthy) + noise
    stat = float(fitness) / ref if ref > 0 else math.inf
    return Adequacy(
        statistic=stat,
        threshold=threshold,
        ok=bool(stat <= threshold),
        stand_in=not belief.level_is_own(healthy),
    )
