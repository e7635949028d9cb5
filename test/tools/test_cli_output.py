"""`ema-phm`: readable text by default and one JSON object with --json, defaults in every help.

The commands run as a user runs them (`python -m ema_phm.tools.cli ...` in a subprocess),
on small inputs: a bundled bag, windows of 0.1-0.2 s, a fleet of 2 units x 2 flights.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from helpers import run_cli

from ema_phm.tools.args import HelpFormatter, shows_default
from ema_phm.tools.cli import build_parser

ROOT = Path(__file__).resolve().parents[2]
BAGS = ROOT / "bags"
K0 = "0,0,0,0,0,0,0.5,0.5"


def ema_phm(*argv: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    """`python -m ema_phm.tools.cli ARGV` in a fresh interpreter (this checkout's package)."""
    env = dict(
        os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    )
    return subprocess.run(
        [sys.executable, "-m", "ema_phm.tools.cli", *argv],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
        cwd=cwd or ROOT,
        env=env,
    )


def text_of(*argv: str, cwd: Path | None = None) -> str:
    """The default (text) output of a command that succeeds: not JSON, at least one line."""
    run = ema_phm(*argv, cwd=cwd)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip(), run.stderr
    with pytest.raises(json.JSONDecodeError):
        json.loads(run.stdout)
    return run.stdout


def json_of(*argv: str, cwd: Path | None = None) -> dict[str, Any]:
    """The --json output of a command that succeeds: exactly one JSON object on stdout."""
    run = ema_phm(*argv, "--json", cwd=cwd)
    assert run.returncode == 0, run.stderr
    assert run.stdout.count("\n") == 1, run.stdout
    out = json.loads(run.stdout)
    assert isinstance(out, dict)
    return out


# --- --help: one formatter, every default shown -------------------------------------------


def _parsers() -> Iterator[tuple[str, argparse.ArgumentParser]]:
    """Every parser of `ema-phm`, subcommands and their own subcommands, by its prog."""
    todo = [build_parser()]
    while todo:
        p = todo.pop()
        yield p.prog, p
        for action in p._actions:
            if isinstance(action, argparse._SubParsersAction):
                todo.extend(action.choices.values())


PARSERS = dict(_parsers())


def test_the_walk_reaches_every_subcommand_and_fleet_subcommand() -> None:
    for name in ("simulate", "calibrate", "fleet", "fleet simulate", "fleet report"):
        assert f"ema-phm {name}" in PARSERS


@pytest.mark.parametrize("prog", sorted(PARSERS))
def test_every_option_with_a_default_shows_it_in_the_help(prog: str) -> None:
    parser = PARSERS[prog]
    assert parser.formatter_class is HelpFormatter
    text = " ".join(parser.format_help().split())
    shown = 0
    for action in parser._actions:
        default = action.default
        if default is None or default is argparse.SUPPRESS or action.help is argparse.SUPPRESS:
            continue
        if not action.option_strings or default is False:
            continue
        assert shows_default(action)
        # argparse prints no help line for an option without help: its default would not show
        assert action.help is not None, (prog, action.option_strings)
        shown_help = " ".join(parser._get_formatter()._expand_help(action).split())
        assert shown_help.endswith(f"(default: {default})"), (prog, action.option_strings)
        assert shown_help in text
        shown += 1
    assert "(default: None)" not in text and "(default: False)" not in text, prog
    assert "(default: ==SUPPRESS==)" not in text, prog


def test_fleet_simulate_help_shows_its_defaults(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run_cli(capsys, "fleet", "simulate", "--help")
    text = " ".join(out.split())
    assert code == 0
    for words in (
        "units to draw (default: 40)",
        "(default: 10)",
        "(default: 2)",
        "(default: 0.75)",
    ):
        assert words in text, text


def test_fleet_simulate_defaults_are_the_generators() -> None:
    from ema_phm.fleet import generate
    from ema_phm.simulator import envelope
    from ema_phm.tools import fleet as fleet_cli

    assert fleet_cli.DEFAULT_DEGRADING_SHARE == generate.DEGRADING_SHARE
    assert fleet_cli.DEFAULT_BASELINES == envelope.BASELINES


def test_every_command_that_prints_a_result_has_json() -> None:
    without = {"ema-phm", "ema-phm fleet"}  # they only hold subcommands
    for prog, parser in PARSERS.items():
        if prog in without:
            continue
        flags = {s for a in parser._actions for s in a.option_strings}
        assert "--json" in flags, prog


# --- each command, text and --json ----------------------------------------------------------


def test_simulate_one_window_text_and_json(tmp_path: Path) -> None:
    text = text_of("simulate", "--k", K0, "--out", str(tmp_path / "a"), "--duration", "0.1")
    assert text.startswith(f"wrote {tmp_path / 'a'}: 201 samples")
    out = json_of("simulate", "--k", K0, "--out", str(tmp_path / "b"), "--duration", "0.1")
    assert out["bag"] == str(tmp_path / "b") and out["samples"] == 201
    assert out["k_true"] == [float(v) for v in K0.split(",")]


def test_simulate_cycles_text_and_json(tmp_path: Path) -> None:
    common = ("--windows", "2", "--degradation", "config/degradation_friction.yaml")
    common += ("--duration", "0.1")
    text = text_of("simulate", *common, "--out", str(tmp_path / "a"))
    assert "2 windows (cycles 0..1" in text
    out = json_of("simulate", *common, "--out", str(tmp_path / "b"))
    assert out["windows"] == 2 and len(out["k_last"]) == 8


def test_recover_text_and_json(tmp_path: Path) -> None:
    text = text_of("recover", str(BAGS / "nominal"), "--out", str(tmp_path / "a"))
    assert "recovered" in text and str(tmp_path / "a") in text
    out = json_of("recover", str(BAGS / "nominal"), "--out", str(tmp_path / "b"))
    assert out["out"] == str(tmp_path / "b") and out["total_messages"] > 0
    assert out["total_messages"] == sum(out["messages"].values())


def test_isolate_text_and_json() -> None:
    argv = ("isolate", str(BAGS / "friction"), "--max-evaluations", "60")
    text = text_of(*argv)
    assert "evaluations in" in text and "k1 friction" in text
    out = json_of(*argv)
    assert len(out["k"]) == 8 and out["level"] in ("OK", "WARN", "ERROR")


def test_calibrate_text_and_json(tmp_path: Path) -> None:
    text = text_of("calibrate", "--out", str(tmp_path / "a.yaml"))
    lines = text.splitlines()
    assert len(lines) == 2 and "ke " in lines[0] and "current MSE" in lines[0]
    assert lines[1].startswith(f"wrote {tmp_path / 'a.yaml'}")
    out = json_of("calibrate", "--out", str(tmp_path / "b.yaml"))
    assert out["written"] == str(tmp_path / "b.yaml")
    assert set(out) == {
        "ke", "gt", "mse_before_a2", "mse_after_a2", "ke_before", "gt_before", "evaluations",
        "written",
    }  # fmt: skip


def test_calibrate_baseline_text_and_json(tmp_path: Path) -> None:
    base = ("calibrate", "--baseline", str(BAGS / "nominal"))
    text = text_of(*base, "--out", str(tmp_path / "a.yaml"))
    assert text.startswith("commissioned one unit from 1 baseline(s)")
    assert re.search(r"^  inertia +x \d", text, re.M) and f"wrote {tmp_path / 'a.yaml'}" in text
    out = json_of(*base, "--out", str(tmp_path / "b.yaml"))
    assert out["written"] == str(tmp_path / "b.yaml") and "inertia" in out["factors"]


def test_prognose_text_and_json(tmp_path: Path) -> None:
    bag = tmp_path / "bag"
    deg = ("--degradation", "config/degradation_friction.yaml")
    made = ema_phm("simulate", "--windows", "3", *deg, "--duration", "0.2", "--out", str(bag))
    assert made.returncode == 0, made.stderr
    argv = ("prognose", str(bag), "--max-evaluations", "40")
    text = text_of(*argv)
    assert "summary after" in text and "cycle    0:" in text
    out = json_of(*argv)
    assert len(out["windows"]) == 3 and "summary" in out


def test_fleet_commands_text_and_json(tmp_path: Path) -> None:
    small = ("--units", "2", "--windows", "2", "--baselines", "0", "--seed", "1")
    text = text_of("fleet", "simulate", "--out", str(tmp_path / "fleet"), *small)
    assert text.startswith(f"wrote {tmp_path / 'fleet'}: 2 units")
    out = json_of("fleet", "simulate", "--out", str(tmp_path / "other"), *small)
    assert out["units"] == 2 and out["windows"] == 2 and Path(out["truth"]).is_file()

    store = ("--store", str(tmp_path / "fleet.sqlite"))
    fit = ("--workers", "0", "--max-evaluations", "40")
    text = text_of("fleet", "ingest", str(tmp_path / "fleet"), *store, *fit)
    assert "windows: 4 diagnosed now" in text
    out = json_of("fleet", "ingest", str(tmp_path / "fleet"), *store, *fit)
    assert out["windows_diagnosed"] == 0  # all stored already

    text = text_of("fleet", "status", *store)
    assert "2 units, most at risk first" in text
    out = json_of("fleet", "status", *store)
    assert len(out["units"]) == 2

    page = tmp_path / "fleet.html"
    text = text_of("fleet", "report", *store, "--out", str(page))
    assert text.strip() == f"wrote {page}: 2 units"
    out = json_of("fleet", "report", *store, "--out", str(page))
    assert out["report"] == str(page) and out["units"] == 2 and page.is_file()


def test_bench_text() -> None:
    text = text_of("bench", "models", "--no-cold-start")
    assert re.search(r"^ +lf_evals_per_s: \d", text, re.M)


def test_errors_stay_one_line_and_exit_2_with_json(tmp_path: Path) -> None:
    for argv in (
        ("calibrate", "--out", str(tmp_path), "--json"),
        ("fleet", "status", "--store", str(tmp_path / "none.sqlite"), "--json"),
        ("simulate", "--k", "0,0", "--out", str(tmp_path / "x"), "--json"),
    ):
        run = ema_phm(*argv)
        assert run.returncode == 2 and run.stdout == "", (argv, run.stdout)
        assert run.stderr.count("\n") == 1 and run.stderr.startswith("ema-phm"), run.stderr


# --- demo: in this process, with the fit's budget capped (a full fit takes ~15 s) -------------


@pytest.fixture
def quick_isolate(monkeypatch: pytest.MonkeyPatch) -> None:
    from ema_phm.diagnosis import isolation

    real = isolation.isolate

    def capped(*args: Any, **kwargs: Any) -> Any:
        return real(*args, **dict(kwargs, max_evaluations=60))

    monkeypatch.setattr(isolation, "isolate", capped)


def test_demo_offline_text_and_json(
    capsys: pytest.CaptureFixture[str], quick_isolate: None
) -> None:
    code, out, err = run_cli(capsys, "demo", "--offline")
    assert code == 0, err
    assert out.startswith("real EMA (HF model)") and "fitted k = " in out
    code, out, err = run_cli(capsys, "demo", "--offline", "--json")
    assert code == 0, err
    data = json.loads(out)
    assert (
        out.count("\n") == 1 and len(data["k"]) == 8 and data["level"] in ("OK", "WARN", "ERROR")
    )


def test_demo_with_the_nodes_json(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("rclpy")
    import numpy as np

    from ema_phm.ros import demo as ros_demo

    health = {
        "window_t0": 0.0, "window_t1": 2.0, "level": "OK", "message": "OK: m",
        "k": np.zeros(8), "k_true": [0.0] * 8, "percent_err": 1.0, "evaluations": 3,
        "elapsed_s": 0.1, "preset": "p",
    }  # fmt: skip
    monkeypatch.setattr(ros_demo, "run_demo", lambda **_: health)
    code, out, err = run_cli(capsys, "demo", "--json")
    assert code == 0, err
    assert json.loads(out)["k"] == [0.0] * 8 and out.count("\n") == 1
    code, out, err = run_cli(capsys, "demo")
    assert code == 0 and out.startswith("starting ema_node") and "level OK: OK: m" in out


def test_fleet_script_help_names_its_environment_variables() -> None:
    run = subprocess.run(
        ["bash", str(ROOT / "scripts" / "fleet.sh"), "--help"],
        capture_output=True,
        text=True,
        timeout=30,
        check=False,
    )
    assert run.returncode == 0, run.stderr
    for name in ("UNITS", "WINDOWS", "SEED", "FLEET", "STORE"):
        assert re.search(rf"^  {name} ", run.stdout, re.M), run.stdout
    assert run.stdout.startswith("Usage: ") and "fleet ingest" in run.stdout
