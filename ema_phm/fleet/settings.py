"""How a fleet's windows are diagnosed: one `DiagnosisSettings`, stored with the results.

Every window of a store is diagnosed with the same settings (a history mixing two presets or
two thresholds would be no history): the store records them on its first ingest and refuses
an ingest that asks for others (`store.Store.check_settings`).
"""

from __future__ import annotations

import functools
from dataclasses import asdict, dataclass
from typing import Any, Mapping

from ..diagnosis.isolation_settings import FitSettings
from ..model.belief import MonitorBelief, belief_for


@dataclass(frozen=True)
class DiagnosisSettings(FitSettings):
    """The isolation, the prognosis and the actuator every window of a store is judged with.

    The fit's settings (`FitSettings`: nuisances searched, 90 % intervals, as `ema-phm
    isolate`); the rest go to the live monitor's `tracker.PrognosticTracker` (`cycle_hours`
    None: each recording's run_info, else 1; `growth_priors` None: the fault table's).
    `actuator`: an actuator file the monitor believes it watches (None: the packaged one).
    """

    actuator: str | None = None
    thresholds: tuple[float, ...] | None = None
    horizon_cycles: int = 10
    alarm_windows: int = 2
    cycle_hours: float | None = None
    growth_priors: Mapping[str, Any] | None = None

    def belief(self) -> MonitorBelief:
        """The monitor's belief before any unit is commissioned (the actuator's)."""
        return _actuator_belief(self.actuator)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready values (what a store records and checks, `store.Store.check_settings`)."""
        out = asdict(self)
        out["thresholds"] = None if self.thresholds is None else list(self.thresholds)
        out["growth_priors"] = None if self.growth_priors is None else dict(self.growth_priors)
        return out


@functools.lru_cache(maxsize=4)
def _actuator_belief(path: str | None) -> MonitorBelief:
    """`belief_for` an actuator file, read once per process (every window asks for it)."""
    return belief_for(path)
