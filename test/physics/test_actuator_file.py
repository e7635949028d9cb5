"""Actuator files (ema_phm.physics.actuator_file) and the typed actuator parts."""

from __future__ import annotations

import dataclasses

import pytest
import yaml

from ema_phm.errors import ConfigError
from ema_phm.physics.actuator import PARTS, Controller
from ema_phm.physics.actuator_file import (
    THESIS_TITLE,
    actuator_text,
    load_actuator,
    packaged_actuator_path,
    write_actuator,
)
from ema_phm.physics.parameters import ActuatorParameters


def _same(a: ActuatorParameters, b: ActuatorParameters) -> None:
    assert a.controller_kind == b.controller_kind
    for section in PARTS:
        pa, pb = getattr(a, section), getattr(b, section)
        for f in dataclasses.fields(pa):
            assert getattr(pa, f.name) == getattr(pb, f.name), f"{section}.{f.name}"


def _packaged_raw() -> dict:
    with open(packaged_actuator_path(), encoding="utf-8") as fh:
        return yaml.safe_load(fh)


def test_packaged_file_is_the_default_actuator_field_by_field():
    _same(load_actuator(None), ActuatorParameters.default())
    assert load_actuator(None).sections == ActuatorParameters.default().sections


def test_packaged_file_is_what_the_writer_writes():
    # the file is generated from config/ema.yaml (actuator_file.write_packaged)
    text = actuator_text(ActuatorParameters.default(), title=THESIS_TITLE)
    assert packaged_actuator_path().read_text(encoding="utf-8") == text


def test_write_then_read_is_equal(tmp_path):
    changed = ActuatorParameters.default().with_values(
        {"mechanics.j_motor": 1.4300000000000001e-5, "controller.speed_ki": 0.1 + 0.2}
    )
    path = write_actuator(changed, tmp_path / "a.yaml")
    back = load_actuator(path)
    _same(back, changed)
    assert back.mechanics.j_motor == 1.4300000000000001e-5
    assert back.source == str(path)


@pytest.mark.parametrize(
    ("section", "key", "value", "needle"),
    [
        ("motor", "r_phase_to_phase_ohm", -1.0, "phase_ohm must be a number > 0, got -1"),
        ("motor", "r_phase_to_phase_ohm", "lots", "'lots'"),
        ("motor", "r_phase_to_phase_ohm", True, "True"),
        ("high_fidelity", "position_resolution_rad", -1e-6, "must be a number >= 0, got -1e-06"),
        ("controller", "kind", "pi_dq", "'pi_dq'"),
        ("controller", "kind", 3, "controller.kind"),
    ],
)
def test_bad_value_names_the_key_and_the_value(tmp_path, section, key, value, needle):
    raw = _packaged_raw()
    raw[section][key] = value
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(raw), encoding="utf-8")
    with pytest.raises(ConfigError, match=r".*") as err:
        load_actuator(path)
    assert needle in str(err.value)
    assert str(path) in str(err.value)


def test_unknown_or_missing_key_is_named(tmp_path):
    raw = _packaged_raw()
    raw["mechanics"]["j_motor"] = raw["mechanics"].pop("j_motor_kg_m2")  # unit left out
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(raw), encoding="utf-8")
    with pytest.raises(ConfigError, match="unknown key in mechanics 'j_motor'"):
        load_actuator(path)
    del raw["mechanics"]["j_motor"]
    path.write_text(yaml.safe_dump(raw), encoding="utf-8")
    with pytest.raises(ConfigError, match="mechanics.j_motor_kg_m2 is missing"):
        load_actuator(path)
    raw["gearbox"] = {}
    path.write_text(yaml.safe_dump(raw), encoding="utf-8")
    with pytest.raises(ConfigError, match="unknown section 'gearbox'"):
        load_actuator(path)


def test_controller_kind_is_validated():
    fields = {f.name: 1.0 for f in dataclasses.fields(Controller) if f.name != "kind"}
    assert Controller(kind="hysteresis_current", **fields).kind == "hysteresis_current"
    with pytest.raises(ConfigError, match="'pi_dq'"):
        Controller(kind="pi_dq", **fields)
    with pytest.raises(ConfigError, match="'pi_dq'"):
        dataclasses.replace(ActuatorParameters.default(), controller_kind="pi_dq")


