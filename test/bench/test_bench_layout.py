"""bench/ as a package: benchmarks, studies and raw rows where they belong, no sys.path edits.

Benchmarks run as ``python -m bench.<name>`` and studies as ``python -m bench.studies.<name>``
from the repository root; their raw rows live in bench/results/, their reports in docs/.
"""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BENCH = ROOT / "bench"
RESULTS = BENCH / "results"
#: The repository's limit per file (raw rows included: bench/prog/isolate.py rounds for it).
MAX_FILE_BYTES = 3 * 1024 * 1024


def _scripts(folder: Path) -> list[Path]:
    return sorted(p for p in folder.glob("*.py") if p.name != "__init__.py")


def _sys_path_edits(path: Path) -> list[str]:
    """Lines of `path` that touch sys.path (sys.path.x, from sys import path, site dirs)."""
    found = []
    where = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if (
            isinstance(node, ast.Attribute)
            and node.attr == "path"
            and isinstance(node.value, ast.Name)
            and node.value.id == "sys"
        ) or (
            isinstance(node, ast.ImportFrom)
            and node.module == "sys"
            and any(a.name == "path" for a in node.names)
        ):
            found.append(f"{where}:{node.lineno}")
        if isinstance(node, ast.Attribute) and node.attr == "addsitedir":
            found.append(f"{where}:{node.lineno}")
    return found


def test_bench_and_its_studies_are_packages():
    assert (BENCH / "__init__.py").is_file()
    assert (BENCH / "studies" / "__init__.py").is_file()
    for sub in ("harness", "prog", "fleet", "external"):
        assert (BENCH / sub / "__init__.py").is_file(), sub


def test_no_file_under_bench_edits_sys_path():
    found = [line for p in sorted(BENCH.rglob("*.py")) for line in _sys_path_edits(p)]
    assert not found, "sys.path edited (import bench.<name> instead):\n" + "\n".join(found)


def test_the_sys_path_check_sees_an_edit(tmp_path):
    for text in (
        "import sys\nsys.path.insert(0, 'x')\n",
        "import sys\nsys.path = ['x']\n",
        "from sys import path\n",
        "import site\nsite.addsitedir('x')\n",
    ):
        bad = tmp_path / "bad.py"
        bad.write_text(text)
        assert _sys_path_edits(bad), text


def test_every_script_runs_as_a_module_of_bench():
    """Each benchmark and study has a main() behind a __main__ guard (what ``-m`` runs)."""
    scripts = _scripts(BENCH) + _scripts(BENCH / "studies")
    assert len(scripts) >= 10
    for path in scripts:
        tree = ast.parse(path.read_text(encoding="utf-8"))
        names = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
        guard = any(isinstance(n, ast.If) and "__main__" in ast.unparse(n.test) for n in tree.body)
        assert "main" in names and guard, f"{path.relative_to(ROOT)}: no main() or no guard"


def test_every_module_under_bench_imports_as_bench_dot_name():
    """Import every module (importlib, main not run) in a fresh process at the repository root.

    A fresh process: bench_nodes sets ROS_DOMAIN_ID on import, which this session keeps.
    """
    code = (
        "import importlib, pkgutil, sys, bench\n"
        "bad = []\n"
        "names = [m.name for m in pkgutil.walk_packages(bench.__path__, 'bench.')]\n"
        "for name in names:\n"
        "    try:\n"
        "        module = importlib.import_module(name)\n"
        "    except Exception as exc:  # noqa: BLE001\n"
        "        bad.append(f'{name}: {exc!r}')\n"
        "        continue\n"
        "    if not module.__file__.startswith(sys.argv[1]):\n"
        "        bad.append(f'{name}: from {module.__file__}')\n"
        "print('\\n'.join(names))\n"
        "sys.exit('\\n'.join(bad) or None)\n"
    )
    run = subprocess.run(
        [sys.executable, "-c", code, str(BENCH)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr
    imported = set(run.stdout.split())
    expected = {f"bench.{p.stem}" for p in _scripts(BENCH)}
    expected |= {f"bench.studies.{p.stem}" for p in _scripts(BENCH / "studies")}
    assert expected <= imported, sorted(expected - imported)


def test_raw_rows_live_in_bench_results_not_in_docs():
    assert not sorted((ROOT / "docs").rglob("*.json")), "raw rows belong in bench/results/"
    rows = sorted(RESULTS.rglob("*.json"))
    assert RESULTS / "bench_robust_recorded.json" in rows
    for path in rows:
        assert path.stat().st_size < MAX_FILE_BYTES, f"{path.relative_to(ROOT)} is over 3 MiB"


@pytest.mark.parametrize(
    "name",
    [
        "bench_external.json",
        "bench_fleet.json",
        "bench_prognostics.json",
        "bench_realistic.json",
        "bench_robust.json",
        "bench_robust_recorded.json",
    ],
)
def test_stored_commands_name_the_module_form(name: str):
    text = (RESULTS / name).read_text(encoding="utf-8")
    assert "python -m bench." in text and "python bench/" not in text
    json.loads(text)
