"""The reader of ema.yaml: what the actuator IS, as its datasheet describes it.

- `ActuatorParameters`: the actuator's sections motor, inverter, controller, mechanics,
  acquisition and high_fidelity of `ema.yaml` (or of an actuator file, actuator_file.py),
  typed parts through `.motor`, `.controller`, ... (actuator.py).  The simulator plays it;
  the monitor's belief (`ema_phm.model.belief.MonitorBelief`) is built from its physical
  sections and the `monitor` section, never from the simulated actuator.

Immutable; `with_values({"mechanics.j_motor": 1.43e-5})` returns a changed
copy, so an actuator can differ from the belief.  Every quantity and its unit is in
`QUANTITIES`.

Packaged files (`packaged_config_dir`): the `config/` folder of the source checkout
when ema_phm is imported from one (a `config/ema.yaml` beside the `ema_phm/` folder),
else `<prefix>/share/ema_phm/config` (pip or colcon install), else the ament index.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from dataclasses import dataclass
from functools import cache, cached_property
from pathlib import Path
from types import MappingProxyType
from typing import Any, ClassVar, Mapping, TypeVar

import yaml

from .. import limits
from ..errors import ConfigError
from .actuator import (
    HYSTERESIS_CURRENT,
    OPTIONAL,
    PI_DQ_CURRENT,
    Acquisition,
    Controller,
    CurrentLoop,
    HighFidelity,
    Inverter,
    Mechanics,
    Motor,
    check_controller_kind,
    check_current_loop,
    check_voltage_limit,
    frozen_drive,
    part_of,
)

#: Every quantity of the parameter files, as "section.name", with its unit ("-": none).
QUANTITIES: Mapping[str, str] = MappingProxyType(
    {
        "motor.pole_pairs": "-",
        "motor.r_phase_to_phase": "ohm",
        "motor.l_phase_to_phase": "H",
        "motor.ke_phase_peak": "V*s/rad (per phase, peak, mechanical angle)",
        "motor.torque_constant": "N*m/A (per ampere of I_3eq)",
        "motor.max_torque": "N*m",
        "motor.eccentricity_sensitivity": "-",
        "motor.min_working_coils": "- (fraction of turns)",
        "inverter.vdc": "V",
        "inverter.hysteresis_band": "A (full width)",
        "controller.position_gain": "1/s (rad/s of motor per rad of user error)",
        "controller.speed_kp": "N*m*s/rad",
        "controller.speed_ki": "N*m/rad",
        "controller.speed_kd": "N*m*s^2/rad",
        "controller.max_speed_rpm": "rpm (motor)",
        "controller.max_current": "A",
        "controller.torque_gain": "N*m/A",
        "controller.rate_hz": "Hz",
        "controller.speed_feedforward": "- (share of the command rate fed forward)",
        "controller.reference_filter_hz": "Hz (1st-order position reference filter; 0: none)",
        "current_loop.bandwidth_hz": "Hz (PI current loop, designed on R and L; 0: kp, ki given)",
        "current_loop.kp": "V/A (PI current loop, used when bandwidth_hz is 0)",
        "current_loop.ki": "V/(A*s) (PI current loop, used when bandwidth_hz is 0)",
        "current_loop.delay_periods": "- (computation delay in control periods: 0, 1 or 2)",
        "current_loop.voltage_limit": "V (phase peak the inverter makes; 0: vdc/sqrt(3))",
        "current_loop.emf_feedforward": "- (1: back-EMF and dq coupling fed forward; 0: not)",
        "current_loop.anti_windup": "- (1: integrators moved back by what the limit cut; 0: not)",
        "current_loop.pwm": "- (1: sine-triangle PWM at the control rate; 0: averaged)",
        "current_loop.feedforward_l": "H (per-phase L of the feed-forward; 0: the motor's)",
        "current_loop.feedforward_ke": "V*s/rad (ke of the feed-forward; 0: the motor's)",
        "mechanics.gear_ratio": "- (user/motor)",
        "mechanics.j_motor": "kg*m^2",
        "mechanics.j_user": "kg*m^2 (reflected to the motor shaft)",
        "mechanics.c_motor": "N*m*s/rad",
        "mechanics.c_user": "N*m*s/rad",
        "mechanics.friction_static_motor": "N*m",
        "mechanics.friction_dynamic_motor": "N*m",
        "mechanics.friction_static_user": "N*m (at the motor shaft)",
        "mechanics.friction_dynamic_user": "N*m (at the motor shaft)",
        "mechanics.backlash": "rad (user shaft, full width)",
        "mechanics.end_stop": "rad (user shaft)",
        "acquisition.sample_rate": "Hz",
        "acquisition.current_filter_hz": "Hz",
        "high_fidelity.dt": "s",
        "high_fidelity.torsional_stiffness": "N*m/rad (transmission, at the user shaft)",
        "high_fidelity.torsional_damping_ratio": "- (of the first torsional mode)",
        "high_fidelity.eccentricity_amplitude": "- (back-EMF modulation per unit zeta)",
        "high_fidelity.position_resolution": "rad (user position sensor step; 0 = exact)",
        "high_fidelity.resolver_resolution": "rad (motor angle, resolver step; 0 = exact)",
        "monitor.r": "ohm",
        "monitor.l": "H",
        "monitor.ke": "V*s/rad",
        "monitor.gt": "N*m/A",
        "monitor.vdc": "V",
        "monitor.sc_gain": "-",
        "monitor.steps_per_sample": "- (LF steps per telemetry sample)",
        "monitor.reference_temperature_c": "degC (where monitor r, ke, gt hold)",
        "monitor.copper_coefficient": "1/K (winding resistance vs temperature)",
        "monitor.magnet_coefficient": "1/K (back-EMF and torque constant vs temperature)",
        "monitor.current_gain": "- (current sensor gain the monitor assumes)",
        "monitor.current_offset": "A (current sensor offset the monitor assumes)",
        "monitor.healthy_fitness": "- (fitness of a healthy window, the adequacy reference)",
        "monitor.healthy_fitness_followed": "- (the same, of a fit following the recorded loop)",
        "monitor.eccentricity_law": "- (0: eq. 3.22 of the thesis LF; 1: three-phase sec. 4.5)",
        "monitor.eccentricity_amplitude": "- (flux modulation per unit zeta, law 1)",
        "monitor.mechanics_model": "- (0: one lumped shaft, thesis; 1: two bodies + play)",
        "monitor.stiffness": "N*m/rad (transmission, at the user shaft; mechanics model 1)",
        "monitor.mesh_damping_ratio": "- (of the torsional mode while the teeth touch)",
    }
)

#: Quantities that must be > 0 (a zero would divide by zero or stop the model).
POSITIVE = frozenset(
    {
        "motor.r_phase_to_phase",
        "motor.l_phase_to_phase",
        "mechanics.j_motor",
        "acquisition.sample_rate",
        "high_fidelity.dt",
        "controller.rate_hz",
        "monitor.steps_per_sample",
        "inverter.vdc",
        "monitor.ke",
        "monitor.gt",
        "high_fidelity.torsional_stiffness",
        "monitor.current_gain",
        "monitor.healthy_fitness",
        "monitor.healthy_fitness_followed",
        "monitor.stiffness",
    }
)

#: Quantities that must be >= 0 (a negative resolution, ratio or amplitude has no meaning).
NON_NEGATIVE = frozenset(
    {
        "controller.speed_feedforward",
        "controller.reference_filter_hz",
        "current_loop.bandwidth_hz",
        "current_loop.kp",
        "current_loop.ki",
        "current_loop.delay_periods",
        "current_loop.voltage_limit",
        "current_loop.feedforward_l",
        "current_loop.feedforward_ke",
        "high_fidelity.torsional_damping_ratio",
        "high_fidelity.eccentricity_amplitude",
        "high_fidelity.position_resolution",
        "high_fidelity.resolver_resolution",
    }
)

PHYSICAL_SECTIONS = ("motor", "inverter", "controller", "current_loop", "mechanics", "acquisition")
#: The simulated actuator's own section (never read by the monitor; optional in a description).
HF_SECTION = "high_fidelity"


def packaged_config_dir() -> Path:
    """The folder holding the packaged ema.yaml (see the module docstring for the search order)."""
    checkout = Path(__file__).resolve().parent.parent.parent / "config"
    if (checkout / "ema.yaml").is_file():
        return checkout
    for prefix in (Path(sys.prefix), Path(sys.base_prefix)):
        installed = prefix / "share" / "ema_phm" / "config"
        if (installed / "ema.yaml").is_file():
            return installed
    try:  # colcon / ROS install
        # only a ROS install has it: imported where it is tried
        from ament_index_python.packages import (  # noqa: PLC0415
            get_package_share_directory,
        )

        shared = Path(get_package_share_directory("ema_phm")) / "config"
        if (shared / "ema.yaml").is_file():
            return shared
    except Exception:  # noqa: BLE001 - an absent ament index is normal for pip users
        pass
    raise ConfigError(
        f"cannot find config/ema.yaml (looked in {checkout} and {sys.prefix}/share/ema_phm/config)"
    )


def read_yaml(path: Path) -> dict[str, Any]:
    """The mapping in a YAML file; ConfigError naming the file if absent, invalid or no mapping."""
    try:
        with open(path, encoding="utf-8") as fh:
            data = yaml.safe_load(fh)
    except (FileNotFoundError, IsADirectoryError):
        raise ConfigError(f"config file not found: {path}") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"config file {path} is not valid YAML: {exc}") from None
    if data is None:  # 0 bytes or only comments: e.g. an older writer cut short by a full disk
        raise ConfigError(f"config file {path} is empty: expected a YAML mapping")
    if not isinstance(data, dict):
        raise ConfigError(f"config file {path} must hold a mapping, got {type(data).__name__}")
    return data


def _range_of(name: str) -> limits.Limit:
    """The range of the quantity `name`: > 0 (`POSITIVE`), >= 0 (`NON_NEGATIVE`) or finite."""
    if name in POSITIVE:
        return limits.POSITIVE
    if name in NON_NEGATIVE:
        return limits.NON_NEGATIVE
    return limits.FINITE


def check_quantity(name: str, value: Any, label: str) -> float:
    """`value` of the quantity `name` as a float in its range; ConfigError naming `label`.

    Numeric strings are numbers too: PyYAML reads '1e5' (no dot, no sign) as a string.
    """
    return float(limits.check(name, value, limit=_range_of(name), label=label))


#: The quantities an actuator description may leave unknown (a range instead of a value):
#: those commissioning identifies from a unit's healthy baselines (diagnosis/commissioning.py).
UNKNOWABLE: tuple[str, ...] = (
    "controller.speed_kp",
    "controller.speed_ki",
    "current_loop.bandwidth_hz",
)
#: What an unknown quantity is to the monitor, whose PI drive is frozen on its datasheet
#: (`ActuatorParameters.drive_frozen`): the current loop's bandwidth designs both its gains
#: (kp = a L, ki = a R, a = 2 pi bandwidth_hz), so a factor on it is that factor on both.
#: Any other unknown is itself.
UNKNOWN_SCALES: Mapping[str, tuple[str, ...]] = MappingProxyType(
    {"current_loop.bandwidth_hz": ("current_loop.kp", "current_loop.ki")}
)


def scaled_by_unknown(name: str) -> tuple[str, ...]:
    """The frozen belief's quantities a factor on unknown `name` scales (`UNKNOWN_SCALES`)."""
    return UNKNOWN_SCALES.get(name, (name,))