def test_belief_for_the_packaged_actuator_is_the_default_belief(tmp_path):
    from ema_phm.model.belief import MonitorBelief

    belief = MonitorBelief.for_actuator(load_actuator(None))
    assert belief.sections == MonitorBelief.default().sections
    other = ActuatorParameters.default().with_values({"mechanics.j_motor": 2e-5})
    assert MonitorBelief.for_actuator(other).value("mechanics.j_motor") == 2e-5
    cal = tmp_path / "cal.yaml"
    cal.write_text("monitor: {ke: 0.03, gt: 0.08}\n", encoding="utf-8")
    calibrated = MonitorBelief.for_actuator(other, calibration=cal)
    assert (calibrated.value("monitor.ke"), calibrated.calibration_file) == (0.03, str(cal))


def test_uncalibrated_belief_for_the_packaged_actuator_is_the_packaged_one():
    from ema_phm.model.belief import MonitorBelief

    belief = MonitorBelief.uncalibrated_for(load_actuator(None))
    assert belief.sections == MonitorBelief.packaged_uncalibrated().sections
    assert belief.calibration_file is None


def _without_high_fidelity(tmp_path):
    data = yaml.safe_load(packaged_actuator_path().read_text(encoding="utf-8"))
    del data["high_fidelity"]
    path = tmp_path / "monitor_only.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


def test_a_file_without_high_fidelity_describes_an_actuator_to_monitor(tmp_path):
    """The monitor never reads high_fidelity: a user with a real drive need not write it."""
    from ema_phm.model.belief import belief_for

    path = _without_high_fidelity(tmp_path)
    actuator = load_actuator(path)
    assert not actuator.simulable and load_actuator(None).simulable
    monitored, full = belief_for(path), belief_for(packaged_actuator_path())
    assert monitored.sections == full.sections
    with pytest.raises(ConfigError, match=r"monitor_only.yaml has no high_fidelity section"):
        actuator.high_fidelity  # noqa: B018
    again = load_actuator(write_actuator(actuator, tmp_path / "written.yaml"))
    assert not again.simulable and again.sections == actuator.sections


def test_simulating_without_high_fidelity_is_one_line_naming_it(tmp_path, capsys):
    from helpers import run_cli

    path = _without_high_fidelity(tmp_path)
    code, out, err = run_cli(
        capsys,
        "simulate",
        "--actuator",
        str(path),
        "--k",
        "0,0,0,0,0,0,0.5,0.5",
        "--out",
        str(tmp_path / "bag"),
    )
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1
    assert "has no high_fidelity section: simulating this actuator needs it" in err
    assert not (tmp_path / "bag").exists()


def test_an_unknown_quantity_is_a_range_that_round_trips(tmp_path):
    raw = _packaged_raw()
    raw["controller"]["speed_kp_N_m_s_per_rad"] = {"unknown": [0.02, 0.08]}
    path = tmp_path / "mine.yaml"
    path.write_text(yaml.safe_dump(raw), encoding="utf-8")
    mine = load_actuator(path)
    assert dict(mine.unknowns) == {"controller.speed_kp": (0.02, 0.08)}
    assert mine.controller.speed_kp == pytest.approx(0.04)  # the range's geometric mean
    text = actuator_text(mine)
    assert "speed_kp_N_m_s_per_rad: {unknown: [0.02, 0.08]}" in text
    back = load_actuator(write_actuator(mine, tmp_path / "again.yaml"))
    assert dict(back.unknowns) == dict(mine.unknowns) and back.sections == mine.sections


@pytest.mark.parametrize(
    ("key", "value", "needle"),
    [
        ("speed_kp_N_m_s_per_rad", {"unknown": [0.08, 0.02]}, "needs 0 < low < high"),
        ("speed_kp_N_m_s_per_rad", {"unknown": 0.05}, "needs a range [low, high], got 0.05"),
        ("speed_kp_N_m_s_per_rad", {"unknown": "12"}, "needs a range [low, high], got '12'"),
        ("speed_kp_N_m_s_per_rad", {"unknown": [True, 2]}, "got [True, 2]"),
        ("speed_kp_N_m_s_per_rad", {"unknown": {0.01: 1, 0.1: 2}}, "needs a range [low, high]"),
        ("speed_kp_N_m_s_per_rad", {"unknown": [0.01, 0.02, 0.03]}, "needs a range [low, high]"),
        ("speed_kp_N_m_s_per_rad", {"guess": [0.02, 0.08]}, "a number or {unknown: [low, high]}"),
        ("position_gain_per_s", {"unknown": [1e3, 1e5]}, "controller.position_gain cannot be"),
    ],
)
def test_a_bad_unknown_names_the_key_and_the_value(tmp_path, key, value, needle):
    raw = _packaged_raw()
    raw["controller"][key] = value
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(raw), encoding="utf-8")
    with pytest.raises(ConfigError) as err:
        load_actuator(path)
    assert needle in str(err.value) and str(path) in str(err.value)
