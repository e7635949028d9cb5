"""What the monitor believes the actuator is: `MonitorBelief`.

The physical sections of an actuator description (ema.yaml's, or an actuator file's through
`MonitorBelief.for_actuator`) without high_fidelity, plus the `monitor` section, whose ke and gt
come from a calibration file when one is given.  Immutable: `with_values` returns a changed
copy.  The monitor side builds it only from what a user can write from a datasheet and what
commissioning measured on the unit's own recordings; it never reads the simulated actuator.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from types import MappingProxyType
from typing import ClassVar, Mapping

from ..errors import ConfigError
from ..physics.actuator import (
    HYSTERESIS_CURRENT,
    PI_DQ_CURRENT,
    check_controller_kind,
    check_current_loop,
    part_of,
    voltage_limit,
)
from ..physics.actuator_file import load_actuator
from ..physics.parameters import (
    PHYSICAL_SECTIONS,
    ActuatorParameters,
    _frozen,
    _ParameterSet,
    _sections_of,
    packaged_config_dir,
    read_yaml,
    scaled_by_unknown,
)
from .calibration_file import read_ke_gt
from .unit_file import read_belief_values

#: The healthy levels a belief may carry (belief quantities): the model-error part of a
#: healthy window's fit, open loop and following the recorded loop (adequacy.py).
HEALTHY_LEVELS: tuple[str, str] = ("monitor.healthy_fitness", "monitor.healthy_fitness_followed")


@dataclass(frozen=True)
class MonitorBelief(_ParameterSet):
    """What the monitor model believes.

    The physical sections of ema.yaml, its `monitor` section, and ke, gt from
    `calibration_file` (None: the uncalibrated values of the monitor section).
    """

    calibration_file: str | None = None
    controller_kind: str = HYSTERESIS_CURRENT
    #: whether a commissioning measured this unit (`commissioned_with`, `with_unit`): False,
    #: the belief is the actuator's description and the unit is any one made to it
    commissioned: bool = False
    #: the healthy levels (`HEALTHY_LEVELS`) that are this actuator's own: given by its
    #: description or measured by a commissioning.  The others hold the packaged thesis
    #: actuator's values, a stand-in a commissioning replaces and does not judge against.
    own_levels: frozenset[str] = frozenset(HEALTHY_LEVELS)
    #: quantities the actuator description leaves unknown and no commissioning has identified
    #: yet ("section.name" -> (low, high), `ActuatorParameters.unknowns`): the belief holds
    #: the range's geometric mean
    unknowns: Mapping[str, tuple[float, float]] = dataclasses.field(
        default_factory=lambda: MappingProxyType({})
    )
    SECTIONS: ClassVar[tuple[str, ...]] = PHYSICAL_SECTIONS + ("monitor",)

    def __post_init__(self) -> None:
        """ConfigError unless the kind is one of CONTROLLER_KINDS and its current loop is set."""
        check_controller_kind(self.controller_kind)
        loop = part_of("current_loop", self.sections["current_loop"], self.controller_kind)
        check_current_loop(self.controller_kind, loop, self.source)

    @classmethod
    def from_file(
        cls, path: str | Path, *, calibration: str | Path | None = None
    ) -> MonitorBelief:
        """The belief sections of an ema.yaml-shaped file, calibrated by `calibration` if given."""
        path = Path(path)
        sections = _sections_of(read_yaml(path), cls.SECTIONS, str(path))
        belief = cls(sections=_frozen(sections), source=str(path))
        return belief if calibration is None else belief.with_calibration(calibration)

    @classmethod
    def default(cls) -> MonitorBelief:
        """The packaged config/ema.yaml calibrated by config/calibration.yaml (read once)."""
        return _default_belief()

    @classmethod
    def for_actuator(
        cls, actuator: ActuatorParameters, *, calibration: str | Path | None = None
    ) -> MonitorBelief:
        """The belief of a monitor watching `actuator`, calibrated.

        `uncalibrated_for(actuator)` with ke and gt from `calibration`.  None: for kind
        hysteresis_current the packaged config/calibration.yaml (fitted on the thesis motor;
        for the packaged actuator the sections are `default()`'s), for kind pi_dq_current no
        calibration (its q-axis equivalents are the datasheet's own, `monitor_equivalents`).
        """
        belief = cls.uncalibrated_for(actuator)
        if calibration is None and actuator.controller_kind == PI_DQ_CURRENT:
            return belief
        return belief.with_calibration(
            packaged_config_dir() / "calibration.yaml" if calibration is None else calibration
        )

    @classmethod
    def uncalibrated_for(cls, actuator: ActuatorParameters) -> MonitorBelief:
        """The belief of a monitor watching `actuator`, before calibration.

        Its physical sections (a PI drive's gains fixed on its datasheet motor,
        `ActuatorParameters.drive_frozen`) and controller kind are the actuator's; its
        monitor section is the packaged ema.yaml's with the actuator's electrical equivalents
        (`monitor_equivalents`) and the actuator file's own monitor values
        (`ActuatorParameters.monitor_values`) over it, and for a PI drive steps_per_sample
        raised to a multiple of its interrupts unless the file sets it (`_steps_for_loop`).
        For the packaged actuator its sections are `packaged_uncalibrated()`'s.  Its healthy
        levels are its own (`own_levels`) where the actuator file sets them, or where it is
        the packaged actuator (whose levels were measured on its units); others keep the
        packaged values as stand-ins.
        """
        packaged = cls.packaged_uncalibrated()
        actuator = actuator.drive_frozen()  # a unit file's motor values never retune it
        sections = {sec: dict(actuator[sec]) for sec in PHYSICAL_SECTIONS}
        monitor = dict(packaged["monitor"])
        changes = {**monitor_equivalents(actuator), **actuator.monitor_values}
        monitor.update({name.split(".", 1)[1]: value for name, value in changes.items()})
        if "monitor.steps_per_sample" not in actuator.monitor_values:
            monitor["steps_per_sample"] = _steps_for_loop(actuator, monitor["steps_per_sample"])
        sections["monitor"] = monitor
        own = HEALTHY_LEVELS if is_packaged(actuator) else actuator.monitor_values
        return cls(
            sections=_frozen(_sections_of(sections, cls.SECTIONS, actuator.source)),
            source=f"{actuator.source} + monitor section of {packaged.source}",
            controller_kind=actuator.controller_kind,
            own_levels=frozenset(name for name in HEALTHY_LEVELS if name in own),
            unknowns=actuator.unknowns,
        )

    @classmethod
    def packaged_uncalibrated(cls) -> MonitorBelief:
        """The packaged config/ema.yaml with the thesis ke and gt (where a calibration starts)."""
        return cls.from_file(packaged_config_dir() / "ema.yaml")

    def with_calibration(self, path: str | Path) -> MonitorBelief:
        """A copy whose monitor ke and gt are those of a calibration file (`calibration_file`)."""
        changed = self.with_values(read_ke_gt(path))
        return dataclasses.replace(changed, calibration_file=str(Path(path)))

    def with_unit(self, path: str | Path) -> MonitorBelief:
        """A copy with the `belief` section of a commissioned unit file applied (`unit_file`)."""
        out = self.commissioned_with(read_belief_values(path, self.SECTIONS))
        return dataclasses.replace(out, source=f"{self.source} + unit {path}")

    def commissioned_with(self, values: Mapping[str, float]) -> MonitorBelief:
        """A copy with a commissioning's belief values (`CommissionResult.values`) applied.

        The healthy levels among them are the unit's own from then on (`own_levels`), and an
        unknown quantity among them is known (`unknowns`).
        """
        own = self.own_levels | {name for name in HEALTHY_LEVELS if name in values}
        known = {q for q in self.unknowns if not set(scaled_by_unknown(q)).isdisjoint(values)}
        left = MappingProxyType({q: r for q, r in self.unknowns.items() if q not in known})
        return dataclasses.replace(
            self.with_values(values), commissioned=True, own_levels=own, unknowns=left
        )

    def level_is_own(self, name: str) -> bool:
        """Whether healthy level `name` is this actuator's own (`own_levels`), not a stand-in."""
        if name not in HEALTHY_LEVELS:
            raise ConfigError(f"{name!r} is not a healthy level (one of {HEALTHY_LEVELS})")
        return name in self.own_levels

    def _replace_sections(self, sections: Mapping[str, Mapping[str, float]]) -> MonitorBelief:
        return dataclasses.replace(self, sections=sections)


def is_packaged(actuator: ActuatorParameters) -> bool:
    """Whether `actuator` is the packaged one (`ActuatorParameters.default()`) to the monitor.

    Its controller kind and physical sections (the drive as tuned on its datasheet) equal the
    packaged description's, it leaves nothing unknown, and the monitor values it sets (other
    than the healthy levels) are the packaged ones; the high_fidelity section, which the
    monitor never reads, is not compared.
    """
    packaged = ActuatorParameters.default()
    if actuator.controller_kind != packaged.controller_kind or actuator.unknowns:
        return False
    monitor = MonitorBelief.packaged_uncalibrated()
    for name, value in actuator.monitor_values.items():
        if name not in HEALTHY_LEVELS and monitor.value(name) != value:
            return False
    mine, theirs = actuator.drive_frozen(), packaged.drive_frozen()
    return all(dict(mine[sec]) == dict(theirs[sec]) for sec in PHYSICAL_SECTIONS)


def _steps_for_loop(actuator: ActuatorParameters, steps: float) -> float:
    """LF steps per sample: `steps`, raised for a PI loop to a multiple of its interrupts.

    The monitor runs a PI current loop once every whole number of its steps, so for kind
    pi_dq_current whose control rate is a whole multiple n of the sample rate the steps are
    the smallest multiple of n not below `steps` (a 20 kHz loop at 2 kHz: 10, a 50 us step).
    """
    if actuator.controller_kind != PI_DQ_CURRENT:
        return steps
    n = actuator.controller.rate_hz / actuator.acquisition.sample_rate
    if n < 1.0 or abs(n - round(n)) > 1e-9:
        return steps  # the monitor model says why it cannot run this loop
    n = round(n)
    return float(n * math.ceil(steps / n))


def monitor_equivalents(actuator: ActuatorParameters) -> dict[str, float]:
    """The monitor quantities the LF takes from `actuator` ("monitor.name" -> value).

    The electrical equivalents depend on the current loop the LF runs.  Kind
    hysteresis_current: chapter 3's single-phase equivalent (eqs. 3.5-3.13) of Table 2.1's
    motor, R and L phase to phase, ke = K/3 and gt = K of its back-EMF constant
    K = 2 ke_phase_peak, the supply vdc.  Kind pi_dq_current: the q axis of the
    amplitude-invariant dq model, per-phase R and L, ke the peak phase back-EMF constant, gt the
    torque per ampere of its sinusoidal three phases, 3/2 ke (motor.torque_constant is
    informative), the PI loop's voltage limit.  The monitor never reads the high_fidelity
    section: its transmission stiffness is the packaged one unless the actuator file's
    `monitor` section gives the datasheet's (commissioning fits each unit's).
    """
    mo = actuator.motor
    out: dict[str, float] = {}
    if actuator.controller_kind == PI_DQ_CURRENT:
        out |= {
            "monitor.r": mo.r_phase_to_phase / 2.0,
            "monitor.l": mo.l_phase_to_phase / 2.0,
            "monitor.ke": mo.ke_phase_peak,
            "monitor.gt": 1.5 * mo.ke_phase_peak,
            "monitor.vdc": voltage_limit(actuator.current_loop, actuator.inverter),
        }
        return out
    k = 2.0 * mo.ke_phase_peak
    return out | {
        "monitor.r": mo.r_phase_to_phase,
        "monitor.l": mo.l_phase_to_phase,
        "monitor.ke": k / 3.0,
        "monitor.gt": k,
        "monitor.vdc": actuator.inverter.vdc,
    }


@cache
def _default_belief() -> MonitorBelief:
    folder = packaged_config_dir()
    return MonitorBelief.from_file(folder / "ema.yaml", calibration=folder / "calibration.yaml")


def belief_for(
    actuator_file: str | Path | None = None,
    *,
    calibration: str | Path | None = None,
    unit_file: str | Path | None = None,
    uncalibrated: bool = False,
) -> MonitorBelief:
    """The monitor's belief: the one place it is built from what a user gives.

    `actuator_file`: the actuator the monitor watches (`MonitorBelief.for_actuator` of it; None
    or '': the packaged belief).  `calibration`: a calibration file's ke and gt instead of the
    packaged ones (nothing is picked up silently).  `unit_file`: a commissioned unit over it.
    `uncalibrated`: the belief before any calibration, where `ema-phm calibrate` starts
    (`MonitorBelief.uncalibrated_for`).  A bad actuator file is a ConfigError naming
    `actuator_file`.
    """
    if actuator_file or uncalibrated:
        try:
            actuator = load_actuator(actuator_file or None)
        except ConfigError as exc:
            raise ConfigError(f"actuator_file: {exc}") from None
        if uncalibrated:
            return MonitorBelief.uncalibrated_for(actuator)
        belief = MonitorBelief.for_actuator(actuator, calibration=calibration)
    elif calibration is None:
        belief = MonitorBelief.default()
    else:
        belief = MonitorBelief.packaged_uncalibrated().with_calibration(calibration)
    return belief.with_unit(unit_file) if unit_file else belief