def check_unknown(name: str, value: Any, where: str) -> tuple[float, float]:
    """(low, high) of an unknown quantity: one of `UNKNOWABLE`, 0 < low < high, both in range.

    ConfigError naming `where`, the quantity and the value otherwise.
    """
    if name not in UNKNOWABLE:
        raise ConfigError(
            f"{where}: {name} cannot be unknown (only {', '.join(UNKNOWABLE)} can: "
            f"commissioning identifies those)"
        )
    numbers = (
        isinstance(value, (list, tuple))
        and len(value) == 2
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
    )
    if not numbers:
        raise ConfigError(f"{where}: unknown {name} needs a range [low, high], got {value!r}")
    low, high = float(value[0]), float(value[1])
    if not 0.0 < low < high:
        raise ConfigError(f"{where}: unknown {name} needs 0 < low < high, got [{low!r}, {high!r}]")
    return _checked(name, low, where), _checked(name, high, where)


def _checked(name: str, value: Any, where: str) -> float:
    return check_quantity(name, value, f"{where}: {name}")


def _sections_of(
    data: dict[str, Any], sections: tuple[str, ...], where: str
) -> dict[str, dict[str, float]]:
    """The listed sections of a parsed ema.yaml, every quantity known, checked and present.

    A quantity of `OPTIONAL` may be absent (its default), and so may a section of only those.
    """
    out: dict[str, dict[str, float]] = {}
    for sec in sections:
        raw = data.get(sec)
        if raw is None and all(n in OPTIONAL for n in QUANTITIES if n.startswith(sec + ".")):
            raw = {}
        if not isinstance(raw, dict):
            raise ConfigError(f"{where}: section {sec!r} is missing")
        raw = {
            **{n.split(".", 1)[1]: v for n, v in OPTIONAL.items() if n.startswith(sec + ".")},
            **raw,
        }
        expected = {name.split(".", 1)[1] for name in QUANTITIES if name.startswith(sec + ".")}
        unknown = sorted(set(raw) - expected)
        if unknown:
            raise ConfigError(
                f"{where}: unknown quantity {sec}.{unknown[0]} "
                f"(known: {', '.join(sorted(expected))})"
            )
        missing = sorted(expected - set(raw))
        if missing:
            raise ConfigError(f"{where}: {sec}.{missing[0]} is missing")
        out[sec] = {key: _checked(f"{sec}.{key}", val, where) for key, val in raw.items()}
    return out


