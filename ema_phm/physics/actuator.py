"""Typed parts of an actuator description (motulator style): motor, inverter, controller, ...

One frozen dataclass per section of `ActuatorParameters` (physics/parameters.py), whose
fields are the section's quantities in the units of `parameters.QUANTITIES`.  Each field's
metadata carries the key the actuator file writes it under, the quantity's name followed by
its unit (`r_phase_to_phase_ohm`); dimensionless quantities keep their bare name
(`min_working_coils_fraction` names its fraction)
(actuator_file.py).  `ActuatorParameters.motor`, `.controller`, ... return these parts and
real_ema.hf_parameters builds the HF kernel's array from them.

The controller has a `kind`: today only `HYSTERESIS_CURRENT`, the thesis's cascade (position
P loop, speed PID loop, hysteresis comparators on the phase currents, sec. 2.1).  A new kind
is added to `CONTROLLER_KINDS` together with the kernel that runs it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, Mapping

from ..errors import ConfigError

#: The thesis's controller: position P and speed PID loops at controller.rate_hz, and the
#: inverter's hysteresis comparators (inverter.hysteresis_band) on the phase currents.
HYSTERESIS_CURRENT = "hysteresis_current"

#: Every controller kind a model can run.
CONTROLLER_KINDS: tuple[str, ...] = (HYSTERESIS_CURRENT,)


def check_controller_kind(kind: object) -> str:
    """`kind` if it is one of CONTROLLER_KINDS, else ConfigError naming it."""
    if not isinstance(kind, str) or kind not in CONTROLLER_KINDS:
        raise ConfigError(
            f"controller kind must be one of {', '.join(CONTROLLER_KINDS)}, got {kind!r}"
        )
    return kind


def _q(key: str) -> Any:
    """A float field written to the actuator file under `key` (name and unit)."""
    return field(metadata={"key": key})


@dataclass(frozen=True)
class Motor:
    """The PMSM (Table 2.1)."""

    pole_pairs: float = _q("pole_pairs")
    r_phase_to_phase: float = _q("r_phase_to_phase_ohm")
    l_phase_to_phase: float = _q("l_phase_to_phase_H")
    ke_phase_peak: float = _q("ke_phase_peak_V_s_per_rad")
    torque_constant: float = _q("torque_constant_N_m_per_A")
    max_torque: float = _q("max_torque_N_m")
    eccentricity_sensitivity: float = _q("eccentricity_sensitivity")
    min_working_coils: float = _q("min_working_coils_fraction")


@dataclass(frozen=True)
class Inverter:
    """The H-bridge supply and its hysteresis band."""

    vdc: float = _q("vdc_V")
    hysteresis_band: float = _q("hysteresis_band_A")


@dataclass(frozen=True)
class Controller:
    """The drive's control loops; `kind` names the law (`CONTROLLER_KINDS`)."""

    kind: str = field(metadata={"key": "kind"})
    position_gain: float = _q("position_gain_per_s")
    speed_kp: float = _q("speed_kp_N_m_s_per_rad")
    speed_ki: float = _q("speed_ki_N_m_per_rad")
    speed_kd: float = _q("speed_kd_N_m_s2_per_rad")
    max_speed_rpm: float = _q("max_speed_rpm")
    max_current: float = _q("max_current_A")
    torque_gain: float = _q("torque_gain_N_m_per_A")
    rate_hz: float = _q("rate_Hz")

    def __post_init__(self) -> None:
        """ConfigError naming the kind unless it is one of CONTROLLER_KINDS."""
        check_controller_kind(self.kind)


@dataclass(frozen=True)
class Mechanics:
    """Motor and user shafts, the reducer between them, friction, play and end stops."""

    gear_ratio: float = _q("gear_ratio")
    j_motor: float = _q("j_motor_kg_m2")
    j_user: float = _q("j_user_kg_m2")
    c_motor: float = _q("c_motor_N_m_s_per_rad")
    c_user: float = _q("c_user_N_m_s_per_rad")
    friction_static_motor: float = _q("friction_static_motor_N_m")
    friction_dynamic_motor: float = _q("friction_dynamic_motor_N_m")
    friction_static_user: float = _q("friction_static_user_N_m")
    friction_dynamic_user: float = _q("friction_dynamic_user_N_m")
    backlash: float = _q("backlash_rad")
    end_stop: float = _q("end_stop_rad")


@dataclass(frozen=True)
class Acquisition:
    """The telemetry sampling and the current sensor's anti-aliasing filter."""

    sample_rate: float = _q("sample_rate_Hz")
    current_filter_hz: float = _q("current_filter_Hz")


@dataclass(frozen=True)
class HighFidelity:
    """What only the HF model reads: its step, compliant reducer, air gap, sensor steps."""

    dt: float = _q("dt_s")
    torsional_stiffness: float = _q("torsional_stiffness_N_m_per_rad")
    torsional_damping_ratio: float = _q("torsional_damping_ratio")
    eccentricity_amplitude: float = _q("eccentricity_amplitude")
    position_resolution: float = _q("position_resolution_rad")
    resolver_resolution: float = _q("resolver_resolution_rad")


#: The typed part of each ActuatorParameters section, in file order.
PARTS: Mapping[str, type] = {
    "motor": Motor,
    "inverter": Inverter,
    "controller": Controller,
    "mechanics": Mechanics,
    "acquisition": Acquisition,
    "high_fidelity": HighFidelity,
}


def file_keys(section: str) -> dict[str, str]:
    """Quantity name -> actuator-file key (name and unit) of one section."""
    return {f.name: f.metadata["key"] for f in dataclasses.fields(PARTS[section])}


def part_of(section: str, values: Mapping[str, float], kind: str) -> Any:
    """The typed part of `section` from its quantities (`kind` for the controller only)."""
    cls = PARTS[section]
    return cls(kind=kind, **values) if cls is Controller else cls(**values)


def quantities_of(part: Any) -> dict[str, float]:
    """The float quantities of a typed part (the controller's kind left out)."""
    return {k: v for k, v in dataclasses.asdict(part).items() if k != "kind"}
