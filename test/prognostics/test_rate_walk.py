"""A growth rate that keeps moving (ema_phm/prognostics/diffusion.py, rul.prognose(rate_walk=))."""

from __future__ import annotations

import numpy as np
import pytest

from ema_phm.domain.faults import NAMES, NOMINAL
from ema_phm.prognostics import diffusion
from ema_phm.prognostics.rul import History, prognose
from ema_phm.prognostics.trend import NOISE_SCALES, fit_trend

NOISE = 0.01
FRICTION = NAMES.index("friction")


def _increments(rates: np.ndarray) -> np.ndarray:
    """Severities 0, r0, r0 + r1, ... of per-cycle rises `rates`."""
    return np.concatenate([[0.0], np.cumsum(rates)])


def _learn(y: np.ndarray, *, rise: float, seed: int = 0) -> diffusion.Diffusion:
    rng = np.random.default_rng(seed)
    c = np.arange(y.size, dtype=np.float64)
    noisy = y + rng.normal(0.0, NOISE, y.size)
    shape = c / c[-1]  # the linear law from cycle 0
    return diffusion.learn(
        c,
        noisy,
        np.full(y.size, NOISE),
        shape=shape,
        rise=rise,
        floor=0.005,
        noise_scales=NOISE_SCALES,
    )


def test_prior_prefers_a_constant_rate_and_keeps_every_diffusion_possible():
    prior = diffusion.DIFFUSION_PRIOR
    assert prior.sum() == pytest.approx(1.0)
    assert prior[0] == diffusion.P_CONSTANT and np.all(prior > 0)
    assert np.all(np.diff(prior[1:]) < 0)  # larger diffusions need more evidence


def test_a_constant_rate_is_read_as_constant():
    # noise alone can wobble a history: over many noise draws the constant rate gains
    y = _increments(np.full(30, 0.01))
    fits = [_learn(y, rise=float(y[-1]), seed=seed) for seed in range(20)]
    assert np.median([d.p_constant for d in fits]) > diffusion.P_CONSTANT
    assert np.median([d.factor_mean[0] for d in fits]) == pytest.approx(1.0, abs=0.1)


def test_a_rate_that_steps_up_is_read_as_moving_and_its_present_factor_follows():
    # the rate quadruples two thirds of the way: a trend through the whole history
    # underestimates the present rate
    rates = np.r_[np.full(20, 0.004), np.full(10, 0.016)]
    y = _increments(rates)
    d = _learn(y, rise=float(y[-1]))
    assert d.p_constant < 0.05
    walking = d.weights[1:] / d.weights[1:].sum()
    present = float(np.sum(walking * d.factor_mean[1:]))
    assert present > 1.5  # the trend's mean rate is y[-1] / 30; the present one is 2.5x it


def test_a_diffusion_the_prior_rules_out_still_has_its_filters_state():
    """Each diffusion's level and factor are its own filter's, whatever its posterior.

    A prior (a user's growth-prior file may give a diffusion weight 0) that rules out all
    but d = 0.2: the other diffusions' states are still their filters' (what `walk` moves
    a constant-rate sample from).  They read 0 before, and a walking sample then started
    from twice the present severity: a RUL of 0 with the fault far from its threshold.
    """
    y = _increments(np.r_[np.full(20, 0.001), np.full(10, 0.02)])
    c = np.arange(y.size, dtype=np.float64)
    common = {"shape": c / c[-1], "rise": float(y[-1]), "floor": 1e-5}
    kw = {**common, "noise_scales": NOISE_SCALES}
    free = diffusion.learn(c, y, np.full(y.size, 1e-4), **kw)
    ruled = diffusion.learn(c, y, np.full(y.size, 1e-4), **kw, prior=(0, 0, 0, 0, 1, 0))
    assert ruled.weights[4] == 1.0
    np.testing.assert_allclose(ruled.level_mean, free.level_mean, rtol=1e-9)
    np.testing.assert_allclose(ruled.factor_mean, free.factor_mean, rtol=1e-9)
    assert np.all(ruled.level_mean > 0.5 * y[-1])


def _walking_fit(law: str) -> tuple:
    c = np.arange(25, dtype=np.float64)
    y = 0.01 * c if law == "linear" else 0.02 * np.exp(0.1 * c)
    sd = np.full(c.size, NOISE)
    fit = fit_trend(c, y, sd, law_prior={"none": 0.1, "linear": 0.45, "exponential": 0.45})
    rng = np.random.default_rng(1)
    m, a, b = fit.sample(500, rng)
    return fit, (m, a, b)


