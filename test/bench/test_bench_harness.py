"""bench/harness: the shared CLI, command line, raw rows and scenarios of the benchmarks."""

from __future__ import annotations

import ast
import json

import numpy as np
import pytest

from bench import harness
from bench.harness import scenarios
from ema_phm.domain.faults import N_K, fault
from ema_phm.physics.commands import default_specs
from ema_phm.physics.parameters import ActuatorParameters
from ema_phm.simulator.unit import Unit

BENCH = harness.ROOT / "bench"


def test_cli_adds_only_the_flags_asked_for_with_their_defaults():
    ap = harness.cli("doc", seed=(100, None), jobs=(1, "processes"), out=("/tmp/x", None))
    args = ap.parse_args([])
    assert (args.seed, args.jobs, args.out) == (100, 1, "/tmp/x")
    assert not hasattr(args, "quick")
    args = harness.cli(None, quick="fast").parse_args(["--quick"])
    assert args.quick and not hasattr(args, "seed")
    with pytest.raises(SystemExit):
        harness.cli(None, seed=(0, None)).parse_args(["--seed", "x"])


def test_command_line_names_the_flags_that_differ_from_their_defaults():
    flags = [("--seed", 0, 100), ("--only", None, None), ("--max-cycles", 0, None)]
    assert (
        harness.command_line("b", "--isolate", flags=flags)
        == ".venv/bin/python -m bench.b --isolate --seed 0"
    )
    assert harness.command_line("b", flags=[("--units", 2, 20), ("--seed", 0, 0)]) == (
        ".venv/bin/python -m bench.b --units 2"
    )


def test_out_dirs_split_rows_from_reports_unless_out_is_given(tmp_path):
    assert harness.out_dirs(None) == (harness.RESULTS, harness.DOCS)
    assert harness.RESULTS == harness.ROOT / "bench" / "results"
    out = tmp_path / "o"
    assert harness.out_dirs(str(out)) == (out, out) and out.is_dir()


def test_rows_written_then_read_and_halves(tmp_path):
    path = tmp_path / "rows.json"
    harness.write_rows(path, {"rows": [1, 2]})
    assert harness.read_rows(path) == {"rows": [1, 2]}
    assert path.read_text() == json.dumps({"rows": [1, 2]}, indent=1)
    assert not list(tmp_path.glob("*.tmp"))
    h = harness.halves([{"index": i} for i in range(5)])
    assert [len(h[k]) for k in ("all", "even", "odd")] == [5, 3, 2]


def test_scenarios_are_the_thesis_cases_by_fault_name():
    cases = scenarios.scenarios()
    assert len(cases) == 16 and cases[-1][0] == "multi-fault (Table 6.17)"
    name, k, thesis = cases[0]
    assert name == "friction low (k1=0.25)" and thesis == 1.99
    assert k[fault("friction").index] == 0.25
    gain = [c for c in cases if c[0].startswith("gain drift high")][0]
    assert gain[0] == "gain drift high (k8=0.7)"
    singles = [c for c in scenarios.cases() if c[2] is not None]
    assert len(singles) == 15 and all(c[3] in scenarios.SEVERITY_TAGS for c in singles)
    assert scenarios.MULTI.shape == (N_K,)


def test_sim_kw_uses_the_noise_it_is_given():
    unit, base = Unit.draw(3), ActuatorParameters.default()
    command, _ = default_specs()
    env = scenarios.hangar(3)[0]
    noisy = scenarios.sim_kw(unit, base, command, env)
    quiet = scenarios.sim_kw(unit, base, command, env, noise={})
    assert noisy["sensors"] != quiet["sensors"]
    assert quiet["sensors"] == unit.sensors()
    assert noisy["temperature_c"] == env["temperature_c"]
    windows = scenarios.hangar_windows(3, unit, base, command, noise={})
    assert len(windows) == scenarios.BASELINES
    assert not np.array_equal(windows[0].matrix(), windows[1].matrix())


def test_no_bench_script_imports_another_bench_script():
    scripts = {f"bench.{p.stem}" for p in BENCH.glob("*.py") if p.stem != "__init__"} | {
        f"bench.studies.{p.stem}" for p in (BENCH / "studies").glob("*.py") if p.stem != "__init__"
    }
    assert "bench.bench_isolation" in scripts and "bench.studies.severity_scale" in scripts
    for path in BENCH.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                assert node.level == 0, (
                    f"{path.name}: relative import (bench imports are absolute)"
                )
                module = node.module or ""
                names = [module, *(f"{module}.{a.name}" for a in node.names)]
            else:
                continue
            for name in names:
                assert name not in scripts, f"{path.name} imports {name}"
