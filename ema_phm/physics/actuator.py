"""Typed parts of an actuator description (motulator style): motor, inverter, controller, ...

One frozen dataclass per section of `ActuatorParameters` (physics/parameters.py), whose
fields are the section's quantities in the units of `parameters.QUANTITIES`.  Each field's
metadata carries the key the actuator file writes it under, the quantity's name followed by
its unit (`r_phase_to_phase_ohm`); dimensionless quantities keep their bare name
(`min_working_coils_fraction` names its fraction)
(actuator_file.py).  `ActuatorParameters.motor`, `.controller`, ... return these parts and
real_ema.hf_parameters builds the HF kernel's array from them.

The controller has a `kind` (`CONTROLLER_KINDS`); both kinds share the position P and speed
PID loops (with an optional speed feed-forward of the command rate and a first-order filter
on the position reference) and differ in the current loop:

- `HYSTERESIS_CURRENT`: the thesis's hysteresis comparators on the phase currents (sec. 2.1);
- `PI_DQ_CURRENT`: a PI loop on the measured d and q currents, run at controller.rate_hz,
  whose voltage reaches the motor after a computation delay through a PWM (sine-triangle
  with min-max zero sequence) or an averaged inverter, limited to a phase-peak voltage, with
  back-calculation anti-windup and optional back-EMF / cross-coupling feed-forward
  (`CurrentLoop`).  The gains are given, or designed from a bandwidth on the motor's per-phase
  R and L (`current_loop_gains`, the usual internal-model rule kp = a L, ki = a R).

Both models (real_ema.py, monitor_model.py) run every kind, each reading the kind and gains
from the parameters it is given.  Keys a kind does not read may be left out of a file
(`OPTIONAL`: their defaults are those of the thesis's structure).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping

from ..errors import ConfigError

#: The thesis's controller: position P and speed PID loops at controller.rate_hz, and the
#: inverter's hysteresis comparators (inverter.hysteresis_band) on the phase currents.
HYSTERESIS_CURRENT = "hysteresis_current"

#: The usual industrial drive: a PI current loop in dq with PWM (`CurrentLoop`).
PI_DQ_CURRENT = "pi_dq_current"

#: Every controller kind a model can run.
CONTROLLER_KINDS: tuple[str, ...] = (HYSTERESIS_CURRENT, PI_DQ_CURRENT)

#: Quantities a file may leave out ("section.name" -> default): the controller's
#: feed-forward and reference filter (off, as in the thesis) and the whole current_loop
#: section, which only kind pi_dq_current reads.
OPTIONAL: Mapping[str, float] = MappingProxyType(
    {
        "controller.speed_feedforward": 0.0,
        "controller.reference_filter_hz": 0.0,
        "current_loop.bandwidth_hz": 0.0,
        "current_loop.kp": 0.0,
        "current_loop.ki": 0.0,
        "current_loop.delay_periods": 1.0,
        "current_loop.voltage_limit": 0.0,
        "current_loop.emf_feedforward": 1.0,
        "current_loop.anti_windup": 1.0,
        "current_loop.pwm": 1.0,
        "current_loop.feedforward_l": 0.0,
        "current_loop.feedforward_ke": 0.0,
    }
)


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
    speed_feedforward: float = _q("speed_feedforward")
    reference_filter_hz: float = _q("reference_filter_Hz")

    def __post_init__(self) -> None:
        """ConfigError naming the kind unless it is one of CONTROLLER_KINDS."""
        check_controller_kind(self.kind)


@dataclass(frozen=True)
class CurrentLoop:
    """The PI current loop in dq of kind pi_dq_current (kind hysteresis_current ignores it).

    bandwidth_hz > 0 designs the gains (`current_loop_gains`); 0 takes kp and ki as given.
    The voltage computed at one control interrupt is applied delay_periods interrupts later
    (0, 1 or 2), held in the stationary frame; voltage_limit is the phase-peak voltage the
    inverter can make (0: vdc/sqrt(3), min-max zero sequence).  emf_feedforward 1 adds the
    back-EMF and the dq cross-coupling of the motor's datasheet values; anti_windup 1 moves
    the integrators back by what the voltage limit cut; pwm 1 is a sine-triangle PWM at the
    control rate (the HF only: the monitor model always averages), 0 an averaged inverter.
    """

    bandwidth_hz: float = _q("bandwidth_Hz")
    kp: float = _q("kp_V_per_A")
    ki: float = _q("ki_V_per_A_s")
    delay_periods: float = _q("delay_periods")
    voltage_limit: float = _q("voltage_limit_V")
    emf_feedforward: float = _q("emf_feedforward")
    anti_windup: float = _q("anti_windup")
    pwm: float = _q("pwm")
    feedforward_l: float = _q("feedforward_L_H")
    feedforward_ke: float = _q("feedforward_ke_V_s_per_rad")


def current_loop_gains(motor: Motor, loop: CurrentLoop) -> tuple[float, float]:
    """(kp [V/A], ki [V/(A*s)]) of the PI current loop: designed from the bandwidth, or given.

    The design is the internal-model rule on the per-phase (dq) R = r_phase_to_phase / 2 and
    L = l_phase_to_phase / 2 of the motor: kp = a L, ki = a R with a = 2 pi bandwidth_hz.
    Without delay that makes the loop a first-order lag of bandwidth a when R and L are right;
    the computation delay and the hold add a lag of about a (delay + 1/2) tc rad at the
    crossover (the packaged small_pi_ema: 0.75 rad, a 48 degree phase margin, a 1.3x peak).
    """
    if loop.bandwidth_hz > 0.0:
        a = 2.0 * math.pi * loop.bandwidth_hz
        return a * motor.l_phase_to_phase / 2.0, a * motor.r_phase_to_phase / 2.0
    return loop.kp, loop.ki


def feedforward_constants(motor: Motor, loop: CurrentLoop) -> tuple[float, float]:
    """(L [H], ke [V*s/rad]) the drive's feed-forward uses: the loop's, or the motor's."""
    return (
        loop.feedforward_l or motor.l_phase_to_phase / 2.0,
        loop.feedforward_ke or motor.ke_phase_peak,
    )


