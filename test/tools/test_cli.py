"""`ema-phm` command line: round trips and every bad-input path (exit 2, one line)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import run_cli, window_at

from ema_phm.domain.faults import N_K, NOMINAL, fault, k_with, percent_err
from ema_phm.domain.window import Window
from ema_phm.physics.commands import CommandSpec
from ema_phm.simulator import real_ema as hf
from ema_phm.telemetry import bags
from ema_phm.tools.cli import main

#: The friction entry of k, and the `--k` text of a friction fault of 0.5 (0.5,0,...,0.5,0.5).
FRICTION = fault("friction").index
FRICTION_K = ",".join(f"{v:g}" for v in k_with(friction=0.5))


@pytest.fixture(scope="module")
def faulty_bag(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("bags") / "fric"
    assert main(["simulate", "--k", FRICTION_K, "--out", str(path), "--duration", "1.0"]) == 0
    return path


def test_simulate_writes_a_bag_with_truth(faulty_bag):
    w = bags.read_window(faulty_bag)
    assert w.n == 2001 and w.k_true[FRICTION] == 0.5
    assert (faulty_bag / "metadata.yaml").is_file()
    assert w.meta["command"]["duration"] == 1.0


def test_simulate_then_isolate_json_round_trip(faulty_bag, capsys):
    code, out, err = run_cli(capsys, "isolate", str(faulty_bag), "--json", "--seed", "3")
    assert code == 0, err
    res = json.loads(out)
    assert set(res) >= {"k", "percent_err", "fitness", "evaluations", "wall_s"}
    assert len(res["k"]) == N_K and abs(res["k"][FRICTION] - 0.5) < 0.02
    assert res["percent_err"] == pytest.approx(percent_err(res["k"], res["k_true"]))
    # measured 12.2 % against the truthful HF (issue 9: two shafts, thesis back-EMF, sensors);
    # it was < 2 % against the old twin HF.  The bound catches a broken pipeline, not accuracy,
    # which bench/bench_realistic.py measures.
    assert res["percent_err"] < 18.0
    assert res["evaluations"] > 1000
    # issue 10: intervals, flags, adequacy, nuisances and the level come with every fit
    iv = np.array(res["k_interval"])
    assert iv.shape == (N_K, 2) and np.all(iv[:, 0] <= np.array(res["k"]) + 1e-12)
    assert np.all(np.array(res["k"]) <= iv[:, 1] + 1e-12)
    assert len(res["identifiable"]) == N_K and all("ok" in f for f in res["identifiable"])
    assert set(res["adequacy"]) == {"statistic", "threshold", "ok"}
    # the bag's load channel is measured (0 N*m): its current offset is fitted, no load
    assert set(res["nuisance"]) == {"current_offset", "temperature_c"}
    assert res["level"] in ("OK", "WARN", "ERROR") and res["message"]


def test_isolate_without_ground_truth_gives_null_err(tmp_path, capsys):
    w = hf.simulate(NOMINAL, command=CommandSpec(duration=0.3)).window
    bags.write_window(tmp_path / "b", Window.from_matrix(w.matrix()))
    code, out, _ = run_cli(
        capsys, "isolate", str(tmp_path / "b"), "--json", "--max-evaluations", "80"
    )
    assert code == 0
    assert json.loads(out)["percent_err"] is None


def test_isolate_plot(faulty_bag, tmp_path, capsys):
    png = tmp_path / "iso.png"
    code, _, err = run_cli(
        capsys, "isolate", str(faulty_bag), "--max-evaluations", "80", "--plot", str(png)
    )
    assert code == 0, err
    assert png.stat().st_size > 10_000


def test_simulate_refuses_existing_output(faulty_bag, capsys):
    code, _, err = run_cli(
        capsys, "simulate", "--k", "0,0,0,0,0,0,0.5,0.5", "--out", str(faulty_bag)
    )
    assert code == 2 and "exists" in err and len(err.strip().splitlines()) == 1


def _bad_bags(tmp_path: Path, faulty_bag: Path) -> dict[str, tuple[Path, str]]:
    cases = {}
    cases["missing"] = (tmp_path / "nope", "nope")
    txt = tmp_path / "foreign.txt"
    txt.write_text("hello")
    cases["foreign"] = (txt, "foreign")
    trunc = tmp_path / "trunc"
    shutil.copytree(faulty_bag, trunc)
    mcap = next(trunc.glob("*.mcap"))
    data = mcap.read_bytes()
    mcap.write_bytes(data[: len(data) // 2])
    cases["truncated"] = (trunc, "trunc")
    notopic = tmp_path / "notopic"
    with bags.BagRecorder(notopic, topics={bags.RUN_INFO_TOPIC: bags.STRING}) as rec:
        rec.write(bags.RUN_INFO_TOPIC, bags.string_msg("{}"), 1)
    cases["no telemetry"] = (notopic, "/ema/telemetry")
    w = bags.read_window(faulty_bag)
    m = w.matrix()
    m[100, 6] = np.nan
    bags.write_window(tmp_path / "nan", Window.from_matrix(m, k_true=w.k_true))
    cases["nan"] = (tmp_path / "nan", "non-finite")
    bags.write_window(tmp_path / "short", Window.from_matrix(m[:20], k_true=w.k_true))
    cases["short"] = (tmp_path / "short", "too short")
    return cases


@pytest.mark.parametrize(
    "case", ["missing", "foreign", "truncated", "no telemetry", "nan", "short"]
)
def test_isolate_bad_bags_exit_2_with_one_line(faulty_bag, tmp_path, capsys, case):
    path, word = _bad_bags(tmp_path, faulty_bag)[case]
    code, out, err = run_cli(capsys, "isolate", str(path), "--json")
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and word in lines[0], err


@pytest.mark.parametrize(
    "argv,word",
    [
        (["simulate", "--k", "0,0,0", "--out", "x"], "8 entries"),
        (["simulate", "--k", "0,0,0,0,0,0,0.5,1.5", "--out", "x"], "k8"),
        (["simulate", "--k", "0,0,0,0,0,0,0.5,0.5", "--out", "x", "--duration", "-1"], "duration"),
        (
            ["simulate", "--k", "0,0,0,0,0,0,0.5,0.5", "--out", "x", "--noise-current", "-1"],
            "noise_current",
        ),
        (["isolate", "x", "--preset", "magic"], "magic"),
        (["isolate", "x", "--seed", "-3"], "seed"),
        (["bench", "nothing"], "invalid choice"),
        (["frobnicate"], "invalid choice"),
    ],
)
def test_bad_arguments_exit_2_with_one_line(capsys, tmp_path, monkeypatch, argv, word):
    monkeypatch.chdir(tmp_path)
    code, _, err = run_cli(capsys, *argv)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and word in lines[0], err
    assert not (tmp_path / "x").exists()


def test_bench_models_json(capsys):
    code, out, _ = run_cli(capsys, "bench", "models", "--json", "--no-cold-start")
    assert code == 0
    res = json.loads(out)
    for key in ("hf_wall_per_sim_s", "lf_evals_per_s", "lf_fine_step_rel_rms"):
        assert isinstance(res[key], float) and res[key] > 0
    assert res["lf_fine_step_rel_rms"] < 0.02


def test_console_script_runs_in_a_fresh_interpreter(tmp_path):
    exe = Path(sys.executable).parent / "ema-phm"
    if not exe.exists():
        pytest.skip("package not installed in this interpreter")
    proc = subprocess.run(
        [
            str(exe),
            "simulate",
            "--k",
            "0,0,0,0,0,0,0.5,0.5",
            "--out",
            str(tmp_path / "b"),
            "--duration",
            "0.1",
        ],
        check=False,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert bags.read_window(tmp_path / "b").n == 201


# ---- issue 7, "first contact": every bad input is one line and exit 2, before any long work ----

K0 = "0,0,0,0,0,0,0.5,0.5"


def _one_line_exit_2(code: int, err: str, *words: str) -> str:
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1, err
    for word in words:
        assert word in lines[0], err
    return lines[0]


def _subcommands() -> list[str]:
    from ema_phm.tools.cli import SUBCOMMANDS

    return sorted(SUBCOMMANDS)


@pytest.mark.parametrize("argv", [["--help"]] + [[name, "--help"] for name in _subcommands()])
def test_help_of_every_parser_prints_and_exits_0(capsys, argv):
    code, out, err = run_cli(capsys, *argv)
    assert code == 0, err
    assert "usage:" in out and err == ""


@pytest.mark.parametrize(
    "argv,words",
    [
        (
            ["simulate", "--k", K0, "--out", "x", "--seed=-1", "--noise-current", "0.1"],
            ("--seed", "-1", "[0, "),
        ),
        (["simulate", "--k", K0, "--out", "x", "--seed", "4294967296"], ("--seed", "4294967296")),
        (["simulate", "--k", K0, "--out", "x", "--seed", "1.5"], ("--seed", "1.5")),
        (["isolate", "x", "--seed", "4294967296"], ("--seed", "4294967296")),
        (["demo", "--offline", "--seed=-1"], ("--seed", "-1")),
        (["simulate", "--k", K0, "--out", "x", "--duration", "1e7"], ("--duration", "1e7", "60")),
        (["simulate", "--k", K0, "--out", "x", "--duration", "1e300"], ("--duration", "1e300")),
        (["simulate", "--k", K0, "--out", "x", "--duration", "1e999"], ("--duration", "1e999")),
        (["simulate", "--k", K0, "--out", "x", "--duration", "nan"], ("--duration", "nan")),
        (
            ["simulate", "--k", K0, "--out", "x", "--duration", "1e-9"],
            ("--duration", "1e-9", "0.05"),
        ),
        (["isolate", "x", "--max-evaluations=-5"], ("--max-evaluations", "-5")),
        (["isolate", "x", "--max-evaluations", str(10**12)], ("--max-evaluations", str(10**12))),
        (["isolate", "x", "--max-evaluations", "9" * 5000], ("--max-evaluations",)),
        (["simulate", "--k", K0, "--out", "x", "--f1", "1500"], ("--f1", "1500")),
        (["simulate", "--k", K0, "--out", "x", "--f1", "1000"], ("f1", "1000", "2000 Hz")),
        (
            ["simulate", "--k", K0, "--out", "x", "--command", "sine", "--f0", "1000"],
            ("f0", "1000 Hz", "2000 Hz"),
        ),
        (["simulate", "--k", K0, "--out", "x", "--f0=-1"], ("--f0", "-1")),
        (["simulate", "--k", K0, "--out", "x", "--amplitude", "1e300"], ("--amplitude", "1e300")),
        (
            ["simulate", "--k", K0, "--out", "x", "--noise-current", "1e300"],
            ("--noise-current", "1e300"),
        ),
        (
            ["simulate", "--k", K0, "--out", "x", "--noise-current", "inf"],
            ("--noise-current", "inf"),
        ),
        (["demo", "--offline", "--noise-current=-0.1"], ("--noise-current", "-0.1")),
        (["simulate", "--k", K0, "--out", "x", "--load", "1e9"], ("--load", "1e9")),
        (["simulate", "--k", "0,,0,0,0,0,0,0.5,0", "--out", "x"], ("empty", "field 2")),
        (["simulate", "--k", "0,0,0,0,0,0,0.5,0.5,", "--out", "x"], ("empty", "field 9")),
        (["simulate", "--k", "0,0,0,0,0,0,0,0.5,0", "--out", "x"], ("8", "9")),
        (["simulate", "--k", K0, "--out", "x", "--plot", "x.txt"], ("--plot", "x.txt", "png")),
        (["simulate", "--k", K0, "--out", "x", "--plot", "nodir/x.png"], ("--plot", "nodir")),
        (["isolate", "x", "--plot", "x.txt"], ("--plot", "x.txt")),
        (["isolate", "x", "--unit", "missing.yaml"], ("missing.yaml",)),
        (["calibrate", "--baseline", "x"], ("--out",)),
        (["demo", "--offline", "--plot", "nodir/x.png"], ("--plot", "nodir")),
    ],
)
def test_bad_input_is_refused_up_front_with_one_line(capsys, tmp_path, monkeypatch, argv, words):
    monkeypatch.chdir(tmp_path)
    code, out, err = run_cli(capsys, *argv)
    _one_line_exit_2(code, err, *words)
    assert "Traceback" not in err and out == ""
    assert not (tmp_path / "x").exists()


def test_plot_into_a_folder_that_cannot_be_written_is_refused_before_the_work(
    capsys, tmp_path, monkeypatch
):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "afile").write_text("")
    for target in (
        "afile/x.png",
        "/proc/x.png",
    ):  # a file as folder; a folder even root cannot write
        code, out, err = run_cli(capsys, "simulate", "--k", K0, "--out", "x", "--plot", target)
        _one_line_exit_2(code, err, "--plot", target)
        assert not (tmp_path / "x").exists()


def test_simulate_plot_still_writes_a_png(capsys, tmp_path):
    png = tmp_path / "w.svg"
    code, _, err = run_cli(
        capsys,
        "simulate",
        "--k",
        K0,
        "--out",
        str(tmp_path / "b"),
        "--duration",
        "0.1",
        "--plot",
        str(png),
    )
    assert code == 0, err
    assert png.stat().st_size > 1000


def test_isolate_a_bag_at_the_wrong_sample_rate_names_both_rates(capsys, tmp_path):
    bags.write_window(tmp_path / "slow", window_at(10))  # 200 Hz
    code, out, err = run_cli(
        capsys, "isolate", str(tmp_path / "slow"), "--json", "--max-evaluations", "80"
    )
    _one_line_exit_2(code, err, "sample rate", "200 Hz", "2000 Hz")


def test_library_checks_behind_the_options():
    from ema_phm.domain import faults as fault_vector
    from ema_phm.errors import ConfigError, FaultVectorError
    from ema_phm.physics.commands import LoadSpec

    for bad in (
        dict(duration=1e7),
        dict(duration=1e-9),
        dict(amplitude=1e300),
        dict(f1=5000.0),
        dict(offset=1e300),
    ):
        with pytest.raises(ConfigError, match=next(iter(bad))):
            CommandSpec(**bad)
    with pytest.raises(ConfigError, match="load"):
        LoadSpec(value=1e9)
    for kwargs in (
        dict(seed=-1),
        dict(seed=2**32),
        dict(noise_current=1e300),
        dict(noise_speed=-1.0),
    ):
        with pytest.raises(ConfigError, match=next(iter(kwargs))):
            hf.simulate(NOMINAL, command=CommandSpec(duration=0.05), **kwargs)
        with pytest.raises(ConfigError, match=next(iter(kwargs))):
            hf.HFStream(NOMINAL, **kwargs)
    with pytest.raises(ConfigError, match="f1 = 1000 Hz"):
        hf.simulate(NOMINAL, command=CommandSpec(duration=0.05, f1=1000.0))
    with pytest.raises(FaultVectorError, match="empty"):
        fault_vector.parse("0,,0,0,0,0,0,0.5,0")
    assert fault_vector.parse(" 0, 0,0,0,0,0,0.5,0.5 ").tolist() == NOMINAL.tolist()


def test_cli_isolate_on_a_fifo_exits_2(tmp_path: Path) -> None:
    fifo = tmp_path / "x.mcap"
    os.mkfifo(fifo)
    proc = subprocess.run(
        [sys.executable, "-m", "ema_phm.tools.cli", "isolate", str(fifo)],
        check=False,
        capture_output=True,
        text=True,
        timeout=120,
        cwd=Path(__file__).parents[2],
    )
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "FIFO" in proc.stderr and str(fifo) in proc.stderr


def test_calibrate_writes_to_the_user_config_location_never_into_the_package(
    capsys, tmp_path, monkeypatch
):
    import yaml

    from ema_phm.physics.parameters import packaged_config_dir

    packaged = packaged_config_dir() / "calibration.yaml"
    before = packaged.read_bytes()
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "xdg"))
    code, out, err = run_cli(capsys, "calibrate", "--json")
    assert code == 0, err
    written = tmp_path / "xdg" / "ema_phm" / "calibration.yaml"  # folder created
    assert json.loads(out)["written"] == str(written)
    data = yaml.safe_load(written.read_text(encoding="utf-8"))
    assert data["monitor"]["ke"] == pytest.approx(
        yaml.safe_load(before)["monitor"]["ke"], rel=1e-6
    )
    assert packaged.read_bytes() == before


def test_calibrate_out_names_the_file(capsys, tmp_path):
    target = tmp_path / "a" / "b" / "cal.yaml"
    code, out, err = run_cli(capsys, "calibrate", "--json", "--out", str(target))
    assert code == 0, err
    assert json.loads(out)["written"] == str(target) and target.is_file()
    code, out, err = run_cli(capsys, "calibrate", "--out", str(tmp_path))
    _one_line_exit_2(code, err, str(tmp_path), "folder")


def test_calibrate_write_is_refused_naming_out(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path))
    code, out, err = run_cli(capsys, "calibrate", "--write")
    _one_line_exit_2(code, err, "--write", "--out")
    assert out == "" and not (tmp_path / "ema_phm").exists()


def test_isolate_uses_the_named_calibration(faulty_bag, capsys, tmp_path):
    from ema_phm.physics.parameters import packaged_config_dir

    common = (str(faulty_bag), "--json", "--seed", "1", "--max-evaluations", "200")
    code, out, err = run_cli(capsys, "isolate", *common)
    assert code == 0, err
    packaged = json.loads(out)
    assert packaged["calibration"] == str(packaged_config_dir() / "calibration.yaml")
    uncalibrated = tmp_path / "thesis.yaml"
    uncalibrated.write_text("monitor: {ke: 0.025066666666666668, gt: 0.0752}\n", encoding="utf-8")
    code, out, err = run_cli(capsys, "isolate", *common, "--calibration", str(uncalibrated))
    assert code == 0, err
    named = json.loads(out)
    assert named["calibration"] == str(uncalibrated) and named["fitness"] != packaged["fitness"]


@pytest.mark.parametrize(
    "content,words",
    [
        (None, ("not found", "absent.yaml")),
        ("monitor: {ke: 0.07}\n", ("cal.yaml", "monitor.gt")),
        ("monitor: {ke: 0.07, gt: nan}\n", ("monitor.gt", "nan")),
    ],
)
def test_isolate_with_a_bad_calibration_file_exits_2_naming_it(
    faulty_bag, capsys, tmp_path, content, words
):
    path = tmp_path / ("absent.yaml" if content is None else "cal.yaml")
    if content is not None:
        path.write_text(content, encoding="utf-8")
    code, out, err = run_cli(capsys, "isolate", str(faulty_bag), "--calibration", str(path))
    _one_line_exit_2(code, err, *words)


def test_load_spec_spring_and_measured_are_checked_and_recorded():
    from ema_phm.errors import ConfigError
    from ema_phm.physics.commands import LoadSpec

    spec = LoadSpec(value=10.0, spring=500.0, measured=False)
    assert spec.as_dict()["spring"] == 500.0 and spec.as_dict()["measured"] is False
    assert LoadSpec().spring == 0.0 and LoadSpec().measured is True
    for bad in (-1.0, 1e6, float("nan"), "5"):
        with pytest.raises(ConfigError, match=r"load spring"):
            LoadSpec(spring=bad)
    with pytest.raises(ConfigError, match=r"load measured must be true or false, got 'no'"):
        LoadSpec(measured="no")


HEALTHY = "0,0,0,0,0,0,0.5,0.5"


def test_simulate_a_unit_in_its_environment_records_what_produced_it(capsys, tmp_path):
    from ema_phm.simulator.unit import Unit
    from ema_phm.telemetry.bags import read_window

    out = tmp_path / "unit"
    code, _out, err = run_cli(
        capsys,
        "simulate",
        "--k",
        HEALTHY,
        "--out",
        str(out),
        "--duration",
        "0.1",
        "--unit-seed",
        "4",
        "--temperature",
        "60",
        "--load",
        "20",
        "--load-spring",
        "1000",
        "--load-unmeasured",
        "--noise-current",
        "0.05",
        "--noise-position",
        "1e-5",
        "--noise-speed",
        "0.1",
    )
    assert code == 0, err
    w = read_window(out)
    assert np.isnan(w.load).all() and np.all(w.temperature == 60.0)
    m = w.meta
    assert m["unit"]["seed"] == 4 and m["unit"]["values"] == Unit.draw(4).as_dict()
    assert m["temperature_c"] == 60.0
    assert m["load"]["spring"] == 1000.0 and m["load"]["measured"] is False
    assert m["load"]["value"] == 20.0
    noises = (m["sensors"]["noise_current"], m["sensors"]["noise_position"])
    assert noises == (0.05, 1e-5) and m["sensors"]["noise_speed"] == 0.1
    assert m["sensors"]["current_gain"] == Unit.draw(4).current_gain


def test_simulate_a_described_unit_changes_the_telemetry(capsys, tmp_path):
    from ema_phm.telemetry.bags import read_window

    paths = []
    for i, extra in enumerate(([], ["--unit", "inertia=1.2,current_offset=0.5"])):
        paths.append(tmp_path / f"u{i}")
        code, _o, err = run_cli(
            capsys,
            "simulate",
            "--k",
            HEALTHY,
            "--out",
            str(paths[-1]),
            "--duration",
            "0.1",
            *extra,
        )
        assert code == 0, err
    nominal, unit = (read_window(p) for p in paths)
    assert nominal.meta["unit"]["spec"] is None and np.isnan(nominal.temperature).all()
    assert unit.meta["unit"]["spec"] == "inertia=1.2,current_offset=0.5"
    assert not np.allclose(nominal.i3eq, unit.i3eq)


@pytest.mark.parametrize(
    "extra, words",
    [
        (["--unit", "inertia=1.1", "--unit-seed", "3"], ["--unit-seed", "--unit"]),
        (["--unit", "inertia=1.1,mass=2"], ["unknown", "mass"]),
        (["--unit", "resistance=0"], ["unit resistance", "0"]),
        (["--unit", "friction=nan"], ["unit spec: friction", "finite", "nan"]),
        (["--unit", str(Path("/nonexistent/unit.yaml"))], ["/nonexistent/unit.yaml"]),
        (["--unit-seed", "-4"], ["--unit-seed", "-4"]),
        (["--temperature", "900"], ["--temperature", "900"]),
        (["--temperature", "nan"], ["--temperature", "nan"]),
        (["--load-spring", "-5"], ["--load-spring", "-5"]),
        (["--noise-position", "7"], ["noise_position", "7"]),
        (["--noise-speed", "-1"], ["noise_speed", "-1"]),
    ],
)
def test_simulate_unit_and_environment_errors_are_one_line(capsys, tmp_path, extra, words):
    code, _out, err = run_cli(
        capsys, "simulate", "--k", HEALTHY, "--out", str(tmp_path / "x"), *extra
    )
    _one_line_exit_2(code, err, *words)
    assert not (tmp_path / "x").exists()


def test_commission_a_unit_then_isolate_against_it(faulty_bag, tmp_path, capsys):
    base = tmp_path / "healthy"
    assert main(["simulate", "--k", "0,0,0,0,0,0,0.5,0.5", "--out", str(base), "--seed", "4"]) == 0
    capsys.readouterr()
    unit = tmp_path / "unit.yaml"
    code, out, err = run_cli(
        capsys, "calibrate", "--baseline", str(base), "--out", str(unit), "--json"
    )
    assert code == 0, err
    rep = json.loads(out)
    assert rep["written"] == str(unit) and rep["identifiable"]["inertia"]
    assert rep["factors"]["inertia"] == pytest.approx(1.0, abs=0.05)  # the datasheet unit
    code, out, err = run_cli(
        capsys,
        "isolate",
        str(faulty_bag),
        "--unit",
        str(unit),
        "--json",
        "--max-evaluations",
        "200",
    )
    assert code == 0, err
    res = json.loads(out)
    assert res["unit"] == str(unit) and len(res["k_interval"]) == N_K


def test_isolate_help_names_every_fitness_weighting(capsys):
    from ema_phm.diagnosis.fitness import WEIGHTINGS
    from ema_phm.tools.diagnose import FITNESS_WEIGHTINGS

    assert sorted(FITNESS_WEIGHTINGS) == sorted(WEIGHTINGS)
    code, out, _ = run_cli(capsys, "isolate", "--help")
    assert code == 0
    assert " | ".join(FITNESS_WEIGHTINGS) in " ".join(out.split())


def test_no_subcommand_module_imports_the_cli_or_another_subcommand():
    import ast

    from ema_phm import tools

    commands = {"cli", "simulate", "diagnose", "prognose", "demo", "play"}
    for path in Path(tools.__file__).parent.glob("*.py"):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if not (isinstance(node, ast.ImportFrom) and node.level == 1):
                continue
            names = {a.name for a in node.names}
            assert not any(n.startswith("_") for n in names), (path.name, node.module, names)
            if path.stem in commands - {"cli"}:
                assert node.module not in commands, (path.name, node.module)
