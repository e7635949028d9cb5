"""The monitor model following the recorded loop (model/recorded_loop.py)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import k_with

from ema_phm.diagnosis.fitness import LOOPS, Fitness
from ema_phm.domain.faults import NOMINAL, fault
from ema_phm.errors import ConfigError
from ema_phm.model import monitor_model as mm
from ema_phm.model.recorded_loop import REC_POSITION, RecordedLoop, low_pass
from ema_phm.simulator import real_ema

#: The benchmark's noise (bench/harness/scenarios.py NOISE).
NOISE = {"noise_current": 0.225, "noise_position": 5.0e-5, "noise_speed": 0.5}


def rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x**2)))


@pytest.fixture(scope="module")
def play_window():
    """A play wide enough to make the loop hunt, read by noisy sensors."""
    return real_ema.simulate(k_with(backlash=0.6), seed=3, **NOISE).window


@pytest.mark.parametrize(
    ("field", "value"),
    [("feedback_hz", -1.0), ("segment_s", float("nan")), ("hunting_feedback_hz", float("inf"))],
)
def test_bad_settings_are_refused_with_the_value(field, value):
    with pytest.raises(ConfigError, match=f"{field} must be finite and >= 0, got {value}"):
        RecordedLoop(**{field: value})


def test_following_without_a_cutoff_is_refused():
    with pytest.raises(ConfigError, match="feedback_hz must be > 0"):
        RecordedLoop(feedback_hz=0.0)


def test_a_segment_shorter_than_a_sample_is_refused(play_window):
    with pytest.raises(ConfigError, match="segment_s 0.0001 s is shorter than one sample"):
        RecordedLoop(segment_s=1e-4).inputs(play_window, 0.002)
    assert not RecordedLoop(follow=False, segment_s=0.0).follows  # the open-loop replay


def test_nothing_followed_is_the_open_loop_model(play_window):
    """No followed position and no segments: the thesis's open-loop replay, unchanged."""
    still = RecordedLoop(follow=False, segment_s=0.0)
    a = mm.MonitorModel(play_window).simulate(NOMINAL)
    b = mm.MonitorModel(play_window, loop=still).simulate(NOMINAL)
    np.testing.assert_array_equal(a, b)


def test_the_loop_reads_the_resolver_plus_the_low_passed_deflection(play_window):
    loop = RecordedLoop(feedback_hz=40.0, motor_side=True)
    gear = mm.MonitorModel(play_window).q[mm.Q_GEAR]
    rec, seg = loop.inputs(play_window, gear)
    motor = gear * play_window.theta_m
    expect = motor + low_pass(play_window.theta_u - motor, 40.0, play_window.dt)
    np.testing.assert_allclose(rec[:, REC_POSITION], expect, rtol=0, atol=1e-15)
    assert seg == round(loop.segment_s / play_window.dt)
    # the deflection's noise is filtered: the fed-back position is smoother than the sensor's
    assert np.std(np.diff(rec[:, REC_POSITION], 2)) < 0.2 * np.std(np.diff(play_window.theta_u, 2))


def test_a_clean_deflection_is_fed_back_unfiltered():
    """No position noise: nothing to keep out, so the recorded deflection goes in as it is."""
    clean = real_ema.simulate(k_with(backlash=0.6), seed=3).window
    loop = RecordedLoop()
    gear = mm.MonitorModel(clean).q[mm.Q_GEAR]
    rec, _ = loop.inputs(clean, gear)
    np.testing.assert_allclose(rec[:, REC_POSITION], clean.theta_u, rtol=0, atol=1e-15)
    noisy = real_ema.simulate(k_with(backlash=0.6), seed=3, **NOISE).window
    assert np.abs(loop.inputs(noisy, gear)[0][:, REC_POSITION] - noisy.theta_u).max() > 1e-5


def test_a_hunting_window_passes_the_limit_cycle_to_the_loop(play_window):
    fit = Fitness(play_window, weights="recorded")
    assert fit.hunting_rms > 1.0 and not fit.hunting  # followed, not compared by envelope
    assert fit.model.loop == LOOPS["recorded"].at(True)
    assert fit.model.loop.feedback_hz == LOOPS["recorded"].hunting_feedback_hz
    quiet = real_ema.simulate(k_with(friction=0.3), seed=3, **NOISE).window
    assert Fitness(quiet, weights="recorded").model.loop.feedback_hz == 40.0


def test_segments_hold_a_wrong_model_to_the_recorded_motion(play_window):
    """Multiple shooting: a badly wrong k cannot drift far from the recorded motor speed."""
    wrong = k_with(friction=1.0)
    free = mm.MonitorModel(play_window, loop=RecordedLoop(segment_s=0.0)).simulate(wrong)
    shot = mm.MonitorModel(play_window, loop=RecordedLoop()).simulate(wrong)
    err = [rms(s[:, mm.OUT_THETA_U] - play_window.theta_u) for s in (free, shot)]
    assert err[1] < 0.5 * err[0]


def test_the_recorded_loop_places_a_hunting_play_where_the_open_loop_cannot(play_window):
    """The fitness along k2 (others true): a sharp minimum at the truth when followed.

    Open-loop ("thesis") the limit cycle's phase drifts and the profile is flat (measured on
    this window: 15.8, 14.4, 16.2 at k2 = 0.4, 0.5, 0.6; followed: 658, 224, 69).
    """
    idx = fault("backlash").index
    grid = np.linspace(0.2, 1.0, 9)
    rows = np.repeat(NOMINAL[None], grid.size, axis=0)
    rows[:, idx] = grid
    f = Fitness(play_window, weights="recorded")(rows)
    assert abs(grid[int(np.argmin(f))] - 0.6) <= 0.1
    assert min(f[2], f[6]) > 3.0 * f.min()  # k2 = 0.4 and 0.8 clearly worse


@pytest.mark.parametrize("mechanics", [mm.MECH_LUMPED, mm.MECH_TWO_BODY])
def test_the_followed_position_carries_the_sensor_offset(mechanics):
    """Restarted from the resolver (no offset), the model still reads like the sensor.

    Review finding: the lumped model's output sat one offset (2e-3 rad) below the telemetry.
    """
    from ema_phm.model.belief import MonitorBelief
    from ema_phm.simulator.sensors import SensorSpec

    w = real_ema.simulate(NOMINAL, seed=3, sensors=SensorSpec(position_offset=2e-3)).window
    belief = MonitorBelief.default().with_values({"monitor.mechanics_model": mechanics})
    for loop in (RecordedLoop(), RecordedLoop(follow=False)):
        out = mm.MonitorModel(w, belief=belief, loop=loop).simulate(NOMINAL)
        assert abs(np.mean(out[:, mm.OUT_THETA_U] - w.theta_u)) < 1e-4, loop