def _frozen(sections: dict[str, dict[str, float]]) -> Mapping[str, Mapping[str, float]]:
    return MappingProxyType({sec: MappingProxyType(dict(vals)) for sec, vals in sections.items()})


P = TypeVar("P", bound="_ParameterSet")


@dataclass(frozen=True)
class _ParameterSet:
    """Read-only sections of named quantities: `p["mechanics"]["j_motor"]` or `p.value(name)`."""

    sections: Mapping[str, Mapping[str, float]]
    source: str  # where the values were read (a file path), for messages
    SECTIONS: ClassVar[tuple[str, ...]] = ()

    def __getitem__(self, section: str) -> Mapping[str, float]:
        try:
            return self.sections[section]
        except KeyError:
            raise ConfigError(
                f"{type(self).__name__} has no section {section!r} "
                f"(sections: {', '.join(self.sections)})"
            ) from None

    def value(self, name: str) -> float:
        """The quantity `name` ("section.name"), in the unit QUANTITIES gives."""
        sec, _, key = name.partition(".")
        if key not in self[sec]:
            raise ConfigError(f"{type(self).__name__} has no quantity {name!r}")
        return self.sections[sec][key]

    def with_values(self: P, changes: Mapping[str, float]) -> P:
        """A copy with the named quantities ("section.name" -> value) replaced and checked."""
        sections = {sec: dict(vals) for sec, vals in self.sections.items()}
        for name, val in changes.items():
            sec, _, key = name.partition(".")
            if sec not in sections or key not in sections[sec]:
                raise ConfigError(
                    f"{type(self).__name__} has no quantity {name!r} "
                    f"(sections: {', '.join(self.sections)})"
                ) from None
            sections[sec][key] = _checked(name, val, "with_values")
        return self._replace_sections(_frozen(sections))

    def _replace_sections(self: P, sections: Mapping[str, Mapping[str, float]]) -> P:
        return type(self)(sections=sections, source=self.source)

    def as_dict(self) -> dict[str, dict[str, float]]:
        """A plain (mutable, independent) copy of the sections."""
        return {sec: dict(vals) for sec, vals in self.sections.items()}


