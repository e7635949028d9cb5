"""How a fleet's windows are diagnosed: one `DiagnosisSettings`, stored with the results.

Every window of a store is diagnosed with the same settings (a history mixing two presets or
two thresholds would be no history): the store records them on its first ingest and refuses
an ingest that asks for others (`store.Store.check_settings`).
"""

from __future__ import annotations

import functools
from dataclasses import asdict, dataclass
from typing import Any, Mapping

from ..diagnosis.isolation import DEFAULT_PRESET, PRESETS
from ..errors import ConfigError
from ..model.belief import MonitorBelief


@dataclass(frozen=True)
class DiagnosisSettings:
    """The isolation, the prognosis and the actuator every window of a store is judged with.

    `preset`, `seed` and `max_evaluations` (None: the preset's budget) go to
    `diagnosis.isolation.isolate` (nuisances searched, 90 % intervals, as `ema-phm
    isolate`); the rest to the live monitor's `tracker.PrognosticTracker` (`cycle_hours`
    None: each recording's run_info, else 1; `growth_priors` None: the fault table's).
    `actuator`: an actuator file the monitor believes it watches (None: the packaged one).
    """

    preset: str = DEFAULT_PRESET
    seed: int = 0
    max_evaluations: int | None = None
    actuator: str | None = None
    thresholds: tuple[float, ...] | None = None
    horizon_cycles: int = 10
    alarm_windows: int = 2
    cycle_hours: float | None = None
    growth_priors: Mapping[str, Any] | None = None

    def __post_init__(self) -> None:
        if self.preset not in PRESETS:
            raise ConfigError(
                f"unknown preset {self.preset!r}; choose from {', '.join(sorted(PRESETS))}"
            )

    def belief(self) -> MonitorBelief:
        """The monitor's belief before any unit is commissioned (the actuator's)."""
        if self.actuator is None:
            return MonitorBelief.default()
        return _actuator_belief(self.actuator)

    def isolation_options(self) -> dict[str, Any]:
        """Keyword arguments of `isolate` besides the window, the start and the belief."""
        return {
            "seed": self.seed,
            "preset": self.preset,
            "max_evaluations": self.max_evaluations,
            "nuisance": True,
            "intervals": True,
        }

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready values."""
        out = asdict(self)
        out["thresholds"] = None if self.thresholds is None else list(self.thresholds)
        out["growth_priors"] = None if self.growth_priors is None else dict(self.growth_priors)
        return out


@functools.lru_cache(maxsize=4)
def _actuator_belief(path: str) -> MonitorBelief:
    """The belief of an actuator file, read once per process (every window asks for it)."""
    from ..physics.actuator_file import load_actuator  # noqa: PLC0415  (only when named)

    return MonitorBelief.for_actuator(load_actuator(path))
