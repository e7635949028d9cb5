"""`--actuator FILE.yaml` on every command that simulates or diagnoses (issue 18 item 3)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from helpers import run_cli

from ema_phm.domain.window import Window
from ema_phm.physics.actuator_file import write_actuator
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.telemetry import bags

HEALTHY = "0,0,0,0,0,0,0.5,0.5"
#: Every subcommand that builds an actuator or a monitor belief.
WITH_ACTUATOR = ("simulate", "isolate", "calibrate", "prognose", "demo")


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    """The packaged actuator written out, two with one value changed, bad ones."""
    folder = tmp_path_factory.mktemp("actuators")
    packaged = ActuatorParameters.default()
    out = {
        "same": write_actuator(packaged, folder / "same.yaml"),
        "hot": write_actuator(
            packaged.with_values({"motor.r_phase_to_phase": 3.0}), folder / "hot.yaml"
        ),
        # the monitor's LF reads the mechanics (its electrical part is the monitor section)
        "heavy": write_actuator(
            packaged.with_values({"mechanics.j_motor": 2 * packaged.value("mechanics.j_motor")}),
            folder / "heavy.yaml",
        ),
        "missing": folder / "absent.yaml",
    }
    text = out["same"].read_text(encoding="utf-8")
    out["negative"] = folder / "negative.yaml"
    out["negative"].write_text(
        text.replace("r_phase_to_phase_ohm: 2.13", "r_phase_to_phase_ohm: -1"), encoding="utf-8"
    )
    out["unknown"] = folder / "unknown.yaml"
    out["unknown"].write_text(text + "gearbox: {teeth: 3}\n", encoding="utf-8")
    return out


def _simulate(capsys, out: Path, *extra: str) -> Window:
    argv = ("simulate", "--k", HEALTHY, "--out", str(out), "--duration", "0.2", *extra)
    code, _out, err = run_cli(capsys, *argv)
    assert code == 0, err
    return bags.read_window(out)


@pytest.fixture(scope="module")
def healthy_bag(tmp_path_factory) -> Path:
    from ema_phm.tools.cli import main

    path = tmp_path_factory.mktemp("bags") / "healthy"
    assert main(["simulate", "--k", HEALTHY, "--out", str(path), "--duration", "0.5"]) == 0
    return path


@pytest.mark.parametrize("command", WITH_ACTUATOR)
def test_help_lists_actuator(capsys, command):
    code, out, _ = run_cli(capsys, command, "--help")
    assert code == 0 and "--actuator FILE.yaml" in out


def test_the_packaged_actuator_file_simulates_what_no_option_does(capsys, tmp_path, files):
    plain = _simulate(capsys, tmp_path / "plain")
    named = _simulate(capsys, tmp_path / "named", "--actuator", str(files["same"]))
    assert np.array_equal(plain.matrix(), named.matrix(), equal_nan=True)
    assert "actuator_file" not in plain.meta
    assert named.meta["actuator_file"] == str(files["same"])


def test_one_changed_value_changes_what_simulate_produces(capsys, tmp_path, files):
    plain = _simulate(capsys, tmp_path / "plain")
    hot = _simulate(capsys, tmp_path / "hot", "--actuator", str(files["hot"]))
    assert np.array_equal(plain.theta_u[:1], hot.theta_u[:1])  # same start
    assert np.abs(plain.i3eq - hot.i3eq).max() > 0.01  # another resistance, another current


def test_simulate_windows_records_and_uses_the_actuator(capsys, tmp_path, files):
    deg = tmp_path / "deg.yaml"
    deg.write_text("faults:\n  friction: {law: linear, onset: 0, initial: 0.0, rate: 0.05}\n")
    rows = []
    for name, extra in (("plain", []), ("hot", ["--actuator", str(files["hot"])])):
        out = tmp_path / name
        argv = ["simulate", "--windows", "2", "--degradation", str(deg), "--duration", "0.1"]
        code, _o, err = run_cli(capsys, *argv, "--out", str(out), *extra)
        assert code == 0, err
        from ema_phm.telemetry.cycle_bags import read_cycle_windows

        windows = read_cycle_windows(out)
        rows.append(np.concatenate([w.i3eq for w in windows]))
        assert windows[0].meta.get("actuator_file") == (extra[1] if extra else None)
    assert np.abs(rows[0] - rows[1]).max() > 0.01


def test_isolate_believes_the_named_actuator(capsys, healthy_bag, files):
    common = (str(healthy_bag), "--json", "--max-evaluations", "80", "--seed", "1")
    fits = {}
    for name, extra in (("plain", ()), ("same", ("--actuator", str(files["same"])))):
        code, out, err = run_cli(capsys, "isolate", *common, *extra)
        assert code == 0, err
        fits[name] = json.loads(out)
    code, out, err = run_cli(capsys, "isolate", *common, "--actuator", str(files["heavy"]))
    assert code == 0, err
    heavy = json.loads(out)
    assert fits["same"]["fitness"] == fits["plain"]["fitness"]  # the packaged belief
    assert "actuator" not in fits["plain"] and heavy["actuator"] == str(files["heavy"])
    assert heavy["fitness"] > fits["plain"]["fitness"]  # believes a rotor the bag has not


def test_calibrate_fits_the_named_actuator(capsys, tmp_path, files):
    results = []
    for name, extra in (("plain", ()), ("hot", ("--actuator", str(files["hot"])))):
        out = tmp_path / f"{name}.yaml"
        code, text, err = run_cli(capsys, "calibrate", "--json", "--out", str(out), *extra)
        assert code == 0, err
        results.append(json.loads(text))
    assert results[0]["ke"] != results[1]["ke"]


@pytest.mark.parametrize("bad", ["missing", "negative", "unknown"])
@pytest.mark.parametrize(
    "argv",
    [
        ("simulate", "--k", HEALTHY, "--out", "x"),
        ("isolate", "BAG"),
        ("calibrate", "--out", "x"),
        ("calibrate", "--baseline", "BAG", "--out", "x"),
        ("prognose", "BAG"),
        ("demo", "--offline"),
    ],
)
def test_a_bad_actuator_file_is_one_line_and_exit_2(
    capsys, tmp_path, monkeypatch, healthy_bag, files, argv, bad
):
    monkeypatch.chdir(tmp_path)
    path = files[bad]
    args = [str(healthy_bag) if a == "BAG" else a for a in argv]
    code, out, err = run_cli(capsys, *args, "--actuator", str(path))
    lines = err.strip().splitlines()
    assert code == 2 and out == "", err
    assert len(lines) == 1 and path.name in lines[0], err
    word = {"missing": "not found", "negative": "r_phase_to_phase_ohm", "unknown": "gearbox"}
    assert word[bad] in lines[0], err
    assert not (tmp_path / "x").exists()


def test_demo_with_the_nodes_refuses_an_actuator_file(capsys, files):
    code, out, err = run_cli(capsys, "demo", "--actuator", str(files["same"]))
    lines = err.strip().splitlines()
    assert code == 2 and out == "" and len(lines) == 1 and "--offline" in lines[0], err


def test_demo_with_the_nodes_refuses_a_plot_it_would_not_draw(capsys, tmp_path):
    """Found by review: without --offline, --plot was accepted and silently ignored."""
    code, out, err = run_cli(capsys, "demo", "--plot", str(tmp_path / "x.png"))
    lines = err.strip().splitlines()
    assert code == 2 and out == "" and len(lines) == 1 and "--offline" in lines[0], err


def test_prognose_fits_with_the_belief_of_the_named_actuator(capsys, tmp_path, files, monkeypatch):
    from ema_phm.monitor import replay as replay_mod

    deg = tmp_path / "deg.yaml"
    deg.write_text("faults:\n  friction: {law: linear, onset: 0, initial: 0.0, rate: 0.05}\n")
    bag = tmp_path / "bag"
    argv = ["simulate", "--windows", "2", "--degradation", str(deg), "--duration", "0.1"]
    assert run_cli(capsys, *argv, "--out", str(bag))[0] == 0
    seen = []

    def fake_replay(windows, **options):  # what prognose hands the replay, nothing fitted
        seen.append(options["belief"])
        return []

    monkeypatch.setattr(replay_mod, "replay", fake_replay)
    code, out, err = run_cli(capsys, "prognose", str(bag), "--actuator", str(files["heavy"]))
    assert code == 0, err
    assert f"actuator {files['heavy']}, unit none" in out
    code, out, err = run_cli(capsys, "prognose", str(bag), "--json")
    assert code == 0, err
    assert "actuator" not in json.loads(out)
    j_motor = ActuatorParameters.default().value("mechanics.j_motor")
    assert seen[0].value("mechanics.j_motor") == 2 * j_motor
    assert seen[1].value("mechanics.j_motor") == j_motor
