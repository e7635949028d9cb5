"""The HF's two-inertia drivetrain, per-phase eccentricity and imperfect sensors (issue 9)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import GEAR, k_with

from ema_phm.domain.faults import NOMINAL
from ema_phm.errors import ConfigError
from ema_phm.physics.commands import CommandSpec, LoadSpec
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator import real_ema as hf
from ema_phm.simulator.hf_drivetrain import coupling_torque, first_mode
from ema_phm.simulator.sensors import SensorSpec, quantize

SHORT = CommandSpec(duration=0.3)
EXACT = {"high_fidelity.position_resolution": 0.0, "high_fidelity.resolver_resolution": 0.0}


def _actuator(**changes: float) -> ActuatorParameters:
    return ActuatorParameters.default().with_values({**EXACT, **changes})


def test_default_first_torsional_mode_is_well_above_the_position_loop():
    a = ActuatorParameters.default()
    k = a["high_fidelity"]["torsional_stiffness"] * GEAR**2
    mode = first_mode(k, a["mechanics"]["j_motor"], a["mechanics"]["j_user"])
    assert 5 * 200.0 < mode < 0.1 / a["high_fidelity"]["dt"]  # resolved at the 1 us step


def test_coupling_is_a_dead_zone_that_only_pushes():
    assert coupling_torque(0.5, 0.0, 10.0, 0.0, 1.0) == 0.0
    assert coupling_torque(1.5, 0.0, 10.0, 0.0, 1.0) == pytest.approx(5.0)
    assert coupling_torque(-1.5, 0.0, 10.0, 0.0, 1.0) == pytest.approx(-5.0)
    assert coupling_torque(1.1, -100.0, 10.0, 1.0, 1.0) == 0.0  # separating: no pull


def test_with_a_very_stiff_reducer_the_shafts_move_together():
    a = _actuator(**{"high_fidelity.torsional_stiffness": 2.5e10, "mechanics.backlash": 0.0})
    w = hf.simulate(NOMINAL, actuator=a, command=SHORT).window
    assert np.abs(w.theta_u - GEAR * w.theta_m).max() < 1e-6 * np.abs(w.theta_u).max()


def test_static_load_twists_the_reducer_by_load_over_stiffness():
    # no friction, no play: at rest the reducer carries the load, twist = load / K_u
    zero = {
        f"mechanics.friction_{kind}_{side}": 0.0
        for kind in ("static", "dynamic")
        for side in ("motor", "user")
    }
    a = _actuator(**zero, **{"mechanics.backlash": 0.0})
    cmd = CommandSpec(kind="step", amplitude=0.0, duration=0.4, offset=0.0)
    w = hf.simulate(NOMINAL, actuator=a, command=cmd, load=LoadSpec(value=50.0)).window
    twist = GEAR * w.theta_m[-1] - w.theta_u[-1]
    assert twist == pytest.approx(50.0 / a["high_fidelity"]["torsional_stiffness"], rel=0.02)


def test_eccentricity_factors_follow_the_air_gap_of_each_phase():
    f = hf.eccentricity_factors(np.pi / 3, 0.5, 0.0, 1.0)
    # phi = 0 is the direction of the smallest gap (k7, sec. 5.5): at theta_m = pi/3 it faces
    # phase B's axis (pi/3 mechanical), where the flux, so the factor, is largest
    assert f[1] == pytest.approx(1.5)
    assert f[0] == pytest.approx(1 + 0.5 * np.cos(np.pi / 3))
    assert hf.eccentricity_factors(0.3, 0.0, 1.0, 1.0) == pytest.approx(np.ones(3))


def test_position_offset_shifts_the_telemetry_and_the_loop_by_exactly_the_offset():
    a = _actuator()
    off = 2e-3
    base = hf.simulate(NOMINAL, actuator=a, command=SHORT).window
    shifted = hf.simulate(
        NOMINAL, actuator=a, command=SHORT, sensors=SensorSpec(position_offset=off)
    ).window
    # the loop holds the READING on the command, so the shaft moves by -offset
    late = base.t > 0.2
    np.testing.assert_allclose(shifted.theta_u[late], base.theta_u[late], atol=2e-5)
    assert np.mean(GEAR * (shifted.theta_m - base.theta_m)[late]) == pytest.approx(-off, rel=0.02)


def test_current_offset_shifts_i3eq_by_exactly_the_offset():
    base = hf.simulate(NOMINAL, command=SHORT).window
    off = hf.simulate(NOMINAL, command=SHORT, sensors=SensorSpec(current_offset=0.3)).window
    np.testing.assert_allclose(off.i3eq - base.i3eq, 0.3, atol=1e-12)
    np.testing.assert_array_equal(off.theta_u, base.theta_u)  # telemetry only


def test_position_and_resolver_readings_are_quantized_to_their_steps():
    w = hf.simulate(NOMINAL, command=SHORT).window
    hfp = ActuatorParameters.default()["high_fidelity"]
    for x, step in (
        (w.theta_u, hfp["position_resolution"]),
        (w.theta_m, hfp["resolver_resolution"]),
    ):
        levels = x / step
        np.testing.assert_allclose(levels, np.round(levels), atol=1e-6)
    assert quantize(0.26, 0.1) == pytest.approx(0.3) and quantize(0.26, 0.0) == 0.26


def test_unmeasured_load_is_nan_and_spring_load_is_in_the_channel():
    w = hf.simulate(NOMINAL, command=SHORT, load=LoadSpec(value=10.0, measured=False)).window
    assert np.isnan(w.load).all()
    w = hf.simulate(NOMINAL, command=SHORT, load=LoadSpec(value=10.0, spring=1000.0)).window
    np.testing.assert_allclose(w.load, 10.0 + 1000.0 * w.theta_u, atol=1000.0 * 2e-5)


def test_temperature_channel_and_bad_sensor_values_are_named():
    w = hf.simulate(NOMINAL, command=SHORT, temperature_c=65.0).window
    assert np.all(w.temperature == 65.0)
    with pytest.raises(ConfigError, match="current_gain"):
        SensorSpec(current_gain=3.0)
    with pytest.raises(ConfigError, match="not both"):
        hf.simulate(NOMINAL, command=SHORT, sensors=SensorSpec(), noise_current=0.1)


def test_stream_continues_the_simulation_with_the_new_state():
    s = hf.HFStream(k_with(friction=0.2), command=SHORT)
    rows = np.vstack([s.advance(100), s.advance(150)])
    w = hf.simulate(k_with(friction=0.2), command=SHORT).window
    np.testing.assert_allclose(rows[:, 3:7], w.matrix()[:250, 3:7], atol=1e-9)
    assert not hasattr(s, "params")
