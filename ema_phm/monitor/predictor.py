"""The predictor: remaining useful life from a history of estimates.

`Predictor` is what the monitor's policy (`policy.FitPolicy`) asks for; `RulPredictor` is the
default, `prognostics.rul.prognose` with fixed settings.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Protocol, Sequence

from ..prognostics.rul import History, Prognosis, prognose


class Predictor(Protocol):
    """Prognoses every fault at the last cycle of a history."""

    def predict(self, history: History, *, seed: int = 0) -> Prognosis:
        """The prognosis after `history`; `seed` seeds its sampling."""
        ...


@dataclass(frozen=True)
class RulPredictor:
    """`rul.prognose` with these settings (None: `prognose`'s own default)."""

    thresholds: Sequence[float] | None = None
    cycle_hours: float = 1.0
    horizon_cycles: float = 10.0
    noise_floor: float | None = None
    #: growth priors by fault (`rul.growth_priors`; None: the fault table's, {}: none)
    growth_priors: Mapping[str, Any] | None = None

    def predict(self, history: History, *, seed: int = 0) -> Prognosis:
        """The prognosis after `history`; `seed` seeds its sampling."""
        floor: dict[str, Any] = (
            {} if self.noise_floor is None else {"noise_floor": self.noise_floor}
        )
        return prognose(
            history,
            thresholds=self.thresholds,
            cycle_hours=self.cycle_hours,
            horizon_cycles=self.horizon_cycles,
            seed=seed,
            growth_priors=self.growth_priors,
            **floor,
        )
