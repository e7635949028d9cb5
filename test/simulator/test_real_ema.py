"""The HF "real EMA" (ema_phm.simulator.real_ema): tracking, faults, noise, compiled kernel."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import GEAR, k_with, rms

from ema_phm.domain.faults import NOMINAL
from ema_phm.physics.commands import CommandSpec
from ema_phm.physics.fault_vector import FaultVector
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator import real_ema as hf


def test_nominal_hf_tracks_the_chirp(nominal):
    w = nominal
    amp = np.abs(w.command).max()
    err = w.command - w.theta_u
    assert np.abs(err).max() < 0.2 * amp  # 32 Hz loop on a 0.5-5 Hz chirp
    assert rms(err) < 0.08 * amp
    assert np.corrcoef(w.command, w.theta_u)[0, 1] > 0.99
    assert np.abs(w.omega_m).max() < 8000 * 2 * np.pi / 60


def test_backlash_starts_consistent_with_the_motor_angle():
    w = hf.simulate(
        NOMINAL,
        command=CommandSpec(kind="step", amplitude=0.01, duration=0.05, offset=0.02),
        x0=(10.0, 0.0, 0.0),
    ).window
    resolution = ActuatorParameters.default()["high_fidelity"]["position_resolution"]
    assert w.theta_u[0] == pytest.approx(GEAR * 10.0, abs=resolution)
    # no spurious jump: the first samples move smoothly
    assert abs(w.theta_u[1] - w.theta_u[0]) < 1e-3


def test_coil_fault_leaves_controller_torque_gain_alone():
    p = ActuatorParameters.default()
    a = hf.hf_parameters(FaultVector.from_k(NOMINAL), p)
    b = hf.hf_parameters(FaultVector.from_k(k_with(sc_a=0.7)), p)
    assert b[hf.P_KTC] == a[hf.P_KTC]
    assert b[hf.P_KEA] < a[hf.P_KEA] and b[hf.P_RA] < a[hf.P_RA] and b[hf.P_LA] < a[hf.P_LA]
    assert b[hf.P_KEB] == a[hf.P_KEB]


@pytest.mark.parametrize("k3", [0.9, 1.0])
def test_one_faulted_phase_keeps_current_control(k3):
    # the neutral point is solved with each phase's own inductance; a wrong solve
    # would leave the healthy phases unable to follow their references
    w = hf.simulate(k_with(sc_a=k3), command=CommandSpec(duration=0.4)).window
    assert np.isfinite(w.i3eq).all()
    assert np.abs(w.command - w.theta_u).max() < 0.2 * np.abs(w.command).max()


def test_same_seed_same_output_and_noise_level():
    a = hf.simulate(NOMINAL, seed=5, noise_current=0.225, command=CommandSpec(duration=0.2)).window
    b = hf.simulate(NOMINAL, seed=5, noise_current=0.225, command=CommandSpec(duration=0.2)).window
    c = hf.simulate(NOMINAL, seed=6, noise_current=0.225, command=CommandSpec(duration=0.2)).window
    clean = hf.simulate(NOMINAL, command=CommandSpec(duration=0.2)).window
    np.testing.assert_array_equal(a.matrix(), b.matrix())
    assert not np.array_equal(a.i3eq, c.i3eq)
    assert rms(a.i3eq - clean.i3eq) == pytest.approx(0.225, rel=0.1)


def test_a_unit_with_an_offset_sensor_starts_where_its_loop_holds_the_command():
    # at rest the loop holds the READING on the command: the shaft sits off by the offset, so
    # the window reads as a unit without offset does (it opened with the loop pulling the
    # shaft across the whole offset before the start was settled)
    from ema_phm.simulator.sensors import SensorSpec

    w = hf.simulate(NOMINAL, sensors=SensorSpec(position_offset=-4.0e-4)).window
    ref = hf.simulate(NOMINAL).window
    resolution = ActuatorParameters.default()["high_fidelity"]["position_resolution"]
    assert GEAR * w.theta_m[0] == pytest.approx(w.command[0] + 4.0e-4, abs=2e-6)
    assert np.abs(w.theta_u - ref.theta_u).max() <= 2 * resolution
    unsettled = hf.simulate(NOMINAL, sensors=SensorSpec(position_offset=-4.0e-4), x0=(0, 0, 0))
    assert np.abs(unsettled.window.theta_u - ref.theta_u).max() > 1e-4
