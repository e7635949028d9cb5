"""What the monitor fits a window with: preset, seed, weighting, budget, thresholds, unit."""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any, Callable, Mapping

from ..errors import ConfigError
from ..limits import check
from ..model.belief import MonitorBelief
from . import health
from .commissioning import unit_warnings
from .fitness import WEIGHTINGS, fitness_name
from .isolation import DEFAULT_PRESET, PRESETS


@dataclass(frozen=True)
class IsolationSettings:
    """One consistent set of the monitor's run-time settings (applied from the next window)."""

    preset: str = DEFAULT_PRESET
    seed: int = 0
    fitness: str = "default"
    max_evaluations: int = 0
    thresholds: health.Thresholds = health.Thresholds()
    #: the monitor's belief: a unit file's, an actuator file's (with any unit file over it),
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
        """From parameter values (`preset` '' = DEFAULT_PRESET); ConfigError naming a bad one."""
        preset = str(values["preset"]) or DEFAULT_PRESET
        if preset not in PRESETS:
            raise ConfigError(
                f"unknown preset {preset!r}; choose from {', '.join(sorted(PRESETS))}"
            )
        fitness = fitness_name(str(values["fitness"]))
        if fitness not in WEIGHTINGS:
            raise ConfigError(
                f"unknown fitness weighting {fitness!r}; choose from {sorted(WEIGHTINGS)}"
            )
        thresholds = health.Thresholds(
            tuple(values["warn_threshold"]), tuple(values["error_threshold"])
        )
        unit_file = str(values.get("unit_file", "") or "")
        belief = MonitorBelief.default().with_unit(unit_file) if unit_file else None
        return cls(
            tracking=bool(values.get("tracking", True)),
            belief=belief,
            unit_warnings=tuple(unit_warnings(unit_file)) if unit_file else (),
            unit_file=unit_file,
            preset=preset,
            seed=int(check("seed", values["seed"])),
            fitness=fitness,
            max_evaluations=int(check("max_evaluations", values["max_evaluations"])),
            thresholds=thresholds,
        )

    def isolate_options(
        self,
        belief: MonitorBelief | None,
        *,
        cancel: threading.Event | None = None,
        on_progress: Callable[[Any], None] | None = None,
    ) -> dict[str, Any]:
        """The keyword arguments of `isolation.isolate` the monitor fits a window with.

        `belief`: the one to fit with (this one's, or a commissioned one); the monitor
        always searches the nuisances and asks for intervals.
        """
        return dict(
            belief=belief,
            nuisance=True,
            intervals=True,
            preset=self.preset,
            seed=self.seed,
            weights=self.fitness,
            cancel=cancel,
            on_progress=on_progress,
            max_evaluations=self.max_evaluations or None,
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
