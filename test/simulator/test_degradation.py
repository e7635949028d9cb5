"""Faults that grow: laws, onset, cap, validation, YAML files (simulator/degradation.py)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from ema_phm.domain.faults import N_K, NOMINAL, fault
from ema_phm.errors import ConfigError, FaultVectorError
from ema_phm.simulator.degradation import Degradation, FaultGrowth

FRICTION, BACKLASH = fault("friction").index, fault("backlash").index
SHORT_B, GAIN = fault("short_circuit_b").index, fault("gain_drift").index

CONFIG = Path(__file__).resolve().parents[2] / "config"


def test_linear_exponential_and_step_laws_with_onset():
    d = Degradation(
        faults=(
            FaultGrowth("friction", "linear", 3, 0.1, 0.05, cap=True),
            FaultGrowth("short_circuit_b", "exponential", 2, 0.02, 0.5, cap=True),
            FaultGrowth("gain_drift", "step", 4, 0.8),
        )
    )
    assert np.array_equal(d.k(0), NOMINAL)
    assert d.k(3)[FRICTION] == pytest.approx(0.1)
    assert d.k(5)[FRICTION] == pytest.approx(0.2)
    assert d.k(1)[SHORT_B] == 0.0
    assert d.k(4)[SHORT_B] == pytest.approx(0.02 * math.exp(1.0))
    assert d.k(3)[GAIN] == 0.5 and d.k(4)[GAIN] == 0.8 and d.k(100)[GAIN] == 0.8
    # deterministic: the same cycle gives the same k
    assert np.array_equal(d.k(7), d.k(7))
    traj = d.trajectory([0, 3, 5])
    assert traj.shape == (3, N_K) and traj[2, FRICTION] == pytest.approx(0.2)


def test_cap_clamps_at_one_and_uncapped_growth_past_one_names_fault_cycle_value():
    capped = Degradation(faults=(FaultGrowth("backlash", "linear", 0, 0.5, 0.1, cap=True),))
    assert capped.k(10)[BACKLASH] == 1.0
    free = Degradation(faults=(FaultGrowth("backlash", "linear", 0, 0.5, 0.1),))
    assert free.k(5)[BACKLASH] == pytest.approx(1.0)
    with pytest.raises(FaultVectorError, match=r"backlash .*k2 = 1\.1 at cycle 6"):
        free.k(6)
    with pytest.raises(FaultVectorError, match="cycle 6"):
        free.check_cycles(10)
    assert free.check_cycles(6).shape == (6, N_K)


@pytest.mark.parametrize(
    ("spec", "match"),
    [
        ({"law": "linear", "onset": 0, "initial": 0.0, "rate": 0.1}, None),
        ({"law": "cubic", "onset": 0, "initial": 0.0}, r"law must be one of .*'cubic'"),
        ({"law": "linear", "onset": -1, "initial": 0.0, "rate": 0.1}, r"onset .* got -1"),
        ({"law": "linear", "onset": 1.5, "initial": 0.0, "rate": 0.1}, r"onset .* got 1\.5"),
        ({"law": "linear", "onset": 0, "initial": 1.2, "rate": 0.1}, r"initial .* got 1\.2"),
        ({"law": "linear", "onset": 0, "initial": 0.0, "rate": -0.1}, r"rate .* got -0\.1"),
        ({"law": "linear", "onset": 0, "initial": 0.0, "rate": "fast"}, r"rate must be a number"),
        ({"law": "linear", "onset": 0, "initial": 0.0}, r"has no 'rate'"),
        ({"law": "exponential", "onset": 0, "initial": 0.0, "rate": 0.1}, r"initial > 0"),
        ({"law": "step", "onset": 0, "initial": 0.3, "rate": 0.1}, r"step has no rate"),
        ({"law": "linear", "onset": 0, "initial": 0.0, "rate": 0.1, "cap": "yes"}, r"cap"),
        ({"law": "linear", "onset": 0, "initial": 0.0, "rate": 0.1, "speed": 1}, r"speed"),
        ({"onset": 0, "initial": 0.0}, r"has no 'law'"),
    ],
)
def test_fault_entry_validation_names_key_and_value(spec, match):
    data = {"faults": {"friction": spec}}
    if match is None:
        Degradation.from_mapping(data)
        return
    with pytest.raises(ConfigError, match=match):
        Degradation.from_mapping(data)


def test_gain_and_phase_may_only_step_and_unknown_names_are_refused():
    with pytest.raises(ConfigError, match=r"gain_drift.*'step'.*sec\. 4\.6.*'linear'"):
        FaultGrowth("gain_drift", "linear", 0, 0.5, 0.01)
    with pytest.raises(ConfigError, match=r"eccentricity_phase.*'step'"):
        FaultGrowth("eccentricity_phase", "exponential", 0, 0.5, 0.01)
    with pytest.raises(ConfigError, match=r"unknown fault 'wear'"):
        Degradation.from_mapping({"faults": {"wear": {"law": "step", "onset": 0, "initial": 1}}})
    with pytest.raises(ConfigError, match=r"unknown key\(s\) cycles"):
        Degradation.from_mapping({"cycles": 3})
    with pytest.raises(ConfigError, match=r"cycle_hours must be .* got -1"):
        Degradation.from_mapping({"cycle_hours": -1})


def test_yaml_duplicate_key_and_missing_file_are_refused(tmp_path):
    f = tmp_path / "d.yaml"
    f.write_text(
        "faults:\n  friction: {law: step, onset: 0, initial: 0.1}\n"
        "  friction: {law: step, onset: 0, initial: 0.2}\n"
    )
    with pytest.raises(ConfigError, match=r"not valid YAML.*'friction' appears twice"):
        Degradation.load(f)
    with pytest.raises(ConfigError, match="not found"):
        Degradation.load(tmp_path / "missing.yaml")


def test_first_cycle_at_threshold_matches_the_cycle_by_cycle_values():
    for law, initial, rate in (("linear", 0.0, 0.015), ("exponential", 0.02, 0.1)):
        d = Degradation(faults=(FaultGrowth("friction", law, 5, initial, rate, cap=True),))
        c = d.first_cycle_at("friction", 0.4)
        assert c is not None and d.k(c)[0] >= 0.4 > d.k(c - 1)[0]
    healthy = Degradation()
    assert healthy.first_cycle_at("friction", 0.4) is None


@pytest.mark.parametrize("path", sorted(CONFIG.glob("degradation_*.yaml")), ids=lambda p: p.name)
def test_packaged_degradation_files_load_and_stay_in_range_for_60_cycles(path):
    d = Degradation.load(path)
    assert d.cycle_hours == 2.0
    assert d.check_cycles(60).shape == (60, N_K)


def test_packaged_scenarios_reach_the_thresholds_their_comments_state():
    expected = {
        "friction": {"friction": 32},
        "backlash": {"backlash": 42},
        "short_circuit": {"short_circuit_a": 35},
        "eccentricity": {"eccentricity": 35},
        "multi_fault": {"friction": 45, "eccentricity": 38},
        "healthy": {},
    }
    for scenario, events in expected.items():
        d = Degradation.load(CONFIG / f"degradation_{scenario}.yaml")
        got = {
            f.name: d.first_cycle_at(f.name, 0.4)
            for f in d.faults
            if f.name != "eccentricity_phase"
        }
        assert got == events, scenario


def test_exponent_numbers_without_a_dot_are_numbers_and_words_are_refused(tmp_path):
    # PyYAML (YAML 1.1) reads `1e-3` as the string "1e-3": it was refused as "not a number"
    path = tmp_path / "deg.yaml"
    path.write_text(
        "cycle_hours: 2e0\n"
        "faults:\n"
        "  friction: {law: linear, onset: 0, initial: 0.0, rate: 1e-3}\n"
        "  backlash: {law: exponential, onset: 2, initial: 1E-2, rate: .5e-1}\n"
    )
    deg = Degradation.load(path)
    rates = {f.name: (f.initial, f.rate) for f in deg.faults}
    assert rates == {"friction": (0.0, 1e-3), "backlash": (1e-2, 0.05)}
    assert deg.cycle_hours == 2.0
    path.write_text("faults:\n  friction: {law: linear, onset: 0, initial: 0.0, rate: abc}\n")
    with pytest.raises(ConfigError, match=r"'friction': linear rate must be .*, got 'abc'"):
        Degradation.load(path)