def frozen_drive(motor: Motor, loop: CurrentLoop) -> dict[str, float]:
    """The current_loop quantities that fix the drive's gains and constants as `motor` gives.

    A drive is tuned once, on the datasheet: a unit whose motor differs, or is hot, keeps
    them (`Unit.actuator` and the monitor's belief apply these before changing the motor).
    """
    kp, ki = current_loop_gains(motor, loop)
    l_ff, ke_ff = feedforward_constants(motor, loop)
    return {
        "current_loop.bandwidth_hz": 0.0,
        "current_loop.kp": kp,
        "current_loop.ki": ki,
        "current_loop.feedforward_l": l_ff,
        "current_loop.feedforward_ke": ke_ff,
    }


def voltage_limit(loop: CurrentLoop, inverter: Inverter) -> float:
    """The phase-peak voltage the PI loop may ask [V]: the file's, or vdc / sqrt(3)."""
    return loop.voltage_limit if loop.voltage_limit > 0.0 else inverter.vdc / math.sqrt(3.0)


def check_voltage_limit(loop: CurrentLoop, inverter: Inverter, where: str) -> None:
    """ConfigError when the loop's voltage limit is above what the bridge makes, vdc/sqrt(3)."""
    most = inverter.vdc / math.sqrt(3.0)
    if loop.voltage_limit > most * (1.0 + 1e-12):
        raise ConfigError(
            f"{where}: current_loop.voltage_limit_V {loop.voltage_limit!r} is above what a "
            f"{inverter.vdc:g} V bridge makes, vdc/sqrt(3) = {most:.4g} V"
        )


def check_current_loop(kind: str, loop: CurrentLoop, where: str) -> None:
    """ConfigError naming what kind pi_dq_current needs and `loop` lacks (nothing otherwise)."""
    if kind != PI_DQ_CURRENT:
        return
    if loop.bandwidth_hz <= 0.0 and (loop.kp <= 0.0 or loop.ki < 0.0):
        raise ConfigError(
            f"{where}: controller kind {PI_DQ_CURRENT} needs current_loop.bandwidth_Hz > 0 or "
            f"kp_V_per_A > 0 and ki_V_per_A_s >= 0, got bandwidth {loop.bandwidth_hz!r}, "
            f"kp {loop.kp!r}, ki {loop.ki!r}"
        )
    if loop.delay_periods not in (0.0, 1.0, 2.0):
        raise ConfigError(
            f"{where}: current_loop.delay_periods must be 0, 1 or 2, got {loop.delay_periods!r}"
        )
    for name in ("emf_feedforward", "anti_windup", "pwm"):
        if getattr(loop, name) not in (0.0, 1.0):
            raise ConfigError(
                f"{where}: current_loop.{name} must be 0 or 1, got {getattr(loop, name)!r}"
            )


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
    "current_loop": CurrentLoop,
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
