"""RUL per fault from a history of k estimates (ema_phm/prognostics/rul.py, trend.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ema_phm.domain.faults import N_K, NOMINAL
from ema_phm.errors import ConfigError
from ema_phm.prognostics import rul
from ema_phm.prognostics.rul import History, prognose
from ema_phm.simulator.degradation import Degradation, FaultGrowth

NOISE = 0.02  # sd of the synthetic estimates; their 90 % intervals are +/- 1.645 sd


def noisy_history(
    deg: Degradation, last: int, *, seed: int, intervals: bool = True, noise: float = NOISE
) -> History:
    """Estimates of cycles 0..last: the true k plus Gaussian noise on k1..k6, clipped."""
    rng = np.random.default_rng(seed)
    cycles = np.arange(last + 1)
    k = deg.trajectory(cycles)
    k[:, :6] = np.clip(k[:, :6] + rng.normal(0.0, noise, (cycles.size, 6)), 0.0, 1.0)
    if not intervals:
        return History.from_estimates(cycles, k)
    half = 1.645 * noise
    return History.from_estimates(cycles, k, np.clip(k - half, 0, 1), np.clip(k + half, 0, 1))


def test_linear_growth_rul_recovered_within_tolerance():
    deg = Degradation(faults=(FaultGrowth("friction", "linear", 5, 0.0, 0.015),))
    eol = deg.first_cycle_at("friction", 0.4)
    assert eol == 32
    hits = 0
    for seed in range(5):
        now = 24
        p = prognose(noisy_history(deg, now, seed=seed), seed=seed, cycle_hours=2.0)
        f = p.fault("friction")
        assert f.status == "degrading", f.message
        true = eol - now
        assert abs(f.rul_cycles.p50 - true) <= 0.25 * true, f.message
        assert f.rul_hours.p50 == pytest.approx(2.0 * f.rul_cycles.p50)
        hits += f.rul_cycles.p5 <= true <= f.rul_cycles.p95
        assert f.law_probabilities["linear"] > f.law_probabilities["exponential"]
        # nothing else degrades
        others = [g for g in p.faults if g.name != "friction" and g.status == "degrading"]
        assert others == []
    assert hits >= 4


def test_exponential_growth_rul_recovered_within_tolerance():
    deg = Degradation(faults=(FaultGrowth("short_circuit_b", "exponential", 5, 0.02, 0.1),))
    eol = deg.first_cycle_at("short_circuit_b", 0.4)
    assert eol == 35
    for seed in range(3):
        now = 30
        p = prognose(noisy_history(deg, now, seed=seed), seed=seed)
        f = p.fault("short_circuit_b")
        assert f.status == "degrading", f.message
        true = eol - now
        assert f.rul_cycles.p5 <= true <= f.rul_cycles.p95, f.message
        assert abs(f.rul_cycles.p50 - true) <= 2, f.message
        assert f.law == "exponential"


def test_flat_history_is_no_degradation_and_has_no_rul():
    for seed in range(5):
        p = prognose(noisy_history(Degradation(), 30, seed=seed), seed=seed)
        for f in p.faults[:6]:
            assert f.status == "no_degradation", f.message
            assert f.rul_cycles is None and math.isnan(f.p_within_horizon)
            assert f.message.startswith("no degradation detected")
        assert p.degrading == ()


def test_one_misnamed_window_is_not_a_trend():
    # an isolation that once puts 0.35 on the wrong fault near the end of a flat history
    messages = []
    for seed in range(10):
        rng = np.random.default_rng(seed)
        k = np.tile(NOMINAL, (25, 1))
        k[:, :6] = np.clip(0.05 + rng.normal(0.0, 0.03, (25, 6)), 0.0, 1.0)
        k[24, 1] = 0.35  # the latest window
        f = prognose(History.from_estimates(np.arange(25), k), seed=seed).fault("backlash")
        assert f.status == "no_degradation", f.message
        messages.append(f.message)
    # the spike alone makes a trend in some of them: the leave-one-out check catches those
    assert any("rests on the estimate at cycle 24 alone" in m for m in messages)


def test_gain_fault_gets_no_rul_even_when_it_drifts():
    cycles = np.arange(20)
    k = np.tile(NOMINAL, (20, 1))
    k[:, 7] = np.linspace(0.5, 1.0, 20)  # a steady drift far past its ERROR threshold
    p = prognose(History.from_estimates(cycles, k))
    gain = p.fault("gain_drift")
    assert gain.status == "not_applicable" and gain.rul_cycles is None
    assert "sec. 4.6" in gain.message
    assert p.fault("eccentricity_phase").status == "not_applicable"


def test_probability_within_horizon_and_samples_agree_and_seed_is_deterministic():
    deg = Degradation(faults=(FaultGrowth("backlash", "linear", 0, 0.0, 0.02),))
    h = noisy_history(deg, 15, seed=3)
    a = prognose(h, seed=7, horizon_cycles=5).fault("backlash")
    b = prognose(h, seed=7, horizon_cycles=5).fault("backlash")
    c = prognose(h, seed=8, horizon_cycles=5).fault("backlash")
    assert a.status == "degrading"
    assert np.array_equal(a.samples, b.samples)
    assert not np.array_equal(a.samples, c.samples)
    assert a.p_within_horizon == pytest.approx(np.mean(a.samples <= 5))
    assert 0.0 <= a.p_within_horizon <= 1.0
    assert a.rul_cycles.p5 <= a.rul_cycles.p50 <= a.rul_cycles.p95


def test_threshold_already_reached_gives_zero_rul():
    deg = Degradation(faults=(FaultGrowth("friction", "linear", 0, 0.1, 0.03),))
    f = prognose(noisy_history(deg, 20, seed=1)).fault("friction")  # k1 ~ 0.7 by now
    assert f.status == "degrading" and f.rul_cycles.p50 == 0.0


def test_custom_threshold_moves_the_rul():
    deg = Degradation(faults=(FaultGrowth("friction", "linear", 0, 0.0, 0.02),))
    h = noisy_history(deg, 15, seed=2)
    low = prognose(h).fault("friction").rul_cycles.p50
    th = (0.6, 0.4, 0.4, 0.4, 0.4, 0.4, 0.0, 0.25)
    high = prognose(h, thresholds=th).fault("friction").rul_cycles.p50
    assert high == pytest.approx(low + 10, abs=3)  # 0.2 more severity at 0.02 per cycle


def test_without_intervals_the_noise_is_learned_and_flagged():
    deg = Degradation(faults=(FaultGrowth("friction", "linear", 5, 0.0, 0.015),))
    p = prognose(noisy_history(deg, 26, seed=0, intervals=False))
    assert p.intervals_known is False and p.as_dict()["intervals_known"] is False
    f = p.fault("friction")
    assert f.status == "degrading"
    assert f.rul_cycles.p5 <= 32 - 26 <= f.rul_cycles.p95


def test_too_few_points_is_insufficient_data():
    p = prognose(History.from_estimates([0, 1, 2], np.tile(NOMINAL, (3, 1))))
    assert {f.status for f in p.faults[:6]} == {"insufficient_data"}


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"cycles": [0, 2, 1]}, r"cycle 1 follows 2"),
        ({"k": np.full((3, N_K), 1.5)}, r"k1 = 1\.5 is outside \[0, 1\]"),
        ({"k": np.zeros((3, N_K - 1))}, rf"shape \(3, {N_K}\)"),
        ({"k_low": np.full((3, N_K), 0.1)}, "give both k_low and k_high"),
        (
            {"k_low": np.full((3, N_K), 0.6), "k_high": np.ones((3, N_K))},
            "not inside its interval",
        ),
    ],
)
def test_bad_history_names_the_problem(kwargs, match):
    args = {"cycles": [0, 1, 2], "k": np.tile(NOMINAL, (3, 1))}
    args.update(kwargs)
    with pytest.raises(ConfigError, match=match):
        History.from_estimates(**args)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"thresholds": [0.4] * (N_K - 1)}, f"{N_K} entries"),
        ({"thresholds": [0.0] * N_K}, r"k1 \(friction\) must be in \(0, 1\]"),
        ({"cycle_hours": -1.0}, "cycle_hours must be a number > 0, got -1"),
        ({"horizon_cycles": math.inf}, "horizon_cycles"),
        ({"seed": -3}, "seed"),
        ({"p_detect": 1.0}, "p_detect"),
    ],
)
def test_bad_options_name_the_problem(kwargs, match):
    h = History.from_estimates(np.arange(6), np.tile(NOMINAL, (6, 1)))
    with pytest.raises(ConfigError, match=match):
        prognose(h, **kwargs)


def _ambiguous_history(seed: int = 3) -> History:
    deg = Degradation(faults=(FaultGrowth("short_circuit_a", "exponential", 5, 0.03, 0.08),))
    return noisy_history(deg, 20, seed=seed)


def test_law_prior_from_physics_and_override():
    h = _ambiguous_history()
    neutral = {"short_circuit_a": {"none": 0.5, "linear": 0.25, "exponential": 0.25}}
    # without growth priors (with one, the split its lives showed replaces the physics one)
    f_phys = prognose(h, growth_priors={}).fault("short_circuit_a")
    f_neutral = prognose(h, law_priors=neutral, growth_priors={}).fault("short_circuit_a")
    assert (
        rul.law_prior("short_circuit_a")["exponential"] > rul.law_prior("friction")["exponential"]
    )
    # the accelerating prior moves probability from linear to exponential, not to none
    assert f_phys.law_probabilities["exponential"] > f_neutral.law_probabilities["exponential"]
    assert f_phys.p_trend == pytest.approx(f_neutral.p_trend, abs=0.05)


@pytest.mark.parametrize(
    "prior, match",
    [
        ({"none": 0.5, "linear": 0.5}, "probability to each"),
        ({"none": 0.5, "linear": 0.5, "exponential": 0.5}, "summing to 1"),
        ({"none": 1.0, "linear": 0.0, "exponential": 0.0}, "positive"),
    ],
)
def test_bad_law_prior_names_the_fault(prior, match):
    with pytest.raises(ConfigError, match=f"friction.*{match}|{match}.*friction"):
        prognose(_ambiguous_history(), law_priors={"friction": prior})


def test_severity_scale_moves_and_widens_the_rul():
    deg = Degradation(faults=(FaultGrowth("friction", "linear", 5, 0.0, 0.015),))
    h = noisy_history(deg, 20, seed=1)
    exact = prognose(h, severity_scale={"friction": (0.0, 0.0)}).fault("friction")
    low = prognose(h, severity_scale={"friction": (-0.1, 0.0)}).fault("friction")
    wide = prognose(h, severity_scale={"friction": (0.0, 0.1)}).fault("friction")
    # estimates 10 % low reach the threshold as they show it (0.36) sooner
    assert low.rul_cycles.p50 < exact.rul_cycles.p50
    assert (wide.rul_cycles.p95 - wide.rul_cycles.p5) > (
        exact.rul_cycles.p95 - exact.rul_cycles.p5
    )
    with pytest.raises(ConfigError, match="severity scale of friction"):
        prognose(h, severity_scale={"friction": (0.0, -0.1)})


def test_detection_level_holds_back_a_trend_still_below_it():
    deg = Degradation(faults=(FaultGrowth("friction", "linear", 5, 0.0, 0.015),))
    h = noisy_history(deg, 16, seed=2)  # true severity 0.165 now
    assert prognose(h).fault("friction").status == "degrading"
    held = prognose(h, detection_level=0.3).fault("friction")
    assert held.status == "no_degradation"
    assert "0.3" in held.message
    with pytest.raises(ConfigError, match="detection_level"):
        prognose(h, detection_level=1.5)


def test_crossing_with_one_threshold_per_sample_equals_one_at_a_time():
    from ema_phm.prognostics.trend import fit_trend

    deg = Degradation(faults=(FaultGrowth("friction", "linear", 5, 0.0, 0.015),))
    h = noisy_history(deg, 20, seed=4)
    sev, sd = h.severity(0)
    fit = fit_trend(h.cycles, sev, np.maximum(sd, 0.01), floor=0.01)
    m, a, b = fit.sample(64, np.random.default_rng(0))
    th = np.linspace(0.2, 0.6, 64)
    together = fit.crossing_cycles(th, m, a, b)
    alone = [
        fit.crossing_cycles(th[j], m[j : j + 1], a[j : j + 1], b[j : j + 1])[0] for j in range(64)
    ]
    np.testing.assert_allclose(together, alone)
