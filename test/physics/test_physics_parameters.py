"""Parameter files (ema_phm.physics.parameters): two immutable objects, read only where asked."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from helpers import k_with

from ema_phm.diagnosis.fitness import Fitness
from ema_phm.errors import ConfigError
from ema_phm.model import monitor_model as mm
from ema_phm.model.belief import MonitorBelief
from ema_phm.physics.actuator import OPTIONAL
from ema_phm.physics.commands import CommandSpec
from ema_phm.physics.parameters import (
    QUANTITIES,
    ActuatorParameters,
    packaged_config_dir,
    read_yaml,
)
from ema_phm.simulator import real_ema as hf

SHORT = CommandSpec(duration=0.5)


def test_defaults_are_the_packaged_files_with_the_packaged_calibration():
    folder = packaged_config_dir()
    raw, cal = read_yaml(folder / "ema.yaml"), read_yaml(folder / "calibration.yaml")
    actuator, belief = ActuatorParameters.default(), MonitorBelief.default()
    assert actuator["mechanics"]["j_motor"] == raw["mechanics"]["j_motor"]
    assert "monitor" not in actuator.sections and "high_fidelity" not in belief.sections
    assert belief.value("monitor.ke") == cal["monitor"]["ke"] != raw["monitor"]["ke"]
    assert belief.value("monitor.gt") == cal["monitor"]["gt"]
    assert belief.calibration_file == str(folder / "calibration.yaml")
    assert MonitorBelief.packaged_uncalibrated().value("monitor.ke") == raw["monitor"]["ke"]
    assert MonitorBelief.packaged_uncalibrated().calibration_file is None


def test_every_quantity_has_a_unit_and_every_file_entry_is_a_quantity():
    raw = read_yaml(packaged_config_dir() / "ema.yaml")
    in_file = {f"{sec}.{key}" for sec, vals in raw.items() for key in vals}
    # only optional quantities (the current loop the thesis's kind does not read) may be absent
    assert in_file <= set(QUANTITIES) and all(QUANTITIES.values())
    assert set(QUANTITIES) - in_file == {n for n in OPTIONAL if n.startswith("current_loop.")}


def test_objects_are_immutable_and_with_values_returns_a_changed_copy():
    base = ActuatorParameters.default()
    with pytest.raises(TypeError):
        base["mechanics"]["j_motor"] = 1.0  # type: ignore[index]
    heavier = base.with_values({"mechanics.j_motor": 1.43e-5})
    assert heavier.value("mechanics.j_motor") == 1.43e-5
    assert base.value("mechanics.j_motor") == 1.3e-5 and ActuatorParameters.default() == base
    assert heavier != base and heavier.with_values({"mechanics.j_motor": 1.3e-5}) == base


@pytest.mark.parametrize(
    "changes,words",
    [
        ({"mechanics.j_motr": 1.0}, ("mechanics.j_motr",)),
        ({"monitor.ke": 0.1}, ("monitor.ke",)),  # the actuator has no monitor section
        ({"mechanics.j_motor": 0.0}, ("mechanics.j_motor", "> 0", "0")),
        ({"mechanics.j_motor": float("nan")}, ("mechanics.j_motor", "nan")),
        ({"mechanics.j_motor": "heavy"}, ("mechanics.j_motor", "heavy")),
    ],
)
def test_bad_changes_are_named(changes, words):
    with pytest.raises(ConfigError) as err:
        ActuatorParameters.default().with_values(changes)
    for word in words:
        assert word in str(err.value)


def _write(path, data) -> str:
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return str(path)


def test_files_are_checked_and_errors_name_the_file_and_the_quantity(tmp_path):
    raw = read_yaml(packaged_config_dir() / "ema.yaml")
    raw["mechanics"]["j_motr"] = raw["mechanics"].pop("j_motor")
    with pytest.raises(ConfigError, match=r"bad\.yaml.*mechanics\.j_motr"):
        ActuatorParameters.from_file(_write(tmp_path / "bad.yaml", raw))
    del raw["mechanics"]
    with pytest.raises(ConfigError, match=r"section 'mechanics' is missing"):
        MonitorBelief.from_file(_write(tmp_path / "bad.yaml", raw))
    with pytest.raises(ConfigError, match=r"not found: .*absent\.yaml"):
        ActuatorParameters.from_file(tmp_path / "absent.yaml")


def test_a_calibration_file_is_read_only_when_named(tmp_path):
    ema = packaged_config_dir() / "ema.yaml"
    cal = _write(tmp_path / "cal.yaml", {"monitor": {"ke": 0.09, "gt": 0.08}})
    belief = MonitorBelief.from_file(ema, calibration=cal)
    assert (belief.value("monitor.ke"), belief.value("monitor.gt")) == (0.09, 0.08)
    assert belief.calibration_file == cal
    assert MonitorBelief.from_file(ema).value("monitor.ke") == read_yaml(ema)["monitor"]["ke"]
    with pytest.raises(ConfigError, match=r"nogt\.yaml must hold monitor\.ke and monitor\.gt"):
        belief.with_calibration(_write(tmp_path / "nogt.yaml", {"monitor": {"ke": 0.09}}))
    with pytest.raises(ConfigError, match=r"monitor\.gt must be a number > 0, got -1"):
        belief.with_calibration(_write(tmp_path / "neg.yaml", {"monitor": {"ke": 0.09, "gt": -1}}))


@pytest.fixture(scope="module")
def heavier_actuator_window():
    """The HF with 10 % more motor inertia than the monitor believes, with a friction fault."""
    k = k_with(friction=0.4)
    actuator = ActuatorParameters.default()
    j_motor = actuator.value("mechanics.j_motor")
    heavier = actuator.with_values({"mechanics.j_motor": 1.1 * j_motor})
    return k, heavier, hf.simulate(k, actuator=heavier, command=SHORT).window


def test_the_actuator_can_differ_from_the_belief_and_it_shows(heavier_actuator_window):
    k, heavier, window = heavier_actuator_window
    nominal = hf.simulate(k, command=SHORT).window
    assert np.abs(window.i3eq - nominal.i3eq).max() > 0.05  # A: more inertia needs more current
    assert not np.array_equal(window.theta_u, nominal.theta_u)
    assert MonitorBelief.default().value("mechanics.j_motor") == 1.3e-5  # the belief is unchanged


def test_fitness_of_the_true_k_is_worse_under_a_wrong_belief(heavier_actuator_window):
    k, heavier, window = heavier_actuator_window
    default = MonitorBelief.default()
    right = default.with_values({"mechanics.j_motor": heavier.value("mechanics.j_motor")})
    wrong_fit = Fitness(window, belief=default)(k[None])[0]
    right_fit = Fitness(window, belief=right)(k[None])[0]
    # measured 2.16 vs 2.00: against the two-inertia HF (issue 9) the inertia belief is one
    # error among several (twin HF: more than 2x)
    assert wrong_fit > 1.04 * right_fit
    # the belief reaches the monitor model itself
    assert mm.MonitorModel(window, belief=right).belief is right


def test_fitness_takes_a_belief_or_a_model_not_both(heavier_actuator_window):
    _, _, window = heavier_actuator_window
    with pytest.raises(ConfigError, match="not both"):
        Fitness(window, belief=MonitorBelief.default(), model=mm.MonitorModel(window))
