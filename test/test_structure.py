"""The house rules of issue 18, held by the suite: floors, sizes.

- Floors: a module imports only from its own floor or lower ones (also inside functions), so
  the domain knows nothing of physics, diagnosis nothing of the monitor, and only ros/ and
  tools/ sit on top.
- Sizes: no class over 300 lines; no function over 60 lines except the numba kernels and
  the benchmark report renderers named below.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "ema_phm"

#: Floors of ema_phm, bottom up (README, "Layout"); a top-level module is its own name.
FLOORS: tuple[tuple[str, ...], ...] = (
    ("errors",),
    ("atomic_file", "limits"),
    ("domain",),
    ("physics", "prognostics"),
    ("diagnosis",),
    ("telemetry",),
    ("monitor",),
    ("ros", "fleet"),
    ("tools",),
)
FLOOR_OF = {part: i for i, parts in enumerate(FLOORS) for part in parts}
#: Imports between two parts of one floor that are allowed (none today).
SIDEWAYS_ALLOWED: set[tuple[str, str]] = set()

MAX_CLASS_LINES = 300
MAX_FUNCTION_LINES = 60
#: Long by nature: numba kernels (one loop the compiler sees whole) and report renderers.
LONG_FUNCTIONS_ALLOWED = {
    "ema_phm/physics/monitor_model.py:lf_kernel",
    "ema_phm/physics/real_ema.py:hf_kernel",
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


def _imported_parts(path: Path) -> set[tuple[str, int]]:
    """(part of ema_phm imported, line) for every import in `path`, at any depth."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = path.relative_to(ROOT).with_suffix("").parts[:-1]
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
