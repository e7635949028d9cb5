"""`ema-phm import` run as a user runs it, and every command reading what it wrote."""

from __future__ import annotations

import copy
import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from helpers import run_cli

from bench.harness import rig_forms
from ema_phm.domain.faults import NOMINAL
from ema_phm.physics.commands import CommandSpec
from ema_phm.simulator import real_ema as hf

#: A life's file names carry the unit, the run and the cycle.
FROM_NAME = r"^(?P<hardware_id>[^_]+)_(?P<run_id>[^_]+)_c(?P<cycle>\d+)\.csv$"


@pytest.fixture(scope="module")
def rig(tmp_path_factory) -> Path:
    """A rig's folder: three CSV flights of unit rig-7 and the map that reads them."""
    folder = tmp_path_factory.mktemp("rig")
    w = hf.simulate(NOMINAL, command=CommandSpec(duration=1.0)).window.without_truth()
    w = rig_forms.with_rest(dataclasses.replace(w, temperature=np.full(w.n, 30.0)), 0.5)
    (folder / "logs").mkdir()
    for cycle in range(3):
        rig_forms.table(folder / "logs" / f"rig-7_life-1_c{cycle}.csv", w)
    m = copy.deepcopy(rig_forms.TABLE_MAP)
    m["identity"] = {"from_name": FROM_NAME}
    (folder / "map.yaml").write_text(yaml.safe_dump(m), encoding="utf-8")
    return folder


def test_import_then_isolate_and_prognose_read_it(rig, tmp_path, capsys):
    out = tmp_path / "rec"
    code, text, err = run_cli(
        capsys, "import", str(rig / "logs"), "--map", str(rig / "map.yaml"), "--out", str(out)
    )
    assert code == 0, err
    assert "3 recordings written" in text
    life = out / "rig-7" / "life-1"
    assert sorted(p.name for p in life.iterdir()) == [f"window_0000{c}" for c in range(3)]
    code, text, err = run_cli(
        capsys, "isolate", str(life / "window_00001"), "--max-evaluations", "80", "--json"
    )
    assert code == 0, err
    assert len(json.loads(text)["k"]) == 8
    code, text, err = run_cli(capsys, "prognose", str(life), "--max-evaluations", "60", "--json")
    assert code == 0, err
    assert [w["cycle"] for w in json.loads(text)["windows"]] == [0, 1, 2]


def test_import_json_and_a_second_run_writes_nothing(rig, tmp_path, capsys):
    args = ["import", str(rig / "logs"), "--map", str(rig / "map.yaml"), "--out", str(tmp_path)]
    code, text, _ = run_cli(capsys, *args, "--json")
    assert code == 0 and len(json.loads(text)["written"]) == 3
    code, text, _ = run_cli(capsys, *args, "--json")
    assert code == 0
    report = json.loads(text)
    assert report["written"] == [] and len(report["unchanged"]) == 3


def test_fleet_ingest_takes_the_raw_logs_through_the_map(rig, tmp_path, capsys):
    store = tmp_path / "fleet.sqlite"
    code, text, err = run_cli(
        capsys,
        "fleet",
        "ingest",
        str(rig / "logs"),
        "--map",
        str(rig / "map.yaml"),
        "--store",
        str(store),
        "--workers",
        "0",
        "--max-evaluations",
        "60",
    )
    assert code == 0, err
    assert "3 recordings written" in text
    assert (tmp_path / "fleet.sqlite.imported" / "rig-7" / "life-1").is_dir()
    code, text, err = run_cli(capsys, "fleet", "status", "--store", str(store), "--json")
    assert code == 0, err
    assert "rig-7" in text


def test_a_bad_map_is_one_line_and_exit_2(rig, tmp_path, capsys):
    bad = tmp_path / "map.yaml"
    bad.write_text(
        (rig / "map.yaml").read_text(encoding="utf-8").replace("unit: deg", "unit: degree"),
        encoding="utf-8",
    )
    code, _, err = run_cli(
        capsys, "import", str(rig / "logs"), "--map", str(bad), "--out", str(tmp_path / "o")
    )
    assert code == 2
    assert err.count("\n") == 1 and "unit 'degree'" in err
    assert not (tmp_path / "o").exists()


def test_commands_given_a_rigs_recording_point_to_import(rig, tmp_path, capsys):
    csv = rig / "logs" / "rig-7_life-1_c0.csv"
    code, _, err = run_cli(capsys, "isolate", str(csv))
    assert code == 2 and "ema-phm import" in err
    w = hf.simulate(NOMINAL, command=CommandSpec(duration=0.2)).window
    bag = rig_forms.joint_states_bag(tmp_path / "rig_bag", w)
    code, _, err = run_cli(capsys, "isolate", str(bag))
    assert code == 2 and "has no /ema/telemetry topic" in err and "ema-phm import" in err


def test_prognose_refuses_a_folder_of_two_lives(rig, tmp_path, capsys):
    out = tmp_path / "rec"
    for run in ("life-1", "life-2"):
        code, _, err = run_cli(
            capsys,
            "import",
            str(rig / "logs" / "rig-7_life-1_c0.csv"),
            "--map",
            str(rig / "map.yaml"),
            "--out",
            str(out),
            "--run-id",
            run,
        )
        assert code == 0, err
    code, _, err = run_cli(capsys, "prognose", str(out))
    assert code == 2
    assert "holds 2 lives" in err and "fleet ingest" in err


def test_prognose_says_which_faults_the_recordings_cannot_show(rig, tmp_path, capsys):
    m = yaml.safe_load((rig / "map.yaml").read_text(encoding="utf-8"))
    m["channels"]["theta_m"] = {"derive": "through_gear"}
    (tmp_path / "no_encoder.yaml").write_text(yaml.safe_dump(m), encoding="utf-8")
    args = ["import", str(rig / "logs"), "--map", str(tmp_path / "no_encoder.yaml")]
    code, _, err = run_cli(capsys, *args, "--out", str(tmp_path / "rec"))
    assert code == 0, err
    life = tmp_path / "rec" / "rig-7" / "life-1"
    code, text, err = run_cli(capsys, "prognose", str(life), "--max-evaluations", "60")
    assert code == 0, err
    assert "not seen in these recordings: backlash" in text
    assert "backlash             not_seen" in text


def test_the_fleet_says_which_faults_a_units_recordings_cannot_show(rig, tmp_path, capsys):
    m = yaml.safe_load((rig / "map.yaml").read_text(encoding="utf-8"))
    m["channels"]["theta_m"] = {"derive": "through_gear"}
    (tmp_path / "no_encoder.yaml").write_text(yaml.safe_dump(m), encoding="utf-8")
    store = str(tmp_path / "fleet.sqlite")
    code, _, err = run_cli(
        capsys,
        *("fleet", "ingest", str(rig / "logs"), "--map", str(tmp_path / "no_encoder.yaml")),
        *("--store", store, "--workers", "0", "--max-evaluations", "60"),
    )
    assert code == 0, err
    code, text, err = run_cli(capsys, "fleet", "status", "--store", store)
    assert code == 0 and "(not seen: backlash)" in text, err
    page = tmp_path / "fleet.html"
    code, _, err = run_cli(capsys, "fleet", "report", "--store", store, "--out", str(page))
    assert code == 0, err
    assert 'class="not-seen" data-fault="backlash"' in page.read_text(encoding="utf-8")
