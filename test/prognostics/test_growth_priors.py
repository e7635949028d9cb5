"""Learned growth priors and recent-weighted evidence (issue 21): trend.py, rul.py, learn.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ema_phm.domain.faults import NOMINAL
from ema_phm.errors import ConfigError
from ema_phm.prognostics import trend
from ema_phm.prognostics.learn import (
    MAX_LOG_SD,
    _log_normal,
    learn_growth_priors,
    load_growth_priors,
)
from ema_phm.prognostics.rul import History, growth_priors, prognose
from ema_phm.simulator.degradation import Degradation, FaultGrowth

NOISE = 0.015


def history(deg: Degradation, last: int, seed: int, index: int = 0) -> History:
    """Estimates of cycles 0..last: the truth plus noise on k1..k6, +/- 1.645 sd."""
    rng = np.random.default_rng(seed)
    cycles = np.arange(last + 1)
    k = deg.trajectory(cycles)
    k[:, :6] = np.clip(k[:, :6] + rng.normal(0.0, NOISE, (cycles.size, 6)), 0.0, 1.0)
    half = 1.645 * NOISE
    return History.from_estimates(cycles, k, np.clip(k - half, 0, 1), np.clip(k + half, 0, 1))


LINEAR = Degradation(faults=(FaultGrowth("friction", "linear", 3, 0.0, 0.0125),))  # EoL 35
EXPONENTIAL = Degradation(
    faults=(FaultGrowth("short_circuit_a", "exponential", 2, 0.03, 0.08),)  # EoL 35
)
PRIORS = {
    "friction": {"linear": (0.0125, 0.25), "exponential": (0.08, 0.4), "p_exponential": 0.1},
    "short_circuit_a": {
        "linear": (0.015, 0.4),
        "exponential": (0.08, 0.3),
        "p_exponential": 0.9,
    },
}


def test_growth_prior_nodes_integrate_its_log_normal_and_bad_values_are_named():
    g = trend.GrowthPrior((0.01, 0.3), (0.1, 0.5))
    nodes, log_w = g.nodes("linear")
    assert nodes.size == trend.RATE_NODES and np.all(np.diff(nodes) > 0)
    w = np.exp(log_w)
    assert w.sum() == pytest.approx(1.0)
    logs = np.log(nodes)
    assert np.sum(w * logs) == pytest.approx(math.log(0.01))  # the log rate's mean ...
    assert np.sqrt(np.sum(w * (logs - math.log(0.01)) ** 2)) == pytest.approx(0.3)  # ... sd
    assert nodes.max() > 0.01 * math.exp(4 * 0.3)  # the tail is a model (an unlikely one)
    assert g.law_prior({"none": 0.5, "linear": 0.3, "exponential": 0.2})["linear"] == 0.3
    split = trend.GrowthPrior((0.01, 0.3), (0.1, 0.5), 0.8).law_prior(
        {"none": 0.5, "linear": 0.3, "exponential": 0.2}
    )
    assert split == pytest.approx({"none": 0.5, "linear": 0.1, "exponential": 0.4})
    with pytest.raises(ConfigError, match=r"linear law .*-0\.01"):
        trend.GrowthPrior((-0.01, 0.3), (0.1, 0.5))
    with pytest.raises(ConfigError, match="p_exponential .* 1.5"):
        trend.GrowthPrior((0.01, 0.3), (0.1, 0.5), 1.5)


@pytest.mark.parametrize(
    "table, match",
    [
        ({"wear": PRIORS["friction"]}, "unknown fault 'wear'"),
        ({"friction": {"linear": (0.01, 0.3)}}, "friction must give linear and exponential"),
        ([1, 2], "must map fault names"),
    ],
)
def test_bad_growth_priors_name_the_problem(table, match):
    with pytest.raises(ConfigError, match=match):
        growth_priors(table)
    h = history(LINEAR, 10, seed=0)
    with pytest.raises(ConfigError, match=match):
        prognose(h, growth_priors=table)


def test_a_learned_prior_gives_a_linear_fault_its_rul_earlier_and_closer():
    # cycle 9 of 35: six cycles of growth, severity 0.075 under noise 0.015
    early = {"flat": [], "learned": []}
    for seed in range(6):
        h = history(LINEAR, 9, seed=seed)
        for label, table in (("flat", {}), ("learned", PRIORS)):
            f = prognose(h, growth_priors=table, seed=seed).fault("friction")
            early[label].append(f.rul_cycles.p50 if f.status == "degrading" else math.inf)
    err = {k: np.median(np.abs(np.array(v) - 26)) for k, v in early.items()}
    assert err["learned"] < 5 and err["learned"] < err["flat"]


def test_the_propagation_form_follows_an_exponential_fault():
    err = {"flat": [], "learned": []}
    covered = 0
    for seed in range(6):
        h = history(EXPONENTIAL, 22, seed=seed)  # true RUL 35 - 22 = 13
        for label, table in (("flat", {}), ("learned", PRIORS)):
            f = prognose(h, growth_priors=table, seed=seed).fault("short_circuit_a")
            assert f.status == "degrading"
            err[label].append(abs(f.rul_cycles.p50 - 13))
            covered += label == "learned" and f.rul_cycles.p5 <= 13 <= f.rul_cycles.p95
    assert covered >= 5
    assert np.median(err["learned"]) <= 3 < np.median(err["flat"])


def test_propagation_crossing_solves_the_trend_it_samples():
    rng = np.random.default_rng(0)
    c = np.arange(20.0)
    y = 0.03 * np.exp(0.1 * np.maximum(c - 4, 0)) + rng.normal(0, 0.005, 20)
    g = trend.GrowthPrior((0.01, 0.3), (0.1, 0.3), 0.9)
    fit = trend.fit_trend(c, y, np.full(20, 0.01), floor=0.01, growth=g)
    assert fit.propagating
    m, a, b = fit.sample(200, rng)
    cross = fit.crossing_cycles(0.4, m, a, b)
    ok = np.isfinite(cross) & (cross > c[-1])
    assert ok.mean() > 0.9
    s = fit.severity(cross[ok], m[ok], a[ok], b[ok])
    assert np.allclose(s, 0.4, atol=1e-9)


def test_short_memory_counts_old_estimates_less():
    h = history(LINEAR, 24, seed=2)
    sev, sd = h.severity(0)
    full = trend.fit_trend(h.cycles, sev, np.maximum(sd, 0.01), floor=0.01)
    short = trend.fit_trend(h.cycles, sev, np.maximum(sd, 0.01), floor=0.01, memory=5.0)
    assert short.sigma[0] > 10 * full.sigma[0] and short.sigma[-1] == full.sigma[-1]
    with pytest.raises(ConfigError, match="memory_cycles"):
        prognose(h, memory_cycles=0.0)


def lives(deg: Degradation, name: str, index: int, eol: int, n: int) -> list:
    return [(name, history(deg, eol - 1, seed=s, index=index), index) for s in range(n)]


def test_learning_recovers_the_lives_rates_and_laws():
    learned = learn_growth_priors(
        lives(LINEAR, "friction", 0, 35, 4) + lives(EXPONENTIAL, "short_circuit_a", 2, 35, 4)
    )
    fr, sc = learned["friction"], learned["short_circuit_a"]
    assert fr["linear"][0] == pytest.approx(0.0125, rel=0.2)
    assert sc["exponential"][0] == pytest.approx(0.08, rel=0.3)
    assert fr["p_exponential"] < 0.5 < sc["p_exponential"]
    assert growth_priors(learned)["friction"].linear == fr["linear"]  # prognose takes it


def test_learning_needs_enough_lives():
    with pytest.raises(ConfigError, match="lives to learn"):
        learn_growth_priors(lives(LINEAR, "friction", 0, 35, 1))


def test_a_fault_of_mixed_lives_learns_each_law_from_its_own_lives():
    # the same fault growing linearly in some units and exponentially in others: the
    # exponential prior must not be dragged down by the linear lives' gentlest curves
    linear = lives(LINEAR, "friction", 0, 35, 4)
    grown = Degradation(faults=(FaultGrowth("friction", "exponential", 2, 0.03, 0.08),))
    learned = learn_growth_priors(linear + lives(grown, "friction", 0, 35, 4))["friction"]
    assert learned["exponential"][0] == pytest.approx(0.08, rel=0.3)
    assert learned["linear"][0] == pytest.approx(0.0125, rel=0.2)
    assert learned["p_exponential"] == pytest.approx(0.5, abs=0.15)


def test_a_falling_sample_that_starts_above_the_threshold_has_reached_it():
    g = trend.GrowthPrior((0.01, 0.3), (0.1, 0.3))
    c = np.arange(10.0)
    fit = trend.fit_trend(c, np.full(10, 0.05), np.full(10, 0.01), floor=0.01, growth=g)
    exp = int(np.flatnonzero(fit.law == 2)[0])
    m = np.array([exp, exp, exp])
    # starts above 0.4; starts below it though its offset a is above (the edge case); below
    a, b = np.array([0.45, 0.45, 0.30]), np.array([-0.01, -0.2, -0.01])
    start = a + b * np.exp(-fit.rate[exp] * fit.span[exp])
    assert start[0] >= 0.4 > start[1] and start[2] < 0.4
    assert list(fit.crossing_cycles(0.4, m, a, b)) == [-np.inf, np.inf, np.inf]


def test_default_memory_scales_with_the_lives_typical_span():
    from ema_phm.prognostics import rul

    g = trend.GrowthPrior((0.01, 0.3), (0.1, 0.3))
    assert rul._memory(None, g, threshold=0.4) == pytest.approx(rul.MEMORY_SHARE * 40.0)
    assert rul._memory(None, None, threshold=0.4) == math.inf  # no prior: every one alike
    assert rul._memory(7.0, g, threshold=0.4) == 7.0  # the caller's own


def test_memory_discounts_an_old_estimate_even_where_the_floor_binds():
    # stated sd below the floor: before the fix the floor swallowed the discount
    c = np.arange(12.0)
    y = np.r_[np.full(6, 0.3), np.zeros(6)]  # old estimates high, recent ones 0
    sigma = np.full(12, 0.001)
    full = trend.fit_trend(c, y, sigma, floor=0.01)
    short = trend.fit_trend(c, y, sigma, floor=0.01, memory=1.0)
    # a constant fitted to the history: the old 0.3s pull it up unless they are discounted
    level = {
        k: float(np.sum(np.exp(f.log_w)[f.law == 0] * f.mean[f.law == 0][..., 0]))
        / max(float(np.exp(f.log_w)[f.law == 0].sum()), 1e-300)
        for k, f in (("full", full), ("short", short))
    }
    assert level["short"] < 0.5 * level["full"]


def test_a_fault_growing_much_faster_than_the_fleet_is_still_followed():
    # the fleet's friction grows 0.0114 / cycle; this unit's 0.04 (3.5x, +5 log sd)
    fast = Degradation(faults=(FaultGrowth("friction", "linear", 0, 0.0, 0.04),))  # EoL 10
    for seed in range(3):
        f = prognose(history(fast, 7, seed=seed)).fault("friction")  # true RUL 3
        assert f.status == "degrading" and f.rul_cycles.p5 < 10 and 1 <= f.rul_cycles.p50 <= 5


def test_growth_priors_load_from_a_file_and_reach_the_live_tracker(tmp_path):
    from ema_phm.monitor.tracker import PrognosticTracker
    from ema_phm.prognostics.learn import load_growth_priors

    good = tmp_path / "priors.yaml"
    good.write_text("friction: {linear: [0.02, 0.3], exponential: [0.1, 0.4]}\n")
    assert load_growth_priors("") is None and load_growth_priors("none") == {}
    assert load_growth_priors(good)["friction"]["linear"] == [0.02, 0.3]
    bad = tmp_path / "bad.yaml"
    bad.write_text("friction: {linear: [-1, 0.3], exponential: [0.1, 0.4]}\n")
    with pytest.raises(ConfigError, match=r"bad\.yaml: friction: growth prior of the linear law"):
        load_growth_priors(bad)
    with pytest.raises(ConfigError, match="cannot read growth priors"):
        load_growth_priors(tmp_path / "missing.yaml")
    values = {
        "prognostics": True,
        "failure_thresholds": [0.4] * 6 + [0.0, 0.25],
        "cycle_hours": 1.0,
        "rul_horizon_cycles": 10,
        "rul_alarm_windows": 2,
        "growth_priors_file": str(good),
    }
    tracker = PrognosticTracker.from_values(values)
    assert tracker.policy.predictor.growth_priors["friction"]["linear"] == [0.02, 0.3]
    assert tracker.fresh().growth_priors == tracker.growth_priors  # kept after maintenance
    none = PrognosticTracker.from_values({**values, "growth_priors_file": "none"})
    assert none.policy.predictor.growth_priors == {}


def _walked_lives(n: int, sd: float) -> list:
    """Friction lives (noise 0.01) whose per-cycle rate takes a log random walk of `sd`."""
    out = []
    for seed in range(n):
        rng = np.random.default_rng(100 + seed)
        rates = np.exp(np.cumsum(rng.normal(0.0, sd, 34)))
        sev = np.concatenate([[0.0], np.cumsum(rates)])
        sev *= 0.4 / sev[-1]
        k = np.tile(NOMINAL, (sev.size, 1))
        k[:, 0] = np.clip(k[:, 0] + sev + rng.normal(0.0, 0.01, sev.size), 0.0, 1.0)
        half = 1.645 * 0.01
        h = History.from_estimates(
            np.arange(sev.size), k, np.clip(k - half, 0, 1), np.clip(k + half, 0, 1)
        )
        out.append(("friction", h, 0))
    return out


def test_learning_reads_how_much_the_lives_rates_moved():
    steady = learn_growth_priors(_walked_lives(4, 0.0))["friction"]["diffusion"]
    walked = learn_growth_priors(_walked_lives(4, 0.3))["friction"]["diffusion"]
    assert len(steady) == len(walked) == 6 and sum(walked) == pytest.approx(1.0)
    assert walked[0] < steady[0]  # the walking fleet puts less on a constant rate
    assert min(steady) >= 0.02 * 0.99 and min(walked) >= 0.02 * 0.99  # none ruled out
    prior = growth_priors(learn_growth_priors(_walked_lives(4, 0.3)))["friction"]
    assert prior.diffusion == pytest.approx(tuple(walked))  # prognose takes it


def test_a_learned_rate_prior_is_always_one_prognose_takes():
    # lives whose rates read under a law span six decades: the log sd is capped, not refused
    median, sd = _log_normal(np.array([1e-6, 1.0, 1e-6, 1.0]), np.zeros(4, dtype=bool))
    assert sd == MAX_LOG_SD
    trend.GrowthPrior((0.01, sd), (median, sd))  # accepted


def test_a_diffusion_prior_is_checked_and_read_from_a_file(tmp_path):
    with pytest.raises(ConfigError, match="diffusion prior must be 6 weights"):
        trend.GrowthPrior((0.01, 0.3), (0.1, 0.5), diffusion=(1.0, 2.0))
    f = tmp_path / "priors.yaml"
    f.write_text(
        "friction: {linear: [0.01, 0.3], exponential: [0.1, 0.5], diffusion: [1, 1, 1, 1, 0, 0]}\n"
    )
    g = growth_priors(load_growth_priors(str(f)))["friction"]
    assert g.diffusion == pytest.approx((0.25, 0.25, 0.25, 0.25, 0.0, 0.0))
    f.write_text("friction: {linear: [0.01, 0.3], exponential: [0.1, 0.5], diffusion: [1, -1]}\n")
    with pytest.raises(ConfigError, match="priors.yaml: friction: a diffusion prior"):
        load_growth_priors(str(f))