@pytest.mark.parametrize("law", ["linear", "exponential"])
def test_a_walk_that_does_not_move_steps_to_the_closed_form_crossing(law):
    fit, (m, a, b) = _walking_fit(law)
    th = np.full(m.size, 0.4)
    now = float(fit.cycles[-1])
    closed = np.maximum(np.ceil(fit.crossing_cycles(th, m, a, b) - now - 1e-9), 0.0)
    grows = np.isfinite(closed) & (closed > 0)
    stepped = diffusion._stepped(
        fit,
        (m[grows], a[grows], b[grows]),
        th[grows],
        now=now,
        factor=np.ones(int(grows.sum())),
        sd=np.zeros(int(grows.sum())),
        rng=np.random.default_rng(0),
    )
    np.testing.assert_array_equal(stepped, closed[grows])


def _friction_history(rates: np.ndarray, seed: int = 0) -> History:
    rng = np.random.default_rng(seed)
    sev = _increments(rates)
    k = np.tile(NOMINAL, (sev.size, 1))
    k[:, FRICTION] = np.clip(sev + rng.normal(0.0, NOISE, sev.size), 0.0, 1.0)
    half = 1.645 * NOISE
    return History.from_estimates(
        np.arange(sev.size), k, np.clip(k - half, 0, 1), np.clip(k + half, 0, 1)
    )


def test_prognose_follows_a_rate_that_has_slowed():
    # the rate has slowed to a quarter: the constant-rate trend (with the fleet's memory)
    # still expects the old pace and fails the unit far too early
    h = _friction_history(np.r_[np.full(20, 0.012), np.full(10, 0.003)])
    true = (0.4 - 0.27) / 0.003  # 43 cycles at the present rate
    walk = prognose(h, seed=3).fault("friction")
    constant = prognose(h, seed=3, rate_walk=False).fault("friction")
    assert walk.status == constant.status == "degrading", walk.message
    assert constant.rul_cycles.p95 < true  # the constant rate misses it
    assert walk.rul_cycles.p5 <= true <= walk.rul_cycles.p95, walk.message
    assert np.mean(np.isinf(walk.samples)) < 0.1  # a slowed rate is not a stopped one
    assert walk.rate_diffusion > 0.1 and np.isnan(constant.rate_diffusion)
    again = prognose(h, seed=3).fault("friction")
    np.testing.assert_array_equal(again.samples, walk.samples)  # same seed, same samples


def _constant_rate_diffusion(weights: np.ndarray) -> diffusion.Diffusion:
    """A diffusion posterior whose filters agree with the constant rate's at every d."""
    n = diffusion.DIFFUSIONS.size
    return diffusion.Diffusion(
        weights, np.full(n, 1.1), np.full(n, 0.2), np.full(n, 0.3), np.full(n, 0.01)
    )


def test_a_walk_that_vanishes_is_the_constant_rate(monkeypatch):
    """A walking sample carries only what the walk adds: at d -> 0 it is the closed form."""
    fit, (m, a, b) = _walking_fit("linear")
    th = np.full(m.size, 0.4)
    now = float(fit.cycles[-1])
    tiny = np.r_[0.0, np.full(diffusion.DIFFUSIONS.size - 1, 1e-12)]
    monkeypatch.setattr(diffusion, "DIFFUSIONS", tiny)
    weights = np.r_[0.0, 1.0, np.zeros(tiny.size - 2)]
    closed = np.maximum(np.ceil(fit.crossing_cycles(th, m, a, b) - now - 1e-9), 0.0)
    walked = diffusion.walk(
        fit,
        (m, a, b),
        th,
        closed,
        now=now,
        diffusion=_constant_rate_diffusion(weights),
        rng=np.random.default_rng(2),
    )
    np.testing.assert_array_equal(walked, closed)


def test_the_prior_alone_walks_around_the_trend_and_never_stops_it():
    fit, (m, a, b) = _walking_fit("linear")
    th = np.full(m.size, 0.4)
    now = float(fit.cycles[-1])
    closed = np.maximum(np.ceil(fit.crossing_cycles(th, m, a, b) - now - 1e-9), 0.0)
    walked = diffusion.walk(
        fit,
        (m, a, b),
        th,
        closed,
        now=now,
        diffusion=diffusion.prior_only(),
        rng=np.random.default_rng(2),
    )
    assert np.isinf(walked).sum() == np.isinf(closed).sum()
    assert abs(np.median(walked) - np.median(closed)) <= 2


def test_a_steady_linear_rul_is_kept():
    h = _friction_history(np.full(25, 0.01))
    walk = prognose(h, seed=0).fault("friction")
    constant = prognose(h, seed=0, rate_walk=False).fault("friction")
    true = 40 - 25
    for f in (walk, constant):
        assert f.rul_cycles.p5 <= true <= f.rul_cycles.p95, f.message
    assert abs(walk.rul_cycles.p50 - constant.rul_cycles.p50) <= 2