@dataclass(frozen=True)
class ActuatorParameters(_ParameterSet):
    """What the simulated actuator is.

    Sections motor, inverter, controller, mechanics, acquisition and high_fidelity (the
    HF-only quantities: integration step, transmission stiffness, eccentricity amplitude,
    sensor resolutions), read as typed parts through `.motor`, `.controller`, ...
    (physics/actuator.py), and the controller's kind.  An actuator file
    (physics/actuator_file.py) holds the same description with units in its keys.
    """

    controller_kind: str = HYSTERESIS_CURRENT
    #: monitor quantities ("monitor.name") the actuator file sets (what its monitor expects)
    monitor_values: Mapping[str, float] = dataclasses.field(
        default_factory=lambda: MappingProxyType({})
    )
    #: quantities the description does not know ("section.name" -> (low, high), one of
    #: `UNKNOWABLE`): the sections hold the range's geometric mean, commissioning identifies them
    unknowns: Mapping[str, tuple[float, float]] = dataclasses.field(
        default_factory=lambda: MappingProxyType({})
    )
    SECTIONS: ClassVar[tuple[str, ...]] = PHYSICAL_SECTIONS + (HF_SECTION,)

    def __post_init__(self) -> None:
        """ConfigError unless the kind is one of CONTROLLER_KINDS and its current loop is set."""
        check_controller_kind(self.controller_kind)
        check_current_loop(self.controller_kind, self.current_loop, self.source)
        check_voltage_limit(self.current_loop, self.inverter, self.source)

    def drive_frozen(self) -> ActuatorParameters:
        """This actuator with its PI drive's gains and constants fixed (`frozen_drive`).

        The same actuator (its outputs unchanged), but a later change of its motor no longer
        retunes the drive.  Kind hysteresis_current: itself.
        """
        if self.controller_kind != PI_DQ_CURRENT:
            return self
        return self.with_values(frozen_drive(self.motor, self.current_loop))

    @classmethod
    def from_file(cls, path: str | Path) -> ActuatorParameters:
        """The actuator sections of an ema.yaml-shaped file (the thesis's controller kind)."""
        path = Path(path)
        sections = _sections_of(read_yaml(path), cls.SECTIONS, str(path))
        return cls(sections=_frozen(sections), source=str(path))

    @classmethod
    def from_sections(
        cls,
        sections: Mapping[str, Mapping[str, Any]],
        *,
        source: str,
        controller_kind: str,
        monitor_values: Mapping[str, float] | None = None,
        unknowns: Mapping[str, tuple[float, float]] | None = None,
    ) -> ActuatorParameters:
        """Every section's quantities ("section" -> name -> value), checked like a file's.

        `monitor_values`: monitor quantities ("monitor.name" of `QUANTITIES`) the file sets.
        `unknowns`: quantities known only to lie in a range (`check_unknown`); their value in
        the sections is the range's geometric mean.
        An absent or empty high_fidelity section is allowed: the actuator can then be
        monitored but not simulated (`high_fidelity` says so).
        """
        given = dict(sections)
        with_hf = bool(given.get(HF_SECTION))
        wanted = cls.SECTIONS if with_hf else PHYSICAL_SECTIONS
        checked = _sections_of(given, wanted, source)
        if not with_hf:
            checked[HF_SECTION] = {}
        mon = {}
        for name, value in (monitor_values or {}).items():
            if not name.startswith("monitor.") or name not in QUANTITIES:
                raise ConfigError(f"{source}: unknown monitor quantity {name!r}")
            mon[name] = _checked(name, value, source)
        ranges = {name: check_unknown(name, rng, source) for name, rng in (unknowns or {}).items()}
        if "current_loop.bandwidth_hz" in ranges and controller_kind != PI_DQ_CURRENT:
            raise ConfigError(
                f"{source}: current_loop.bandwidth_Hz can be unknown only for a PI current loop "
                f"(controller kind {PI_DQ_CURRENT}), not {controller_kind!r}"
            )
        for name, (low, high) in ranges.items():
            sec, _, key = name.partition(".")
            checked[sec][key] = math.sqrt(low * high)
        return cls(
            sections=_frozen(checked),
            source=source,
            controller_kind=controller_kind,
            monitor_values=MappingProxyType(mon),
            unknowns=MappingProxyType(ranges),
        )

    @classmethod
    def default(cls) -> ActuatorParameters:
        """The packaged config/ema.yaml (read once; the object is immutable)."""
        return _default_actuator()

    def _part(self, section: str) -> Any:
        return part_of(section, self.sections[section], self.controller_kind)

    @cached_property
    def motor(self) -> Motor:
        """The motor section, typed."""
        return self._part("motor")

    @cached_property
    def inverter(self) -> Inverter:
        """The inverter section, typed."""
        return self._part("inverter")

    @cached_property
    def controller(self) -> Controller:
        """The controller section and kind, typed."""
        return self._part("controller")

    @cached_property
    def current_loop(self) -> CurrentLoop:
        """The PI current loop (kind pi_dq_current; the other kind ignores it), typed."""
        return self._part("current_loop")

    @cached_property
    def mechanics(self) -> Mechanics:
        """The mechanics section (shafts, reducer, friction, play), typed."""
        return self._part("mechanics")

    @cached_property
    def acquisition(self) -> Acquisition:
        """The acquisition section (sampling, current filter), typed."""
        return self._part("acquisition")

    @property
    def simulable(self) -> bool:
        """Whether the description has the HF-only quantities a simulation needs."""
        return bool(self.sections[HF_SECTION])

    def require_simulable(self) -> None:
        """ConfigError (one line) unless the description has the HF-only section."""
        if not self.simulable:
            raise ConfigError(
                f"{self.source} has no high_fidelity section: simulating this actuator needs "
                "it (integration step, transmission stiffness, eccentricity amplitude, sensor "
                "resolutions); monitoring it does not"
            )

    @cached_property
    def high_fidelity(self) -> HighFidelity:
        """The HF-only section, typed; ConfigError (`require_simulable`) when there is none."""
        self.require_simulable()
        return self._part(HF_SECTION)

    def _replace_sections(self, sections: Mapping[str, Mapping[str, float]]) -> ActuatorParameters:
        return dataclasses.replace(self, sections=sections)


@cache
def _default_actuator() -> ActuatorParameters:
    return ActuatorParameters.from_file(packaged_config_dir() / "ema.yaml")
