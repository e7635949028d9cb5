"""Nuisances searched with k: the unmeasured load, the measured temperature, the hunting loop."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from helpers import k_with

from ema_phm.diagnosis import nuisance
from ema_phm.diagnosis.fitness import Fitness
from ema_phm.diagnosis.isolation import isolate
from ema_phm.domain.faults import N_K, NOMINAL
from ema_phm.model import monitor_model as mm
from ema_phm.model.belief import MonitorBelief
from ema_phm.physics.commands import LoadSpec
from ema_phm.simulator import real_ema


@pytest.fixture(scope="module")
def window():
    return real_ema.simulate(k_with(friction=0.3), seed=2).window


def test_a_searched_load_is_the_same_as_a_measured_one(window):
    """The nuisance load enters the monitor exactly where a measured load channel does."""
    measured = dataclasses.replace(window, load=np.full(window.n, 25.0))
    unmeasured = dataclasses.replace(window, load=np.full(window.n, np.nan))
    a = mm.MonitorModel(measured).simulate(NOMINAL)
    b = mm.MonitorModel(unmeasured).simulate_batch(NOMINAL[None], nuisance=[[25.0, 0.0]])[0]
    assert np.allclose(a, b, rtol=0, atol=1e-9)
    c = mm.MonitorModel(unmeasured).simulate(NOMINAL)
    assert np.abs(a[:, 0] - c[:, 0]).mean() > 0.1  # and the load matters


@pytest.mark.parametrize("measured", [True, False])
def test_vectorized_rows_equal_row_by_row(window, measured):
    if not measured:
        window = dataclasses.replace(window, load=np.full(window.n, np.nan))
    fit = Fitness(window, nuisance=True)
    rng = np.random.default_rng(0)
    rows = rng.random((5, fit.dim))
    together = fit(rows)
    alone = np.array([fit(r[None])[0] for r in rows])
    assert np.allclose(together, alone, rtol=1e-12)
    searched = nuisance.MEASURED_LOAD_NUISANCES if measured else nuisance.NUISANCES
    assert fit.nuisances == searched and fit.dim == N_K + len(searched)


def test_a_measured_load_channel_is_not_fitted_a_load_beside_it(window):
    """Issue 20: the load channel measured (finite), the load nuisances are not searched.

    The current offset is, instead: it shifts the predicted current by itself and nothing
    else (an offset on the acquired I_3eq, which the loops do not read).
    """
    assert nuisance.load_measured(window) and np.all(window.load == 0.0)
    fit = Fitness(window, nuisance=True)
    assert [n.name for n in fit.nuisances] == ["current_offset"]
    healthy = fit.healthy_row
    offset = healthy.copy()
    offset[N_K] = nuisance.CURRENT_OFFSET.normalized(0.2)
    a, b = fit.simulate(np.vstack([healthy, offset]))
    np.testing.assert_allclose(b[:, 0] - a[:, 0], 0.2, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(b[:, 1:], a[:, 1:])
    # one NaN sample and the load is not measured there: the unmeasured load is searched
    gap = window.load.copy()
    gap[10] = np.nan
    part = Fitness(dataclasses.replace(window, load=gap), nuisance=True)
    assert part.nuisances == nuisance.NUISANCES


def test_isolation_fits_the_current_offset_where_the_load_is_measured():
    from ema_phm.simulator.sensors import SensorSpec

    w = real_ema.simulate(
        k_with(friction=0.2), sensors=SensorSpec(current_offset=0.15), seed=4
    ).window
    res = isolate(w, seed=1, nuisance=True, intervals=True)
    assert set(res.nuisance) == {"current_offset", "temperature_c"}  # no load_torque
    assert res.nuisance["current_offset"] == pytest.approx(0.15, abs=0.03)
    assert res.k[0] == pytest.approx(0.2, abs=0.03)
    assert res.row.shape == (N_K + 1,)
    from ema_phm.tools.plotting import _fitted_lf  # the plot draws the offset the fit used

    drawn = Fitness(w, nuisance=True).simulate(res.row[None])[0]
    np.testing.assert_allclose(_fitted_lf(w, res, None), drawn, rtol=0, atol=1e-12)


def test_weighted_residuals_square_to_the_fitness(window):
    fit = Fitness(window, nuisance=True)
    rows = np.random.default_rng(1).random((3, fit.dim))
    e = fit.weighted_residuals(rows)
    assert np.allclose(np.sum(e**2, axis=(1, 2)), fit(rows), rtol=1e-10)


def test_temperature_moves_r_ke_gt_by_the_materials_laws(window):
    b = MonitorBelief.default()
    hot = dataclasses.replace(window, temperature=np.full(window.n, 70.0))
    q = mm.MonitorModel(hot).q
    d = 70.0 - b.value("monitor.reference_temperature_c")
    assert q[mm.Q_R] == pytest.approx(b.value("monitor.r") * (1 + 0.00393 * d))
    assert q[mm.Q_KE] == pytest.approx(b.value("monitor.ke") * (1 - 0.0012 * d))
    assert q[mm.Q_GT] == pytest.approx(b.value("monitor.gt") * (1 - 0.0012 * d))
    unknown = dataclasses.replace(window, temperature=np.full(window.n, np.nan))
    assert mm.MonitorModel(unknown).q[mm.Q_R] == pytest.approx(b.value("monitor.r"))


def test_a_wide_play_makes_the_loop_hunt_and_the_fitness_says_so(window):
    hunting = real_ema.simulate(k_with(backlash=0.2), seed=2).window
    thesis = Fitness(hunting, weights="thesis")
    assert thesis.hunting and thesis.hunting_rms > 2.0
    assert not Fitness(window, weights="thesis").hunting
    assert Fitness(window, weights="thesis").hunting_rms < 0.5
    # the recorded loop follows the hunting instead of comparing its envelope
    assert not Fitness(hunting).hunting and Fitness(hunting).hunting_rms > 2.0
    assert Fitness(hunting).loop_hunts and not Fitness(window).loop_hunts  # still reported
    assert not Fitness(hunting, weights="position").hunting  # the issue-9 weighting: never


def test_isolation_estimates_an_unmeasured_load():
    k = k_with(sc_a=0.3)
    w = real_ema.simulate(
        k, load=LoadSpec(value=-40.0, spring=1500.0, measured=False), seed=5
    ).window
    res = isolate(w, seed=2, nuisance=True, intervals=True)
    assert res.nuisance["load_torque"] == pytest.approx(-40.0, abs=12.0)
    assert res.nuisance["load_stiffness"] == pytest.approx(1500.0, abs=500.0)
    assert res.k[2] == pytest.approx(0.3, abs=0.05)
    assert res.k_interval.shape == (N_K, 2) and len(res.identifiable) == N_K
    assert res.adequacy is not None and res.adequacy.ok is not None
    d = res.as_dict()
    assert {"k_interval", "identifiable", "adequacy", "nuisance", "loop_hunting"} <= set(d)
    assert d["fitness_name"] == "recorded"  # "default" is recorded resolved


def test_the_plotted_prediction_is_the_model_the_fit_used(window):
    """A recorded-loop fit is drawn with the recorded-loop model, an open-loop one without."""
    from ema_phm.tools.plotting import _fitted_lf

    for name in ("recorded", "thesis"):
        res = isolate(window, seed=1, weights=name, max_evaluations=40, check_excitation=False)
        assert res.fitness_name == name
        expect = Fitness(window, weights=name).model.simulate(res.k)
        np.testing.assert_array_equal(_fitted_lf(window, res, None), expect)


def test_tracking_from_a_previous_fit_is_cheaper_and_as_good(window):
    from ema_phm.errors import EmaPhmError

    first = isolate(window, seed=1, nuisance=True, intervals=True)
    nearby = real_ema.simulate(k_with(friction=0.32), seed=3).window
    fresh = isolate(nearby, seed=1, nuisance=True, intervals=True)
    tracked = isolate(nearby, seed=1, nuisance=True, intervals=True, start=first.row)
    assert tracked.tracked and not fresh.tracked and tracked.row.shape == (9,)  # + offset
    assert tracked.evaluations < 0.4 * fresh.evaluations
    assert tracked.fitness <= 1.05 * fresh.fitness
    assert tracked.k[0] == pytest.approx(0.32, abs=0.03)
    # a bare k is a start too (no nuisance assumed), and so is the row of a window whose
    # nuisances were the unmeasured load; a wrong size is refused
    assert isolate(nearby, seed=1, nuisance=True, start=first.k).tracked
    loads = np.concatenate([first.k, nuisance.zero(nuisance.NUISANCES)])
    assert isolate(nearby, seed=1, nuisance=True, start=loads, max_evaluations=30).tracked
    with pytest.raises(EmaPhmError, match="start must be 9"):
        isolate(nearby, seed=1, nuisance=True, start=np.zeros(5))
