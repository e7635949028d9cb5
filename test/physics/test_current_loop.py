"""Controller kind pi_dq_current: the PI current loop in dq, in both models and the files."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from ema_phm.domain.faults import NOMINAL, k_with
from ema_phm.errors import ConfigError
from ema_phm.model import monitor_model as mm
from ema_phm.model.belief import MonitorBelief
from ema_phm.physics.actuator import PI_DQ_CURRENT, current_loop_gains
from ema_phm.physics.actuator_file import (
    load_actuator,
    packaged_actuator_path,
    write_actuator,
)
from ema_phm.physics.fault_vector import FaultVector
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator import real_ema as hf
from ema_phm.simulator.unit import Unit

SMALL = packaged_actuator_path().parent / "small_pi_ema.yaml"


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


@pytest.fixture(scope="module")
def small() -> ActuatorParameters:
    return load_actuator(SMALL)


def _hf_lf(actuator: ActuatorParameters, belief: MonitorBelief, k=NOMINAL) -> tuple:
    w = hf.simulate(k, actuator=actuator).window
    return w, mm.MonitorModel(w, belief=belief).simulate(k)


def test_packaged_small_actuator_is_a_pi_drive_with_designed_gains(small):
    assert small.controller_kind == PI_DQ_CURRENT
    kp, ki = current_loop_gains(small.motor, small.current_loop)
    a = 2 * math.pi * small.current_loop.bandwidth_hz
    assert kp == pytest.approx(a * small.motor.l_phase_to_phase / 2)
    assert ki == pytest.approx(a * small.motor.r_phase_to_phase / 2)


def test_the_monitor_of_a_pi_drive_is_its_q_axis_uncalibrated(small):
    belief = MonitorBelief.for_actuator(small)
    assert belief.controller_kind == PI_DQ_CURRENT and belief.calibration_file is None
    assert belief.value("monitor.r") == small.motor.r_phase_to_phase / 2
    assert belief.value("monitor.ke") == small.motor.ke_phase_peak
    assert belief.value("monitor.gt") == pytest.approx(small.motor.torque_constant)
    assert belief.value("monitor.vdc") == pytest.approx(small.inverter.vdc / math.sqrt(3))
    assert belief.value("monitor.stiffness") == small.monitor_values["monitor.stiffness"]


def test_averaged_three_phase_hf_and_q_axis_lf_agree(small):
    # two implementations of one drive: three phases with a floating neutral against the LF's
    # single q axis; with the PWM averaged they differ by the mechanics' details only
    averaged = small.with_values({"current_loop.pwm": 0.0})
    w, y = _hf_lf(averaged, MonitorBelief.for_actuator(averaged))
    assert _rms(w.i3eq) > 0.3
    assert _rms(y[:, mm.OUT_I3EQ] - w.i3eq) < 0.05 * _rms(w.i3eq)
    assert _rms(y[:, mm.OUT_THETA_U] - w.theta_u) < 0.02 * _rms(w.command)


def test_pwm_legs_average_to_the_commanded_voltage_whatever_the_step():
    for steps in (7, 50, 100):  # odd: one step holds the carrier's valley
        m = np.arange(steps) / steps
        for r in (-0.5, -0.31, 0.0, 0.17, 0.5):
            mean = np.mean([hf.pwm_leg(r, a, a + 1 / steps) for a in m])
            assert mean == pytest.approx(2 * r, abs=1e-12)


def test_the_pwm_drive_is_the_averaged_drive_plus_ripple(small):
    switched = hf.simulate(NOMINAL, actuator=small).window
    averaged = hf.simulate(NOMINAL, actuator=small.with_values({"current_loop.pwm": 0.0})).window
    assert _rms(switched.i3eq - averaged.i3eq) < 0.03 * _rms(averaged.i3eq)


def test_a_drawn_unit_keeps_the_datasheet_drive(small):
    unit = Unit(resistance=1.1, inductance=1.2, torque_constant=0.9)
    built = unit.actuator(small, temperature_c=100.0)
    assert built.motor.r_phase_to_phase > 1.3 * small.motor.r_phase_to_phase
    kp, ki = current_loop_gains(small.motor, small.current_loop)
    assert current_loop_gains(built.motor, built.current_loop) == (kp, ki)
    p_unit, p_sheet = (
        hf.hf_parameters(FaultVector.from_k(NOMINAL), built),
        hf.hf_parameters(FaultVector.from_k(NOMINAL), small),
    )
    for col in (hf.P_CKP, hf.P_CKI, hf.P_LS_HAT, hf.P_KE_HAT):
        assert p_unit[col] == pytest.approx(p_sheet[col], rel=1e-12)
    assert p_unit[hf.P_RA] != p_sheet[hf.P_RA]


def test_the_monitor_refuses_a_step_that_does_not_divide_the_control_period(small):
    w = hf.simulate(NOMINAL, actuator=small).window
    with pytest.raises(ConfigError, match="steps_per_sample"):
        mm.MonitorModel(w, belief=MonitorBelief.for_actuator(small), steps_per_sample=4)


def test_the_monitor_runs_the_files_gains_not_the_drives(small):
    # a 200 Hz drive is followed by the monitor of a 200 Hz file better than by an 800 Hz one
    slow = small.with_values({"current_loop.bandwidth_hz": 200.0, "current_loop.pwm": 0.0})
    w = hf.simulate(NOMINAL, actuator=slow).window
    right = mm.MonitorModel(w, belief=MonitorBelief.for_actuator(slow)).simulate(NOMINAL)
    wrong = mm.MonitorModel(w, belief=MonitorBelief.for_actuator(small)).simulate(NOMINAL)
    e_right = _rms(right[:, mm.OUT_I3EQ] - w.i3eq)
    e_wrong = _rms(wrong[:, mm.OUT_I3EQ] - w.i3eq)
    assert e_right < 0.5 * e_wrong


def test_a_friction_fault_raises_the_pi_drives_current(small):
    healthy = hf.simulate(NOMINAL, actuator=small).window
    worn = hf.simulate(k_with(friction=0.5), actuator=small).window
    assert _rms(worn.i3eq) > 1.3 * _rms(healthy.i3eq)


def test_the_hysteresis_kind_ignores_the_current_loop_section():
    base = ActuatorParameters.default()
    changed = base.with_values({"current_loop.bandwidth_hz": 50.0, "current_loop.pwm": 0.0})
    a = hf.simulate(NOMINAL, command=None, actuator=base).window
    b = hf.simulate(NOMINAL, command=None, actuator=changed).window
    assert np.array_equal(a.i3eq, b.i3eq)


def test_pi_file_round_trip_keeps_the_loop_and_the_monitor_section(small, tmp_path):
    changed = small.with_values({"current_loop.delay_periods": 2.0})
    changed = dataclasses.replace(changed, monitor_values={"monitor.healthy_fitness": 0.25})
    back = load_actuator(write_actuator(changed, tmp_path / "a.yaml"))
    assert back.controller_kind == PI_DQ_CURRENT
    assert back.current_loop == changed.current_loop
    assert dict(back.monitor_values) == {"monitor.healthy_fitness": 0.25}
    assert MonitorBelief.for_actuator(back).value("monitor.healthy_fitness") == 0.25


@pytest.mark.parametrize(
    ("change", "needle"),
    [
        ({"current_loop.bandwidth_hz": 0.0, "current_loop.kp": 0.0}, "needs current_loop"),
        ({"current_loop.delay_periods": 3.0}, "delay_periods must be 0, 1 or 2, got 3.0"),
        ({"current_loop.pwm": 0.5}, "pwm must be 0 or 1, got 0.5"),
        ({"current_loop.voltage_limit": 20.0}, "above what a 28 V bridge makes"),
    ],
)
def test_a_pi_drive_without_a_usable_loop_is_refused(small, change, needle):
    with pytest.raises(ConfigError, match=needle.replace("(", r"\(")):
        small.with_values(change)


def test_a_pi_file_without_its_loop_section_is_refused(small, tmp_path):
    path = write_actuator(small, tmp_path / "a.yaml")
    text = path.read_text(encoding="utf-8")
    cut = text[: text.index("current_loop:")] + text[text.index("mechanics:") :]
    path.write_text(cut, encoding="utf-8")
    with pytest.raises(ConfigError, match="needs current_loop.bandwidth_Hz > 0"):
        load_actuator(path)


@pytest.mark.parametrize(
    ("change", "effect"),
    [
        ({"controller.speed_feedforward": 1.0}, lambda plain, changed: changed < 0.5 * plain),
        ({"controller.reference_filter_hz": 5.0}, lambda plain, changed: changed > 2.0 * plain),
    ],
)
def test_feedforward_and_reference_filter_act_alike_in_both_models(small, change, effect):
    # the command rate fed forward cuts the lag of a P position loop; a 5 Hz reference
    # filter adds lag on a 4.5 Hz chirp; the LF runs the same controller as the HF
    plain = small.with_values({"current_loop.pwm": 0.0})
    changed = plain.with_values(change)
    errors = []
    for a in (plain, changed):
        w, y = _hf_lf(a, MonitorBelief.for_actuator(a))
        errors.append((_rms(w.theta_u - w.command), _rms(y[:, mm.OUT_THETA_U] - w.command)))
    (hf_plain, lf_plain), (hf_changed, lf_changed) = errors
    assert effect(hf_plain, hf_changed) and effect(lf_plain, lf_changed)
    assert lf_changed == pytest.approx(hf_changed, rel=0.05)


def test_the_monitor_of_a_20_khz_pi_drive_steps_to_its_interrupts():
    thesis = ActuatorParameters.default()
    pi = dataclasses.replace(
        thesis.with_values({"current_loop.bandwidth_hz": 800.0}), controller_kind=PI_DQ_CURRENT
    )
    belief = MonitorBelief.for_actuator(pi)
    assert belief.value("monitor.steps_per_sample") == 10  # 20 kHz over 2 kHz samples
    assert MonitorBelief.for_actuator(thesis).value("monitor.steps_per_sample") == 5
    w = hf.simulate(NOMINAL, actuator=pi.with_values({"current_loop.pwm": 0.0})).window
    y = mm.MonitorModel(w, belief=belief).simulate(NOMINAL)
    assert _rms(y[:, mm.OUT_I3EQ] - w.i3eq) < 0.1 * _rms(w.i3eq)
