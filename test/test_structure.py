"""The house rules, held by the suite: floors, the two sides, sizes.

- Floors: a module imports only from its own floor or lower ones (also inside functions), so
  the domain knows nothing of physics, diagnosis nothing of the monitor, and only ros/ and
  tools/ sit on top.
- Two sides: the simulator (`ema_phm.simulator`, the actuator's stand-in) and everything that
  monitors.  No module imports the simulator but the simulator's own, `evaluation` (scoring
  against the truth) and the few named in `SIMULATOR_USERS` that drive it (ema_node, the
  simulate/demo/benchmark commands, the fleet generator).  So the monitor's model, diagnosis,
  monitor, prognostics, telemetry, monitor_node and the fleet's ingest cannot read what a
  real actuator never records (docs/architecture.md).
- Sizes: no class over 300 lines; no function over 60 lines except the numba kernels and
  the benchmark report renderers named below.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "ema_phm"

#: Floors of ema_phm, bottom up (docs/layout.md); a top-level module is its own name.
FLOORS: tuple[tuple[str, ...], ...] = (
    ("errors",),
    ("atomic_file", "limits"),
    ("domain",),
    ("physics", "prognostics"),
    ("simulator", "model"),
    ("diagnosis",),
    ("telemetry",),
    ("monitor", "importing"),
    ("evaluation",),
    ("ros", "fleet"),
    ("tools",),
)
#: The simulator's side: modules outside ema_phm/simulator/ that may import it, each because
#: it drives the simulated actuator (and nothing that monitors).  `evaluation` may too.
SIMULATOR_USERS: frozenset[str] = frozenset(
    {
        "ema_phm/ros/ema_node.py",  # the simulated actuator's node
        "ema_phm/ros/ema_node_parameters.py",  # its parameter table (units, degradations)
        "ema_phm/tools/simulate.py",  # `ema-phm simulate`
        "ema_phm/tools/demo.py",  # the demo simulates the windows it isolates
        "ema_phm/tools/benchmark.py",  # `ema-phm benchmark`: HF and LF speed
        "ema_phm/tools/diagnose.py",  # `ema-phm calibrate`: the packaged calibration's window
        "ema_phm/fleet/generate.py",  # `ema-phm fleet simulate`
    }
)
FLOOR_OF = {part: i for i, parts in enumerate(FLOORS) for part in parts}
#: Imports between two parts of one floor that are allowed (none today).
SIDEWAYS_ALLOWED: set[tuple[str, str]] = set()

MAX_CLASS_LINES = 300
MAX_FUNCTION_LINES = 60
#: Long by nature: numba kernels (one loop the compiler sees whole) and report renderers.
LONG_FUNCTIONS_ALLOWED = {
    "ema_phm/model/monitor_model.py:lf_kernel",
    "ema_phm/simulator/real_ema.py:hf_kernel",
    "bench/bench_realistic.py:report",
    "bench/bench_robust.py:report",
    "bench/studies/bench_severity_bias.py:table",
    "bench/bench_isolation.py:table",
    "bench/make_reference_bags.py:readme",
    "bench/prog/report.py:_targets",
    "bench/prog/report.py:_isolation",
    "bench/prog/report.py:_controls",
}


def _modules() -> list[Path]:
    return sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)


def _part(path: Path) -> str:
    rel = path.relative_to(PACKAGE)
    return rel.parts[0].removesuffix(".py")


def _imported_parts(path: Path, root: Path = ROOT) -> set[tuple[str, int]]:
    """(part of ema_phm imported, line) for every import in `path`, at any depth."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = path.relative_to(root).with_suffix("").parts[:-1]
    out: set[tuple[str, int]] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                target = (*base, *(node.module.split(".") if node.module else ()))
            else:
                target = tuple((node.module or "").split("."))
            names = [a.name for a in node.names]
            if target[:1] == ("ema_phm",):
                if len(target) > 1:
                    out.add((target[1], node.lineno))
                else:
                    out.update((n, node.lineno) for n in names)
        elif isinstance(node, ast.Import):
            for alias in node.names:
                parts = alias.name.split(".")
                if parts[0] == "ema_phm" and len(parts) > 1:
                    out.add((parts[1], node.lineno))
    return out


def test_every_part_of_the_package_has_a_floor() -> None:
    parts = {_part(p) for p in _modules()} - {"__init__"}
    assert parts <= set(FLOOR_OF), f"parts without a floor: {sorted(parts - set(FLOOR_OF))}"


def test_no_import_runs_back_up_a_floor() -> None:
    wrong = []
    for path in _modules():
        me = _part(path)
        if me == "__init__":
            continue
        for part, line in _imported_parts(path):
            if part in FLOOR_OF and FLOOR_OF[part] > FLOOR_OF[me]:
                wrong.append(f"{path.relative_to(ROOT)}:{line} imports {part} (floor above)")
            elif (
                part in FLOOR_OF
                and part != me
                and FLOOR_OF[part] == FLOOR_OF[me]
                and (me, part) not in SIDEWAYS_ALLOWED
            ):
                wrong.append(f"{path.relative_to(ROOT)}:{line} imports {part} (same floor)")
    assert not wrong, "\n".join(sorted(wrong))


