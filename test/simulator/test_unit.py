"""Unit: parse, draw and apply a manufactured actuator; temperature moves R and ke."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from ema_phm.errors import ConfigError
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.physics.tolerances import SCALED_BY_NAME, UNIT_KEYS, Tolerances, scaled_quantities
from ema_phm.simulator.sensors import SensorSpec
from ema_phm.simulator.unit import Unit

BASE = ActuatorParameters.default()


def test_every_key_of_the_issue_exists():
    assert set(UNIT_KEYS) == {
        "inertia",
        "torque_constant",
        "resistance",
        "inductance",
        "friction",
        "damping",
        "stiffness",
        "current_gain",
        "current_offset",
        "position_offset",
        "speed_gain",
        "mesh_damping",
    }
    assert UNIT_KEYS[-1] == "mesh_damping"  # drawn last: the other keys' draws did not move


@pytest.mark.parametrize("key", list(SCALED_BY_NAME))
def test_every_factor_scales_at_least_one_actuator_quantity(key):
    names = scaled_quantities(key)
    assert names, key
    for name in names:
        BASE.value(name)  # exists in the actuator's own sections
    assert "controller.torque_gain" not in names  # what the controller believes is not scaled


def test_the_table_of_the_docstring_today():
    assert scaled_quantities("inertia") == ("mechanics.j_motor", "mechanics.j_user")
    assert set(scaled_quantities("torque_constant")) == {
        "motor.ke_phase_peak",
        "motor.torque_constant",
    }
    assert scaled_quantities("resistance") == ("motor.r_phase_to_phase",)
    assert "high_fidelity.torsional_stiffness" in scaled_quantities("stiffness")


def test_parse_key_values_and_round_trip():
    u = Unit.parse(" inertia=1.1, torque_constant = 0.97,current_offset=-0.05 ")
    assert (u.inertia, u.torque_constant, u.current_offset, u.resistance) == (
        1.1,
        0.97,
        -0.05,
        1.0,
    )
    assert Unit.parse(u.spec()) == u
    drawn = Unit.draw(11)
    assert Unit.parse(drawn.spec()) == drawn


def test_parse_a_yaml_file(tmp_path: Path):
    f = tmp_path / "unit.yaml"
    f.write_text("resistance: 1.25\nposition_offset: 5.0e-4\n")
    u = Unit.parse(str(f))
    assert u == Unit(resistance=1.25, position_offset=5e-4)


@pytest.mark.parametrize(
    "spec, words",
    [
        ("inertia=1.1,mass=2", ["mass", "unknown"]),
        ("inertia=0", ["unit inertia", "0.25", "got 0.0"]),
        ("inertia=-1", ["unit inertia", "got -1.0"]),
        ("resistance=nan", ["unit spec: resistance", "finite", "'nan'"]),
        ("friction=inf", ["unit spec: friction", "finite", "'inf'"]),
        ("friction=10", ["unit friction", "got 10.0"]),
        ("current_gain=3", ["unit current_gain", "got 3.0"]),
        ("position_offset=1", ["unit position_offset", "rad"]),
        ("inertia=abc", ["inertia", "'abc'"]),
        ("inertia", ["neither", "inertia"]),
        ("inertia=1,inertia=2", ["inertia", "twice"]),
        ("inertia=", ["'inertia='", "KEY=VALUE"]),
        ("", ["empty"]),
    ],
)
def test_bad_specs_are_named(spec, words):
    with pytest.raises(ConfigError) as err:
        Unit.parse(spec)
    assert all(w in str(err.value) for w in words), str(err.value)


def test_bad_yaml_file_keys_are_named(tmp_path: Path):
    f = tmp_path / "u.yaml"
    f.write_text("inertia: 1.0\nstiffnes: 1.1\n")
    with pytest.raises(ConfigError, match=r"unknown key\(s\) stiffnes"):
        Unit.parse(str(f))
    f.write_text("- 1\n- 2\n")
    with pytest.raises(ConfigError, match="mapping"):
        Unit.parse(str(f))


def test_a_drawn_unit_is_reproducible_from_its_seed_and_inside_its_bands():
    tol = Tolerances.load()
    units = [Unit.draw(s) for s in range(200)]
    assert Unit.draw(7) == Unit.draw(7) and Unit.draw(7) != Unit.draw(8)
    for key in UNIT_KEYS:
        vals = np.array([getattr(u, key) for u in units])
        centre = 0.0 if key.endswith("offset") else 1.0
        assert np.all(np.abs(vals - centre) <= tol.bands[key] + 1e-12), key
        # a band is 3 sigma: 200 draws spread with a std near band / 3
        assert 0.7 < np.std(vals) / (tol.bands[key] / 3.0) < 1.3, key


def test_draw_refuses_a_bad_seed():
    with pytest.raises(ConfigError, match="unit seed"):
        Unit.draw(-1)


def test_every_tolerance_has_its_reason_in_the_config():
    text = (Path(__file__).parents[2] / "config" / "unit_tolerances.yaml").read_text()
    lines = text.splitlines()
    for key in UNIT_KEYS:
        i = next(n for n, line in enumerate(lines) if line.strip().startswith(f"{key}:"))
        assert lines[i - 1].strip().startswith("#"), key


def test_actuator_scales_every_named_quantity_and_nothing_else():
    u = Unit(inertia=1.1, torque_constant=0.97, friction=1.3, damping=0.8, stiffness=0.9)
    a = u.actuator(BASE)
    scaled = {}
    for key in SCALED_BY_NAME:
        for name in scaled_quantities(key):
            scaled[name] = getattr(u, key)
    for sec, vals in BASE.as_dict().items():
        for k, v in vals.items():
            name = f"{sec}.{k}"
            assert a.value(name) == pytest.approx(v * scaled.get(name, 1.0), rel=1e-12), name
    assert Unit().actuator(BASE).as_dict() == BASE.as_dict()


def test_temperature_moves_r_and_ke_by_the_stated_coefficients():
    thermal = Tolerances.load().thermal
    assert thermal.copper_resistance_coefficient == pytest.approx(0.00393)
    assert thermal.magnet_backemf_coefficient == pytest.approx(-0.0012)
    u = Unit(resistance=1.1, torque_constant=0.95)
    t = thermal.reference_temperature_c + 80.0
    hot, ref = u.actuator(BASE, temperature_c=t), u.actuator(BASE)
    r = "motor.r_phase_to_phase"
    assert hot.value(r) / ref.value(r) == pytest.approx(1.0 + 0.00393 * 80.0, rel=1e-12)
    for ke in scaled_quantities("torque_constant"):
        assert hot.value(ke) / ref.value(ke) == pytest.approx(1.0 - 0.0012 * 80.0, rel=1e-12)
    for name in ("motor.l_phase_to_phase", "mechanics.j_motor"):
        assert hot.value(name) == ref.value(name)
    at_ref = u.actuator(BASE, temperature_c=thermal.reference_temperature_c)
    assert at_ref.as_dict() == ref.as_dict()
    with pytest.raises(ConfigError, match="temperature"):
        u.actuator(BASE, temperature_c=500.0)
    with pytest.raises(ConfigError, match="temperature"):
        u.actuator(BASE, temperature_c=math.nan)


def test_sensors_carry_the_unit_errors_and_the_noises():
    u = Unit(current_gain=1.02, current_offset=0.1, position_offset=5e-4, speed_gain=0.99)
    s = u.sensors(noise_current=0.05, noise_position=1e-4, noise_speed=0.3)
    assert s == SensorSpec(
        current_gain=1.02,
        current_offset=0.1,
        position_offset=5e-4,
        speed_gain=0.99,
        noise_current=0.05,
        noise_position=1e-4,
        noise_speed=0.3,
    )


def test_a_tolerance_file_with_a_bad_band_is_named(tmp_path: Path):
    src = (Path(__file__).parents[2] / "config" / "unit_tolerances.yaml").read_text()
    f = tmp_path / "tol.yaml"
    f.write_text(src.replace("inertia: 0.05", "inertia: 2.0"))
    with pytest.raises(ConfigError, match=r"tolerances.inertia"):
        Tolerances.load(f)
    f.write_text(src.replace("speed_gain: 0.01", "speed_gain: 0.01\n  mass: 0.1"))
    with pytest.raises(ConfigError, match=r"unknown key\(s\) mass"):
        Tolerances.load(f)
