"""The LF monitor model (ema_phm.model.monitor_model): invariants, agreement with the HF."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import GEAR, k_with, rms, window_at
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from ema_phm.domain.faults import N_K, NOMINAL, fault
from ema_phm.errors import ConfigError, FaultVectorError
from ema_phm.model import monitor_model as mm
from ema_phm.model.belief import MonitorBelief
from ema_phm.physics.commands import CommandSpec, LoadSpec
from ema_phm.physics.fault_vector import FaultVector
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator import real_ema as hf


def both(k: np.ndarray, window_for_lf=None):
    """HF window for k, and the LF run with the same k on that window."""
    w = hf.simulate(k).window
    lf = mm.MonitorModel(w).simulate(k)
    return w, lf


def test_nominal_lf_tracks_like_the_hf(nominal):
    lf = mm.MonitorModel(nominal).simulate(NOMINAL)
    assert rms(lf[:, 1] - nominal.theta_u) < 0.02 * np.abs(nominal.command).max()
    # calibrated monitor against the two-inertia HF: measured 0.069 A^2 (thesis after
    # calibration: 0.0644 A^2); a twin would score ~1e-3
    assert np.mean((lf[:, 0] - nominal.i3eq) ** 2) < 0.1


@pytest.mark.parametrize("fault", ["friction", "sc_a", "sc_b", "sc_c"])
def test_friction_and_short_circuit_raise_current_in_both_models(nominal, fault):
    lf_nom = mm.MonitorModel(nominal).simulate(NOMINAL)
    k = k_with(**{fault: 0.5})
    w, lf = both(k)
    assert rms(w.i3eq) > 1.05 * rms(nominal.i3eq)
    assert rms(lf[:, 0]) > 1.05 * rms(lf_nom[:, 0])


def _theta_e_modulation(
    diff: np.ndarray, current: np.ndarray, theta_m: np.ndarray
) -> tuple[float, complex]:
    """Fit diff ~ current * (a cos theta_e + b sin theta_e): share explained and phasor a + ib."""
    te = 2.0 * theta_m
    basis = np.column_stack([current * np.cos(te), current * np.sin(te)])
    coef, *_ = np.linalg.lstsq(basis, diff, rcond=None)
    r2 = 1.0 - np.sum((diff - basis @ coef) ** 2) / np.sum(diff**2)
    return float(r2), complex(coef[0], coef[1])


def _fit(diff: np.ndarray, current: np.ndarray, angle: np.ndarray) -> tuple[float, complex]:
    basis = np.column_stack([current * np.cos(angle), current * np.sin(angle)])
    coef, *_ = np.linalg.lstsq(basis, diff, rcond=None)
    r2 = 1.0 - np.sum((diff - basis @ coef) ** 2) / np.sum(diff**2)
    return float(r2), complex(coef[0], coef[1])


def test_eccentricity_harmonic_lf_and_hf_mechanical_at_the_derived_angle(nominal):
    # HF, sec. 4.5 per phase (real_ema.eccentricity_factors): the torque per ampere is
    # 1 + (2/3) zeta cos(theta_m - phi) plus 3rd/5th harmonics (phi: the smallest gap), so the
    # current that supplies the torque gains a theta_m harmonic of phasor ~ -(2/3) zeta e^{i phi}.
    # LF, default law 1 (the same sec. 4.5 law summed over the phases): the same harmonic.
    # LF, law 0 (the thesis's eq. 3.22, 1 - 0.42 zeta cos(theta_e + phi)): a theta_e harmonic
    # instead.  Fit where the drive is below its voltage limit (t < 0.8 s).
    thesis = MonitorBelief.default().with_values({"monitor.eccentricity_law": 0})
    lf_nom = mm.MonitorModel(nominal).simulate(NOMINAL)
    lf_nom_thesis = mm.MonitorModel(nominal, belief=thesis).simulate(NOMINAL)
    m = nominal.t < 0.8
    phasors = {}
    for phase in (0.5, 0.75):
        k = k_with(ecc=0.6, phase=phase)
        w, lf = both(k)
        phi = FaultVector.from_k(k).phi
        lf_thesis = mm.MonitorModel(w, belief=thesis).simulate(k)
        r2, ph = _theta_e_modulation(
            (lf_thesis[:, 0] - lf_nom_thesis[:, 0])[m], lf_nom_thesis[m, 0], w.theta_m[m]
        )
        assert r2 > 0.6, ("lf eq. 3.22", phase, r2)
        assert abs(ph) == pytest.approx(0.42 * 0.6, rel=0.25)
        phasors["lf", phase] = ph
        for who, cur, base in (
            ("hf", w.i3eq, nominal.i3eq),
            ("lf", lf[:, 0], lf_nom[:, 0]),
        ):
            r2, ph = _fit((cur - base)[m], base[m], w.theta_m[m])
            assert r2 > 0.4, (who, phase, r2)
            assert 0.3 < abs(ph) < 0.7, (who, phase, abs(ph))
            assert abs(np.angle(-ph * np.exp(-1j * phi))) < 0.15, (who, phase, np.angle(ph), phi)
    wf, _ = both(k_with(friction=0.5))  # a friction fault changes the current, not that way
    assert (
        _theta_e_modulation((wf.i3eq - nominal.i3eq)[m], nominal.i3eq[m], wf.theta_m[m])[0] < 0.2
    )
    dphi = np.angle(phasors["lf", 0.75] / phasors["lf", 0.5])  # k7 +0.25: phi turns by pi/2
    assert abs(abs(dphi) - np.pi / 2) < 0.3, dphi


@pytest.mark.parametrize("gain,direction", [(0.2, +1), (0.8, -1)])
def test_gain_drift_changes_tracking_bandwidth_in_both_models(nominal, gain, direction):
    lf_nom = mm.MonitorModel(nominal).simulate(NOMINAL)
    w, lf = both(k_with(gain=gain))
    e_nom_hf, e_hf = rms(nominal.command - nominal.theta_u), rms(w.command - w.theta_u)
    e_nom_lf, e_lf = rms(nominal.command - lf_nom[:, 1]), rms(w.command - lf[:, 1])
    assert direction * (e_hf - e_nom_hf) > 0.1 * e_nom_hf
    assert direction * (e_lf - e_nom_lf) > 0.1 * e_nom_lf


def test_backlash_shows_in_position_in_both_models(nominal):
    k = k_with(backlash=0.6)
    w, lf = both(k)
    width = (
        ActuatorParameters.default()["mechanics"]["backlash"]
        * FaultVector.from_k(k).backlash_factor
    )
    # HF: user minus motor angle = the play plus the reducer's elastic twist.  With a
    # 100x stiffer reducer and exact sensors it is the half width; with the default
    # reducer the twist adds (measured max 6.6e-4 rad vs half width 3.0e-4, nominal 5.6e-5)
    stiff = ActuatorParameters.default().with_values(
        {
            "high_fidelity.torsional_stiffness": 2.5e8,
            "high_fidelity.position_resolution": 0.0,
            "high_fidelity.resolver_resolution": 0.0,
        }
    )
    ws = hf.simulate(k, actuator=stiff).window
    assert np.abs(ws.theta_u - GEAR * ws.theta_m).max() == pytest.approx(width / 2, rel=0.05)
    gap_hf = np.abs(w.theta_u - GEAR * w.theta_m).max()
    assert gap_hf > width / 2
    assert np.abs(nominal.theta_u - GEAR * nominal.theta_m).max() < width / 4
    # the position loop sees the dead band: tracking error grows in both models
    lf_nom = mm.MonitorModel(nominal).simulate(NOMINAL)
    assert rms(w.command - w.theta_u) > rms(nominal.command - nominal.theta_u)
    assert rms(w.command - lf[:, 1]) > rms(nominal.command - lf_nom[:, 1])


def test_end_stops_hold():
    stop = ActuatorParameters.default()["mechanics"]["end_stop"]
    cmd = CommandSpec(
        kind="step", amplitude=0.4, offset=0.4, duration=0.6, t_start=0.0
    )  # 0.8 rad: past the stop
    w = hf.simulate(NOMINAL, command=cmd).window
    # HF: the stops hold the user shaft (read through the 1.5e-5 rad position sensor)
    resolution = ActuatorParameters.default()["high_fidelity"]["position_resolution"]
    assert w.theta_u.max() <= stop + resolution
    assert w.theta_u.max() == pytest.approx(stop, abs=resolution)
    assert (w.theta_u >= stop - resolution).sum() > 10
    lf = mm.MonitorModel(w).simulate(NOMINAL)
    # the LF reads its user body plus the sensor zero offset it estimated (median of
    # theta_u - gear * theta_m: the twist and quantization leave a few 1e-5 rad)
    assert lf[:, 1].max() == pytest.approx(stop, abs=4e-5)


def test_load_torque_is_felt_by_both_models(nominal):
    w = hf.simulate(NOMINAL, load=LoadSpec(value=40.0)).window
    lf = mm.MonitorModel(w).simulate(NOMINAL)
    shift_hf = np.mean(w.i3eq) - np.mean(nominal.i3eq)
    shift_lf = np.mean(lf[:, 0]) - np.mean(mm.MonitorModel(nominal).simulate(NOMINAL)[:, 0])
    # opposing load -> positive mean current, over each model's own torque per ampere
    kt_hf = 1.5 * ActuatorParameters.default()["motor"]["ke_phase_peak"]  # 0.0564 N*m/A
    assert shift_hf == pytest.approx(40.0 * GEAR / kt_hf, rel=0.2)
    gt_lf = mm.MonitorBelief.default()["monitor"]["gt"]
    assert shift_lf == pytest.approx(40.0 * GEAR / gt_lf, rel=0.2)


def test_sign_law_at_fine_step_matches_the_averaged_law(nominal):
    short = nominal  # full default window
    k = k_with(friction=0.3, sc_a=0.3, ecc=0.3)
    fine_sign = mm.MonitorModel(short, steps_per_sample=500, current_law=mm.SIGN).simulate(
        k
    )  # 1 us step
    coarse = mm.MonitorModel(short).simulate(k)
    rel = rms(fine_sign[:, 0] - coarse[:, 0]) / rms(fine_sign[:, 0])
    assert rel < 0.05
    # while the sign law at the coarse step chatters badly
    coarse_sign = mm.MonitorModel(short, current_law=mm.SIGN).simulate(k)
    assert rms(coarse_sign[:, 0] - fine_sign[:, 0]) > 3 * rms(coarse[:, 0] - fine_sign[:, 0])


def test_lf_coarse_step_within_two_percent_of_ten_times_finer(nominal):
    for k in (NOMINAL, k_with(friction=0.5, sc_b=0.4, ecc=0.5, gain=0.3)):
        a = mm.MonitorModel(nominal).simulate(k)[:, 0]
        b = mm.MonitorModel(nominal, steps_per_sample=50).simulate(k)[:, 0]
        assert rms(a - b) / rms(b) < 0.02


def test_batch_equals_one_by_one(nominal):
    m = mm.MonitorModel(nominal)
    pop = np.random.default_rng(3).random((7, N_K))
    batch = m.simulate_batch(pop)
    for i, k in enumerate(pop):
        np.testing.assert_array_equal(batch[i], m.simulate(k))


def test_batches_from_several_threads_at_once_equal_one_thread_s(nominal):
    # the kernel runs without the GIL (a node serves meanwhile); its launches stay one at a time
    from concurrent.futures import ThreadPoolExecutor

    m = mm.MonitorModel(nominal)
    pops = [np.random.default_rng(s).random((6, N_K)) for s in range(4)]
    alone = [m.simulate_batch(p) for p in pops]
    with ThreadPoolExecutor(4) as pool:
        together = list(pool.map(m.simulate_batch, pops))
    for a, b in zip(alone, together, strict=True):
        np.testing.assert_array_equal(a, b)


def test_compiled_and_pure_python_agree_on_a_short_window():
    cmd = CommandSpec(duration=0.05, amplitude=0.04, f0=5, f1=5)
    k = k_with(friction=0.4, sc_c=0.3, ecc=0.5, gain=0.7)
    a = hf.simulate(k, command=cmd).window
    b = hf.simulate(k, command=cmd, compiled=False).window
    np.testing.assert_allclose(a.matrix(), b.matrix(), rtol=1e-9, atol=1e-12)
    w = hf.simulate(k, command=CommandSpec(duration=0.05)).window
    m = mm.MonitorModel(w)
    np.testing.assert_allclose(m.simulate(k), m.simulate(k, compiled=False), rtol=1e-9, atol=1e-12)


@settings(max_examples=25, deadline=None)
@given(arrays(np.float64, (N_K,), elements=st.floats(0.0, 1.0)))
def test_lf_stays_finite_for_any_k(k):
    w = _short_window()
    out = mm.MonitorModel(w).simulate(k)
    assert np.isfinite(out).all()
    assert (
        np.abs(out[:, 0]).max() <= 22.5 * 1.1
    )  # current limit (+ the acquisition filter's overshoot)


_SHORT = {}


def _short_window():
    if "w" not in _SHORT:
        _SHORT["w"] = hf.simulate(NOMINAL, command=CommandSpec(duration=0.3)).window
    return _SHORT["w"]


def test_extreme_fault_vectors_stay_finite():
    w = _short_window()
    m = mm.MonitorModel(w)
    two_shorted = k_with(sc_a=1, sc_b=1)
    all_but_gain = np.ones(N_K)
    all_but_gain[fault("gain_drift").index] = 0.0
    for k in (np.ones(N_K), np.zeros(N_K), two_shorted, all_but_gain):
        assert np.isfinite(m.simulate(k)).all()
    assert np.isfinite(
        hf.simulate(two_shorted, command=CommandSpec(duration=0.05)).window.i3eq
    ).all()


@pytest.mark.parametrize(
    "bad,word",
    [
        ([0] * (N_K - 1), f"{N_K} entries"),
        (k_with(gain=float("nan")), fault("gain_drift").label),
        (k_with(backlash=1.5), fault("backlash").label),
        (k_with(sc_b=-0.1), fault("short_circuit_b").label),
        ("abc", str(N_K)),
    ],
)
def test_bad_k_gives_a_clear_error(bad, word):
    with pytest.raises(FaultVectorError, match=word):
        hf.simulate(bad)
    with pytest.raises(FaultVectorError, match=word):
        mm.MonitorModel(_short_window()).simulate(bad)


def test_monitor_model_refuses_a_window_at_another_rate():
    from ema_phm.errors import WindowError
    from ema_phm.model.monitor_model import MonitorModel

    with pytest.raises(WindowError, match=r"1000 Hz.*2000 Hz"):
        MonitorModel(window_at(2))  # 1000 Hz: used to be fitted with a 5 kHz controller, silently


def test_scaling_belief_quantities_scales_their_columns_only():
    m = mm.MonitorModel(_short_window())
    inertia = ("mechanics.j_motor", "mechanics.j_user")
    rows = m.row_parameters(np.zeros((2, 2)), scales=[(inertia, np.array([1.0, 1.5]))])
    np.testing.assert_array_equal(rows[0], m.q)
    changed = np.flatnonzero(rows[1] != m.q)
    assert sorted(changed) == sorted(mm.scaled_columns(inertia))
    np.testing.assert_array_equal(rows[1, changed], 1.5 * m.q[changed])
    # scaled together, a belief with every quantity x1.5 gives the same model
    b = m.belief.with_values({q: 1.5 * m.belief.value(q) for q in inertia})
    np.testing.assert_allclose(mm.MonitorModel(_short_window(), belief=b).q, rows[1], rtol=1e-15)
    with pytest.raises(ConfigError, match="mechanics.j_user"):
        mm.scaled_columns(("mechanics.j_motor",))
    with pytest.raises(ConfigError, match="monitor.vdc"):
        mm.scaled_columns(("monitor.vdc",))


def test_step_and_steps_per_sample_are_named():
    m = mm.MonitorModel(_short_window())
    assert m.steps_per_sample == round(m.belief.value("monitor.steps_per_sample"))
    assert m.step_s == pytest.approx(m.window.dt / m.steps_per_sample, rel=1e-12)
    assert mm.MonitorModel(_short_window(), steps_per_sample=50).steps_per_sample == 50


def test_a_mode_switch_out_of_its_values_is_refused():
    b = MonitorBelief.default().with_values({"monitor.mechanics_model": 0.5})
    with pytest.raises(ConfigError, match=r"monitor.mechanics_model must be one of \(0, 1\)"):
        mm.lf_parameters(b, 2000.0)
    with pytest.raises(ConfigError, match="current_law"):
        mm.lf_parameters(MonitorBelief.default(), 2000.0, current_law=2)
