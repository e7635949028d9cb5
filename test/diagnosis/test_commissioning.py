"""Commissioning a unit from healthy windows; unit files round trip; errors name the problem."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from ema_phm.diagnosis.commissioning import FACTORS, commission, write_unit
from ema_phm.errors import ConfigError, WindowError
from ema_phm.physics import real_ema
from ema_phm.physics.commands import LoadSpec
from ema_phm.physics.fault_vector import NOMINAL
from ema_phm.physics.parameters import ActuatorParameters, MonitorBelief
from ema_phm.physics.unit import Unit


@pytest.fixture(scope="module")
def unit_result():
    """A unit 8 % heavier with 25 % less friction, one healthy window with a hidden load."""
    unit = Unit(inertia=1.08, friction=0.75)
    actuator = unit.actuator(ActuatorParameters.default(), temperature_c=20.0)
    w = real_ema.simulate(
        NOMINAL,
        actuator=actuator,
        load=LoadSpec(value=20.0, spring=500.0, measured=False),
        temperature_c=20.0,
        seed=1,
    ).window
    return commission([w])


def test_commissioning_finds_the_unit(unit_result):
    f = unit_result.factors
    assert f["inertia"] == pytest.approx(1.08, abs=0.04)
    assert f["friction"] == pytest.approx(0.75, abs=0.06)
    assert unit_result.identifiable["inertia"] and unit_result.identifiable["friction"]
    assert unit_result.fitness_after[0] < unit_result.fitness_before[0]
    nu = unit_result.nuisances[0]
    assert nu["load_torque"] == pytest.approx(20.0, abs=10.0)
    assert nu["load_stiffness"] == pytest.approx(500.0, abs=400.0)


def test_unit_file_round_trip(unit_result, tmp_path):
    path = write_unit(unit_result, tmp_path / "sub" / "unit.yaml")
    belief = MonitorBelief.default().with_unit(path)
    for fac in FACTORS:
        for q in fac.quantities:
            assert belief.value(q) == pytest.approx(unit_result.values[q], rel=1e-12)
    assert belief.value("monitor.healthy_fitness") == pytest.approx(
        unit_result.values["monitor.healthy_fitness"]
    )
    assert "unit" in belief.source
    doc = yaml.safe_load(path.read_text())
    assert set(doc["commissioning"]["factors"]) == {f.name for f in FACTORS}


def test_commissioning_errors(tmp_path, unit_result):
    with pytest.raises(WindowError, match="at least one"):
        commission([])
    with pytest.raises(ConfigError, match="is a folder"):
        write_unit(unit_result, tmp_path)
    bad = tmp_path / "bad.yaml"
    bad.write_text("commissioning: {}\n")
    with pytest.raises(ConfigError, match="no 'belief' mapping"):
        MonitorBelief.default().with_unit(bad)
    bad.write_text("belief: {mechanics.j_motor: 1.0e-5, motor.nonsense: 2}\n")
    with pytest.raises(ConfigError, match="motor.nonsense"):
        MonitorBelief.default().with_unit(bad)
    bad.write_text("belief: {mechanics.j_motor: -1.0}\n")
    with pytest.raises(ConfigError, match="j_motor"):
        MonitorBelief.default().with_unit(bad)
    with pytest.raises(ConfigError, match="not found|No such"):
        MonitorBelief.default().with_unit(tmp_path / "missing.yaml")


def test_the_commissioned_values_are_the_factors_times_the_belief(unit_result):
    b = MonitorBelief.default()
    j = unit_result.values["mechanics.j_motor"] / b.value("mechanics.j_motor")
    assert j == pytest.approx(unit_result.factors["inertia"])
    assert np.isfinite(list(unit_result.values.values())).all()
