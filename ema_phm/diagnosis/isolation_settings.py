"""What the monitor fits a window with: one `FitSettings` for every caller, and the live extras.

`FitSettings` (preset, seed, fitness, budget, nuisances) is how `isolate` is asked to fit, the
same for `ema-phm prognose` (`monitor.replay`), a fleet's ingest (`fleet.settings`) and
monitor_node (`IsolationSettings`, which adds thresholds, the belief, tracking and the unit).
`max_evaluations` 0 is the preset's own budget everywhere.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any, Callable, Mapping

from ..errors import ConfigError
from ..limits import check
from ..model.belief import MonitorBelief, belief_for
from ..model.unit_file import read_warnings
from . import health
from .fitness import WEIGHTINGS, fitness_name
from .isolation import DEFAULT_PRESET, PRESETS


@dataclass(frozen=True)
class FitSettings:
    """How `isolation.isolate` fits a window, checked on construction (ConfigError naming it).

    `preset` ('' = DEFAULT_PRESET), `seed` (of the search), `fitness` (a `fitness.WEIGHTINGS`
    name), `max_evaluations` (0: the preset's budget; a positive value: the global stage
    only, stopped there), `nuisance` (search the unmeasured load with k, as the monitor does).
    """

    preset: str = DEFAULT_PRESET
    seed: int = 0
    fitness: str = "default"
    max_evaluations: int = 0
    nuisance: bool = True

    def __post_init__(self) -> None:
        preset = self.preset or DEFAULT_PRESET
        if preset not in PRESETS:
            raise ConfigError(
                f"unknown preset {preset!r}; choose from {', '.join(sorted(PRESETS))}"
            )
        fitness = fitness_name(str(self.fitness))
        if fitness not in WEIGHTINGS:
            raise ConfigError(
                f"unknown fitness weighting {fitness!r}; choose from {sorted(WEIGHTINGS)}"
            )
        object.__setattr__(self, "preset", preset)
        object.__setattr__(self, "fitness", fitness)
        object.__setattr__(self, "seed", int(check("seed", self.seed)))
        budget = int(check("max_evaluations", self.max_evaluations or 0))
        object.__setattr__(self, "max_evaluations", budget)

    def isolate_options(
        self,
        belief: MonitorBelief | None,
        *,
        cancel: threading.Event | None = None,
        on_progress: Callable[[Any], None] | None = None,
    ) -> dict[str, Any]:
        """The keyword arguments of `isolation.isolate` (with 90 % intervals) for `belief`."""
        return dict(
            belief=belief,
            nuisance=self.nuisance,
            intervals=True,
            preset=self.preset,
            seed=self.seed,
            weights=self.fitness,
            cancel=cancel,
            on_progress=on_progress,
            max_evaluations=self.max_evaluations or None,
        )


@dataclass(frozen=True)
class IsolationSettings(FitSettings):
    """One consistent set of the monitor's run-time settings (applied from the next window).

    The fit's settings and the live monitor's own: thresholds, belief, tracking, unit file.
    """

    thresholds: health.Thresholds = health.Thresholds()
    #: the monitor's belief (`model.belief.belief_for` of the actuator file and unit file),
    #: or None for the packaged one
    belief: MonitorBelief | None = None
    #: start each window from the last explained fit (isolate(start=...)) instead of a
    #: global search
    tracking: bool = True
    #: what the unit file says speaks against it (commissioned with --force), each naming it
    unit_warnings: tuple[str, ...] = ()
    #: the commissioned unit file `belief` carries ('' none: the monitor may commission
    #: itself, against `belief`)
    unit_file: str = ""

    @classmethod
    def from_values(cls, values: Mapping[str, Any]) -> IsolationSettings:
        """From parameter values (`preset` '' = DEFAULT_PRESET); ConfigError naming a bad one.

        The belief: `belief_for` of `actuator_file` and `unit_file` when either is given
        (read here, at start-up only), else None (the packaged one).
        """
        thresholds = health.Thresholds(
            tuple(values["warn_threshold"]), tuple(values["error_threshold"])
        )
        unit_file = str(values.get("unit_file", "") or "")
        actuator_file = str(values.get("actuator_file", "") or "").strip()
        belief = (
            belief_for(actuator_file, unit_file=unit_file) if actuator_file or unit_file else None
        )
        return cls(
            tracking=bool(values.get("tracking", True)),
            belief=belief,
            unit_warnings=tuple(read_warnings(unit_file)) if unit_file else (),
            unit_file=unit_file,
            preset=str(values["preset"]),
            seed=values["seed"],
            fitness=str(values["fitness"]),
            max_evaluations=values["max_evaluations"],
            thresholds=thresholds,
        )

    def reported(self) -> dict[str, Any]:
        """Settings copied into every diagnostic status (and so into recordings)."""
        return {
            "preset": self.preset,
            "seed": self.seed,
            "fitness_weighting": self.fitness,
            "max_evaluations": self.max_evaluations,
            "unit": "packaged" if self.belief is None else self.belief.source,
            "tracking": self.tracking,
        }
