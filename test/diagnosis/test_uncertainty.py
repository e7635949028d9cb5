"""Intervals, identifiability flags and model adequacy of a fit."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from helpers import k_with

from ema_phm.diagnosis import adequacy, identifiability, uncertainty
from ema_phm.diagnosis.fitness import Fitness
from ema_phm.domain.faults import N_K, NOMINAL
from ema_phm.domain.window import Window
from ema_phm.model.belief import MonitorBelief
from ema_phm.model.monitor_model import MonitorModel
from ema_phm.simulator import real_ema


def test_hac_without_lags_is_the_plain_score_product():
    g = np.random.default_rng(0).standard_normal((4000, 3))
    assert np.allclose(uncertainty.hac_score_covariance(g, 0), g.T @ g)
    s = uncertainty.hac_score_covariance(g, 20)
    assert np.allclose(s, s.T) and np.all(np.linalg.eigvalsh(s) > 0)
    # white scores: the lags add little
    assert np.allclose(np.diag(s), np.diag(g.T @ g), rtol=0.3)


def test_hac_grows_with_correlated_scores():
    rng = np.random.default_rng(1)
    e = rng.standard_normal((4000, 1))
    g = np.empty_like(e)
    g[0] = e[0]
    for t in range(1, len(e)):  # AR(1), phi 0.9: variance of the sum ~19x the white one
        g[t] = 0.9 * g[t - 1] + e[t]
    ratio = uncertainty.hac_score_covariance(g, 200)[0, 0] / float(g[:, 0] @ g[:, 0])
    assert 8.0 < ratio < 30.0


def _twin_window(k: np.ndarray, noise: float, seed: int) -> Window:
    """Telemetry made by the monitor model itself plus white current noise (a pure LF twin)."""
    w = real_ema.simulate(k, seed=0).window
    lf = MonitorModel(w).simulate(k)
    rng = np.random.default_rng(seed)
    return dataclasses.replace(
        w,
        i3eq=lf[:, 0] + noise * rng.standard_normal(w.n),
        theta_u=lf[:, 1],
        omega_m=lf[:, 2],
    )


def test_standard_errors_scale_with_the_noise():
    k = k_with(friction=0.3, sc_a=0.2)
    std = []
    for noise in (0.2, 0.4):
        fit = Fitness(_twin_window(k, noise, seed=3), weights="thesis")
        std.append(uncertainty.estimate(fit, k).std)
    ratio = std[1][[0, 2, 7]] / std[0][[0, 2, 7]]
    assert np.all((ratio > 1.6) & (ratio < 2.5)), ratio


def test_interval_is_clipped_and_an_unconstrained_entry_is_infinite():
    k = k_with(ecc=0.0)
    fit = Fitness(_twin_window(k, 0.2, seed=4), weights="thesis")
    u = uncertainty.estimate(fit, k)
    assert np.all(u.interval[:, 0] >= 0.0) and np.all(u.interval[:, 1] <= 1.0)
    assert np.all(u.interval[:, 0] <= k) and np.all(k <= u.interval[:, 1])
    # with no eccentricity its phase does not move the prediction: no information
    assert u.jacobian_norms[6] < 1e-6 * u.jacobian_norms.max()


def test_phase_is_not_identifiable_without_eccentricity():
    interval = np.tile([0.0, 0.05], (N_K, 1))
    interval[6] = (0.4, 0.6)
    flags = identifiability.flags(NOMINAL, interval, np.ones(N_K))
    assert not flags[6][0] and "reaches 0" in flags[6][1]
    assert all(ok for i, (ok, _) in enumerate(flags) if i != 6)
    assert identifiability.phase_interval(interval)[6].tolist() == [0.0, 1.0]
    interval[5] = (0.2, 0.3)  # a clear eccentricity: its phase means something
    assert identifiability.flags(NOMINAL, interval, np.ones(N_K))[6][0]


def test_wide_and_flat_entries_are_flagged():
    interval = np.tile([0.1, 0.2], (N_K, 1))
    interval[0] = (0.05, 0.95)
    norms = np.ones(N_K)
    norms[3] = 0.0
    flags = identifiability.flags(NOMINAL, interval, norms)
    assert not flags[0][0] and "most of [0, 1]" in flags[0][1]
    assert not flags[3][0] and "does not change" in flags[3][1]


def test_adequacy_is_the_fitness_over_the_healthy_reference():
    belief = MonitorBelief.default().with_values({"monitor.healthy_fitness": 2.0})
    ok = adequacy.judge(4.0, belief=belief, threshold=3.0)
    assert ok.statistic == pytest.approx(2.0) and ok.ok
    bad = adequacy.judge(8.0, belief=belief, threshold=3.0)
    assert bad.statistic == pytest.approx(4.0) and not bad.ok
    assert bad.as_dict() == {"statistic": 4.0, "threshold": 3.0, "ok": False}


def test_a_followed_fit_is_judged_against_its_own_healthy_reference():
    belief = MonitorBelief.default().with_values(
        {"monitor.healthy_fitness": 2.0, "monitor.healthy_fitness_followed": 4.0}
    )
    assert adequacy.judge(8.0, belief=belief, followed=True).statistic == pytest.approx(2.0)
    assert adequacy.judge(8.0, belief=belief).statistic == pytest.approx(4.0)


def test_a_healthy_clean_window_is_explained_whichever_fitness_fits_it():
    """The datasheet unit's healthy window: explained by both fitnesses.

    Without its own healthy reference the recorded-loop fit scored 0.41 against the open
    loop's 0.08 (statistic 5.1: every clean window "not explained").
    """
    from ema_phm.diagnosis.isolation import isolate

    w = real_ema.simulate(NOMINAL, seed=1).window
    for name in ("recorded", "thesis"):
        res = isolate(w, seed=1, nuisance=True, intervals=True, weights=name)
        assert res.adequacy.ok and res.adequacy.statistic < 1.2, (name, res.adequacy)


def test_a_forward_jacobian_is_the_one_sided_difference_and_costs_half():
    x = k_with(friction=0.3, k8=0.3)
    fit = Fitness(_twin_window(x, 0.2, seed=4), weights="thesis")
    x[1] = 1.0  # the backlash at its bound: its step must turn back
    _, n_central = uncertainty.jacobian(fit, x)
    forward, n_forward = uncertainty.jacobian(fit, x, central=False)
    assert (n_central, n_forward) == (2 * x.size, x.size + 1)
    base = fit.weighted_residuals(x[None])[0]
    for i, h in ((7, uncertainty.STEP), (1, -uncertainty.STEP)):
        moved = x.copy()
        moved[i] += h
        direct = (fit.weighted_residuals(moved[None])[0] - base) / h
        assert np.linalg.norm(direct) > 0.0
        assert np.allclose(forward[:, :, i], direct, rtol=1e-9, atol=1e-9), i


def test_the_same_jacobian_again_costs_no_simulation_and_gives_the_same_intervals():
    x = k_with(friction=0.3, k8=0.3)
    w = _twin_window(x, 0.2, seed=5)
    fit = Fitness(w, weights="thesis")
    jac, sims = uncertainty.jacobian(fit, x)
    before = fit.evaluations
    again, none = uncertainty.jacobian(fit, x.copy())
    assert (sims, none, fit.evaluations) == (2 * x.size, 0, before)
    assert again is jac
    # another point, step or kind of difference is simulated
    assert uncertainty.jacobian(fit, x, step=1e-3)[1] == 2 * x.size
    assert uncertainty.jacobian(fit, x, central=False)[1] == x.size + 1
    moved = x.copy()
    moved[0] += 0.01
    assert uncertainty.jacobian(fit, moved)[1] == 2 * x.size
    # the intervals at the polish's last point are those of a fit that never polished
    uncertainty.jacobian(fit, x)
    cached = uncertainty.estimate(fit, x)
    fresh = uncertainty.estimate(Fitness(w, weights="thesis"), x)
    assert np.array_equal(cached.std, fresh.std)