def simulator_imports(root: Path = ROOT) -> list[str]:
    """Imports of ema_phm.simulator from the monitoring side under `root` (path:line)."""
    package = root / "ema_phm"
    wrong = []
    for path in sorted(p for p in package.rglob("*.py") if "__pycache__" not in p.parts):
        rel = path.relative_to(root).as_posix()
        if rel.split("/")[1] in ("simulator", "evaluation") or rel in SIMULATOR_USERS:
            continue
        wrong += [
            f"{rel}:{line} imports the simulator"
            for part, line in _imported_parts(path, root)
            if part == "simulator"
        ]
    return wrong


def test_the_monitoring_side_never_imports_the_simulator() -> None:
    wrong = simulator_imports()
    assert not wrong, "\n".join(wrong)


@pytest.mark.parametrize(
    "module,line",
    [
        ("ema_phm/diagnosis/fitness.py", "from ..simulator import real_ema\n"),
        ("ema_phm/model/monitor_model.py", "from ..simulator.sensors import SensorSpec\n"),
        (
            "ema_phm/monitor/replay.py",
            "    from ema_phm.simulator.degradation import Degradation\n",
        ),
        ("ema_phm/prognostics/rul.py", "import ema_phm.simulator.unit\n"),
        ("ema_phm/ros/monitor_node.py", "from ..simulator import envelope\n"),
        ("ema_phm/fleet/ingest.py", "from ema_phm import simulator\n"),
    ],
)
def test_the_side_rule_catches_an_import_into_the_simulator(
    tmp_path: Path, module: str, line: str
) -> None:
    """Mutation check: the rule above fails on one such import in a copy of the package."""
    import shutil

    shutil.copytree(PACKAGE, tmp_path / "ema_phm", ignore=shutil.ignore_patterns("__pycache__"))
    target = tmp_path / module
    text = target.read_text(encoding="utf-8")
    if line.startswith(" "):  # inside a function, as a lazy import would be
        line = "\n\ndef _lazy() -> None:\n" + line
        target.write_text(text + line, encoding="utf-8")
    else:
        target.write_text(text + "\n" + line, encoding="utf-8")
    assert simulator_imports() == []
    assert any(w.startswith(module) for w in simulator_imports(tmp_path))


def _long_definitions() -> list[str]:
    found = []
    for path in [*_modules(), *sorted((ROOT / "bench").rglob("*.py"))]:
        rel = path.relative_to(ROOT).as_posix()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            lines = getattr(node, "end_lineno", 0) - getattr(node, "lineno", 0) + 1
            if isinstance(node, ast.ClassDef) and lines > MAX_CLASS_LINES:
                found.append(f"class {rel}:{node.name} has {lines} lines")
            if (
                isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
                and lines > MAX_FUNCTION_LINES
                and f"{rel}:{node.name}" not in LONG_FUNCTIONS_ALLOWED
            ):
                found.append(f"function {rel}:{node.name} has {lines} lines")
    return found


def test_no_class_or_function_is_too_long() -> None:
    found = _long_definitions()
    assert not found, "\n".join(found)


@pytest.mark.parametrize("name", sorted(LONG_FUNCTIONS_ALLOWED))
def test_every_allowed_long_function_still_exists(name: str) -> None:
    rel, func = name.split(":")
    tree = ast.parse((ROOT / rel).read_text(encoding="utf-8"))
    assert any(isinstance(n, ast.FunctionDef) and n.name == func for n in ast.walk(tree)), (
        f"{name} is gone: take it off LONG_FUNCTIONS_ALLOWED"
    )


def test_test_files_have_unique_names() -> None:
    """Test modules are imported by basename (no __init__.py): two alike stop collection."""
    names = [p.name for p in (ROOT / "test").rglob("test_*.py")]
    assert sorted({n for n in names if names.count(n) > 1}) == []


#: How a MonitorBelief is built from a user's files: only `model.belief.belief_for` may call
#: these (a second builder is how four different beliefs came about before).
BELIEF_BUILDERS = (
    "for_actuator(",
    "uncalibrated_for(",
    "packaged_uncalibrated(",
    ".with_calibration(",
    ".with_unit(",
    "MonitorBelief.from_file(",
)


def test_the_belief_is_built_in_one_place() -> None:
    home = PACKAGE / "model" / "belief.py"
    found = []
    for path in _modules():
        if path == home:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call):
                call = ast.unparse(node.func) + "("
                if any(call.endswith(b) or b in call for b in BELIEF_BUILDERS):
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno} calls {call}")
    assert not found, "build the belief with model.belief.belief_for:\n" + "\n".join(found)


#: Each file format and the one module that reads and writes it.
FORMAT_HOMES = {
    "unit file": "ema_phm/model/unit_file.py",
    "actuator file": "ema_phm/physics/actuator_file.py",
    "ema.yaml": "ema_phm/physics/parameters.py",
}


@pytest.mark.parametrize("marker", ["'belief'", '"belief"'])
def test_the_unit_file_is_read_and_written_in_one_module(marker: str) -> None:
    """Its `belief` key appears in its home only (and the commissioning that fills it)."""
    users = sorted(
        str(p.relative_to(ROOT))
        for p in _modules()
        if f".get({marker})" in p.read_text(encoding="utf-8")
        or f"{{{marker}:" in p.read_text(encoding="utf-8")
    )
    assert users in ([FORMAT_HOMES["unit file"]], []), users
